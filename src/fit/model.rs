//! The internal parameterisation shared by the polynomial and rational fits:
//! f(s) = P(s)/Q(s) with P = Σ a_j T_j(s), Q = 1 + Σ_{j≥1} b_j T_j(s) in the Chebyshev product
//! basis of the scaled variables s ∈ [−1, 1]^d. Fixing Q's *Chebyshev* constant to 1 normalises
//! Q to mean ≈ 1 over the box, which keeps the parameters well scaled; the emitted form is
//! renormalised to the paper's convention (monomial constant of Q = 1) afterwards. A numerator
//! whose exponents are not downward closed (support closed, [`super::basis::is_support_closed`])
//! is P = Σ a_j g_j(s) in the vanishing basis of [`ChebyshevBasis::with_vanishing`] instead.
//!
//! Parameters: [a_0 … a_{nP−1}, b_1 … b_{nQ−1}].

use std::ops::Range;

use rayon::prelude::*;

use super::basis::{
    chebyshev_to_monomial, exponents, is_downward_closed, monomial_to_chebyshev,
    monomial_to_vanishing, vanishing_to_monomial, ChebyshevBasis, Polynomial,
};
use super::data::{AxisScale, FitData, InputTransform, Prepared};
use super::linear::LinearRows;
use super::lm::LeastSquaresProblem;
use super::poles::{certify_polynomial, CertifyOptions, RawVerdict};
use super::result::Approximant;

/// Denominator values at data points must stay above this (Q's Chebyshev constant is 1, so
/// |Q| ~ 1 typically): a barrier that keeps Levenberg–Marquardt on the pole-free side.
pub const Q_FLOOR: f64 = 1e-8;

/// Most basis values (points × basis functions) [`Model::basis_table`] precomputes: 2²⁴ f64 =
/// 128 MiB. Above it, the values are recomputed at every pass (slower, same results).
pub const MAX_CACHED_BASIS_VALUES: usize = 1 << 24;

/// If |Q's monomial constant| falls below this fraction of its largest coefficient, the
/// paper's normalisation Q(0) = 1 would blow the coefficients up; the Chebyshev normalisation
/// is kept instead.
pub const NORMALISE_MIN_RATIO: f64 = 1e-8;

#[derive(Clone, Debug)]
pub(crate) struct Model {
    /// The union of P's and Q's exponents (scikit-learn order).
    pub basis: ChebyshevBasis,
    /// P's exponents and their positions in `basis`.
    pub num_exps: Vec<Vec<u32>>,
    pub num_idx: Vec<usize>,
    /// Q's exponents (the constant first) and their positions in `basis`; None for a polynomial.
    pub den_exps: Option<Vec<Vec<u32>>>,
    pub den_idx: Vec<usize>,
    pub n_num: usize,
    pub n_den: usize,
    /// P's exponents are not downward closed: P is in the vanishing basis
    /// ([`ChebyshevBasis::with_vanishing`]), whose weights [`Model::with_scales`] sets.
    pub num_vanishing: bool,
}

impl Model {
    pub fn polynomial(d: usize, degree: u32) -> Model {
        Model::from_exponents(d, exponents(d, degree), None)
    }

    pub fn rational(d: usize, num_degree: u32, den_degree: u32) -> Model {
        Model::from_exponents(d, exponents(d, num_degree), Some(exponents(d, den_degree)))
    }

    /// P and Q over exponent lists in scikit-learn order (Q's list then starts with the
    /// constant, whose Chebyshev coefficient is fixed to 1), Q's downward closed. With
    /// total-degree lists, the lower degree's is a prefix of the higher one's, so the basis is
    /// the higher one's and the positions are 0, 1, 2, … A P list that is support closed but
    /// not downward closed ([`super::basis::is_support_closed`]) is in the vanishing basis,
    /// after Q's Chebyshev functions; the fit then binds the model to its data's scales
    /// ([`Model::with_scales`]).
    pub fn from_exponents(
        d: usize,
        num_exps: Vec<Vec<u32>>,
        den_exps: Option<Vec<Vec<u32>>>,
    ) -> Model {
        if !is_downward_closed(&num_exps) {
            return Model::vanishing_numerator(d, num_exps, den_exps);
        }
        let top = num_exps
            .iter()
            .chain(den_exps.iter().flatten())
            .map(|e| e.iter().sum::<u32>())
            .max()
            .unwrap_or(0);
        let union: Vec<Vec<u32>> = exponents(d, top)
            .into_iter()
            .filter(|e| num_exps.contains(e) || den_exps.as_ref().is_some_and(|q| q.contains(e)))
            .collect();
        let position = |e: &Vec<u32>| union.iter().position(|u| u == e).expect("in the union");
        let num_idx = num_exps.iter().map(position).collect();
        let den_idx = den_exps
            .as_ref()
            .map_or_else(Vec::new, |q| q.iter().map(position).collect());
        let (n_num, n_den) = (num_exps.len(), den_exps.as_ref().map_or(0, Vec::len));
        Model {
            basis: ChebyshevBasis::from_exponents(d, union),
            num_exps,
            num_idx,
            den_exps,
            den_idx,
            n_num,
            n_den,
            num_vanishing: false,
        }
    }

    /// [`Model::from_exponents`] with P in the vanishing basis: Q's Chebyshev functions first,
    /// then P's.
    fn vanishing_numerator(
        d: usize,
        num_exps: Vec<Vec<u32>>,
        den_exps: Option<Vec<Vec<u32>>>,
    ) -> Model {
        let mut exps: Vec<Vec<u32>> = den_exps.clone().unwrap_or_default();
        let n_den = exps.len();
        let mut vanishing = vec![false; n_den];
        exps.extend(num_exps.iter().cloned());
        vanishing.extend(std::iter::repeat_n(true, num_exps.len()));
        Model {
            basis: ChebyshevBasis::with_vanishing(d, exps, vanishing),
            num_idx: (n_den..n_den + num_exps.len()).collect(),
            n_num: num_exps.len(),
            num_exps,
            den_idx: (0..n_den).collect(),
            den_exps,
            n_den,
            num_vanishing: true,
        }
    }

    /// The model bound to the scales of its data (the vanishing basis's weights).
    pub fn with_scales(mut self, scales: &[AxisScale]) -> Model {
        self.basis.set_scales(scales);
        self
    }

    /// P's basis coefficients → P's monomial coefficients in t.
    pub fn num_to_monomial(&self, scales: &[AxisScale], c: &[f64]) -> Vec<f64> {
        let n = self.num_max_exponent();
        if self.num_vanishing {
            vanishing_to_monomial(&self.num_exps, n, scales, c)
        } else {
            chebyshev_to_monomial(&self.num_exps, n, scales, c)
        }
    }

    /// P's monomial coefficients in t → P's basis coefficients.
    pub fn num_from_monomial(&self, scales: &[AxisScale], c: &[f64]) -> Vec<f64> {
        let n = self.num_max_exponent();
        if self.num_vanishing {
            monomial_to_vanishing(&self.num_exps, n, scales, c)
        } else {
            monomial_to_chebyshev(&self.num_exps, n, scales, c)
        }
    }

    /// Largest single exponent of P (the size of the per-variable conversion maps).
    pub fn num_max_exponent(&self) -> u32 {
        self.num_exps.iter().flatten().copied().max().unwrap_or(0)
    }

    /// Largest single exponent of Q.
    pub fn den_max_exponent(&self) -> u32 {
        self.den_exps
            .iter()
            .flatten()
            .flatten()
            .copied()
            .max()
            .unwrap_or(0)
    }

    pub fn n_params(&self) -> usize {
        self.n_num + self.n_den.saturating_sub(1)
    }

    pub fn is_rational(&self) -> bool {
        self.den_exps.is_some()
    }

    /// (P, Q) at one point given the basis values `phi`.
    #[inline]
    pub fn pq(&self, p: &[f64], phi: &[f64]) -> (f64, f64) {
        let mut num = 0.0;
        for j in 0..self.n_num {
            num += p[j] * phi[self.num_idx[j]];
        }
        let mut den = 1.0;
        for j in 1..self.n_den {
            den += p[self.n_num + j - 1] * phi[self.den_idx[j]];
        }
        (num, den)
    }

    /// The basis values at every point of `data`, row-major (point i's at
    /// [i·len, (i + 1)·len)), or None if there would be more than [`MAX_CACHED_BASIS_VALUES`].
    /// The data do not change during a fit, so Levenberg–Marquardt passes read them instead of
    /// re-evaluating the Chebyshev recurrences (a third of a fit's time otherwise).
    pub fn basis_table(&self, data: &Prepared) -> Option<Vec<f64>> {
        const CHUNK: usize = 4096;
        let (n, len) = (data.len(), self.basis.len());
        if n.checked_mul(len)? > MAX_CACHED_BASIS_VALUES {
            return None;
        }
        let mut out = vec![0.0; n * len];
        out.par_chunks_mut(CHUNK * len)
            .enumerate()
            .for_each(|(c, block)| {
                let mut table = vec![0.0; self.basis.table_len()];
                for (k, phi) in block.chunks_exact_mut(len).enumerate() {
                    self.basis.eval(data.point(c * CHUNK + k), &mut table, phi);
                }
            });
        Some(out)
    }

    /// The basis values at point i: from `cached` (a [`Model::basis_table`] of the same data) or
    /// evaluated into `phi` with scratch `table`.
    #[inline]
    pub fn basis_at<'b>(
        &self,
        data: &Prepared,
        cached: Option<&'b [f64]>,
        i: usize,
        table: &mut [f64],
        phi: &'b mut [f64],
    ) -> &'b [f64] {
        match cached {
            Some(t) => {
                let len = self.basis.len();
                &t[i * len..(i + 1) * len]
            }
            None => {
                self.basis.eval(data.point(i), table, phi);
                phi
            }
        }
    }

    /// f − y at every point (unweighted), or None if Q ≤ Q_FLOOR somewhere (rational only).
    /// `cached`: a [`Model::basis_table`] of `data`, if there is one.
    pub fn errors(&self, data: &Prepared, cached: Option<&[f64]>, p: &[f64]) -> Option<Vec<f64>> {
        const CHUNK: usize = 4096;
        let n = data.len();
        let parts: Vec<Option<Vec<f64>>> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut table = vec![0.0; self.basis.table_len()];
                let mut buf = vec![0.0; self.basis.len()];
                let rows = c * CHUNK..((c + 1) * CHUNK).min(n);
                let mut out = Vec::with_capacity(rows.len());
                for i in rows {
                    let phi = self.basis_at(data, cached, i, &mut table, &mut buf);
                    let (num, den) = self.pq(p, phi);
                    if self.is_rational() && !(den > Q_FLOOR) {
                        return None;
                    }
                    out.push(num / den - data.y[i]);
                }
                Some(out)
            })
            .collect();
        let mut all = Vec::with_capacity(n);
        for part in parts {
            all.extend(part?);
        }
        Some(all)
    }

    /// Q at every point (rational only). `cached`: a [`Model::basis_table`] of `data`, if
    /// there is one (the same values as evaluating the basis again, read instead).
    pub fn denominators(&self, data: &Prepared, cached: Option<&[f64]>, p: &[f64]) -> Vec<f64> {
        let mut table = vec![0.0; self.basis.table_len()];
        let mut buf = vec![0.0; self.basis.len()];
        (0..data.len())
            .map(|i| {
                let phi = self.basis_at(data, cached, i, &mut table, &mut buf);
                self.pq(p, phi).1
            })
            .collect()
    }

    /// The emitted form: monomials in the transformed variables, Q normalised to constant 1.
    pub fn to_approximant(
        &self,
        data: &FitData,
        transforms: &[InputTransform],
        prep: &Prepared,
        p: &[f64],
    ) -> Approximant {
        let mut num = self.num_to_monomial(&prep.scales, &p[..self.n_num]);
        let denominator = self.den_exps.as_ref().map(|den_exps| {
            let mut cheb = vec![1.0];
            cheb.extend_from_slice(&p[self.n_num..]);
            let mut den =
                chebyshev_to_monomial(den_exps, self.den_max_exponent(), &prep.scales, &cheb);
            let q0 = den[0];
            let qmax = den.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            if q0.abs() >= NORMALISE_MIN_RATIO * qmax && q0 != 0.0 {
                for c in den.iter_mut() {
                    *c /= q0;
                }
                den[0] = 1.0; // exactly, by construction
                for c in num.iter_mut() {
                    *c /= q0;
                }
            }
            Polynomial {
                exponents: den_exps.clone(),
                coefficients: den,
            }
        });
        Approximant {
            variables: data.names.clone(),
            transforms: transforms.to_vec(),
            domain: data.domain.clone(),
            numerator: Polynomial {
                exponents: self.num_exps.clone(),
                coefficients: num,
            },
            denominator,
            factor: None,
            terms: Vec::new(),
        }
    }
}

/// The linear least-squares rows of a polynomial fit (Q ≡ 1) or of the linearised rational
/// problem P − yQ ≈ 0, i.e. P(s_i) − y_i Σ_{j≥1} b_j T_j(s_i) ≈ y_i (Levy 1959), each row scaled
/// by the weight v_i = w_i · extra_i.
pub(crate) struct LinearisedRows<'a> {
    pub model: &'a Model,
    pub data: &'a Prepared,
    /// Extra per-point row weights (reweighting, Sanathanan–Koerner 1/|Q|).
    pub extra: Option<&'a [f64]>,
    /// A [`Model::basis_table`] of `data`, if there is one: the rows read the basis values
    /// from it instead of evaluating the Chebyshev recurrences again (the same values).
    pub phi: Option<&'a [f64]>,
}

impl LinearRows for LinearisedRows<'_> {
    fn n_rows(&self) -> usize {
        self.data.len()
    }
    fn n_cols(&self) -> usize {
        self.model.n_params()
    }
    fn fill(&self, rows: Range<usize>, a: &mut [f64], b: &mut [f64]) {
        let len = rows.len();
        let m = self.model;
        let mut table = vec![0.0; m.basis.table_len()];
        let mut buf = vec![0.0; m.basis.len()];
        for (k, i) in rows.enumerate() {
            let phi = m.basis_at(self.data, self.phi, i, &mut table, &mut buf);
            let v = self.data.w[i] * self.extra.map_or(1.0, |e| e[i]);
            let y = self.data.y[i];
            for j in 0..m.n_num {
                a[j * len + k] = v * phi[m.num_idx[j]];
            }
            for j in 1..m.n_den {
                a[(m.n_num + j - 1) * len + k] = -v * y * phi[m.den_idx[j]];
            }
            b[k] = v * y;
        }
    }
}

/// The nonlinear problem min ½ Σ (v_i (P/Q − y_i))², v_i = w_i · extra_i, for Levenberg–Marquardt.
/// With `certified_steps`, only parameters whose denominator is proved pole-free on the whole
/// domain box are admissible, so a run from a certified start can only end certified.
pub(crate) struct RationalProblem<'a> {
    pub model: &'a Model,
    pub data: &'a Prepared,
    /// The model's [`Model::basis_table`] of `data`, if it was precomputed.
    pub phi: Option<&'a [f64]>,
    pub extra: Option<&'a [f64]>,
    /// Certificate options and margin: admissible iff Q ≥ margin is proved on the domain.
    pub certified_steps: Option<(&'a CertifyOptions, f64)>,
}

impl Model {
    /// Q in monomial form of the transformed variables (Chebyshev normalisation kept).
    pub fn denominator_monomial(&self, data: &Prepared, p: &[f64]) -> Option<Polynomial> {
        let exps = self.den_exps.as_ref()?;
        let mut cheb = vec![1.0];
        cheb.extend_from_slice(&p[self.n_num..]);
        let coefficients =
            chebyshev_to_monomial(exps, self.den_max_exponent(), &data.scales, &cheb);
        Some(Polynomial {
            exponents: exps.clone(),
            coefficients,
        })
    }

    /// True if Q − margin is proved to have no zero on the (transformed) domain box; since Q's
    /// Chebyshev mean is 1 > margin, that means Q ≥ margin everywhere there.
    pub fn denominator_certified(
        &self,
        data: &Prepared,
        p: &[f64],
        opts: &CertifyOptions,
        margin: f64,
    ) -> bool {
        let Some(mut q) = self.denominator_monomial(data, p) else {
            return true;
        };
        q.coefficients[0] -= margin; // exponent (0, …, 0) comes first
        let bounds: Vec<(f64, f64)> = data.scales.iter().map(|s| (s.lo, s.hi)).collect();
        matches!(
            certify_polynomial(&q, &bounds, opts),
            RawVerdict::Certified { .. }
        )
    }
}

impl LeastSquaresProblem for RationalProblem<'_> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }
    fn admissible(&self, p: &[f64]) -> bool {
        self.certified_steps.is_none_or(|(opts, margin)| {
            self.model.denominator_certified(self.data, p, opts, margin)
        })
    }
    fn n_residuals(&self) -> usize {
        self.data.len()
    }
    fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
        let m = self.model;
        let mut table = vec![0.0; m.basis.table_len()];
        let mut buf = vec![0.0; m.basis.len()];
        for (k, i) in rows.enumerate() {
            let phi = m.basis_at(self.data, self.phi, i, &mut table, &mut buf);
            let (num, den) = m.pq(p, phi);
            if m.is_rational() && !(den > Q_FLOOR) {
                return false;
            }
            let v = self.data.w[i] * self.extra.map_or(1.0, |e| e[i]);
            r[k] = v * (num / den - self.data.y[i]);
        }
        true
    }
    fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
        let m = self.model;
        let np = m.n_params();
        let mut table = vec![0.0; m.basis.table_len()];
        let mut buf = vec![0.0; m.basis.len()];
        for (k, i) in rows.enumerate() {
            let phi = m.basis_at(self.data, self.phi, i, &mut table, &mut buf);
            let (num, den) = m.pq(p, phi);
            if m.is_rational() && !(den > Q_FLOOR) {
                return false;
            }
            let v = self.data.w[i] * self.extra.map_or(1.0, |e| e[i]);
            let f = num / den;
            r[k] = v * (f - self.data.y[i]);
            let g = v / den; // ∂f/∂a_j = T_j/Q, ∂f/∂b_j = −f T_j/Q
            let row = &mut jac[k * np..(k + 1) * np];
            for j in 0..m.n_num {
                row[j] = g * phi[m.num_idx[j]];
            }
            let gf = -g * f;
            for j in 1..m.n_den {
                row[m.n_num + j - 1] = gf * phi[m.den_idx[j]];
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::FitData;

    #[test]
    fn cached_basis_gives_the_same_residuals_and_jacobian() {
        let ax: Vec<f64> = (0..70).map(|i| i as f64 / 69.0).collect();
        let vals = ax
            .iter()
            .flat_map(|&r| ax.iter().map(move |&m| (1.0 + r * m) / (2.0 + m)))
            .collect();
        let data =
            FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
        let prep = Prepared::new(&data, &[InputTransform::Identity, InputTransform::Sqrt]).unwrap();
        let model = Model::rational(2, 3, 2);
        let table = model.basis_table(&prep).unwrap();
        assert_eq!(table.len(), prep.len() * model.basis.len());
        let p: Vec<f64> = (0..model.n_params())
            .map(|j| 0.1 / (1.0 + j as f64))
            .collect();
        let (n, np) = (prep.len(), model.n_params());
        let run = |phi: Option<&[f64]>| {
            let problem = RationalProblem {
                model: &model,
                data: &prep,
                phi,
                extra: None,
                certified_steps: None,
            };
            let (mut r, mut jac) = (vec![0.0; n], vec![0.0; n * np]);
            assert!(problem.jacobian(&p, 0..n, &mut r, &mut jac));
            let mut r2 = vec![0.0; n];
            assert!(problem.residuals(&p, 0..n, &mut r2));
            assert_eq!(r, r2);
            (r, jac)
        };
        assert_eq!(
            run(None),
            run(Some(&table)),
            "bit-identical with and without the cache"
        );
        assert_eq!(
            model.errors(&prep, None, &p),
            model.errors(&prep, Some(&table), &p)
        );
        // the row-major layout: ∂r_i/∂a_0 = T_0/Q = 1/Q at every point
        let (_, jac) = run(Some(&table));
        let q = model.denominators(&prep, None, &p);
        assert_eq!(q, model.denominators(&prep, Some(&table), &p));
        for i in [0, 17, n - 1] {
            assert!((jac[i * np] - 1.0 / q[i]).abs() < 1e-15);
        }
        // the linearised rows (Levy, Sanathanan–Koerner) read the same values from the cache
        let extra: Vec<f64> = q.iter().map(|q| 1.0 / q.abs()).collect();
        let fill = |phi: Option<&[f64]>| {
            let rows = LinearisedRows {
                model: &model,
                data: &prep,
                extra: Some(&extra),
                phi,
            };
            let (mut a, mut b) = (vec![0.0; n * np], vec![0.0; n]);
            rows.fill(0..n, &mut a, &mut b);
            (a, b)
        };
        assert_eq!(fill(None), fill(Some(&table)));
    }
}
