//! Objectives other than least squares, by reweighting a least-squares solver:
//! - mean absolute error: iteratively reweighted least squares with u_i = 1/max(|ρ_i|, δ)
//!   (Beaton & Tukey 1974; δ smooths the kink at ρ = 0),
//! - minimax: Lawson's algorithm u_i ← u_i |ρ_i| / Σ_j u_j |ρ_j| (Lawson 1961; Rice & Usow 1968,
//!   "The Lawson algorithm and extensions"), which converges to the best L∞ fit for linear
//!   problems and is used here as a heuristic for rationals,
//!
//! where ρ_i = w_i (f(x_i) − y_i). The best iterate in the target objective is kept.

use super::error::Result;
use super::lm::TerminationReason;
use super::result::Objective;

/// IRLS smoothing δ relative to the current mean |ρ|.
const IRLS_DELTA: f64 = 1e-3;
/// Lawson weights below this fraction of the largest are raised to it, so no point drops out
/// entirely and the weighted system stays full rank.
const LAWSON_WEIGHT_FLOOR: f64 = 1e-12;
/// Stop after this many rounds without improving the best objective value.
const PATIENCE: usize = 8;

/// The objective's value on weighted residuals ρ_i = w_i e_i.
pub(crate) fn objective_value(obj: Objective, w: &[f64], e: &[f64]) -> f64 {
    let rho = w.iter().zip(e).map(|(w, e)| w * e);
    match obj {
        Objective::LeastSquares => rho.map(|r| r * r).sum(),
        Objective::MeanAbsolute => rho.map(f64::abs).sum(),
        Objective::Minimax => rho.map(f64::abs).fold(0.0, f64::max),
    }
}

/// One weighted least-squares solve: given extra row weights and warm-start parameters,
/// returns (parameters, unweighted errors f − y, LM termination if any, LM steps), or None if
/// the solve failed to produce a usable point (e.g. a pole appeared).
pub(crate) type Solve<'a> = dyn FnMut(&[f64], &[f64]) -> Result<Option<Solved>> + 'a;

/// (parameters, errors f − y, LM termination, LM steps) of one reweighted solve.
pub(crate) type Solved = (Vec<f64>, Vec<f64>, Option<TerminationReason>, usize);

pub(crate) struct Reweighted {
    pub params: Vec<f64>,
    pub rounds: usize,
    pub converged: bool,
    pub termination: Option<TerminationReason>,
    pub lm_iterations: usize,
}

/// Reweighting loop for MeanAbsolute / Minimax from a least-squares solution `(p0, e0)`.
/// `accept` vets a new best candidate (e.g. the pole certificate for rationals).
pub(crate) fn reweight(
    objective: Objective,
    max_rounds: usize,
    w: &[f64],
    p0: Vec<f64>,
    e0: Vec<f64>,
    solve: &mut Solve<'_>,
    accept: &mut dyn FnMut(&[f64]) -> bool,
) -> Result<Reweighted> {
    let n = w.len();
    let mut best = (objective_value(objective, w, &e0), p0.clone());
    let mut out = Reweighted {
        params: p0.clone(),
        rounds: 0,
        converged: false,
        termination: None,
        lm_iterations: 0,
    };
    if objective == Objective::LeastSquares {
        out.converged = true;
        return Ok(out);
    }
    let mut u = vec![1.0; n];
    let (mut p, mut e) = (p0, e0);
    let mut since_best = 0;
    for round in 1..=max_rounds {
        let rho: Vec<f64> = w.iter().zip(&e).map(|(w, e)| (w * e).abs()).collect();
        match objective {
            Objective::MeanAbsolute => {
                let mean = rho.iter().sum::<f64>() / n as f64;
                let delta = (IRLS_DELTA * mean).max(f64::MIN_POSITIVE);
                for (ui, r) in u.iter_mut().zip(&rho) {
                    *ui = 1.0 / r.max(delta);
                }
            }
            Objective::Minimax => {
                for (ui, r) in u.iter_mut().zip(&rho) {
                    *ui *= r;
                }
                let umax = u.iter().fold(0.0f64, |m, &x| m.max(x));
                if !(umax > 0.0) {
                    out.converged = true; // exact fit
                    break;
                }
                for ui in u.iter_mut() {
                    *ui = (*ui / umax).max(LAWSON_WEIGHT_FLOOR);
                }
            }
            Objective::LeastSquares => unreachable!("returned above"),
        }
        let extra: Vec<f64> = u.iter().map(|x| x.sqrt()).collect();
        out.rounds = round;
        let Some((pn, en, term, its)) = solve(&extra, &p)? else {
            break;
        };
        out.termination = term;
        out.lm_iterations += its;
        p = pn;
        e = en;
        let value = objective_value(objective, w, &e);
        if value < best.0 * (1.0 - 1e-9) && accept(&p) {
            best = (value, p.clone());
            since_best = 0;
        } else {
            since_best += 1;
            if since_best >= PATIENCE {
                out.converged = true;
                break;
            }
        }
    }
    out.params = best.1;
    Ok(out)
}
