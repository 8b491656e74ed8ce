//! Levenberg–Marquardt for large least-squares problems as an [argmin] [`Solver`]: a problem
//! trait that produces residuals and Jacobian rows in chunks ([`LeastSquaresProblem`]), its
//! argmin operator ([`LeastSquares`]: cost ½‖r‖², gradient Jᵀr, Gauss–Newton Hessian JᵀJ),
//! validated settings ([`LevenbergMarquardt`]), the running solver ([`LmSolver`]) driven by
//! argmin's [`Executor`] (observers, iteration limit, termination status), and the result
//! ([`LmReport`]) with furnace's finer [`TerminationReason`].
//!
//! The Jacobian is never stored: JᵀJ and Jᵀr are accumulated over fixed chunks of
//! [`CHUNK_ROWS`] residuals in parallel (rayon) and the partial sums are added in chunk order,
//! so results are bit-for-bit identical for any thread count.
//!
//! Algorithm: Marquardt's scaled damping (Moré 1978, "The Levenberg–Marquardt algorithm:
//! implementation and theory": D = running max of the column norms of J) with Nielsen's damping
//! update (Madsen, Nielsen & Tingleff 2004, "Methods for non-linear least squares problems",
//! eq. 3.16) and MINPACK's three convergence tests (ftol, xtol, gtol). argmin has no
//! Levenberg–Marquardt; its trust-region method on the same Gauss–Newton model is the second
//! solver ([`super::trust_region`]).
//!
//! ```
//! use furnace::fit::{LeastSquaresProblem, LevenbergMarquardt};
//! use std::ops::Range;
//!
//! /// y = b0 · exp(b1 · x) through three exact points.
//! struct Exp;
//! const X: [f64; 3] = [0.0, 1.0, 2.0];
//! impl LeastSquaresProblem for Exp {
//!     fn n_params(&self) -> usize { 2 }
//!     fn n_residuals(&self) -> usize { 3 }
//!     fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
//!         for (k, i) in rows.enumerate() {
//!             r[k] = p[0] * (p[1] * X[i]).exp() - 2.0 * (0.5 * X[i]).exp();
//!         }
//!         true
//!     }
//!     fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
//!         for (k, i) in rows.enumerate() {
//!             let e = (p[1] * X[i]).exp();
//!             r[k] = p[0] * e - 2.0 * (0.5 * X[i]).exp();
//!             jac[2 * k] = e;
//!             jac[2 * k + 1] = p[0] * X[i] * e;
//!         }
//!         true
//!     }
//! }
//!
//! let report = LevenbergMarquardt::new().solve(&Exp, vec![1.0, 0.0]).unwrap();
//! assert!(report.termination.converged());
//! assert!((report.state.params[0] - 2.0).abs() < 1e-9 && (report.state.params[1] - 0.5).abs() < 1e-9);
//! ```
//!
//! [argmin]: https://argmin-rs.org

use std::cell::RefCell;
use std::ops::Range;

use argmin::core::{
    CostFunction, Error as ArgminError, Executor, Gradient, Hessian, IterState, OptimizationResult,
    Problem, Solver, State, TerminationReason as ArgminReason, TerminationStatus, KV,
};
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

/// The argmin state both least-squares solvers run on: parameters, ½‖r‖², and (for the trust
/// region) the gradient Jᵀr and the Gauss–Newton Hessian JᵀJ.
pub type LsqState = IterState<DVector<f64>, DVector<f64>, (), DMatrix<f64>, (), f64>;

/// A [`LeastSquaresProblem`] as an argmin operator: cost ½‖r(p)‖² (+∞ where `p` is
/// infeasible or inadmissible, so a solver rejects the step), gradient Jᵀr and Gauss–Newton
/// Hessian JᵀJ. Gradient and Hessian at the same point share one accumulation.
pub struct LeastSquares<'a, P: LeastSquaresProblem + ?Sized> {
    problem: &'a P,
    last: RefCell<Option<(Vec<f64>, NormalEquations)>>,
}

impl<'a, P: LeastSquaresProblem + ?Sized> LeastSquares<'a, P> {
    pub fn new(problem: &'a P) -> Self {
        LeastSquares {
            problem,
            last: RefCell::new(None),
        }
    }

    /// The wrapped problem.
    pub fn problem(&self) -> &'a P {
        self.problem
    }

    /// ½‖r(p)‖², or +∞ if `p` is inadmissible, infeasible or gives non-finite residuals.
    pub fn cost_at(&self, p: &[f64]) -> f64 {
        if self.problem.admissible(p) {
            cost(self.problem, p).unwrap_or(f64::INFINITY)
        } else {
            f64::INFINITY
        }
    }

    /// JᵀJ, Jᵀr and the cost at `p` (reused when asked again at the same point), or None if
    /// `p` is infeasible or non-finite.
    pub(crate) fn normal_equations_at(&self, p: &[f64]) -> Option<NormalEquations> {
        let mut last = self.last.borrow_mut();
        if let Some((q, ne)) = last.as_ref() {
            if q.iter().zip(p).all(|(a, b)| a.to_bits() == b.to_bits()) {
                return Some(ne.clone());
            }
        }
        let ne = normal_equations(self.problem, p)?;
        *last = Some((p.to_vec(), ne.clone()));
        Some(ne)
    }
}

fn infeasible_point() -> ArgminError {
    FitError::Solver {
        solver: "least-squares",
        message:
            "the Jacobian was requested at a point where the residuals are infeasible or non-finite"
                .into(),
    }
    .into()
}

impl<P: LeastSquaresProblem + ?Sized> CostFunction for LeastSquares<'_, P> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, p: &DVector<f64>) -> std::result::Result<f64, ArgminError> {
        Ok(self.cost_at(p.as_slice()))
    }
}

impl<P: LeastSquaresProblem + ?Sized> Gradient for LeastSquares<'_, P> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, p: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        self.normal_equations_at(p.as_slice())
            .map(|ne| ne.jtr)
            .ok_or_else(infeasible_point)
    }
}

impl<P: LeastSquaresProblem + ?Sized> Hessian for LeastSquares<'_, P> {
    type Param = DVector<f64>;
    type Hessian = DMatrix<f64>;
    fn hessian(&self, p: &DVector<f64>) -> std::result::Result<DMatrix<f64>, ArgminError> {
        self.normal_equations_at(p.as_slice())
            .map(|ne| ne.jtj)
            .ok_or_else(infeasible_point)
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

    /// What argmin's [`Executor`] records: converged reasons as `SolverConverged`, the
    /// iteration limit as `MaxItersReached`, the others as `SolverExit` with this text.
    pub fn to_argmin(self) -> ArgminReason {
        match self {
            r if r.converged() => ArgminReason::SolverConverged,
            TerminationReason::MaxIterations => ArgminReason::MaxItersReached,
            r => ArgminReason::SolverExit(r.text().into()),
        }
    }

    /// One line on the reason.
    pub fn text(self) -> &'static str {
        match self {
            TerminationReason::GradientSmall => "gradient orthogonal to the residuals (gtol)",
            TerminationReason::StepSmall => "step below xtol",
            TerminationReason::CostReductionSmall => "cost reduction below ftol",
            TerminationReason::ZeroResidual => "zero residual",
            TerminationReason::MaxIterations => "iteration limit",
            TerminationReason::NoProgress => "no decrease found (damping or radius at its limit)",
            TerminationReason::InfeasibleStart => "infeasible start",
        }
    }
}

/// Solver state, handed back with the result.
#[derive(Clone, Debug)]
pub struct LmState {
    pub params: Vec<f64>,
    /// ½ Σ r_i².
    pub cost: f64,
    /// Current damping λ (relative to the scaled JᵀJ, whose diagonal is ≤ 1); NaN for the
    /// trust-region solver, which has a radius instead.
    pub damping: f64,
    /// Nielsen's growth factor ν (NaN for the trust-region solver).
    pub nu: f64,
    /// Steps attempted (argmin's iteration count).
    pub iterations: usize,
    /// Jacobian accumulations.
    pub jacobian_evaluations: usize,
    /// max_j |g_j| / (‖J_j‖ ‖r‖) at the last accepted point.
    pub gradient_cosine: f64,
    /// The trust radius at the end (trust-region solver only).
    pub trust_radius: Option<f64>,
}

#[derive(Clone, Debug)]
pub struct LmReport {
    pub state: LmState,
    pub termination: TerminationReason,
}

/// Which least-squares solver a fit runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LsqMethod {
    /// [`LevenbergMarquardt`] (the default).
    #[default]
    LevenbergMarquardt,
    /// argmin's trust-region method with the dogleg step
    /// ([`super::trust_region::TrustRegionSettings`]), with the same iteration limit and
    /// tolerances.
    TrustRegion,
}

impl LsqMethod {
    /// Both, in the order benchmarks list them.
    pub const ALL: [LsqMethod; 2] = [LsqMethod::LevenbergMarquardt, LsqMethod::TrustRegion];

    /// Minimises ½‖r(p)‖² from `x0` with this method and `lm`'s iteration limit and
    /// tolerances.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(
        self,
        lm: &LevenbergMarquardt,
        problem: &P,
        x0: Vec<f64>,
    ) -> Result<LmReport> {
        match self {
            LsqMethod::LevenbergMarquardt => lm.solve(problem, x0),
            LsqMethod::TrustRegion => {
                super::trust_region::TrustRegionSettings::from_lm(lm).solve(problem, x0)
            }
        }
    }

    /// The method's name in reports.
    pub fn label(self) -> &'static str {
        match self {
            LsqMethod::LevenbergMarquardt => "Levenberg–Marquardt",
            LsqMethod::TrustRegion => "trust region (argmin, dogleg)",
        }
    }

    /// The name on the command line (`lm`, `trust-region`).
    pub fn name(self) -> &'static str {
        match self {
            LsqMethod::LevenbergMarquardt => "lm",
            LsqMethod::TrustRegion => "trust-region",
        }
    }
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

/// An iteration limit, at least 1.
pub(crate) fn check_max_iterations(n: usize) -> Result<usize> {
    if n == 0 {
        return Err(FitError::InvalidSetting {
            name: "max_iterations",
            value: n.to_string(),
            expected: "must be at least 1",
        });
    }
    Ok(n)
}

/// Checks a start: one finite value per parameter.
pub(crate) fn check_start(n: usize, x0: &[f64], what: &'static str) -> Result<()> {
    if x0.len() != n {
        return Err(FitError::ShapeMismatch {
            what,
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
    Ok(())
}

/// argmin's [`Executor`] for `solver` on `problem` from `x0` (checked: one finite value per
/// parameter) with `max_iterations` as argmin's iteration limit.
pub(crate) fn executor_for<'a, P, S>(
    problem: &'a P,
    solver: S,
    x0: Vec<f64>,
    max_iterations: usize,
    what: &'static str,
) -> Result<Executor<LeastSquares<'a, P>, S, LsqState>>
where
    P: LeastSquaresProblem + ?Sized,
    S: Solver<LeastSquares<'a, P>, LsqState>,
{
    check_start(problem.n_params(), &x0, what)?;
    let max_iters = max_iterations as u64;
    Ok(Executor::new(LeastSquares::new(problem), solver)
        .configure(|state| state.param(DVector::from_vec(x0)).max_iters(max_iters)))
}

/// Runs an executor, its errors as fit errors.
pub(crate) fn run<O, S>(
    executor: Executor<O, S, LsqState>,
    solver: &'static str,
) -> Result<OptimizationResult<O, S, LsqState>>
where
    S: Solver<O, LsqState>,
{
    executor.run().map_err(|e| from_argmin(solver, e))
}

/// An argmin error as a fit error (furnace's own errors pass through unchanged).
pub(crate) fn from_argmin(solver: &'static str, e: ArgminError) -> FitError {
    match e.downcast::<FitError>() {
        Ok(f) => f,
        Err(e) => FitError::Solver {
            solver,
            message: e.to_string(),
        },
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

    /// (ftol, xtol, gtol).
    pub fn tolerances(&self) -> (f64, f64, f64) {
        (self.ftol, self.xtol, self.gtol)
    }

    pub fn with_max_iterations(mut self, n: usize) -> Result<Self> {
        self.max_iterations = check_max_iterations(n)?;
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

    /// The argmin solver for these settings (its state starts empty; [`Self::executor`] sets
    /// the start and the iteration limit).
    pub fn solver(&self) -> LmSolver {
        LmSolver {
            settings: self.clone(),
            params: Vec::new(),
            ne: None,
            diag: Vec::new(),
            damping: self.initial_damping,
            nu: 2.0,
            jacobian_evaluations: 0,
            gradient_cosine: f64::INFINITY,
            reason: None,
        }
    }

    /// argmin's [`Executor`] for `problem` from `x0`, with these settings' iteration limit:
    /// add observers to it, run it, and read the result with [`LmReport::from_result`].
    /// Errors only on malformed input (wrong length, NaN start).
    pub fn executor<'a, P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &'a P,
        x0: Vec<f64>,
    ) -> Result<Executor<LeastSquares<'a, P>, LmSolver, LsqState>> {
        executor_for(
            problem,
            self.solver(),
            x0,
            self.max_iterations,
            "Levenberg–Marquardt start",
        )
    }

    /// Minimises ½‖r(p)‖² from `x0` under argmin's [`Executor`]. Errors only on malformed input
    /// (wrong length, NaN start); an infeasible start or non-convergence is reported through
    /// the termination reason.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        x0: Vec<f64>,
    ) -> Result<LmReport> {
        let result = run(self.executor(problem, x0)?, "Levenberg–Marquardt")?;
        Ok(LmReport::from_result(result))
    }
}

/// The Levenberg–Marquardt iteration as an argmin [`Solver`]: one `next_iter` is one attempted
/// step (accepted, or rejected with the damping raised). Made by [`LevenbergMarquardt::solver`].
#[derive(Clone, Debug)]
pub struct LmSolver {
    settings: LevenbergMarquardt,
    params: Vec<f64>,
    ne: Option<NormalEquations>,
    /// Moré's scaling D_j = max over iterations of ‖J_j‖ (1 for an all-zero column).
    diag: Vec<f64>,
    damping: f64,
    nu: f64,
    jacobian_evaluations: usize,
    gradient_cosine: f64,
    reason: Option<TerminationReason>,
}

impl LmSolver {
    fn stop(&mut self, state: LsqState, reason: TerminationReason) -> LsqState {
        self.reason = Some(reason);
        state.terminate_with(reason.to_argmin())
    }

    fn kv(&self, accepted: bool) -> KV {
        argmin::kv!(
            "damping" => self.damping;
            "gradient_cosine" => self.gradient_cosine;
            "accepted" => accepted;
        )
    }
}

impl<P: LeastSquaresProblem + ?Sized> Solver<LeastSquares<'_, P>, LsqState> for LmSolver {
    fn name(&self) -> &str {
        "Levenberg–Marquardt"
    }

    fn init(
        &mut self,
        problem: &mut Problem<LeastSquares<'_, P>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let x0 = state.get_param().ok_or_else(|| -> ArgminError {
            FitError::Solver {
                solver: "Levenberg–Marquardt",
                message: "no start given (configure the executor with a parameter vector)".into(),
            }
            .into()
        })?;
        self.params = x0.as_slice().to_vec();
        let start = problem.problem("jacobian_count", |op| {
            Ok(if op.problem.admissible(&self.params) {
                normal_equations(op.problem, &self.params)
            } else {
                None
            })
        })?;
        let Some(ne) = start else {
            let state = self.stop(state, TerminationReason::InfeasibleStart);
            return Ok((state, None));
        };
        self.jacobian_evaluations += 1;
        self.diag = (0..self.params.len()).map(|j| col_norm(&ne, j)).collect();
        let cost = ne.cost;
        self.ne = Some(ne);
        Ok((state.cost(cost), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<LeastSquares<'_, P>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let (ftol, xtol, max_damping) = (
            self.settings.ftol,
            self.settings.xtol,
            self.settings.max_damping,
        );
        let Some(ne) = self.ne.as_ref() else {
            return Err(FitError::Solver {
                solver: "Levenberg–Marquardt",
                message: "next_iter before a feasible init".into(),
            }
            .into());
        };
        let cost = ne.cost;
        // solve (D⁻¹JᵀJD⁻¹ + λI) z = −D⁻¹Jᵀr, δ = D⁻¹z
        let Some(delta) = damped_step(ne, &self.diag, self.damping) else {
            self.damping *= self.nu;
            self.nu *= 2.0;
            let kv = self.kv(false);
            if self.damping > max_damping {
                return Ok((self.stop(state, TerminationReason::NoProgress), Some(kv)));
            }
            return Ok((state, Some(kv)));
        };
        let dx_norm = delta
            .iter()
            .zip(&self.diag)
            .map(|(d, s)| (d * s).powi(2))
            .sum::<f64>()
            .sqrt();
        let x_norm = self
            .params
            .iter()
            .zip(&self.diag)
            .map(|(x, s)| (x * s).powi(2))
            .sum::<f64>()
            .sqrt();
        // predicted reduction of ½‖r + Jδ‖²: −gᵀδ − ½ δᵀJᵀJδ
        let jtj_delta = &ne.jtj * DVector::from_column_slice(&delta);
        let g_delta: f64 = delta.iter().zip(ne.jtr.iter()).map(|(a, b)| a * b).sum();
        let quad: f64 = delta.iter().zip(jtj_delta.iter()).map(|(a, b)| a * b).sum();
        let predicted = -g_delta - 0.5 * quad;

        let trial: Vec<f64> = self.params.iter().zip(&delta).map(|(x, d)| x + d).collect();
        let trial_cost = problem.problem("cost_count", |op| Ok(op.cost_at(&trial)))?;
        let actual = cost - trial_cost;
        let rho = if predicted > 0.0 {
            actual / predicted
        } else {
            f64::NEG_INFINITY
        };
        let small_step = dx_norm <= xtol * (x_norm + xtol);

        if rho > 0.0 && trial_cost.is_finite() {
            // (a finite cost but a non-finite Jacobian is treated as a rejection)
            let next = problem.problem("jacobian_count", |op| {
                Ok(normal_equations(op.problem, &trial))
            })?;
            if let Some(next) = next {
                self.jacobian_evaluations += 1;
                let old_cost = cost;
                let new_cost = next.cost;
                for (j, d) in self.diag.iter_mut().enumerate() {
                    *d = d.max(col_norm(&next, j));
                }
                self.ne = Some(next);
                self.damping *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                self.nu = 2.0;
                let state = state
                    .param(DVector::from_column_slice(&trial))
                    .cost(new_cost);
                self.params = trial;
                let kv = self.kv(true);
                if actual.abs() <= ftol * old_cost && predicted <= ftol * old_cost && rho <= 2.0 {
                    return Ok((
                        self.stop(state, TerminationReason::CostReductionSmall),
                        Some(kv),
                    ));
                }
                if small_step {
                    return Ok((self.stop(state, TerminationReason::StepSmall), Some(kv)));
                }
                return Ok((state, Some(kv)));
            }
        }
        // rejected
        if small_step {
            let kv = self.kv(false);
            return Ok((self.stop(state, TerminationReason::StepSmall), Some(kv)));
        }
        if predicted >= 0.0 && predicted <= ftol * cost && actual.abs() <= ftol * cost {
            let kv = self.kv(false);
            return Ok((
                self.stop(state, TerminationReason::CostReductionSmall),
                Some(kv),
            ));
        }
        self.damping *= self.nu;
        self.nu *= 2.0;
        let kv = self.kv(false);
        if self.damping > max_damping {
            return Ok((self.stop(state, TerminationReason::NoProgress), Some(kv)));
        }
        Ok((state, Some(kv)))
    }

    /// MINPACK's tests at the current point (zero residual, gradient cosine ≤ gtol), before
    /// argmin's own iteration limit.
    fn terminate(&mut self, _state: &LsqState) -> TerminationStatus {
        if let Some(r) = self.reason {
            return TerminationStatus::Terminated(r.to_argmin());
        }
        let Some(ne) = self.ne.as_ref() else {
            return TerminationStatus::NotTerminated;
        };
        if ne.cost == 0.0 {
            self.reason = Some(TerminationReason::ZeroResidual);
        } else {
            self.gradient_cosine = gradient_cosine(ne);
            if self.gradient_cosine <= self.settings.gtol {
                self.reason = Some(TerminationReason::GradientSmall);
            }
        }
        match self.reason {
            Some(r) => TerminationStatus::Terminated(r.to_argmin()),
            None => TerminationStatus::NotTerminated,
        }
    }
}

impl LmReport {
    /// The report of a finished Levenberg–Marquardt run (from [`LevenbergMarquardt::executor`]).
    pub fn from_result<P: LeastSquaresProblem + ?Sized>(
        result: OptimizationResult<LeastSquares<'_, P>, LmSolver, LsqState>,
    ) -> LmReport {
        let OptimizationResult { solver, state, .. } = result;
        let termination = solver
            .reason
            .unwrap_or(match state.get_termination_reason() {
                Some(ArgminReason::MaxItersReached) | None => TerminationReason::MaxIterations,
                // an interrupt or timeout an observer or the caller asked for: not converged
                Some(_) => TerminationReason::NoProgress,
            });
        LmReport {
            state: LmState {
                params: solver.params,
                cost: solver.ne.as_ref().map_or(f64::INFINITY, |ne| ne.cost),
                damping: solver.damping,
                nu: solver.nu,
                iterations: state.get_iter() as usize,
                jacobian_evaluations: solver.jacobian_evaluations,
                gradient_cosine: solver.gradient_cosine,
                trust_radius: None,
            },
            termination,
        }
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

/// Rows of JᵀJ per matrix product in [`upper_gram`]: a multiple of the 8 rows of
/// matrixmultiply's f64 micro-kernel.
const GRAM_BLOCK_ROWS: usize = 24;

/// Below this many rows or columns nalgebra's `gemm` does not call matrixmultiply (its
/// `SMALL_DIM` is 5): [`upper_gram`] then takes the one full product, as every block must go
/// through the same kernel for the sums to be the same bit for bit.
const GRAM_MIN_DIM: usize = 6;

/// The upper triangle of JᵀJ, packed row by row ((0,0), (0,1), …, (0,n−1), (1,1), …), for
/// `jt` = Jᵀ (n × len) and `jv` = J (len × n).
///
/// Row block [a0, a1) of JᵀJ is needed only from column a0 on, so it is one product
/// Jᵀ[a0..a1, :] · J[:, a0..n]: about (n + GRAM_BLOCK_ROWS)/(2n) of the full product's
/// multiply-adds (58 % at n = 139). Each entry is the same sum as in the full product
/// (matrixmultiply adds over the len rows in the same fixed order whatever the entry's place:
/// kc-blocks in turn, one fused multiply-add per row within a block), so the result is the
/// full product's bit for bit; `upper_gram_is_the_full_product_bit_for_bit` checks it.
fn upper_gram(jt: &DMatrixView<'_, f64>, jv: &DMatrixView<'_, f64, Dyn, Dyn>) -> Vec<f64> {
    let n = jt.nrows();
    let len = jt.ncols();
    let mut packed = Vec::with_capacity(n * (n + 1) / 2);
    if n < 2 * GRAM_BLOCK_ROWS || len < GRAM_MIN_DIM {
        let mut block = DMatrix::zeros(n, n);
        block.gemm(1.0, jt, jv, 0.0);
        for a in 0..n {
            for b in a..n {
                packed.push(block[(a, b)]);
            }
        }
        return packed;
    }
    let mut a0 = 0;
    while a0 < n {
        // the last block takes a remainder too short for the kernel's path
        let a1 = if n - a0 < GRAM_BLOCK_ROWS + GRAM_MIN_DIM {
            n
        } else {
            a0 + GRAM_BLOCK_ROWS
        };
        let rows = jt.rows(a0, a1 - a0);
        let cols = jv.columns(a0, n - a0);
        let mut block = DMatrix::zeros(a1 - a0, n - a0);
        block.gemm(1.0, &rows, &cols, 0.0);
        for a in a0..a1 {
            for b in a..n {
                packed.push(block[(a - a0, b - a0)]);
            }
        }
        a0 = a1;
    }
    packed
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
                // JᵀJ of the block: its upper triangle by blocked matrix products
                // ([`upper_gram`]). The row-major block is Jᵀ in column-major (n × len), and J
                // the same memory read with swapped strides, so nothing is copied.
                let jt = DMatrixView::from_slice(jac, n, len);
                let jv = DMatrixView::from_slice_with_strides_generic(
                    jac,
                    Dyn(len),
                    Dyn(n),
                    Dyn(n),
                    Dyn(1),
                );
                let jtj = upper_gram(&jt, &jv);
                let mut jtr_block = DVector::zeros(n);
                jtr_block.gemv(1.0, &jt, &DVectorView::from_slice(r, len), 0.0);
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

    /// The full product's upper triangle, packed as [`upper_gram`] packs it.
    fn full_gram(jac: &[f64], n: usize, len: usize) -> Vec<f64> {
        let jt = DMatrixView::from_slice(jac, n, len);
        let jv =
            DMatrixView::from_slice_with_strides_generic(jac, Dyn(len), Dyn(n), Dyn(n), Dyn(1));
        let mut block = DMatrix::zeros(n, n);
        block.gemm(1.0, &jt, &jv, 0.0);
        (0..n)
            .flat_map(|a| (a..n).map(move |b| (a, b)))
            .map(|(a, b)| block[(a, b)])
            .collect()
    }

    #[test]
    fn upper_gram_is_the_full_product_bit_for_bit() {
        // values of mixed signs and magnitudes (a fixed linear congruential sequence), so
        // that a different order of the additions would show in the last bits
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            (u - 0.4) * 10f64.powi((state % 7) as i32 - 3)
        };
        let sizes = [
            (139, 4096),
            (160, 1000),
            (48, 4096),
            (49, 300),
            (53, 6),
            (77, 5),
            (30, 4096),
            (1, 10),
        ];
        for (n, len) in sizes {
            let jac: Vec<f64> = (0..n * len).map(|_| next()).collect();
            let jt = DMatrixView::from_slice(&jac, n, len);
            let jv = DMatrixView::from_slice_with_strides_generic(
                &jac,
                Dyn(len),
                Dyn(n),
                Dyn(n),
                Dyn(1),
            );
            let got = upper_gram(&jt, &jv);
            let want = full_gram(&jac, n, len);
            assert_eq!(got.len(), n * (n + 1) / 2);
            let differ = got
                .iter()
                .zip(&want)
                .filter(|(a, b)| a.to_bits() != b.to_bits())
                .count();
            assert_eq!(differ, 0, "n = {n}, len = {len}");
            // and it is JᵀJ: one entry against a plain sum
            let (a, b) = (n / 2, n - 1);
            let terms = (0..len).map(|k| jac[k * n + a] * jac[k * n + b]);
            let exact: f64 = terms.clone().sum();
            let scale: f64 = terms.map(f64::abs).sum();
            let idx = (0..a).map(|x| n - x).sum::<usize>() + (b - a);
            assert!(
                (got[idx] - exact).abs() <= 1e-12 * scale,
                "{} vs {exact}",
                got[idx]
            );
        }
    }

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

    /// The same problems with argmin's trust region (from the starts near the solution: the
    /// unscaled dogleg needs many more steps than Levenberg–Marquardt from far away).
    #[test]
    fn nist_problems_with_the_trust_region() {
        use crate::fit::trust_region::TrustRegionSettings;
        let tr = TrustRegionSettings::from_lm(&tight().with_max_iterations(5000).unwrap());
        for (name, problem, start, cert, rss) in [
            (
                "Misra1a",
                misra1a(),
                vec![250.0, 5e-4],
                vec![2.3894212918E+02, 5.5015643181E-04],
                1.2455138894E-01,
            ),
            (
                "MGH09",
                mgh09(),
                vec![0.25, 0.39, 0.415, 0.39],
                vec![
                    1.9280693458E-01,
                    1.9128232873E-01,
                    1.2305650693E-01,
                    1.3606233068E-01,
                ],
                3.0750560385E-04,
            ),
            (
                "Thurber",
                thurber(),
                vec![1300.0, 1500.0, 500.0, 75.0, 1.0, 0.4, 0.05],
                vec![
                    1.2881396800E+03,
                    1.4910792535E+03,
                    5.8323836877E+02,
                    7.5416644291E+01,
                    9.6629502864E-01,
                    3.9797285797E-01,
                    4.9727297349E-02,
                ],
                5.6427082397E+03,
            ),
        ] {
            let rep = tr.solve(&problem, start).unwrap();
            let worst = rep
                .state
                .params
                .iter()
                .zip(&cert)
                .map(|(g, w)| ((g - w) / w).abs())
                .fold(0.0, f64::max);
            let rel = (2.0 * rep.state.cost - rss).abs() / rss;
            eprintln!(
                "trust region {name}: worst parameter rel. error {worst:.1e}, RSS rel. error {rel:.1e}, {:?} after {} steps",
                rep.termination, rep.state.iterations
            );
            assert!(rep.termination.converged(), "{name}: {:?}", rep.termination);
            assert!(worst < 1e-5 && rel < 1e-8, "{name}: {worst:.2e}, {rel:.2e}");
        }
    }

    /// Both solvers run under argmin's executor: an observer sees every iteration, the cost
    /// never rises, and argmin's termination status agrees with furnace's reason.
    #[test]
    fn the_executor_drives_both_solvers_with_observers() {
        use crate::fit::trust_region::TrustRegionSettings;
        use argmin::core::observers::{Observe, ObserverMode};
        use std::sync::{Arc, Mutex};

        #[derive(Clone, Default)]
        struct Costs(Arc<Mutex<Vec<f64>>>);
        impl Observe<LsqState> for Costs {
            fn observe_iter(
                &mut self,
                state: &LsqState,
                _kv: &KV,
            ) -> std::result::Result<(), ArgminError> {
                self.0.lock().unwrap().push(state.get_cost());
                Ok(())
            }
        }
        let check = |costs: &Costs, iterations: usize, status: &TerminationStatus| {
            let costs = costs.0.lock().unwrap();
            assert_eq!(costs.len(), iterations);
            assert!(costs.windows(2).all(|w| w[1] <= w[0]), "{costs:?}");
            assert_eq!(
                *status,
                TerminationStatus::Terminated(ArgminReason::SolverConverged)
            );
        };

        fn observed<'a, S: Solver<LeastSquares<'a, Curve>, LsqState>>(
            executor: Executor<LeastSquares<'a, Curve>, S, LsqState>,
        ) -> (
            OptimizationResult<LeastSquares<'a, Curve>, S, LsqState>,
            Costs,
        ) {
            let costs = Costs::default();
            let result = executor
                .add_observer(costs.clone(), ObserverMode::Always)
                .run()
                .unwrap();
            (result, costs)
        }

        let problem = misra1a();
        let lm = tight();
        let (result, costs) = observed(lm.executor(&problem, vec![500.0, 1e-4]).unwrap());
        let status = result.state.get_termination_status().clone();
        let rep = LmReport::from_result(result);
        assert!(rep.termination.converged(), "{:?}", rep.termination);
        check(&costs, rep.state.iterations, &status);

        let tr = TrustRegionSettings::from_lm(&lm);
        let (result, costs) = observed(tr.executor(&problem, vec![250.0, 5e-4]).unwrap());
        let status = result.state.get_termination_status().clone();
        let rep = TrustRegionSettings::report(result);
        assert!(rep.termination.converged(), "{:?}", rep.termination);
        check(&costs, rep.state.iterations, &status);
    }

    /// The iteration limit is argmin's: MaxIterations after exactly that many steps.
    #[test]
    fn the_iteration_limit_stops_both_solvers() {
        let lm = LevenbergMarquardt::new().with_max_iterations(3).unwrap();
        let start = vec![1000.0, 1000.0, 400.0, 40.0, 0.7, 0.3, 0.03];
        for method in LsqMethod::ALL {
            let rep = method.solve(&lm, &thurber(), start.clone()).unwrap();
            assert_eq!(
                (rep.termination, rep.state.iterations),
                (TerminationReason::MaxIterations, 3),
                "{method:?}"
            );
        }
    }

    /// A start where the model cannot be evaluated is reported, not an error, by both solvers.
    #[test]
    fn an_infeasible_start_is_a_termination_reason() {
        struct Infeasible;
        impl LeastSquaresProblem for Infeasible {
            fn n_params(&self) -> usize {
                1
            }
            fn n_residuals(&self) -> usize {
                2
            }
            fn residuals(&self, _p: &[f64], _rows: Range<usize>, _r: &mut [f64]) -> bool {
                false
            }
            fn jacobian(
                &self,
                _p: &[f64],
                _rows: Range<usize>,
                _r: &mut [f64],
                _j: &mut [f64],
            ) -> bool {
                false
            }
        }
        for method in LsqMethod::ALL {
            let rep = method
                .solve(&LevenbergMarquardt::new(), &Infeasible, vec![1.0])
                .unwrap();
            assert_eq!(
                (rep.termination, rep.state.iterations),
                (TerminationReason::InfeasibleStart, 0),
                "{method:?}"
            );
            assert_eq!(rep.state.params, [1.0], "{method:?}");
        }
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
