//! The second least-squares solver: argmin's trust-region method (Nocedal & Wright 2006,
//! "Numerical Optimization", Algorithm 4.1) with its dogleg step (§4.1) on the Gauss–Newton
//! model m(δ) = ½‖r‖² + (Jᵀr)ᵀδ + ½ δᵀJᵀJδ, driven by argmin's [`Executor`] on the same operator
//! as Levenberg–Marquardt ([`LeastSquares`]).
//!
//! argmin's `TrustRegion` never declares convergence by itself, so [`TrustRegionSolver`] wraps
//! it with the stopping tests of [`LevenbergMarquardt`] and its tolerances: gradient cosine
//! ≤ gtol, relative cost reduction of an accepted step ≤ ftol, scaled step ≤ xtol relative to
//! the scaled parameters; a radius that shrinks to nothing is `NoProgress`.
//! Infeasible trial points (a rational's pole at the data, an inadmissible denominator) cost +∞,
//! which the trust region rejects by shrinking its radius.

use argmin::core::{
    Error as ArgminError, Executor, OptimizationResult, Problem, Solver, State, TerminationStatus,
    KV,
};
use argmin::solver::trustregion::{Dogleg, TrustRegion};
use nalgebra::DVector;

use super::error::{FitError, Result};
use super::lm::{
    check_max_iterations, executor_for, from_argmin, run, LeastSquares, LeastSquaresProblem,
    LevenbergMarquardt, LmReport, LmState, LsqState, TerminationReason,
};

/// Trust-region settings. Construct with [`TrustRegionSettings::new`] or
/// [`TrustRegionSettings::from_lm`] (the iteration limit and tolerances of Levenberg–Marquardt
/// settings), adjust with the validating `with_*` setters.
#[derive(Clone, Debug, PartialEq)]
pub struct TrustRegionSettings {
    max_iterations: usize,
    ftol: f64,
    xtol: f64,
    gtol: f64,
    initial_radius: f64,
    max_radius: f64,
    eta: f64,
}

impl Default for TrustRegionSettings {
    fn default() -> Self {
        TrustRegionSettings::new()
    }
}

/// A radius below this, relative to the parameters' norm, cannot move them in f64 (a quarter of
/// the unit roundoff): the run has stalled.
const MIN_RELATIVE_RADIUS: f64 = f64::EPSILON / 4.0;

impl TrustRegionSettings {
    /// Defaults: Levenberg–Marquardt's iteration limit and tolerances
    /// ([`LevenbergMarquardt::new`]), initial radius 1, maximal radius 100 and acceptance
    /// threshold η = 0.125 (argmin's defaults).
    pub fn new() -> Self {
        TrustRegionSettings::from_lm(&LevenbergMarquardt::new())
    }

    /// The iteration limit and tolerances of `lm`, argmin's radius defaults.
    pub fn from_lm(lm: &LevenbergMarquardt) -> Self {
        let (ftol, xtol, gtol) = lm.tolerances();
        TrustRegionSettings {
            max_iterations: lm.max_iterations(),
            ftol,
            xtol,
            gtol,
            initial_radius: 1.0,
            max_radius: 100.0,
            eta: 0.125,
        }
    }

    pub fn with_max_iterations(mut self, n: usize) -> Result<Self> {
        self.max_iterations = check_max_iterations(n)?;
        Ok(self)
    }

    /// Initial and maximal radius, 0 < initial ≤ maximal, both finite.
    pub fn with_radius(mut self, initial: f64, max: f64) -> Result<Self> {
        if !(initial > 0.0 && initial <= max && max.is_finite()) {
            return Err(FitError::InvalidSetting {
                name: "radius",
                value: format!("{initial} (max {max})"),
                expected: "must satisfy 0 < initial ≤ max < ∞",
            });
        }
        (self.initial_radius, self.max_radius) = (initial, max);
        Ok(self)
    }

    fn solver(&self) -> Result<TrustRegionSolver> {
        let argmin = |e| from_argmin("trust-region", e);
        let inner = TrustRegion::new(Dogleg::new())
            .with_radius(self.initial_radius)
            .map_err(argmin)?
            .with_max_radius(self.max_radius)
            .map_err(argmin)?
            .with_eta(self.eta)
            .map_err(argmin)?;
        Ok(TrustRegionSolver {
            inner,
            settings: self.clone(),
            radius: self.initial_radius,
            gradient_cosine: f64::INFINITY,
            jacobian_evaluations: 0,
            reason: None,
        })
    }

    /// argmin's [`Executor`] for `problem` from `x0` with these settings' iteration limit: add
    /// observers, run it, read it with [`TrustRegionSettings::report`].
    pub fn executor<'a, P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &'a P,
        x0: Vec<f64>,
    ) -> Result<Executor<LeastSquares<'a, P>, TrustRegionSolver, LsqState>> {
        executor_for(
            problem,
            self.solver()?,
            x0,
            self.max_iterations,
            "trust-region start",
        )
    }

    /// Minimises ½‖r(p)‖² from `x0`. Errors only on malformed input; an infeasible start or
    /// non-convergence is reported through the termination reason.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        x0: Vec<f64>,
    ) -> Result<LmReport> {
        let result = run(self.executor(problem, x0)?, "trust-region")?;
        Ok(Self::report(result))
    }

    /// The report of a finished run.
    pub fn report<P: LeastSquaresProblem + ?Sized>(
        result: OptimizationResult<LeastSquares<'_, P>, TrustRegionSolver, LsqState>,
    ) -> LmReport {
        let OptimizationResult { solver, state, .. } = result;
        let termination = solver.reason.unwrap_or(TerminationReason::MaxIterations);
        let params = state
            .get_param()
            .map(|p| p.as_slice().to_vec())
            .unwrap_or_default();
        LmReport {
            state: LmState {
                params,
                cost: state.get_cost(),
                damping: f64::NAN,
                nu: f64::NAN,
                iterations: state.get_iter() as usize,
                jacobian_evaluations: solver.jacobian_evaluations,
                gradient_cosine: solver.gradient_cosine,
                trust_radius: Some(solver.radius),
            },
            termination,
        }
    }
}

/// argmin's `TrustRegion<Dogleg>` with Levenberg–Marquardt's stopping tests, as an argmin
/// [`Solver`]. Made by [`TrustRegionSettings::executor`].
#[derive(Clone)]
pub struct TrustRegionSolver {
    inner: TrustRegion<Dogleg<f64>, f64>,
    settings: TrustRegionSettings,
    /// The radius of the last step (argmin reports it per iteration).
    radius: f64,
    gradient_cosine: f64,
    jacobian_evaluations: usize,
    reason: Option<TerminationReason>,
}

impl TrustRegionSolver {
    fn stop(&mut self, state: LsqState, reason: TerminationReason) -> LsqState {
        self.reason = Some(reason);
        state.terminate_with(reason.to_argmin())
    }
}

/// max_j |g_j| / (‖J_j‖ ‖r‖), from Jᵀr, the diagonal of JᵀJ and the cost ½‖r‖² (as
/// Levenberg–Marquardt's gtol test).
fn gradient_cosine(state: &LsqState) -> f64 {
    let (Some(g), Some(h)) = (state.get_gradient(), state.get_hessian()) else {
        return f64::INFINITY;
    };
    let rnorm = (2.0 * state.get_cost()).sqrt();
    (0..g.len())
        .map(|j| {
            let cn = h[(j, j)].max(0.0).sqrt();
            if cn > 0.0 {
                g[j].abs() / (cn * rnorm)
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}

/// ‖D x‖ with D_j = ‖J_j‖ (1 for an all-zero column): Levenberg–Marquardt's scaled norm.
fn scaled_norm(x: &DVector<f64>, state: &LsqState) -> f64 {
    let Some(h) = state.get_hessian() else {
        return x.norm();
    };
    x.iter()
        .enumerate()
        .map(|(j, v)| {
            let c = h[(j, j)].max(0.0).sqrt();
            let d = if c > 0.0 && c.is_finite() { c } else { 1.0 };
            (v * d).powi(2)
        })
        .sum::<f64>()
        .sqrt()
}

impl<P: LeastSquaresProblem + ?Sized> Solver<LeastSquares<'_, P>, LsqState> for TrustRegionSolver {
    fn name(&self) -> &str {
        "trust region (dogleg)"
    }

    fn init(
        &mut self,
        problem: &mut Problem<LeastSquares<'_, P>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let x0 = state.get_param().cloned().unwrap_or_default();
        // the start's normal equations, kept by the operator for the gradient and Hessian that
        // argmin's init asks for next
        let cost = problem.problem("jacobian_count", |op| {
            Ok(if op.problem().admissible(x0.as_slice()) {
                op.normal_equations_at(x0.as_slice()).map(|ne| ne.cost)
            } else {
                None
            })
        })?;
        let Some(cost) = cost else {
            let state = state.cost(f64::INFINITY);
            return Ok((self.stop(state, TerminationReason::InfeasibleStart), None));
        };
        self.jacobian_evaluations += 1;
        <TrustRegion<Dogleg<f64>, f64> as Solver<LeastSquares<'_, P>, LsqState>>::init(
            &mut self.inner,
            problem,
            state.cost(cost),
        )
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<LeastSquares<'_, P>>,
        state: LsqState,
    ) -> std::result::Result<(LsqState, Option<KV>), ArgminError> {
        let old_cost = state.get_cost();
        let old_param = state.get_param().cloned().unwrap_or_default();
        let x_norm = scaled_norm(&old_param, &state);
        let (state, kv) = <TrustRegion<Dogleg<f64>, f64> as Solver<
            LeastSquares<'_, P>,
            LsqState,
        >>::next_iter(&mut self.inner, problem, state)?;
        if let Some(r) = kv
            .as_ref()
            .and_then(|kv| kv.get("radius"))
            .and_then(|v| v.get_float())
        {
            self.radius = r;
        }
        let new_param = state.get_param().cloned().unwrap_or_default();
        let accepted = new_param != old_param;
        if accepted {
            self.jacobian_evaluations += 1;
        }
        let step = scaled_norm(&(&new_param - &old_param), &state);
        let (ftol, xtol) = (self.settings.ftol, self.settings.xtol);
        let reduction = old_cost - state.get_cost();
        let state = if accepted && reduction.abs() <= ftol * old_cost {
            self.stop(state, TerminationReason::CostReductionSmall)
        } else if accepted && step <= xtol * (x_norm + xtol) {
            self.stop(state, TerminationReason::StepSmall)
        } else if self.radius <= xtol * (old_param.norm() + xtol) {
            // MINPACK's xtol test on the radius (Moré 1978, §7): no step that short can matter
            self.stop(state, TerminationReason::StepSmall)
        } else if !(self.radius.is_finite() && self.radius > MIN_RELATIVE_RADIUS * old_param.norm())
        {
            self.stop(state, TerminationReason::NoProgress)
        } else {
            state
        };
        Ok((state, kv))
    }

    /// Zero residual and the gradient test (gtol) at the current point, before argmin's own
    /// iteration limit.
    fn terminate(&mut self, state: &LsqState) -> TerminationStatus {
        if self.reason.is_none() {
            if state.get_cost() == 0.0 {
                self.reason = Some(TerminationReason::ZeroResidual);
            } else {
                self.gradient_cosine = gradient_cosine(state);
                if self.gradient_cosine <= self.settings.gtol {
                    self.reason = Some(TerminationReason::GradientSmall);
                }
            }
        }
        match self.reason {
            Some(r) => TerminationStatus::Terminated(r.to_argmin()),
            None => TerminationStatus::NotTerminated,
        }
    }
}
