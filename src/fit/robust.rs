//! Objectives other than least squares, by reweighting a least-squares solver:
//! - mean absolute error: iteratively reweighted least squares with u_i = 1/max(|ρ_i|, δ)
//!   (Beaton & Tukey 1974; δ smooths the kink at ρ = 0),
//! - minimax: Lawson's algorithm u_i ← u_i |ρ_i| / Σ_j u_j |ρ_j| (Lawson 1961; Rice & Usow 1968,
//!   "The Lawson algorithm and extensions"), which converges to the best L∞ fit for linear
//!   problems and is used here as a heuristic for rationals,
//!
//! where ρ_i = w_i (f(x_i) − y_i). The best iterate in the target objective is kept.
//!
//! Lawson's iterates trade mean error for max error as the weights concentrate on the worst
//! points, so the path itself is a family of fits: for minimax the loop also keeps a few
//! iterates of its (max, MAE) Pareto front ([`PathIterate`]), the lowest max error among those
//! whose MAE stays within each of [`PATH_MAE_BOUNDS`] × the least-squares start's. A short
//! branch from the same start solves with weights blended towards uniform ([`LAWSON_BLEND`]),
//! passing through fits of small MAE cost that Lawson's first round jumps over.
//!
//! On request (`lp_polish`, empty by default) a minimax refit also runs an L_p polish from the
//! least-squares fit: Levenberg–Marquardt on Σ |ρ_i|^p ([`PnormProblem`]) for a rising list of
//! p, each solve warm-started from the previous one, every solve one more iterate of the path.

use super::error::Result;
use super::lm::{LeastSquaresProblem, TerminationReason};
use super::result::Objective;
use std::ops::Range;

/// IRLS smoothing δ relative to the current mean |ρ|.
const IRLS_DELTA: f64 = 1e-3;
/// Lawson weights below this fraction of the largest are raised to it, so no point drops out
/// entirely and the weighted system stays full rank.
const LAWSON_WEIGHT_FLOOR: f64 = 1e-12;
/// Stop after this many rounds without improving the best objective value.
const PATIENCE: usize = 8;
/// The Lawson path iterates kept beside the best one: per bound b, the iterate with the lowest
/// max error among those whose MAE (on the fitting points) is at most b × the start's.
pub(crate) const PATH_MAE_BOUNDS: [f64; 3] = [1.15, 1.3, 1.5];
/// A blended branch of the path: rounds solved with the weights (1 − λ)·1 + λ·u (u Lawson's,
/// normalised to a largest of 1), λ from this list in turn, u updated as Lawson's: it passes
/// through fits of small MAE cost that Lawson's own first round jumps over.
pub(crate) const LAWSON_BLEND: [f64; 3] = [0.25, 0.5, 0.75];
/// Candidates tried per bound when `accept` (a pole certificate) rejects the first.
const PATH_TRIES: usize = 3;

/// An iterate of the Lawson path kept beside the lowest-objective one.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PathIterate {
    /// The reweighting round that produced it (1 = the first reweighted solve).
    pub round: usize,
    /// The MAE bound (a multiple of the least-squares start's MAE) it was kept for.
    pub mae_bound: f64,
    /// λ of the weights it was solved with (< 1: the blended branch, [`LAWSON_BLEND`]; 1 =
    /// Lawson's own).
    pub blend: f64,
    /// p of the L_p polish it came from ([`pnorm_branch`]); None for Lawson's path.
    pub pnorm: Option<f64>,
    /// λ of the max–mean polish it came from ([`max_mean_branch`]); None otherwise.
    pub max_mean: Option<f64>,
    pub params: Vec<f64>,
}

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
    /// The round of the kept (lowest-objective) iterate; 0 = the start.
    pub best_round: usize,
    /// Minimax only: other iterates of the path ([`PATH_MAE_BOUNDS`]), in the bounds' order,
    /// each with a lower max error than the start, none the best iterate itself.
    pub path: Vec<PathIterate>,
}

/// Reweighting loop for MeanAbsolute / Minimax from a least-squares solution `(p0, e0)`.
/// `accept` vets a new best candidate (e.g. the pole certificate for rationals).
///
/// For minimax, a short branch of [`LAWSON_BLEND`]`.len()` rounds from the same start solves
/// with blended weights first; its iterates are candidates of the path only. With
/// `lp_polish` (its p values and an L_p solve), the polish of [`pnorm_branch`] runs from the
/// same start last, each of its accepted solves a path iterate ([`pnorm_path`]).
pub(crate) fn reweight(
    objective: Objective,
    max_rounds: usize,
    w: &[f64],
    (p0, e0): (Vec<f64>, Vec<f64>),
    solve: &mut Solve<'_>,
    lp_polish: Option<(&[f64], &mut PnormSolve<'_>)>,
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
        best_round: 0,
        path: Vec::new(),
    };
    if objective == Objective::LeastSquares {
        out.converged = true;
        return Ok(out);
    }
    // every minimax iterate, for the path
    let mut iterates: Vec<Iterate> = Vec::new();
    let start = (max_abs(w, &e0), mean_abs(w, &e0));
    if objective == Objective::Minimax {
        let mut u = vec![1.0; n];
        let (mut p, mut e) = (p0.clone(), e0.clone());
        for (round, &blend) in (1..).zip(&LAWSON_BLEND) {
            if !lawson_update(&mut u, w, &e) {
                break;
            }
            let Some((pn, en, _, _)) = solve(&blended_roots(&u, blend), &p)? else {
                break;
            };
            (p, e) = (pn, en);
            iterates.push(Iterate {
                round,
                blend,
                pnorm: None,
                max_mean: None,
                max: max_abs(w, &e),
                mae: mean_abs(w, &e),
                params: p.clone(),
            });
        }
    }
    let ls_start = (p0.clone(), e0.clone());
    let mut u = vec![1.0; n];
    let (mut p, mut e) = (p0, e0);
    let mut since_best = 0;
    for round in 1..=max_rounds {
        match objective {
            Objective::MeanAbsolute => {
                let rho: Vec<f64> = w.iter().zip(&e).map(|(w, e)| (w * e).abs()).collect();
                let mean = rho.iter().sum::<f64>() / n as f64;
                let delta = (IRLS_DELTA * mean).max(f64::MIN_POSITIVE);
                for (ui, r) in u.iter_mut().zip(&rho) {
                    *ui = 1.0 / r.max(delta);
                }
            }
            Objective::Minimax => {
                if !lawson_update(&mut u, w, &e) {
                    out.converged = true; // exact fit
                    break;
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
        if objective == Objective::Minimax {
            iterates.push(Iterate {
                round,
                blend: 1.0,
                pnorm: None,
                max_mean: None,
                max: value,
                mae: mean_abs(w, &e),
                params: p.clone(),
            });
        }
        if value < best.0 * (1.0 - 1e-9) && accept(&p) {
            best = (value, p.clone());
            out.best_round = round;
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
    out.path = path_iterates(&iterates, start, out.best_round, accept);
    if let (Objective::Minimax, Some((ps, pnorm_solve))) = (objective, lp_polish) {
        let polished = pnorm_branch(w, ls_start, ps, pnorm_solve)?;
        out.path.extend(pnorm_path(&polished, start.1, accept));
    }
    Ok(out)
}

/// A least-squares problem's residuals r_i turned into R_i = s·sign(r_i)·|r_i/s|^(p/2), so
/// that ½ Σ R_i² = ½ s² Σ |r_i/s|^p: Levenberg–Marquardt on it minimises the L_p norm of the
/// residuals (p ≥ 2; the smoothed max norm of Lawson 1961 and Rice & Usow 1968 as p grows),
/// with the Jacobian rows scaled by ∂R_i/∂r_i = (p/2)·|r_i/s|^(p/2 − 1). s (the start's largest
/// |r_i|) keeps the powers in range.
pub(crate) struct PnormProblem<'a, P: LeastSquaresProblem + ?Sized> {
    pub inner: &'a P,
    pub p: f64,
    pub scale: f64,
}

impl<P: LeastSquaresProblem + ?Sized> PnormProblem<'_, P> {
    fn power(&self, r: f64) -> (f64, f64) {
        let h = 0.5 * self.p;
        let a = (r / self.scale).abs();
        (self.scale * r.signum() * a.powf(h), h * a.powf(h - 1.0))
    }
}

impl<P: LeastSquaresProblem + ?Sized> LeastSquaresProblem for PnormProblem<'_, P> {
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }
    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }
    fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
        if !self.inner.residuals(p, rows, r) {
            return false;
        }
        for x in r.iter_mut() {
            *x = self.power(*x).0;
        }
        true
    }
    fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
        if !self.inner.jacobian(p, rows, r, jac) {
            return false;
        }
        let n = self.n_params();
        for (x, row) in r.iter_mut().zip(jac.chunks_mut(n)) {
            let (v, d) = self.power(*x);
            *x = v;
            row.iter_mut().for_each(|j| *j *= d);
        }
        true
    }
    fn admissible(&self, p: &[f64]) -> bool {
        self.inner.admissible(p)
    }
}

/// One L_p solve from warm parameters: (p, warm) → the solved parameters and their errors.
pub(crate) type PnormSolve<'a> = dyn FnMut(f64, &[f64]) -> Result<Option<Solved>> + 'a;

/// The L_p polish of a minimax refit: from the least-squares fit `start` (parameters,
/// errors), Levenberg–Marquardt on Σ |ρ_i|^p ([`PnormProblem`]) for each p of `ps` in turn,
/// each solve warm-started from the previous one (a homotopy from L_2 towards the max norm);
/// every solve an iterate, with its max and MAE on `w` and its errors.
pub(crate) fn pnorm_branch(
    w: &[f64],
    start: (Vec<f64>, Vec<f64>),
    ps: &[f64],
    solve: &mut PnormSolve<'_>,
) -> Result<Vec<Iterate>> {
    let mut out = Vec::new();
    let mut p = start.0;
    for &pn in ps {
        let Some((np, ne, _, _)) = solve(pn, &p)? else {
            break;
        };
        p = np;
        out.push(Iterate {
            round: out.len() + 1,
            blend: 1.0,
            pnorm: Some(pn),
            max_mean: None,
            max: max_abs(w, &ne),
            mae: mean_abs(w, &ne),
            params: p.clone(),
        });
    }
    Ok(out)
}

/// The max–mean polish of a minimax fit ([`super::maxmean`]): from `start`, for each λ of
/// `lambdas`, the parameters `linear` (in which `problem`'s residuals ρ are jointly linear when
/// the others are held, e.g. the numerators of a rational with its denominator held) set to
/// the exact minimiser of max_i |ρ_i| + λ·mean_i |ρ_i|, the other parameters kept. Returns
/// (λ, parameters) per λ, in order; a λ whose linear program fails is left out.
fn max_mean_branch(
    problem: &dyn LeastSquaresProblem,
    linear: &[usize],
    start: &[f64],
    lambdas: &[f64],
) -> Result<Vec<(f64, Vec<f64>)>> {
    let (n, np) = (problem.n_residuals(), problem.n_params());
    if lambdas.is_empty() || linear.is_empty() || n == 0 {
        return Ok(Vec::new());
    }
    let (mut r, mut jac) = (vec![0.0; n], vec![0.0; n * np]);
    if !problem.jacobian(start, 0..n, &mut r, &mut jac) {
        return Ok(Vec::new());
    }
    // ρ(c) = ρ(start) + J_L (c − c_start): rows J_L, targets J_L c_start − ρ(start)
    let nl = linear.len();
    let mut a = vec![0.0; n * nl];
    let mut b = vec![0.0; n];
    for i in 0..n {
        let row = &jac[i * np..(i + 1) * np];
        let mut dot = 0.0;
        for (k, &j) in linear.iter().enumerate() {
            a[i * nl + k] = row[j];
            dot += row[j] * start[j];
        }
        b[i] = dot - r[i];
    }
    let mut out = Vec::new();
    for &lambda in lambdas {
        let Ok(fit) = super::maxmean::max_mean_fit(&a, &b, lambda) else {
            continue;
        };
        let mut p = start.to_vec();
        for (k, &j) in linear.iter().enumerate() {
            p[j] = fit.c[k];
        }
        out.push((lambda, p));
    }
    Ok(out)
}

/// (max, MAE) of parameters on the fitting points; None where they cannot be evaluated.
pub(crate) type MaxMae<'a> = dyn Fn(&[f64]) -> Option<(f64, f64)> + 'a;

/// The max–mean polish of a minimax fit as path iterates: [`max_mean_branch`] from the fit's
/// parameters `params` and from the L_p polish's last solve in `path` (if any), each iterate
/// measured by `measure` ((max, MAE) on the fitting points, None to drop it) and kept if
/// `accept`ed, its `mae_bound` its MAE as a multiple of `start_mae` (the least-squares start's).
pub(crate) fn max_mean_path(
    problem: &dyn LeastSquaresProblem,
    linear: &[usize],
    (params, path): (&[f64], &[PathIterate]),
    lambdas: &[f64],
    measure: &MaxMae<'_>,
    start_mae: f64,
    accept: &mut dyn FnMut(&[f64]) -> bool,
) -> Result<Vec<PathIterate>> {
    let mut starts = vec![(None, params.to_vec())];
    if let Some(last) = path.iter().rfind(|it| it.pnorm.is_some()) {
        starts.push((last.pnorm, last.params.clone()));
    }
    let mut polished: Vec<Iterate> = Vec::new();
    for (pnorm, from) in starts {
        for (l, p) in max_mean_branch(problem, linear, &from, lambdas)? {
            if let Some((max, mae)) = measure(&p) {
                polished.push(Iterate {
                    round: polished.len() + 1,
                    blend: 1.0,
                    pnorm,
                    max_mean: Some(l),
                    max,
                    mae,
                    params: p,
                });
            }
        }
    }
    Ok(pnorm_path(&polished, start_mae, accept))
}

/// Checks the λ values of a max–mean polish: each finite and ≥ 0.
pub(crate) fn check_max_mean(lambdas: &[f64]) -> Result<()> {
    match lambdas.iter().find(|l| !(l.is_finite() && **l >= 0.0)) {
        Some(l) => Err(super::error::FitError::InvalidSetting {
            name: "max_mean_polish",
            value: l.to_string(),
            expected: "every λ of the max–mean polish must be a finite number ≥ 0 (0 is the minimax fit of the linear coefficients; larger λ weigh the mean error more)",
        }),
        None => Ok(()),
    }
}

/// Every accepted iterate of the L_p polish as a path iterate, its `mae_bound` its own MAE on
/// the fitting points as a multiple of the least-squares start's.
pub(crate) fn pnorm_path(
    iterates: &[Iterate],
    start_mae: f64,
    accept: &mut dyn FnMut(&[f64]) -> bool,
) -> Vec<PathIterate> {
    iterates
        .iter()
        .filter(|it| it.max.is_finite() && accept(&it.params))
        .map(|it| PathIterate {
            round: it.round,
            mae_bound: it.mae / start_mae,
            blend: it.blend,
            pnorm: it.pnorm,
            max_mean: it.max_mean,
            params: it.params.clone(),
        })
        .collect()
}

/// Checks the p values of an L_p polish: each finite and ≥ 2.
pub(crate) fn check_lp_polish(ps: &[f64]) -> Result<()> {
    match ps.iter().find(|p| !(p.is_finite() && **p >= 2.0)) {
        Some(p) => Err(super::error::FitError::InvalidSetting {
            name: "lp_polish",
            value: p.to_string(),
            expected: "every p of the L_p polish must be a finite number ≥ 2 (p = 2 is least squares; larger p approach the max norm)",
        }),
        None => Ok(()),
    }
}

/// Lawson's update u_i ← u_i |ρ_i| / max_j u_j |ρ_j| (Lawson 1961), floored at
/// [`LAWSON_WEIGHT_FLOOR`]; false if every residual is zero (an exact fit).
pub(crate) fn lawson_update(u: &mut [f64], w: &[f64], e: &[f64]) -> bool {
    for ((ui, w), e) in u.iter_mut().zip(w).zip(e) {
        *ui *= (w * e).abs();
    }
    let umax = u.iter().fold(0.0f64, |m, &x| m.max(x));
    if !(umax > 0.0) {
        return false;
    }
    for ui in u.iter_mut() {
        *ui = (*ui / umax).max(LAWSON_WEIGHT_FLOOR);
    }
    true
}

/// The square roots of the blended weights (1 − λ)·1 + λ·u of the branch ([`LAWSON_BLEND`]),
/// the factors a weighted solve multiplies the residuals by.
pub(crate) fn blended_roots(u: &[f64], blend: f64) -> Vec<f64> {
    u.iter()
        .map(|x| ((1.0 - blend) + blend * x).sqrt())
        .collect()
}

/// One minimax iterate: its round, the blend λ of its weights, its errors on the fitting points.
#[derive(Clone, Debug)]
pub(crate) struct Iterate {
    pub round: usize,
    pub blend: f64,
    /// p of the L_p polish it came from ([`pnorm_branch`]); None for Lawson's path.
    pub pnorm: Option<f64>,
    /// λ of the max–mean polish it came from ([`max_mean_branch`]); None otherwise.
    pub max_mean: Option<f64>,
    pub max: f64,
    pub mae: f64,
    pub params: Vec<f64>,
}

pub(crate) fn max_abs(w: &[f64], e: &[f64]) -> f64 {
    objective_value(Objective::Minimax, w, e)
}

pub(crate) fn mean_abs(w: &[f64], e: &[f64]) -> f64 {
    objective_value(Objective::MeanAbsolute, w, e) / e.len().max(1) as f64
}

/// The iterates kept beside the best: per bound b of [`PATH_MAE_BOUNDS`], the accepted iterate
/// with the lowest max error (ties: Lawson's own, then the earlier round) among those with
/// MAE ≤ b × the start's MAE and a max error below the start's; an iterate is kept once, the
/// best one (round `best_round` of Lawson's own weights) never.
pub(crate) fn path_iterates(
    iterates: &[Iterate],
    (start_max, start_mae): (f64, f64),
    best_round: usize,
    accept: &mut dyn FnMut(&[f64]) -> bool,
) -> Vec<PathIterate> {
    let key = |a: &Iterate| (a.round, a.blend, a.pnorm);
    let same = |a: &Iterate, k: (usize, f64, Option<f64>)| key(a) == k;
    let mut kept: Vec<PathIterate> = Vec::new();
    let mut rejected: Vec<(usize, f64, Option<f64>)> = Vec::new();
    for bound in PATH_MAE_BOUNDS {
        let mut c: Vec<&Iterate> = iterates
            .iter()
            .filter(|it| {
                !same(it, (best_round, 1.0, None))
                    && it.max.is_finite()
                    && it.max < start_max
                    && it.mae <= bound * start_mae
                    && !rejected.iter().any(|&k| same(it, k))
            })
            .collect();
        c.sort_by(|a, b| {
            a.max
                .total_cmp(&b.max)
                .then(b.blend.total_cmp(&a.blend))
                .then(a.round.cmp(&b.round))
        });
        for it in c.into_iter().take(PATH_TRIES) {
            if kept.iter().any(|k| same(it, (k.round, k.blend, k.pnorm))) {
                break; // a tighter bound already kept the best of these
            }
            if accept(&it.params) {
                kept.push(PathIterate {
                    round: it.round,
                    mae_bound: bound,
                    blend: it.blend,
                    pnorm: it.pnorm,
                    max_mean: it.max_mean,
                    params: it.params.clone(),
                });
                break;
            }
            rejected.push(key(it));
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit_polynomial, FitData, InputTransform, PolynomialOptions};

    fn grid() -> FitData {
        let ax: Vec<f64> = (0..21).map(|i| i as f64 / 20.0).collect();
        let vals = ax
            .iter()
            .flat_map(|&x| ax.iter().map(move |&y| (x, y)))
            .map(|(x, y)| (1.0 + 3.0 * x * y).sqrt() / (1.1 + x) + (-8.0 * y).exp())
            .collect();
        FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap()
    }

    #[test]
    fn the_lawson_path_keeps_iterates_inside_the_mae_bands() {
        let data = grid();
        let t = [InputTransform::Identity; 2];
        let opts = PolynomialOptions::default();
        let ls = fit_polynomial(&data, &t, 3, Objective::LeastSquares, &opts).unwrap();
        let mm = fit_polynomial(&data, &t, 3, Objective::Minimax, &opts).unwrap();
        // the path's end trades MAE for max error beyond the tightest band
        assert!(mm.metrics.max_abs_error < ls.metrics.max_abs_error);
        assert!(
            mm.metrics.mae > PATH_MAE_BOUNDS[0] * ls.metrics.mae,
            "{mm:?}"
        );
        assert!(!mm.path.is_empty());
        let rounds = mm.solver.as_ref().unwrap().reweighting_iterations;
        let mut seen = Vec::new();
        for p in &mm.path {
            let it = p.solver.as_ref().unwrap().lawson_path.clone().unwrap();
            assert!(it.round >= 1 && it.round <= rounds && it.of_rounds == rounds);
            assert_eq!(p.solver.as_ref().unwrap().reweighting_iterations, it.round);
            assert!(!seen.contains(&it.round));
            seen.push(it.round);
            assert!(p.metrics.max_abs_error < ls.metrics.max_abs_error);
            assert!(p.metrics.max_abs_error > mm.metrics.max_abs_error);
            // relative slack: the bound is judged on the solver's (Chebyshev) coefficients
            assert!(
                p.metrics.mae <= it.mae_bound * ls.metrics.mae * (1.0 + 1e-6),
                "round {}: MAE {:e} vs start {:e}",
                it.round,
                p.metrics.mae,
                ls.metrics.mae
            );
            assert!(p.path.is_empty() && p.is_usable());
        }
        // one of them is within the selection's band of the start's MAE
        assert!(mm
            .path
            .iter()
            .any(|p| p.metrics.mae <= crate::fit::sweep::MAE_TOLERANCE * ls.metrics.mae));
        // deterministic
        let again = fit_polynomial(&data, &t, 3, Objective::Minimax, &opts).unwrap();
        assert_eq!(again.path, mm.path);
        // least squares and the mean-absolute objective have no path
        assert!(ls.path.is_empty());
        let mae = fit_polynomial(&data, &t, 3, Objective::MeanAbsolute, &opts).unwrap();
        assert!(mae.path.is_empty());
    }

    #[test]
    fn path_fits_say_what_they_are_and_old_files_load() {
        let data = grid();
        let t = [InputTransform::Identity; 2];
        let mm = fit_polynomial(
            &data,
            &t,
            3,
            Objective::Minimax,
            &PolynomialOptions::default(),
        )
        .unwrap();
        let end = mm.to_json().unwrap();
        // the path's end carries no field of the path
        assert!(!end.contains("lawson_path"), "{end}");
        let back: crate::fit::FitResult = serde_json::from_str(&end).unwrap();
        assert_eq!(back.solver, mm.solver);
        let p = &mm.path[0];
        let json = p.to_json().unwrap();
        assert!(json.contains("\"lawson_path\"") && json.contains("\"minimax\""));
        let back: crate::fit::FitResult = serde_json::from_str(&json).unwrap();
        let it = back.solver.unwrap().lawson_path.unwrap();
        assert_eq!(Some(&it), p.solver.as_ref().unwrap().lawson_path.as_ref());
        let label = it.label("-", "");
        assert!(label.starts_with("round") || label.starts_with("blend"));
        assert!(label.ends_with(&format!("round{}", it.round)), "{label}");
    }

    /// r_i = a + b x_i − x_i² at 201 points of [0, 1]: the line nearest x².
    struct Line(Vec<f64>);

    impl LeastSquaresProblem for Line {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            self.0.len()
        }
        fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
            for (k, i) in rows.enumerate() {
                let x = self.0[i];
                r[k] = p[0] + p[1] * x - x * x;
            }
            true
        }
        fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
            for (k, i) in rows.clone().enumerate() {
                jac[2 * k] = 1.0;
                jac[2 * k + 1] = self.0[i];
            }
            self.residuals(p, rows, r)
        }
    }

    #[test]
    fn the_lp_polish_approaches_the_minimax_line() {
        let line = Line((0..=200).map(|i| i as f64 / 200.0).collect());
        let max_err = |p: &[f64]| {
            line.0
                .iter()
                .map(|&x| (p[0] + p[1] * x - x * x).abs())
                .fold(0.0f64, f64::max)
        };
        // the Jacobian of |r/s|^(p/2) against central differences
        let pn = PnormProblem {
            inner: &line,
            p: 7.0,
            scale: 0.2,
        };
        let at = [-0.1, 0.9];
        let (mut r, mut jac) = (vec![0.0; 201], vec![0.0; 402]);
        assert!(pn.jacobian(&at, 0..201, &mut r, &mut jac));
        for j in 0..2 {
            let h = 1e-6;
            let (mut up, mut down) = (at, at);
            up[j] += h;
            down[j] -= h;
            let (mut ru, mut rd) = (vec![0.0; 201], vec![0.0; 201]);
            assert!(pn.residuals(&up, 0..201, &mut ru) && pn.residuals(&down, 0..201, &mut rd));
            for i in 0..201 {
                let fd = (ru[i] - rd[i]) / (2.0 * h);
                assert!(
                    (fd - jac[2 * i + j]).abs() < 1e-6,
                    "{i} {j}: {fd} vs {}",
                    jac[2 * i + j]
                );
            }
        }
        // least squares: x − 1/6 on [0, 1] (max error 1/6 at x = 0; the 201 points shift it by
        // O(1/n)); minimax (Chebyshev equioscillation at 0, 1/2, 1): x − 1/8, max error 1/8
        let lm = crate::fit::lm::LevenbergMarquardt::new();
        let ls = lm.solve(&line, vec![0.0, 0.0]).unwrap().state.params;
        assert!(
            (ls[0] + 1.0 / 6.0).abs() < 5e-3 && (ls[1] - 1.0).abs() < 5e-3,
            "{ls:?}"
        );
        let mut warm = ls.clone();
        let mut maxima = Vec::new();
        for p in [4.0, 16.0, 64.0] {
            let problem = PnormProblem {
                inner: &line,
                p,
                scale: max_err(&warm),
            };
            warm = lm.solve(&problem, warm).unwrap().state.params;
            maxima.push(max_err(&warm));
        }
        eprintln!("max error after p = 4, 16, 64: {maxima:?}, line {warm:?}");
        assert!(maxima.windows(2).all(|m| m[1] < m[0]), "{maxima:?}");
        assert!(maxima[0] < 1.0 / 6.0);
        let end = maxima[2];
        assert!(end > 0.125 - 1e-9 && end < 0.125 * 1.03, "{end}");
        assert!(
            (warm[1] - 1.0).abs() < 0.02 && (warm[0] + 0.125).abs() < 0.005,
            "{warm:?}"
        );
    }

    #[test]
    fn lp_polish_settings_are_checked() {
        assert!(check_lp_polish(&[]).is_ok() && check_lp_polish(&[2.0, 8.0]).is_ok());
        for bad in [1.5, f64::NAN, f64::INFINITY] {
            let e = check_lp_polish(&[8.0, bad]).unwrap_err().to_string();
            assert!(e.contains("lp_polish") && e.contains("≥ 2"), "{e}");
        }
    }

    #[test]
    fn path_selection_per_bound() {
        // (round, max, MAE): start max 1.0, MAE 1.0
        let it = |round: usize, max: f64, mae: f64| Iterate {
            round,
            blend: 1.0,
            pnorm: None,
            max_mean: None,
            max,
            mae,
            params: vec![round as f64],
        };
        let iterates = vec![
            it(1, 0.8, 1.1),  // ≤ 1.15
            it(2, 0.7, 1.2),  // ≤ 1.3
            it(3, 0.75, 1.1), // ≤ 1.15, lower max than round 1
            it(4, 0.5, 2.0),  // the best (the path's end): never kept here
            it(5, 1.2, 1.0),  // worse than the start's max
        ];
        let mut all = |_: &[f64]| true;
        let kept = path_iterates(&iterates, (1.0, 1.0), 4, &mut all);
        let rounds: Vec<(usize, f64)> = kept.iter().map(|k| (k.round, k.mae_bound)).collect();
        // 1.5 finds round 2 again, kept once
        assert_eq!(rounds, vec![(3, 1.15), (2, 1.3)]);
        // a rejected candidate (e.g. no pole certificate) gives way to the next
        let mut not_3 = |p: &[f64]| p[0] != 3.0;
        let kept = path_iterates(&iterates, (1.0, 1.0), 4, &mut not_3);
        let rounds: Vec<usize> = kept.iter().map(|k| k.round).collect();
        assert_eq!(rounds, vec![1, 2]);
    }
}
