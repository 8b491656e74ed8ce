//! Total-degree polynomial bases.
//!
//! *Output* form: monomials in the transformed variables t, in scikit-learn
//! `PolynomialFeatures` order (graded, then lexicographic by variable index), so the paper's
//! coefficients (Sforza & Pellacini 2022, Appendix A) map coefficient-for-coefficient.
//!
//! *Solving* form: products of Chebyshev polynomials T_{e_1}(s_1)…T_{e_d}(s_d) in the variables
//! scaled to s ∈ [−1, 1]. It spans the same space (T_n has degree n) and is far better
//! conditioned, which matters because the nonlinear solver works with normal equations. Results
//! are converted back to monomials in t exactly (up to rounding) by binomial expansion.

use serde::{Deserialize, Serialize};

use super::data::AxisScale;
use super::error::{FitError, Result};
use crate::math::CompensatedSum;

/// Highest total degree accepted: beyond this, monomial coefficients on [0, 1] lose all
/// meaning in f64 (the paper sweeps up to 10).
pub const MAX_DEGREE: u32 = 20;

pub(crate) fn check_degree(degree: u32) -> Result<()> {
    if degree > MAX_DEGREE {
        return Err(FitError::DegreeTooHigh {
            degree,
            max: MAX_DEGREE,
        });
    }
    Ok(())
}

/// Exponent tuples of all monomials of total degree ≤ `degree` in `d` variables, in
/// scikit-learn `PolynomialFeatures` order: by total degree, then the index combinations with
/// replacement in lexicographic order. 2D: 1, x, y, x², xy, y², x³, x²y, xy², y³, …
pub fn exponents(d: usize, degree: u32) -> Vec<Vec<u32>> {
    fn push(d: usize, len: usize, start: usize, combo: &mut Vec<usize>, out: &mut Vec<Vec<u32>>) {
        if combo.len() == len {
            let mut e = vec![0u32; d];
            for &v in combo.iter() {
                e[v] += 1;
            }
            out.push(e);
            return;
        }
        for v in start..d {
            combo.push(v);
            push(d, len, v, combo, out);
            combo.pop();
        }
    }
    let mut out = Vec::new();
    for total in 0..=degree as usize {
        push(d, total, 0, &mut Vec::with_capacity(total), &mut out);
    }
    out
}

/// A set of exponent tuples: every e with e_k ≤ `caps[k]` for each variable and
/// Σ_{k in the total} e_k ≤ `total`, where the variables in the total are those with
/// `in_total[k]`, and, with [`FreeOf`], only those members free of its variable (e_j = 0) whose
/// total degree is at most its `degree`. It covers
/// - total degree n: caps n, every variable in the total;
/// - per-variable degrees (a tensor product) m_k: caps m_k, no variable in the total;
/// - the split-sum numerator Σ_{a ≤ K} t_j^a·P_a(others), P_a of total degree n: cap K and
///   outside the total for variable j, caps n and in the total for the others; its shared
///   denominator Q(others) has cap 0 for variable j;
/// - a numerator whose part free of t_j is restricted, c + t_j·R(t) (tensor 1, 4 with
///   `FreeOf { variable: j, degree: 0 }`): the shape of the FON albedo's numerator
///   1 + r·G_F(μ)/π (EON paper, eq. 12), exactly 1 at r = 0.
///
/// Without [`FreeOf`] the set is downward closed (e in the set and e' ≤ e componentwise ⇒ e' in
/// the set), so the exact Chebyshev ↔ monomial conversions, the pole certificate's Bernstein
/// form and the emitted Horner and Bernstein forms all stay inside it. With it, the set is still
/// closed under lowering a positive exponent to a smaller positive one
/// ([`is_support_closed`]), which is what a numerator's solving basis needs
/// (the vanishing basis of the crate's `ChebyshevBasis::with_vanishing`); a denominator must
/// stay downward closed.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExponentSet {
    /// Largest Σ e_k over the variables in the total.
    pub total: u32,
    /// Largest exponent of each variable.
    pub caps: Vec<u32>,
    /// Whether each variable counts towards `total`.
    pub in_total: Vec<bool>,
    /// The restriction of the members free of one variable (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub free_of: Option<FreeOf>,
}

/// The members e of an [`ExponentSet`] with e_variable = 0 have total degree Σ e_k ≤ `degree`
/// (`degree` 0: the constant only, so P − P(0) is divisible by t_variable).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FreeOf {
    pub variable: usize,
    pub degree: u32,
}

impl ExponentSet {
    /// All monomials of total degree ≤ `degree` in `d` variables (same set as [`exponents`]).
    pub fn total_degree(d: usize, degree: u32) -> ExponentSet {
        ExponentSet {
            total: degree,
            caps: vec![degree; d],
            in_total: vec![true; d],
            free_of: None,
        }
    }

    /// The tensor product of per-variable degrees: e_k ≤ degrees[k].
    pub fn tensor(degrees: &[u32]) -> ExponentSet {
        ExponentSet {
            total: degrees.iter().sum(),
            caps: degrees.to_vec(),
            in_total: vec![false; degrees.len()],
            free_of: None,
        }
    }

    /// The same set with its members free of variable `variable` restricted to total degree
    /// ≤ `degree` ([`FreeOf`]).
    pub fn free_of(mut self, variable: usize, degree: u32) -> ExponentSet {
        self.free_of = Some(FreeOf { variable, degree });
        self
    }

    /// Degree ≤ `split_degree` in variable `split` times total degree ≤ `degree` in the others
    /// (the numerator of Σ_a t_split^a P_a(others)); `split_degree` 0 drops the variable (a
    /// shared denominator Q(others)).
    pub fn split(d: usize, split: usize, split_degree: u32, degree: u32) -> ExponentSet {
        let mut s = ExponentSet::total_degree(d, degree);
        if split < d {
            s.caps[split] = split_degree;
            s.in_total[split] = false;
        }
        s
    }

    pub fn dim(&self) -> usize {
        self.caps.len()
    }

    /// Whether the exponent tuple `e` belongs to the set.
    pub fn contains(&self, e: &[u32]) -> bool {
        e.len() == self.dim()
            && e.iter().zip(&self.caps).all(|(x, c)| x <= c)
            && e.iter()
                .zip(&self.in_total)
                .filter(|(_, &t)| t)
                .map(|(x, _)| *x)
                .sum::<u32>()
                <= self.total
            && self.free_of.is_none_or(|f| {
                e.get(f.variable).is_none_or(|&x| x > 0) || e.iter().sum::<u32>() <= f.degree
            })
    }

    /// Largest total degree Σ e_k of a member.
    pub fn max_total_degree(&self) -> u32 {
        if self.free_of.is_none() {
            return self.unrestricted_total_degree();
        }
        self.exponents()
            .iter()
            .map(|e| e.iter().sum::<u32>())
            .max()
            .unwrap_or(0)
    }

    /// Largest total degree of a member without the [`FreeOf`] restriction.
    fn unrestricted_total_degree(&self) -> u32 {
        let outside: u32 = self
            .caps
            .iter()
            .zip(&self.in_total)
            .filter(|(_, &t)| !t)
            .map(|(c, _)| *c)
            .sum();
        let inside: u32 = self
            .caps
            .iter()
            .zip(&self.in_total)
            .filter(|(_, &t)| t)
            .map(|(c, _)| *c)
            .sum();
        outside + inside.min(self.total)
    }

    /// Largest exponent of variable `k` in a member.
    pub fn max_exponent_of(&self, k: usize) -> u32 {
        if self.free_of.is_some() {
            return self
                .exponents()
                .iter()
                .filter_map(|e| e.get(k).copied())
                .max()
                .unwrap_or(0);
        }
        match (self.caps.get(k), self.in_total.get(k)) {
            (Some(&c), Some(true)) => c.min(self.total),
            (Some(&c), _) => c,
            _ => 0,
        }
    }

    /// Largest exponent of any one variable in a member.
    pub fn max_exponent(&self) -> u32 {
        (0..self.dim())
            .map(|k| self.max_exponent_of(k))
            .max()
            .unwrap_or(0)
    }

    /// The members in scikit-learn `PolynomialFeatures` order (the order of [`exponents`]).
    pub fn exponents(&self) -> Vec<Vec<u32>> {
        exponents(self.dim(), self.unrestricted_total_degree())
            .into_iter()
            .filter(|e| self.contains(e))
            .collect()
    }

    /// Number of members.
    pub fn len(&self) -> usize {
        self.exponents().len()
    }

    pub fn is_empty(&self) -> bool {
        false // the constant term is always a member
    }

    /// Checks the shape against `d` variables and the degree limit.
    pub fn check(&self, d: usize) -> Result<()> {
        if self.caps.len() != d || self.in_total.len() != d {
            return Err(FitError::ShapeMismatch {
                what: "exponent set (caps / in_total)",
                expected: d,
                got: self.caps.len().min(self.in_total.len()),
                fix: "give one cap and one in_total flag per variable",
            });
        }
        if let Some(f) = self.free_of {
            if f.variable >= d {
                return Err(FitError::BadExponents {
                    problem: format!(
                        "the restriction of the members free of variable {} names a variable the {d} variables do not have",
                        f.variable
                    ),
                    fix: format!("give a variable index below {d}"),
                });
            }
        }
        check_degree(self.max_total_degree())
    }

    /// Whether the set is downward closed (no [`FreeOf`] restriction, or one that removes no
    /// member).
    pub fn is_downward_closed(&self) -> bool {
        self.free_of.is_none() || is_downward_closed(&self.exponents())
    }

    /// "3/(r+mu≤4)": the caps, and the total over the variables in it.
    pub fn label(&self, names: &[String]) -> String {
        let name = |k: usize| names.get(k).cloned().unwrap_or_else(|| format!("x{k}"));
        let mut parts = Vec::new();
        let inside: Vec<usize> = (0..self.dim()).filter(|&k| self.in_total[k]).collect();
        for k in 0..self.dim() {
            // a variable outside the total, or one capped below it
            if !self.in_total[k] || self.caps[k] < self.total {
                parts.push(format!("{}^{}", name(k), self.caps[k]));
            }
        }
        if !inside.is_empty() {
            let vars: Vec<String> = inside.iter().map(|&k| name(k)).collect();
            parts.push(format!("deg({}) ≤ {}", vars.join(", "), self.total));
        }
        let mut label = parts.join(" × ");
        if let Some(f) = self.free_of {
            label.push_str(&format!(
                ", deg ≤ {} where {} is absent",
                f.degree,
                name(f.variable)
            ));
        }
        label
    }
}

/// Whether every member e of `exps` with e_k > 0 has e − unit_k in `exps` too.
pub fn is_downward_closed(exps: &[Vec<u32>]) -> bool {
    let set: std::collections::HashSet<&[u32]> = exps.iter().map(Vec::as_slice).collect();
    exps.iter().all(|e| {
        (0..e.len()).all(|k| {
            e[k] == 0 || {
                let mut f = e.clone();
                f[k] -= 1;
                set.contains(f.as_slice())
            }
        })
    })
}

/// Whether every member e of `exps` with e_k ≥ 2 has e − unit_k in `exps` too: closed under
/// lowering a positive exponent to a smaller positive one (a zero exponent stays zero). Every
/// downward-closed set is; `{1, r, r·μ, r·μ²}` is too. These are the sets the vanishing basis
/// (the crate's `ChebyshevBasis::with_vanishing`) spans exactly and its conversions to
/// monomials stay inside.
pub fn is_support_closed(exps: &[Vec<u32>]) -> bool {
    let set: std::collections::HashSet<&[u32]> = exps.iter().map(Vec::as_slice).collect();
    exps.iter().all(|e| {
        (0..e.len()).all(|k| {
            e[k] < 2 || {
                let mut f = e.clone();
                f[k] -= 1;
                set.contains(f.as_slice())
            }
        })
    })
}

/// Number of monomials of total degree ≤ `degree` in `d` variables: C(d + degree, d).
pub fn n_terms(d: usize, degree: u32) -> usize {
    binomial(d as u32 + degree, d as u32) as usize
}

/// Binomial coefficient C(n, k) as f64 (exact for the small n used here).
pub(crate) fn binomial(n: u32, k: u32) -> f64 {
    if k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    let mut c = 1.0f64;
    for i in 0..k {
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    c.round()
}

/// A polynomial in monomial form: Σ_j c_j Π_k t_k^{e_jk}.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Polynomial {
    pub exponents: Vec<Vec<u32>>,
    pub coefficients: Vec<f64>,
}

impl Polynomial {
    /// Total degree.
    pub fn degree(&self) -> u32 {
        self.exponents
            .iter()
            .map(|e| e.iter().sum::<u32>())
            .max()
            .unwrap_or(0)
    }

    pub fn dim(&self) -> usize {
        self.exponents.first().map_or(0, Vec::len)
    }

    /// Value at t (already transformed), summed in coefficient order.
    pub fn eval(&self, t: &[f64]) -> f64 {
        self.eval_impl::<false>(t).0
    }

    /// Value and a bound on its floating-point evaluation error:
    /// |computed − exact| ≤ γ_{2(deg+n)+d} Σ |c_j| |t^e_j| (Higham 2002, §3.1 bounds).
    pub fn eval_with_bound(&self, t: &[f64]) -> (f64, f64) {
        let (v, abs) = self.eval_impl::<true>(t);
        let ops = 2 * (self.degree() as usize + self.coefficients.len()) + t.len();
        (v, gamma(ops) * abs)
    }

    /// [`Self::eval`] at `out.len()` points whose `d` transformed coordinates stand one point
    /// after the other in `ts`. Every point gets exactly the arithmetic of [`Self::eval`]
    /// (powers by repeated products, each term c·Π t_k^e_k left to right, terms summed in
    /// coefficient order), so the values are the same to the bit; the loops run across a block
    /// of points, which vectorises.
    pub fn eval_many(&self, d: usize, ts: &[f64], out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2")]
            unsafe fn wide(p: &Polynomial, d: usize, ts: &[f64], out: &mut [f64]) {
                p.eval_many_impl(d, ts, out)
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just above). Wider vectors do the same
                // IEEE operations in the same order (nothing is fused or reassociated), so the
                // bits do not depend on the path.
                return unsafe { wide(self, d, ts, out) };
            }
        }
        self.eval_many_impl(d, ts, out)
    }

    /// The body of [`Self::eval_many`], compiled once per instruction set.
    #[inline(always)]
    fn eval_many_impl(&self, d: usize, ts: &[f64], out: &mut [f64]) {
        const BLOCK: usize = 32;
        debug_assert_eq!(ts.len(), d * out.len());
        let deg = self.degree() as usize;
        let stride = deg + 1;
        let mut pw = vec![1.0; d * stride * BLOCK];
        let (mut m, mut sum) = ([0.0; BLOCK], [0.0; BLOCK]);
        for (block, o) in out.chunks_mut(BLOCK).enumerate() {
            let nb = o.len();
            let t = &ts[block * BLOCK * d..(block * BLOCK + nb) * d];
            for k in 0..d {
                for j in 1..=deg {
                    let (lo, hi) = pw.split_at_mut((k * stride + j) * BLOCK);
                    let prev = &lo[(k * stride + j - 1) * BLOCK..];
                    for p in 0..nb {
                        hi[p] = prev[p] * t[p * d + k];
                    }
                }
            }
            sum[..nb].iter_mut().for_each(|s| *s = 0.0);
            for (e, &c) in self.exponents.iter().zip(&self.coefficients) {
                m[..nb].iter_mut().for_each(|v| *v = c);
                for (k, &ek) in e.iter().enumerate().take(d) {
                    let row = &pw[(k * stride + ek as usize) * BLOCK..];
                    for p in 0..nb {
                        m[p] *= row[p];
                    }
                }
                for p in 0..nb {
                    sum[p] += m[p];
                }
            }
            o.copy_from_slice(&sum[..nb]);
        }
    }

    /// (Σ terms, Σ |terms| if `ABS`, else 0), summed in coefficient order.
    #[inline]
    fn eval_impl<const ABS: bool>(&self, t: &[f64]) -> (f64, f64) {
        let d = t.len();
        if d > super::data::MAX_DIM {
            return self.eval_general::<ABS>(t);
        }
        // Powers t_k^j filled on demand as the terms need them: the same products
        // (t^j = t^{j−1}·t) as a full table, without a pass over the exponents for the degree.
        const STRIDE: usize = MAX_DEGREE as usize + 1;
        let mut pw = [[1.0f64; STRIDE]; super::data::MAX_DIM];
        let mut filled = [0usize; super::data::MAX_DIM];
        let (mut sum, mut abs) = (0.0, 0.0);
        for (e, &c) in self.exponents.iter().zip(&self.coefficients) {
            let mut m = c;
            for (k, &ek) in e.iter().enumerate().take(d) {
                let ek = ek as usize;
                if ek >= STRIDE {
                    return self.eval_general::<ABS>(t);
                }
                if ek > filled[k] {
                    for j in filled[k] + 1..=ek {
                        pw[k][j] = pw[k][j - 1] * t[k];
                    }
                    filled[k] = ek;
                }
                m *= pw[k][ek];
            }
            sum += m;
            if ABS {
                abs += m.abs();
            }
        }
        (sum, abs)
    }

    /// [`Self::eval_impl`] for any dimension and degree (a full power table first).
    fn eval_general<const ABS: bool>(&self, t: &[f64]) -> (f64, f64) {
        let d = t.len();
        let deg = self.degree() as usize;
        let stride = deg + 1;
        let mut pw = vec![1.0; d * stride];
        for k in 0..d {
            for j in 1..=deg {
                pw[k * stride + j] = pw[k * stride + j - 1] * t[k];
            }
        }
        let (mut sum, mut abs) = (0.0, 0.0);
        for (e, &c) in self.exponents.iter().zip(&self.coefficients) {
            let mut m = c;
            for (k, &ek) in e.iter().enumerate().take(d) {
                m *= pw[k * stride + ek as usize];
            }
            sum += m;
            if ABS {
                abs += m.abs();
            }
        }
        (sum, abs)
    }
}

/// γ_n = n·u/(1 − n·u), u = 2⁻⁵³ (Higham 2002, eq. 3.8), inflated by 2 for safety.
pub(crate) fn gamma(n: usize) -> f64 {
    let nu = n as f64 * f64::EPSILON * 0.5;
    2.0 * nu / (1.0 - nu)
}

/// Chebyshev product basis of total degree ≤ `degree` in s ∈ [−1, 1]^d, same exponent order.
///
/// Functions marked *vanishing* ([`ChebyshevBasis::with_vanishing`]) are instead products
/// Π_k g_{e_k}(s_k) with g_0 = 1 and g_e = w_k·T_{e−1}(s_k) for e ≥ 1, where w_k = t_k/max|t_k|
/// is the transformed variable itself, scaled to [−1, 1] over the box: g_e is t_k times a
/// polynomial of degree e − 1, so these products span exactly the monomials of a
/// support-closed exponent set ([`is_support_closed`]) even where it is not downward closed,
/// and stay as well conditioned as the Chebyshev products (T_{e−1} on the box, times a factor
/// bounded by 1).
#[derive(Clone, Debug)]
pub(crate) struct ChebyshevBasis {
    pub d: usize,
    pub degree: u32,
    pub exps: Vec<Vec<u32>>,
    /// Per function and variable: the function's factor in that variable's table block.
    flat: Vec<usize>,
    /// Per variable: w_k = α_k + β_k s_k (t_k/max|t_k|); empty without vanishing functions.
    weights: Vec<(f64, f64)>,
    /// Whether any function is vanishing (each variable's table block then holds
    /// T_0 … T_n followed by g_0 … g_n).
    vanishing: bool,
}

impl ChebyshevBasis {
    #[cfg(test)]
    pub fn new(d: usize, degree: u32) -> ChebyshevBasis {
        ChebyshevBasis::from_exponents(d, exponents(d, degree))
    }

    /// The basis of any exponent list (`degree` is then its largest single exponent, which
    /// sizes the per-variable recurrence tables).
    pub fn from_exponents(d: usize, exps: Vec<Vec<u32>>) -> ChebyshevBasis {
        let n = exps.len();
        ChebyshevBasis::with_vanishing(d, exps, vec![false; n])
    }

    /// The basis of an exponent list whose functions with `vanishing[j]` are the products of
    /// g_e (see the type); the weights w_k come from [`ChebyshevBasis::set_scales`], which must
    /// be called before such a basis is evaluated.
    pub fn with_vanishing(d: usize, exps: Vec<Vec<u32>>, vanishing: Vec<bool>) -> ChebyshevBasis {
        let degree = exps.iter().flatten().copied().max().unwrap_or(0);
        let any = vanishing.iter().any(|&v| v);
        let stride = degree as usize + 1;
        let flat = exps
            .iter()
            .zip(&vanishing)
            .flat_map(|(e, &v)| {
                e.iter().map(move |&x| {
                    if v && x > 0 {
                        stride + x as usize
                    } else {
                        x as usize
                    }
                })
            })
            .collect();
        ChebyshevBasis {
            d,
            degree,
            exps,
            flat,
            weights: if any { vec![(0.0, 0.0); d] } else { Vec::new() },
            vanishing: any,
        }
    }

    /// Sets the weights w_k = t_k/max|t_k| = (c_k + h_k s_k)/(|c_k| + h_k) of the vanishing
    /// functions from the scales of the data (no effect without vanishing functions).
    pub fn set_scales(&mut self, scales: &[AxisScale]) {
        if self.vanishing {
            self.weights = scales
                .iter()
                .map(|sc| {
                    let m = sc.center.abs() + sc.half;
                    (sc.center / m, sc.half / m)
                })
                .collect();
        }
    }

    pub fn len(&self) -> usize {
        self.exps.len()
    }

    /// Length of one variable's block of the scratch table.
    fn block(&self) -> usize {
        (self.degree as usize + 1) * if self.vanishing { 2 } else { 1 }
    }

    /// Scratch size for [`ChebyshevBasis::eval`].
    pub fn table_len(&self) -> usize {
        self.d * self.block()
    }

    /// All basis values at s into `out` (len ≥ self.len()); `table` is scratch.
    #[inline]
    pub fn eval(&self, s: &[f64], table: &mut [f64], out: &mut [f64]) {
        let n1 = self.degree as usize + 1;
        let stride = self.block();
        for k in 0..self.d {
            let t = &mut table[k * stride..(k + 1) * stride];
            let x = s[k];
            t[0] = 1.0;
            if n1 > 1 {
                t[1] = x;
            }
            for j in 2..n1 {
                t[j] = 2.0 * x * t[j - 1] - t[j - 2]; // T_{j} = 2x T_{j−1} − T_{j−2}
            }
            if self.vanishing {
                // g_0 = 1, g_e = w·T_{e−1}
                let (a, b) = self.weights[k];
                let w = a + b * x;
                t[n1] = 1.0;
                for e in 1..n1 {
                    t[n1 + e] = w * t[e - 1];
                }
            }
        }
        match self.d {
            1 => {
                for (j, o) in out[..self.len()].iter_mut().enumerate() {
                    *o = table[self.flat[j]];
                }
            }
            2 => {
                for (j, o) in out[..self.len()].iter_mut().enumerate() {
                    *o = table[self.flat[2 * j]] * table[stride + self.flat[2 * j + 1]];
                }
            }
            _ => {
                let d = self.d;
                for (j, o) in out[..self.len()].iter_mut().enumerate() {
                    let mut v = 1.0;
                    for k in 0..d {
                        v *= table[k * stride + self.flat[d * j + k]];
                    }
                    *o = v;
                }
            }
        }
    }
}

/// Square matrix acting on the coefficients of one variable: out[m] = Σ_a M[m][a] in[a].
type AxisMap = Vec<Vec<f64>>;

/// Chebyshev → power basis in s: column a holds the coefficients of T_a.
fn chebyshev_to_power(n: usize) -> AxisMap {
    let mut m = vec![vec![0.0; n + 1]; n + 1];
    m[0][0] = 1.0;
    if n >= 1 {
        m[1][1] = 1.0;
    }
    for a in 2..=n {
        for k in 0..=n {
            let up = if k >= 1 { 2.0 * m[k - 1][a - 1] } else { 0.0 };
            m[k][a] = up - m[k][a - 2];
        }
    }
    m
}

/// Power basis in s → power basis in t where s = α t + β:
/// s^a = Σ_m C(a, m) α^m β^(a−m) t^m.
fn affine_power(n: usize, alpha: f64, beta: f64) -> AxisMap {
    let mut m = vec![vec![0.0; n + 1]; n + 1];
    for a in 0..=n {
        for k in 0..=a {
            m[k][a] =
                binomial(a as u32, k as u32) * alpha.powi(k as i32) * beta.powi((a - k) as i32);
        }
    }
    m
}

fn mat_mul(a: &AxisMap, b: &AxisMap) -> AxisMap {
    let n = a.len();
    let mut c = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            let mut s = CompensatedSum::default();
            for k in 0..n {
                s.add(a[i][k] * b[k][j]);
            }
            c[i][j] = s.value();
        }
    }
    c
}

/// Inverse of an upper-triangular matrix with non-zero diagonal (back substitution).
fn upper_inverse(a: &AxisMap) -> AxisMap {
    let n = a.len();
    let mut inv = vec![vec![0.0; n]; n];
    for j in 0..n {
        for i in (0..=j).rev() {
            let mut s = CompensatedSum::default();
            s.add(if i == j { 1.0 } else { 0.0 });
            for k in i + 1..=j {
                s.add(-a[i][k] * inv[k][j]);
            }
            inv[i][j] = s.value() / a[i][i];
        }
    }
    inv
}

/// Applies per-variable maps to a coefficient vector over a total-degree exponent set:
/// out[m] = Σ_a c[a] Π_k M_k[m_k][a_k]. The maps are degree-non-increasing (triangular), so
/// the exponent set is closed under them.
fn apply_axis_maps(exps: &[Vec<u32>], coeffs: &[f64], maps: &[AxisMap]) -> Vec<f64> {
    exps.iter()
        .map(|m| {
            let mut s = CompensatedSum::default();
            for (a, &c) in exps.iter().zip(coeffs) {
                if c == 0.0 || m.iter().zip(a).any(|(mk, ak)| mk > ak) {
                    continue;
                }
                let mut v = c;
                for (k, map) in maps.iter().enumerate() {
                    v *= map[m[k] as usize][a[k] as usize];
                }
                s.add(v);
            }
            s.value()
        })
        .collect()
}

/// Coefficients in the Chebyshev basis of s = (t − center)/half → monomial coefficients in t.
pub(crate) fn chebyshev_to_monomial(
    exps: &[Vec<u32>],
    degree: u32,
    scales: &[AxisScale],
    coeffs: &[f64],
) -> Vec<f64> {
    let n = degree as usize;
    let c2p = chebyshev_to_power(n);
    let maps: Vec<AxisMap> = scales
        .iter()
        .map(|sc| mat_mul(&affine_power(n, 1.0 / sc.half, -sc.center / sc.half), &c2p))
        .collect();
    apply_axis_maps(exps, coeffs, &maps)
}

/// Monomial coefficients in t → coefficients in the Chebyshev basis of s (inverse of
/// [`chebyshev_to_monomial`]; t = center + half·s).
pub(crate) fn monomial_to_chebyshev(
    exps: &[Vec<u32>],
    degree: u32,
    scales: &[AxisScale],
    coeffs: &[f64],
) -> Vec<f64> {
    let n = degree as usize;
    let p2c = upper_inverse(&chebyshev_to_power(n));
    let maps: Vec<AxisMap> = scales
        .iter()
        .map(|sc| mat_mul(&p2c, &affine_power(n, sc.half, sc.center)))
        .collect();
    apply_axis_maps(exps, coeffs, &maps)
}

/// Per-variable maps of the vanishing basis g_0 = 1, g_e = (t/M)·T_{e−1}(s) (see
/// [`ChebyshevBasis`]) to powers of t, M = |c| + h: column e holds g_e's coefficients. Upper
/// triangular with a non-zero diagonal, and a zero exponent maps only to a zero exponent.
fn vanishing_maps(n: usize, scales: &[AxisScale]) -> Vec<AxisMap> {
    let c2p = chebyshev_to_power(n);
    scales
        .iter()
        .map(|sc| {
            let a = mat_mul(&affine_power(n, 1.0 / sc.half, -sc.center / sc.half), &c2p);
            let m = sc.center.abs() + sc.half;
            let mut g = vec![vec![0.0; n + 1]; n + 1];
            g[0][0] = 1.0;
            for e in 1..=n {
                for k in 1..=e {
                    g[k][e] = a[k - 1][e - 1] / m;
                }
            }
            g
        })
        .collect()
}

/// Coefficients in the vanishing basis ([`ChebyshevBasis::with_vanishing`]) → monomial
/// coefficients in t, over a support-closed exponent set ([`is_support_closed`]).
pub(crate) fn vanishing_to_monomial(
    exps: &[Vec<u32>],
    degree: u32,
    scales: &[AxisScale],
    coeffs: &[f64],
) -> Vec<f64> {
    apply_axis_maps(exps, coeffs, &vanishing_maps(degree as usize, scales))
}

/// Monomial coefficients in t → coefficients in the vanishing basis (inverse of
/// [`vanishing_to_monomial`]).
pub(crate) fn monomial_to_vanishing(
    exps: &[Vec<u32>],
    degree: u32,
    scales: &[AxisScale],
    coeffs: &[f64],
) -> Vec<f64> {
    let maps: Vec<AxisMap> = vanishing_maps(degree as usize, scales)
        .iter()
        .map(upper_inverse)
        .collect();
    apply_axis_maps(exps, coeffs, &maps)
}

/// Monomial coefficients in t → monomial coefficients in u where t = lo + (hi − lo)·u, together
/// with the same map applied to |coefficients| with |map entries| (for rounding-error bounds).
pub(crate) fn monomial_to_unit_box(p: &Polynomial, bounds: &[(f64, f64)]) -> (Vec<f64>, Vec<f64>) {
    let n = p.degree() as usize;
    let maps: Vec<AxisMap> = bounds
        .iter()
        .map(|&(lo, hi)| affine_power(n, hi - lo, lo))
        .collect();
    let abs_maps: Vec<AxisMap> = maps
        .iter()
        .map(|m| {
            m.iter()
                .map(|r| r.iter().map(|x| x.abs()).collect())
                .collect()
        })
        .collect();
    let abs: Vec<f64> = p.coefficients.iter().map(|c| c.abs()).collect();
    (
        apply_axis_maps(&p.exponents, &p.coefficients, &maps),
        apply_axis_maps(&p.exponents, &abs, &abs_maps),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eval_many_is_eval_to_the_bit() {
        // a small LCG: deterministic coefficients and points, some outside [0, 1]
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.6 - 0.8
        };
        for d in 1..=3 {
            for degree in [0, 1, 4, 10, 20] {
                let exps = exponents(d, degree);
                let p = Polynomial {
                    coefficients: exps.iter().map(|_| next()).collect(),
                    exponents: exps,
                };
                let n = 77; // not a multiple of the block
                let ts: Vec<f64> = (0..n * d).map(|_| next()).collect();
                let mut many = vec![0.0; n];
                p.eval_many(d, &ts, &mut many);
                for (k, v) in many.iter().enumerate() {
                    assert_eq!(
                        v.to_bits(),
                        p.eval(&ts[k * d..(k + 1) * d]).to_bits(),
                        "d {d} degree {degree} point {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn sklearn_order_2d_and_3d() {
        let e2 = exponents(2, 3);
        let want2: Vec<Vec<u32>> = vec![
            vec![0, 0],
            vec![1, 0],
            vec![0, 1],
            vec![2, 0],
            vec![1, 1],
            vec![0, 2],
            vec![3, 0],
            vec![2, 1],
            vec![1, 2],
            vec![0, 3],
        ];
        assert_eq!(e2, want2);
        let e3 = exponents(3, 3);
        assert_eq!(e3.len(), 20);
        // 1, x, r, μ, x², xr, xμ, r², rμ, μ², x³, x²r, x²μ, xr², xrμ, xμ², r³, r²μ, rμ², μ³
        assert_eq!(e3[4], vec![2, 0, 0]);
        assert_eq!(e3[6], vec![1, 0, 1]);
        assert_eq!(e3[14], vec![1, 1, 1]);
        assert_eq!(e3[15], vec![1, 0, 2]);
        assert_eq!(e3[19], vec![0, 0, 3]);
        assert_eq!(n_terms(2, 10), 66);
        assert_eq!(n_terms(3, 5), 56);
        assert_eq!(
            exponents(1, 4),
            vec![vec![0], vec![1], vec![2], vec![3], vec![4]]
        );
    }

    fn pseudo_random(seed: u64, n: usize) -> Vec<f64> {
        let mut r = crate::fit::data::SplitMix64(seed);
        (0..n).map(|_| 2.0 * r.next_f64() - 1.0).collect()
    }

    #[test]
    fn chebyshev_monomial_round_trip() {
        for (d, deg) in [(1usize, 7u32), (2, 6), (3, 4)] {
            let scales: Vec<AxisScale> = (0..d)
                .map(|k| AxisScale::new(0.1 * k as f64, 1.0 + 0.5 * k as f64))
                .collect();
            let basis = ChebyshevBasis::new(d, deg);
            let c = pseudo_random(7 + d as u64, basis.len());
            let mono = chebyshev_to_monomial(&basis.exps, deg, &scales, &c);
            let p = Polynomial {
                exponents: basis.exps.clone(),
                coefficients: mono.clone(),
            };
            // same function at random points
            let mut table = vec![0.0; basis.table_len()];
            let mut phi = vec![0.0; basis.len()];
            for pt in pseudo_random(99, 50 * d).chunks(d) {
                basis.eval(pt, &mut table, &mut phi);
                let want: f64 = phi.iter().zip(&c).map(|(a, b)| a * b).sum();
                let t: Vec<f64> = pt
                    .iter()
                    .zip(&scales)
                    .map(|(s, sc)| sc.center + sc.half * s)
                    .collect();
                assert!(
                    (p.eval(&t) - want).abs() < 1e-11,
                    "d={d} deg={deg}: {} vs {want}",
                    p.eval(&t)
                );
            }
            // and back
            let back = monomial_to_chebyshev(&basis.exps, deg, &scales, &mono);
            for (a, b) in back.iter().zip(&c) {
                assert!((a - b).abs() < 1e-11, "round trip {a} vs {b}");
            }
        }
    }

    #[test]
    fn a_set_restricted_where_a_variable_is_absent() {
        // c + r·(b0 + … + b4 μ⁴): the tensor 1, 4 without μ, …, μ⁴
        let s = ExponentSet::tensor(&[1, 4]).free_of(0, 0);
        let e = s.exponents();
        assert_eq!(
            e,
            vec![
                vec![0, 0],
                vec![1, 0],
                vec![1, 1],
                vec![1, 2],
                vec![1, 3],
                vec![1, 4]
            ]
        );
        assert_eq!((s.len(), s.max_total_degree(), s.max_exponent()), (6, 5, 4));
        assert_eq!((s.max_exponent_of(0), s.max_exponent_of(1)), (1, 4));
        assert!(!s.is_downward_closed() && !is_downward_closed(&e));
        assert!(is_support_closed(&e));
        assert!(s
            .label(&["r".into(), "mu".into()])
            .contains("where r is absent"));
        // a restriction that removes nothing leaves the set downward closed
        assert!(ExponentSet::tensor(&[1, 2])
            .free_of(0, 2)
            .is_downward_closed());
        // without r² the set {1, r², …} is not support closed; r·μ² without r·μ neither
        assert!(!is_support_closed(&[vec![0, 0], vec![2, 0]]));
        assert!(!is_support_closed(&[vec![0, 0], vec![1, 2]]));
        assert!(is_support_closed(&[vec![0, 0], vec![1, 1]]));
        // a restriction naming a variable the data do not have is refused with the fix
        let e = ExponentSet::tensor(&[1, 4])
            .free_of(2, 0)
            .check(2)
            .unwrap_err();
        assert!(e.to_string().contains("below 2"), "{e}");
        // fit files without the field still load, and the field round-trips
        let old: ExponentSet =
            serde_json::from_str(r#"{"total": 5, "caps": [1, 4], "in_total": [false, false]}"#)
                .unwrap();
        assert_eq!(old, ExponentSet::tensor(&[1, 4]));
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<ExponentSet>(&json).unwrap(), s);
        assert!(!serde_json::to_string(&old).unwrap().contains("free_of"));
    }

    #[test]
    fn vanishing_basis_spans_the_set_and_converts_exactly() {
        // over t_r ∈ [0.2, 1.4] (so r = 0 lies outside the box: the factor is t itself, not
        // t − lo) and t_μ ∈ [0, 1]
        let scales = [AxisScale::new(0.2, 1.4), AxisScale::new(0.0, 1.0)];
        let exps = ExponentSet::tensor(&[2, 3]).free_of(0, 1).exponents();
        assert!(exps.contains(&vec![0, 1]) && !exps.contains(&vec![0, 2]));
        let mut basis = ChebyshevBasis::with_vanishing(2, exps.clone(), vec![true; exps.len()]);
        basis.set_scales(&scales);
        let c = pseudo_random(5, exps.len());
        let mono = vanishing_to_monomial(&exps, 3, &scales, &c);
        let p = Polynomial {
            exponents: exps.clone(),
            coefficients: mono.clone(),
        };
        let mut table = vec![0.0; basis.table_len()];
        let mut phi = vec![0.0; basis.len()];
        for pt in pseudo_random(41, 100).chunks(2) {
            basis.eval(pt, &mut table, &mut phi);
            let want: f64 = phi.iter().zip(&c).map(|(a, b)| a * b).sum();
            let t: Vec<f64> = pt
                .iter()
                .zip(&scales)
                .map(|(s, sc)| sc.center + sc.half * s)
                .collect();
            assert!(
                (p.eval(&t) - want).abs() < 1e-12,
                "{} vs {want}",
                p.eval(&t)
            );
        }
        let back = monomial_to_vanishing(&exps, 3, &scales, &mono);
        for (a, b) in back.iter().zip(&c) {
            assert!((a - b).abs() < 1e-12, "round trip {a} vs {b}");
        }
    }

    #[test]
    fn unit_box_map() {
        // q(t) = 1 + 2t on [2, 4]: q(2 + 2u) = 5 + 4u
        let p = Polynomial {
            exponents: vec![vec![0], vec![1]],
            coefficients: vec![1.0, 2.0],
        };
        let (u, _) = monomial_to_unit_box(&p, &[(2.0, 4.0)]);
        assert_eq!(u, vec![5.0, 4.0]);
    }
}
