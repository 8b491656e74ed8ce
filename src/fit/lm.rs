//! Levenberg–Marquardt for large least-squares problems, argmin-style: a problem trait that
//! produces residuals and Jacobian rows in chunks ([`LeastSquaresProblem`]), a solver with
//! validated settings ([`LevenbergMarquardt`]), a plain state struct ([`LmState`]) and a
//! recorded [`TerminationReason`].
//!
//! The Jacobian is never stored: JᵀJ and Jᵀr are accumulated over fixed chunks of
//! [`CHUNK_ROWS`] residuals in parallel (rayon) and the partial sums are added in chunk order,
//! so results are bit-for-bit identical for any thread count.
//!
//! Algorithm: Marquardt's scaled damping (Moré 1978, "The Levenberg–Marquardt algorithm:
//! implementation and theory": D = running max of the column norms of J) with Nielsen's damping
//! update (Madsen, Nielsen & Tingleff 2004, "Methods for non-linear least squares problems",
//! eq. 3.16) and MINPACK's three convergence tests (ftol, xtol, gtol).

use std::ops::Range;

use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView, Dyn};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::error::{FitError, Result};

/// Residuals per accumulation chunk (fixed: it determines the summation order).
pub const CHUNK_ROWS: usize = 4096;

/// A nonlinear least-squares problem min ½ Σ r_i(p)².
pub trait LeastSquaresProblem: Sync {
    fn n_params(&self) -> usize;
    fn n_residuals(&self) -> usize;
    /// Writes r_i(p) for i in `rows` into `r` (len = rows.len()). Returns false if `p` is
    /// infeasible for one of these residuals (e.g. a rational's denominator vanishes there).
    fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool;
    /// Writes residuals and the Jacobian block ∂r_i/∂p_j row by row (row-major, `rows.len()` ×
    /// n_params: ∂r_i/∂p_j at `(i − rows.start)·n_params + j`), so each point writes one
    /// contiguous run.
    fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool;
    /// Whether `p` is admissible beyond the residuals (e.g. a denominator proved pole-free on
    /// the whole domain). Checked for the start and for every trial point before its
    /// residuals; an inadmissible trial is rejected like a cost increase. Default: always.
    fn admissible(&self, _p: &[f64]) -> bool {
        true
    }
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TerminationReason {
    /// Every column of J is (nearly) orthogonal to r: |cos| ≤ gtol (MINPACK `info = 4`).
    GradientSmall,
    /// The scaled step is below xtol relative to the scaled parameters (MINPACK `info = 2`).
    StepSmall,
    /// Actual and predicted relative cost reductions are both below ftol (MINPACK `info = 1`).
    CostReductionSmall,
    /// The residuals are exactly zero.
    ZeroResidual,
    /// The iteration limit was reached before convergence.
    MaxIterations,
    /// The damping grew past its limit without finding a decrease: a local minimum to working
    /// precision, or a step blocked by infeasibility (e.g. a pole).
    NoProgress,
    /// The starting point is infeasible, inadmissible or gives non-finite residuals.
    InfeasibleStart,
}

impl TerminationReason {
    /// True for the reasons that signal convergence to a (local) minimum. `NoProgress` is not
    /// counted: the point may be a minimum to working precision or a step blocked by a pole.
    pub fn converged(self) -> bool {
        matches!(
            self,
            TerminationReason::GradientSmall
                | TerminationReason::StepSmall
                | TerminationReason::CostReductionSmall
                | TerminationReason::ZeroResidual
        )
    }
}

/// Solver state, handed back with the result.
#[derive(Clone, Debug)]
pub struct LmState {
    pub params: Vec<f64>,
    /// ½ Σ r_i².
    pub cost: f64,
    /// Current damping λ (relative to the scaled JᵀJ, whose diagonal is ≤ 1).
    pub damping: f64,
    /// Nielsen's growth factor ν.
    pub nu: f64,
    /// Steps attempted.
    pub iterations: usize,
    /// Jacobian accumulations.
    pub jacobian_evaluations: usize,
    /// max_j |g_j| / (‖J_j‖ ‖r‖) at the last accepted point.
    pub gradient_cosine: f64,
}

#[derive(Clone, Debug)]
pub struct LmReport {
    pub state: LmState,
    pub termination: TerminationReason,
}

/// Levenberg–Marquardt settings. Construct with [`LevenbergMarquardt::new`], adjust with the
/// validating `with_*` setters.
#[derive(Clone, Debug, PartialEq)]
pub struct LevenbergMarquardt {
    max_iterations: usize,
    ftol: f64,
    xtol: f64,
    gtol: f64,
    initial_damping: f64,
    max_damping: f64,
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        LevenbergMarquardt::new()
    }
}

impl LevenbergMarquardt {
    /// Defaults: 200 iterations, ftol = 1e-12, xtol = 1e-10, gtol = 1e-10, λ₀ = 1e-3
    /// (Madsen, Nielsen & Tingleff's τ), λ_max = 1e16.
    pub fn new() -> Self {
        LevenbergMarquardt {
            max_iterations: 200,
            ftol: 1e-12,
            xtol: 1e-10,
            gtol: 1e-10,
            initial_damping: 1e-3,
            max_damping: 1e16,
        }
    }

    pub fn max_iterations(&self) -> usize {
        self.max_iterations
    }

    pub fn with_max_iterations(mut self, n: usize) -> Result<Self> {
        if n == 0 {
            return Err(FitError::InvalidSetting {
                name: "max_iterations",
                value: n.to_string(),
                expected: "must be at least 1",
            });
        }
        self.max_iterations = n;
        Ok(self)
    }

    /// Relative tolerances on cost reduction, step size and gradient cosine; each in [0, 1).
    pub fn with_tolerances(mut self, ftol: f64, xtol: f64, gtol: f64) -> Result<Self> {
        for (name, v) in [("ftol", ftol), ("xtol", xtol), ("gtol", gtol)] {
            if !(0.0..1.0).contains(&v) {
                return Err(FitError::InvalidSetting {
                    name,
                    value: v.to_string(),
                    expected: "must be in [0, 1)",
                });
            }
        }
        (self.ftol, self.xtol, self.gtol) = (ftol, xtol, gtol);
        Ok(self)
    }

    /// Initial damping τ relative to the scaled JᵀJ; must be > 0.
    pub fn with_initial_damping(mut self, tau: f64) -> Result<Self> {
        if !(tau > 0.0 && tau.is_finite()) {
            return Err(FitError::InvalidSetting {
                name: "initial_damping",
                value: tau.to_string(),
                expected: "must be finite and > 0",
            });
        }
        self.initial_damping = tau;
        Ok(self)
    }

    /// Minimises ½‖r(p)‖² from `x0`. Errors only on malformed input (wrong length, NaN start);
    /// an infeasible start or non-convergence is reported through the termination reason.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        x0: Vec<f64>,
    ) -> Result<LmReport> {
        let n = problem.n_params();
        if x0.len() != n {
            return Err(FitError::ShapeMismatch {
                what: "Levenberg–Marquardt start",
                expected: n,
                got: x0.len(),
                fix: "give one starting value per parameter",
            });
        }
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(FitError::NonFinite {
                what: "starting parameter",
                index: i,
                value: x0[i],
            });
        }
        let mut state = LmState {
            params: x0,
            cost: f64::INFINITY,
            damping: self.initial_damping,
            nu: 2.0,
            iterations: 0,
            jacobian_evaluations: 0,
            gradient_cosine: f64::INFINITY,
        };
        let start = if problem.admissible(&state.params) {
            normal_equations(problem, &state.params)
        } else {
            None
        };
        let Some(mut ne) = start else {
            return Ok(LmReport {
                state,
                termination: TerminationReason::InfeasibleStart,
            });
        };
        state.jacobian_evaluations += 1;
        state.cost = ne.cost;
        // Moré's scaling D_j = max over iterations of ‖J_j‖ (1 for an all-zero column).
        let mut diag: Vec<f64> = (0..n).map(|j| col_norm(&ne, j)).collect();

        let termination = loop {
            if state.cost == 0.0 {
                break TerminationReason::ZeroResidual;
            }
            state.gradient_cosine = gradient_cosine(&ne);
            if state.gradient_cosine <= self.gtol {
                break TerminationReason::GradientSmall;
            }
            if state.iterations >= self.max_iterations {
                break TerminationReason::MaxIterations;
            }
            state.iterations += 1;

            // solve (D⁻¹JᵀJD⁻¹ + λI) z = −D⁻¹Jᵀr, δ = D⁻¹z
            let Some(delta) = damped_step(&ne, &diag, state.damping) else {
                state.damping *= state.nu;
                state.nu *= 2.0;
                if state.damping > self.max_damping {
                    break TerminationReason::NoProgress;
                }
                continue;
            };
            let dx_norm = delta
                .iter()
                .zip(&diag)
                .map(|(d, s)| (d * s).powi(2))
                .sum::<f64>()
                .sqrt();
            let x_norm = state
                .params
                .iter()
                .zip(&diag)
                .map(|(x, s)| (x * s).powi(2))
                .sum::<f64>()
                .sqrt();
            // predicted reduction of ½‖r + Jδ‖²: −gᵀδ − ½ δᵀJᵀJδ
            let jtj_delta = &ne.jtj * DVector::from_column_slice(&delta);
            let g_delta: f64 = delta.iter().zip(ne.jtr.iter()).map(|(a, b)| a * b).sum();
            let quad: f64 = delta.iter().zip(jtj_delta.iter()).map(|(a, b)| a * b).sum();
            let predicted = -g_delta - 0.5 * quad;

            let trial: Vec<f64> = state
                .params
                .iter()
                .zip(&delta)
                .map(|(x, d)| x + d)
                .collect();
            let trial_cost = if problem.admissible(&trial) {
                cost(problem, &trial).unwrap_or(f64::INFINITY)
            } else {
                f64::INFINITY
            };
            let actual = state.cost - trial_cost;
            let rho = if predicted > 0.0 {
                actual / predicted
            } else {
                f64::NEG_INFINITY
            };

            if rho > 0.0 && trial_cost.is_finite() {
                // (a finite cost but a non-finite Jacobian is treated as a rejection)
                if let Some(next) = normal_equations(problem, &trial) {
                    state.jacobian_evaluations += 1;
                    let old_cost = state.cost;
                    state.params = trial;
                    state.cost = next.cost;
                    ne = next;
                    for (j, d) in diag.iter_mut().enumerate() {
                        *d = d.max(col_norm(&ne, j));
                    }
                    state.damping *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                    state.nu = 2.0;
                    if actual.abs() <= self.ftol * old_cost
                        && predicted <= self.ftol * old_cost
                        && rho <= 2.0
                    {
                        break TerminationReason::CostReductionSmall;
                    }
                    if dx_norm <= self.xtol * (x_norm + self.xtol) {
                        break TerminationReason::StepSmall;
                    }
                    continue;
                }
            }
            // rejected
            if dx_norm <= self.xtol * (x_norm + self.xtol) {
                break TerminationReason::StepSmall;
            }
            if predicted >= 0.0
                && predicted <= self.ftol * state.cost
                && actual.abs() <= self.ftol * state.cost
            {
                break TerminationReason::CostReductionSmall;
            }
            state.damping *= state.nu;
            state.nu *= 2.0;
            if state.damping > self.max_damping {
                break TerminationReason::NoProgress;
            }
        };
        Ok(LmReport { state, termination })
    }
}

/// JᵀJ, Jᵀr and ½‖r‖² at one point.
#[derive(Clone, Debug)]
pub(crate) struct NormalEquations {
    pub jtj: DMatrix<f64>,
    pub jtr: DVector<f64>,
    pub cost: f64,
}

fn col_norm(ne: &NormalEquations, j: usize) -> f64 {
    let c = ne.jtj[(j, j)].max(0.0).sqrt();
    if c > 0.0 && c.is_finite() {
        c
    } else {
        1.0
    }
}

fn gradient_cosine(ne: &NormalEquations) -> f64 {
    let rnorm = (2.0 * ne.cost).sqrt();
    (0..ne.jtr.len())
        .map(|j| {
            let cn = ne.jtj[(j, j)].max(0.0).sqrt();
            if cn > 0.0 {
                ne.jtr[j].abs() / (cn * rnorm)
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}

fn damped_step(ne: &NormalEquations, diag: &[f64], lambda: f64) -> Option<Vec<f64>> {
    let n = diag.len();
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..n {
            a[(i, j)] = ne.jtj[(i, j)] / (diag[i] * diag[j]);
        }
        a[(i, i)] += lambda;
    }
    let g = DVector::from_iterator(n, (0..n).map(|i| -ne.jtr[i] / diag[i]));
    let chol = a.cholesky()?;
    let z = chol.solve(&g);
    let delta: Vec<f64> = (0..n).map(|i| z[i] / diag[i]).collect();
    delta.iter().all(|d| d.is_finite()).then_some(delta)
}

/// 4-way unrolled dot product (fixed order, vectorises).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (mut s0, mut s1, mut s2, mut s3) = (0.0, 0.0, 0.0, 0.0);
    let mut i = 0;
    while i + 4 <= n {
        s0 += a[i] * b[i];
        s1 += a[i + 1] * b[i + 1];
        s2 += a[i + 2] * b[i + 2];
        s3 += a[i + 3] * b[i + 3];
        i += 4;
    }
    while i < n {
        s0 += a[i] * b[i];
        i += 1;
    }
    (s0 + s1) + (s2 + s3)
}

/// Per-chunk partial sums: packed upper JᵀJ, Jᵀr, Σr².
struct Partial {
    jtj: Vec<f64>,
    jtr: Vec<f64>,
    rr: f64,
}

/// Accumulates the normal equations at `p`, or None if `p` is infeasible / non-finite.
pub(crate) fn normal_equations<P: LeastSquaresProblem + ?Sized>(
    problem: &P,
    p: &[f64],
) -> Option<NormalEquations> {
    let m = problem.n_residuals();
    let n = problem.n_params();
    let n_chunks = m.div_ceil(CHUNK_ROWS);
    let partials: Vec<Option<Partial>> = (0..n_chunks)
        .into_par_iter()
        .map_init(
            || (vec![0.0; CHUNK_ROWS], vec![0.0; CHUNK_ROWS * n]),
            |(r, jac), c| {
                let rows = c * CHUNK_ROWS..((c + 1) * CHUNK_ROWS).min(m);
                let len = rows.len();
                let (r, jac) = (&mut r[..len], &mut jac[..len * n]);
                if !problem.jacobian(p, rows, r, jac) {
                    return None;
                }
                // JᵀJ of the block by one blocked matrix product (matrixmultiply through
                // nalgebra's gemm: single-threaded, fixed blocking → deterministic). The
                // row-major block is Jᵀ in column-major (n × len), and J the same memory read
                // with swapped strides, so nothing is copied.
                let jt = DMatrixView::from_slice(jac, n, len);
                let jv = DMatrixView::from_slice_with_strides_generic(
                    jac,
                    Dyn(len),
                    Dyn(n),
                    Dyn(n),
                    Dyn(1),
                );
                let mut block = DMatrix::zeros(n, n);
                block.gemm(1.0, &jt, &jv, 0.0);
                let mut jtr_block = DVector::zeros(n);
                jtr_block.gemv(1.0, &jt, &DVectorView::from_slice(r, len), 0.0);
                let mut jtj = Vec::with_capacity(n * (n + 1) / 2);
                for a in 0..n {
                    for b in a..n {
                        jtj.push(block[(a, b)]);
                    }
                }
                let jtr = jtr_block.as_slice().to_vec();
                Some(Partial {
                    jtj,
                    jtr,
                    rr: dot(r, r),
                })
            },
        )
        .collect();
    let mut jtj_packed = vec![0.0; n * (n + 1) / 2];
    let mut jtr = vec![0.0; n];
    let mut rr = 0.0;
    for part in partials {
        let part = part?;
        for (a, b) in jtj_packed.iter_mut().zip(&part.jtj) {
            *a += b;
        }
        for (a, b) in jtr.iter_mut().zip(&part.jtr) {
            *a += b;
        }
        rr += part.rr;
    }
    let mut jtj = DMatrix::zeros(n, n);
    let mut k = 0;
    for a in 0..n {
        for b in a..n {
            jtj[(a, b)] = jtj_packed[k];
            jtj[(b, a)] = jtj_packed[k];
            k += 1;
        }
    }
    let ok = rr.is_finite()
        && jtr.iter().all(|x| x.is_finite())
        && jtj_packed.iter().all(|x| x.is_finite());
    ok.then(|| NormalEquations {
        jtj,
        jtr: DVector::from_vec(jtr),
        cost: 0.5 * rr,
    })
}

/// ½‖r(p)‖², or None if infeasible / non-finite. Same chunking and order as the accumulation.
pub(crate) fn cost<P: LeastSquaresProblem + ?Sized>(problem: &P, p: &[f64]) -> Option<f64> {
    let m = problem.n_residuals();
    let n_chunks = m.div_ceil(CHUNK_ROWS);
    let partials: Vec<Option<f64>> = (0..n_chunks)
        .into_par_iter()
        .map_init(
            || vec![0.0; CHUNK_ROWS],
            |r, c| {
                let rows = c * CHUNK_ROWS..((c + 1) * CHUNK_ROWS).min(m);
                let len = rows.len();
                let r = &mut r[..len];
                problem.residuals(p, rows, r).then(|| dot(r, r))
            },
        )
        .collect();
    let mut rr = 0.0;
    for part in partials {
        rr += part?;
    }
    rr.is_finite().then_some(0.5 * rr)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-variable model y ≈ f(x; b) with its gradient, as NIST StRD states them.
    struct Curve {
        x: Vec<f64>,
        y: Vec<f64>,
        n: usize,
        f: fn(&[f64], f64, &mut [f64]) -> f64,
    }

    impl LeastSquaresProblem for Curve {
        fn n_params(&self) -> usize {
            self.n
        }
        fn n_residuals(&self) -> usize {
            self.x.len()
        }
        fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
            let mut g = vec![0.0; self.n];
            for (k, i) in rows.enumerate() {
                r[k] = (self.f)(p, self.x[i], &mut g) - self.y[i];
            }
            true
        }
        fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
            let mut g = vec![0.0; self.n];
            for (k, i) in rows.enumerate() {
                r[k] = (self.f)(p, self.x[i], &mut g) - self.y[i];
                jac[k * self.n..(k + 1) * self.n].copy_from_slice(&g);
            }
            true
        }
    }

    fn tight() -> LevenbergMarquardt {
        LevenbergMarquardt::new()
            .with_max_iterations(1000)
            .unwrap()
            .with_tolerances(1e-15, 1e-15, 1e-15)
            .unwrap()
    }

    fn check(name: &str, problem: &Curve, start: &[f64], certified: &[f64], rss: f64) {
        let rep = tight().solve(problem, start.to_vec()).unwrap();
        assert!(rep.termination.converged(), "{name}: {:?}", rep.termination);
        for (j, (got, want)) in rep.state.params.iter().zip(certified).enumerate() {
            let rel = ((got - want) / want).abs();
            assert!(
                rel < 1e-6,
                "{name} from {start:?}: b{} = {got} vs certified {want} (rel {rel:.2e})",
                j + 1
            );
        }
        let rel = (2.0 * rep.state.cost - rss).abs() / rss;
        assert!(rel < 1e-8, "{name}: RSS {} vs {rss}", 2.0 * rep.state.cost);
        let worst = rep
            .state
            .params
            .iter()
            .zip(certified)
            .map(|(g, w)| ((g - w) / w).abs())
            .fold(0.0, f64::max);
        eprintln!("{name} from {start:?}: worst parameter rel. error {worst:.1e}, RSS rel. error {rel:.1e}, {:?} after {} steps", rep.termination, rep.state.iterations);
    }

    // NIST StRD nonlinear regression data sets (https://www.itl.nist.gov/div898/strd/nls/),
    // data and certified values as published there (public domain).

    fn misra1a() -> Curve {
        Curve {
            y: vec![
                10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40,
                75.47, 81.78,
            ],
            x: vec![
                77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1,
                689.1, 760.0,
            ],
            n: 2,
            // y = b1 (1 − exp(−b2 x))
            f: |b, x, g| {
                let e = (-b[1] * x).exp();
                g[0] = 1.0 - e;
                g[1] = b[0] * x * e;
                b[0] * (1.0 - e)
            },
        }
    }

    #[test]
    fn nist_misra1a() {
        let cert = [2.3894212918E+02, 5.5015643181E-04];
        let rss = 1.2455138894E-01;
        check("Misra1a", &misra1a(), &[500.0, 1e-4], &cert, rss);
        check("Misra1a", &misra1a(), &[250.0, 5e-4], &cert, rss);
    }

    fn thurber() -> Curve {
        Curve {
            y: vec![
                80.574, 84.248, 87.264, 87.195, 89.076, 89.608, 89.868, 90.101, 92.405, 95.854,
                100.696, 101.060, 401.672, 390.724, 567.534, 635.316, 733.054, 759.087, 894.206,
                990.785, 1090.109, 1080.914, 1122.643, 1178.351, 1260.531, 1273.514, 1288.339,
                1327.543, 1353.863, 1414.509, 1425.208, 1421.384, 1442.962, 1464.350, 1468.705,
                1447.894, 1457.628,
            ],
            x: vec![
                -3.067, -2.981, -2.921, -2.912, -2.840, -2.797, -2.702, -2.699, -2.633, -2.481,
                -2.363, -2.322, -1.501, -1.460, -1.274, -1.212, -1.100, -1.046, -0.915, -0.714,
                -0.566, -0.545, -0.400, -0.309, -0.109, -0.103, 0.010, 0.119, 0.377, 0.790, 0.963,
                1.006, 1.115, 1.572, 1.841, 2.047, 2.200,
            ],
            n: 7,
            // y = (b1 + b2 x + b3 x² + b4 x³) / (1 + b5 x + b6 x² + b7 x³)
            f: |b, x, g| {
                let (x2, x3) = (x * x, x * x * x);
                let p = b[0] + b[1] * x + b[2] * x2 + b[3] * x3;
                let q = 1.0 + b[4] * x + b[5] * x2 + b[6] * x3;
                let f = p / q;
                g[0] = 1.0 / q;
                g[1] = x / q;
                g[2] = x2 / q;
                g[3] = x3 / q;
                g[4] = -f * x / q;
                g[5] = -f * x2 / q;
                g[6] = -f * x3 / q;
                f
            },
        }
    }

    #[test]
    fn nist_thurber_rational() {
        let cert = [
            1.2881396800E+03,
            1.4910792535E+03,
            5.8323836877E+02,
            7.5416644291E+01,
            9.6629502864E-01,
            3.9797285797E-01,
            4.9727297349E-02,
        ];
        let rss = 5.6427082397E+03;
        check(
            "Thurber",
            &thurber(),
            &[1000.0, 1000.0, 400.0, 40.0, 0.7, 0.3, 0.03],
            &cert,
            rss,
        );
        check(
            "Thurber",
            &thurber(),
            &[1300.0, 1500.0, 500.0, 75.0, 1.0, 0.4, 0.05],
            &cert,
            rss,
        );
    }

    fn mgh09() -> Curve {
        Curve {
            y: vec![
                1.957000E-01,
                1.947000E-01,
                1.735000E-01,
                1.600000E-01,
                8.440000E-02,
                6.270000E-02,
                4.560000E-02,
                3.420000E-02,
                3.230000E-02,
                2.350000E-02,
                2.460000E-02,
            ],
            x: vec![
                4.000000E+00,
                2.000000E+00,
                1.000000E+00,
                5.000000E-01,
                2.500000E-01,
                1.670000E-01,
                1.250000E-01,
                1.000000E-01,
                8.330000E-02,
                7.140000E-02,
                6.250000E-02,
            ],
            n: 4,
            // y = b1 (x² + x b2) / (x² + x b3 + b4)
            f: |b, x, g| {
                let p = x * x + x * b[1];
                let q = x * x + x * b[2] + b[3];
                let f = b[0] * p / q;
                g[0] = p / q;
                g[1] = b[0] * x / q;
                g[2] = -f * x / q;
                g[3] = -f / q;
                f
            },
        }
    }

    #[test]
    fn nist_mgh09() {
        let cert = [
            1.9280693458E-01,
            1.9128232873E-01,
            1.2305650693E-01,
            1.3606233068E-01,
        ];
        let rss = 3.0750560385E-04;
        check("MGH09", &mgh09(), &[0.25, 0.39, 0.415, 0.39], &cert, rss);
        check("MGH09", &mgh09(), &[25.0, 39.0, 41.5, 39.0], &cert, rss);
    }

    #[test]
    fn settings_are_validated() {
        assert!(LevenbergMarquardt::new().with_max_iterations(0).is_err());
        assert!(LevenbergMarquardt::new()
            .with_tolerances(1.0, 0.0, 0.0)
            .is_err());
        let e = LevenbergMarquardt::new()
            .with_initial_damping(-1.0)
            .unwrap_err();
        assert!(e.to_string().contains("initial_damping"), "{e}");
        assert!(LevenbergMarquardt::new()
            .solve(&misra1a(), vec![1.0])
            .is_err());
    }

    #[test]
    fn accumulation_is_deterministic_across_thread_counts() {
        // a problem with many chunks
        let m = 3 * CHUNK_ROWS + 17;
        let x: Vec<f64> = (0..m).map(|i| i as f64 / m as f64).collect();
        let y: Vec<f64> = x.iter().map(|&t| (3.0 * t).sin()).collect();
        let p = Curve {
            x,
            y,
            n: 7,
            f: thurber().f,
        };
        let run = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| {
                    let ne = normal_equations(&p, &[0.1, 2.0, -1.0, 0.3, 0.1, 0.2, 0.0]).unwrap();
                    (
                        ne.jtj.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        ne.cost.to_bits(),
                    )
                })
        };
        assert_eq!(run(1), run(4));
    }
}
