//! Rational fits P/Q (Q's constant fixed to 1), the paper's form (Sforza & Pellacini 2022,
//! §3.5 and Appendix A, eqs. 24–25).
//!
//! A plain Levenberg–Marquardt run from one start lands in poor local minima or grows poles,
//! so the fit is a strategy:
//! 1. starts, on a deterministic random subset of at most `exploration_points` points:
//!    - the linearised least-squares solution of P − yQ ≈ 0 (Levy 1959),
//!    - Sanathanan–Koerner reweightings of it, rows scaled by 1/|Q_prev| (Sanathanan & Koerner
//!      1963), which approach the true least-squares weighting,
//!    - the least-squares polynomial P with Q = 1,
//!    - caller-supplied approximants (e.g. the previous degree of a sweep, padded with zeros);
//! 2. Levenberg–Marquardt ([`super::lm`]) from each start, with a barrier Q > [`Q_FLOOR`] at
//!    every data point; from a start whose Q is certified pole-free, every trial step must be
//!    certified too (the certificate is the feasibility oracle), so the run ends certified;
//! 3. the result with the lowest cost on all points among those whose denominator is
//!    *certified* ≥ a small margin on the whole domain ([`super::poles`]) is refined on all points;
//! 4. for MeanAbsolute / Minimax, reweighted LM runs (IRLS / Lawson) from there, keeping the
//!    best certified iterate.
//!
//! [`Q_FLOOR`]: super::model::Q_FLOOR

use std::time::Instant;

use super::basis::{check_degree, monomial_to_chebyshev};
use super::data::{FitData, InputTransform, Prepared};
use super::error::{FitError, Result};
use super::linear::solve_lstsq;
use super::lm::{cost, LeastSquaresProblem, LevenbergMarquardt, LsqMethod, TerminationReason};
use super::model::{LinearisedRows, Model, RationalProblem, Q_FLOOR};
use super::poles::CertifyOptions;
use super::polynomial::solve_polynomial;
use super::result::{Approximant, FitResult, Form, Objective, SolverReport, StartReport};
use super::robust::{
    check_lp_polish, check_max_mean, max_abs, max_mean_path, mean_abs, reweight, PnormProblem,
    PnormSolve, Solve, Solved,
};

/// Settings of a rational fit.
#[derive(Clone, Debug)]
pub struct RationalOptions {
    /// Levenberg–Marquardt settings for every run (iteration limits and tolerances also of the
    /// trust-region method).
    pub lm: LevenbergMarquardt,
    /// The least-squares solver of every run: Levenberg–Marquardt (default) or argmin's trust
    /// region.
    pub method: LsqMethod,
    /// Sanathanan–Koerner rounds after the linearised start.
    pub sk_iterations: usize,
    /// Points used to explore the starts (0 = automatic: max(16 384, 200 × parameters)).
    pub exploration_points: usize,
    /// Levenberg–Marquardt step limit when refining on all points after a subsampled
    /// exploration (each step is a pass over all data).
    pub refine_iterations: usize,
    /// Reweighting rounds for MeanAbsolute / Minimax.
    pub reweight_iterations: usize,
    /// Levenberg–Marquardt steps per reweighting round.
    pub reweight_lm_iterations: usize,
    /// Pole certificate of the final result.
    pub certify: CertifyOptions,
    /// Cheaper certificate that every Levenberg–Marquardt trial point must pass when the run
    /// started certified (an undecided trial is rejected), so such runs end certified.
    pub step_certify: CertifyOptions,
    /// Runs from a start whose Q is proved ≥ `denominator_margin` on the whole domain (Q
    /// normalised to Chebyshev mean 1) keep it so at every step, and candidates are ranked
    /// certified only with this margin. Keeps fits away from near-poles, whose cancellation
    /// makes f32 evaluation fragile. 0 = only require Q > 0.
    pub denominator_margin: f64,
    /// Extra starting points, in monomial form with the same variables and transforms
    /// (lower degrees are padded with zeros; mismatching ones are skipped and reported).
    pub extra_starts: Vec<(String, Approximant)>,
    /// Minimax only: the p values of an L_p polish from the least-squares fit (Levenberg–
    /// Marquardt on Σ |e_i|^p for each p in turn, [`super::robust::PnormProblem`]); every
    /// solve is one more iterate of the path ([`FitResult::path`]). Empty (the default): none.
    /// Each p must be finite and ≥ 2.
    pub lp_polish: Vec<f64>,
    /// Minimax only: the λ values of a max–mean polish of the minimax fit (its denominator
    /// held, the numerator set to the exact minimiser of max error + λ·mean error on the fitting
    /// points, [`super::maxmean`]); every λ one more iterate of the path. Empty (the default):
    /// none. Each λ must be finite and ≥ 0.
    pub max_mean_polish: Vec<f64>,
}

impl Default for RationalOptions {
    fn default() -> Self {
        RationalOptions {
            lm: LevenbergMarquardt::new(),
            method: LsqMethod::LevenbergMarquardt,
            sk_iterations: 6,
            exploration_points: 0,
            refine_iterations: 50,
            reweight_iterations: 30,
            reweight_lm_iterations: 30,
            certify: CertifyOptions::default(),
            step_certify: CertifyOptions {
                max_boxes: 5_000,
                min_box_width: 1e-6,
                refine_splits: 0,
            },
            denominator_margin: 1e-3,
            extra_starts: Vec::new(),
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        }
    }
}

/// Linearised least squares (Levy) with optional extra row weights.
fn linearised(
    model: &Model,
    data: &Prepared,
    phi: Option<&[f64]>,
    extra: Option<&[f64]>,
    what: &str,
) -> Result<Vec<f64>> {
    let rows = LinearisedRows {
        model,
        data,
        extra,
        phi,
    };
    Ok(solve_lstsq(&rows, what)?.x)
}

/// Converts an approximant to this model's Chebyshev parameters, or says why not.
fn start_from_approximant(
    model: &Model,
    prep: &Prepared,
    transforms: &[InputTransform],
    a: &Approximant,
) -> std::result::Result<Vec<f64>, String> {
    if a.transforms != transforms || a.variables.len() != prep.d {
        return Err("different variables or transforms".into());
    }
    // the approximant's monomial coefficients on this model's exponents
    let embed = |p: &super::basis::Polynomial,
                 exps: &[Vec<u32>]|
     -> std::result::Result<Vec<f64>, String> {
        let mut c = vec![0.0; exps.len()];
        for (e, &v) in p.exponents.iter().zip(&p.coefficients) {
            match exps.iter().position(|x| x == e) {
                Some(j) => c[j] = v,
                None if v == 0.0 => {}
                None => {
                    return Err(format!(
                        "has a term of degree {} outside this fit's exponents",
                        e.iter().sum::<u32>()
                    ))
                }
            }
        }
        Ok(c)
    };
    let num = model.num_from_monomial(&prep.scales, &embed(&a.numerator, &model.num_exps)?);
    let den_exps = model
        .den_exps
        .clone()
        .unwrap_or_else(|| vec![vec![0; prep.d]]);
    let dd = model.den_max_exponent();
    let den = match &a.denominator {
        Some(q) => monomial_to_chebyshev(&den_exps, dd, &prep.scales, &embed(q, &den_exps)?),
        None => {
            let mut one = vec![0.0; den_exps.len()];
            one[0] = 1.0;
            monomial_to_chebyshev(&den_exps, dd, &prep.scales, &one)
        }
    };
    let c0 = den[0];
    if !(c0.abs() > 0.0) {
        return Err("its denominator's mean over the box is zero".into());
    }
    let mut p: Vec<f64> = num.iter().map(|x| x / c0).collect();
    p.extend(den[1..].iter().map(|x| x / c0));
    Ok(p)
}

struct Candidate {
    params: Vec<f64>,
    cost: f64,
    certified: bool,
    termination: TerminationReason,
    iterations: usize,
}

/// Fits P/Q with total degrees `num_degree` / `den_degree` in the transformed variables.
pub fn fit_rational(
    data: &FitData,
    transforms: &[InputTransform],
    num_degree: u32,
    den_degree: u32,
    objective: Objective,
    opts: &RationalOptions,
) -> Result<FitResult> {
    check_degree(num_degree)?;
    check_degree(den_degree)?;
    let d = data.dim();
    let form = Form::Rational {
        numerator_degree: num_degree,
        denominator_degree: den_degree,
    };
    let model = Model::rational(d, num_degree, den_degree);
    let poly_model = Model::polynomial(d, num_degree);
    fit_rational_model(data, transforms, form, &model, &poly_model, objective, opts)
}

/// [`fit_rational`] for any model: `poly_model` is the polynomial (Q = 1) over the same
/// numerator exponents, a start.
pub(crate) fn fit_rational_model(
    data: &FitData,
    transforms: &[InputTransform],
    form: Form,
    model: &Model,
    poly_model: &Model,
    objective: Objective,
    opts: &RationalOptions,
) -> Result<FitResult> {
    let start_time = Instant::now();
    check_lp_polish(&opts.lp_polish)?;
    check_max_mean(&opts.max_mean_polish)?;
    let prep = Prepared::new(data, transforms)?;
    let model = &model.clone().with_scales(&prep.scales);
    let poly_model = &poly_model.clone().with_scales(&prep.scales);
    let label = form.label();
    let np = model.n_params();
    if prep.n_weighted() < np {
        return Err(FitError::TooFewPoints {
            form: label,
            coefficients: np,
            points: prep.n_weighted(),
        });
    }
    let explore_n = if opts.exploration_points == 0 {
        (200 * np).max(16_384)
    } else {
        opts.exploration_points.max(np)
    };
    let sub = prep.subsample(explore_n);
    let ex = sub.as_ref().unwrap_or(&prep);
    // basis values of the exploration set and of all points, evaluated once per fit
    let table_ex = model.basis_table(ex);
    let table_all = if sub.is_some() {
        model.basis_table(&prep)
    } else {
        None
    };
    let phi_ex = table_ex.as_deref();
    let phi_all = if sub.is_some() {
        table_all.as_deref()
    } else {
        phi_ex
    };

    // Q ≥ margin proved on the whole domain: the admissibility test of constrained LM runs and
    // the "certified" of candidates (the final verdict is the plain certificate, no margin).
    let guard = (&opts.step_certify, opts.denominator_margin);
    let safe = |p: &[f64]| model.denominator_certified(&prep, p, guard.0, guard.1);

    // 1. starts
    let mut starts: Vec<(String, std::result::Result<Vec<f64>, String>)> = Vec::new();
    let lin = linearised(model, ex, phi_ex, None, &label).map_err(|e| e.to_string());
    starts.push(("linearised".into(), lin.clone()));
    if let Ok(mut p) = lin {
        let mut ok = true;
        for _ in 0..opts.sk_iterations {
            let q = model.denominators(ex, phi_ex, &p);
            let extra: Vec<f64> = q.iter().map(|q| 1.0 / q.abs().max(Q_FLOOR)).collect();
            match linearised(model, ex, phi_ex, Some(&extra), &label) {
                Ok(next) => p = next,
                Err(e) => {
                    starts.push(("sanathanan_koerner".into(), Err(e.to_string())));
                    ok = false;
                    break;
                }
            }
        }
        if ok && opts.sk_iterations > 0 {
            starts.push(("sanathanan_koerner".into(), Ok(p)));
        }
    }
    match solve_polynomial(poly_model, ex, None, &label) {
        Ok((a, _)) => {
            let mut p = a;
            p.resize(np, 0.0);
            starts.push(("polynomial".into(), Ok(p)));
        }
        Err(e) => starts.push(("polynomial".into(), Err(e.to_string()))),
    }
    for (name, a) in &opts.extra_starts {
        starts.push((
            name.clone(),
            start_from_approximant(model, &prep, transforms, a),
        ));
    }

    // 2. LM from each start on the exploration set
    let mut reports = Vec::new();
    let mut candidates: Vec<Candidate> = Vec::new();
    for (name, s) in starts {
        let p0 = match s {
            Ok(p) => p,
            Err(note) => {
                reports.push(StartReport {
                    name,
                    cost: None,
                    cost_all_points: None,
                    termination: None,
                    iterations: 0,
                    certified_steps: false,
                    certified: false,
                    note: Some(note),
                });
                continue;
            }
        };
        let constrained = safe(&p0);
        let problem = RationalProblem {
            model,
            data: ex,
            phi: phi_ex,
            extra: None,
            certified_steps: constrained.then_some(guard),
        };
        let rep = opts.method.solve(&opts.lm, &problem, p0)?;
        if rep.termination == TerminationReason::InfeasibleStart {
            reports.push(StartReport {
                name,
                cost: None,
                termination: Some(rep.termination),
                iterations: 0,
                cost_all_points: None,
                certified_steps: false,
                certified: false,
                note: Some("its denominator vanishes or changes sign at the data".into()),
            });
            continue;
        }
        let certified = safe(&rep.state.params);
        // the exploration cost can hide a blow-up between sampled points: rank on all points
        let cost_all = if sub.is_some() {
            cost(
                &RationalProblem {
                    model,
                    data: &prep,
                    phi: phi_all,
                    extra: None,
                    certified_steps: None,
                },
                &rep.state.params,
            )
        } else {
            Some(rep.state.cost)
        };
        reports.push(StartReport {
            name,
            cost: Some(rep.state.cost),
            cost_all_points: cost_all,
            termination: Some(rep.termination),
            iterations: rep.state.iterations,
            certified_steps: constrained,
            certified,
            note: None,
        });
        let cost = cost_all.unwrap_or(f64::INFINITY);
        candidates.push(Candidate {
            params: rep.state.params,
            cost,
            certified,
            termination: rep.termination,
            iterations: rep.state.iterations,
        });
    }
    if candidates.is_empty() {
        let tried = reports
            .iter()
            .map(|r| format!("{}: {}", r.name, r.note.as_deref().unwrap_or("failed")))
            .collect::<Vec<_>>()
            .join("; ");
        return Err(FitError::NoFeasibleStart { form: label, tried });
    }
    // certified first, then by cost on all points (stable: ties keep start order)
    candidates.sort_by(|a, b| {
        b.certified
            .cmp(&a.certified)
            .then(a.cost.total_cmp(&b.cost))
    });

    // 3. refine the best on all points
    let mut best = candidates.swap_remove(0);
    if sub.is_some() {
        let lm = opts
            .lm
            .clone()
            .with_max_iterations(opts.refine_iterations.max(1))?;
        let problem = RationalProblem {
            model,
            data: &prep,
            phi: phi_all,
            extra: None,
            certified_steps: best.certified.then_some(guard),
        };
        let rep = opts.method.solve(&lm, &problem, best.params.clone())?;
        if rep.termination != TerminationReason::InfeasibleStart {
            let certified = safe(&rep.state.params);
            if certified || !best.certified {
                best = Candidate {
                    params: rep.state.params,
                    cost: rep.state.cost,
                    certified,
                    termination: rep.termination,
                    iterations: rep.state.iterations,
                };
            }
        }
    }

    // 4. other objectives
    let mut rounds = 0;
    let mut path = Vec::new();
    let mut final_termination = best.termination;
    let mut final_iterations = best.iterations;
    let mut converged = best.termination.converged();
    let mut params = best.params;
    if objective != Objective::LeastSquares {
        if let Some(e0) = model.errors(&prep, phi_all, &params) {
            let lm = opts
                .lm
                .clone()
                .with_max_iterations(opts.reweight_lm_iterations.max(1))?;
            let constrained = best.certified;
            // one solve from `warm` and the errors of its parameters (None: infeasible start)
            let run = |problem: &dyn LeastSquaresProblem, warm: &[f64]| -> Result<Option<Solved>> {
                let rep = opts.method.solve(&lm, problem, warm.to_vec())?;
                if rep.termination == TerminationReason::InfeasibleStart {
                    return Ok(None);
                }
                Ok(model.errors(&prep, phi_all, &rep.state.params).map(|e| {
                    (
                        rep.state.params,
                        e,
                        Some(rep.termination),
                        rep.state.iterations,
                    )
                }))
            };
            let mut solve = |extra: &[f64], warm: &[f64]| -> Result<Option<Solved>> {
                let problem = RationalProblem {
                    model,
                    data: &prep,
                    phi: phi_all,
                    extra: Some(extra),
                    certified_steps: constrained.then_some(guard),
                };
                run(&problem, warm)
            };
            let mut pnorm_solve = |pn: f64, warm: &[f64]| -> Result<Option<Solved>> {
                let Some(e) = model.errors(&prep, phi_all, warm) else {
                    return Ok(None);
                };
                let scale = e
                    .iter()
                    .zip(&prep.w)
                    .fold(0.0f64, |m, (e, w)| m.max((w * e).abs()));
                let inner = RationalProblem {
                    model,
                    data: &prep,
                    phi: phi_all,
                    extra: None,
                    certified_steps: constrained.then_some(guard),
                };
                let problem = PnormProblem {
                    inner: &inner,
                    p: pn,
                    scale,
                };
                run(&problem, warm)
            };
            let mut accept = |p: &[f64]| !best.certified || safe(p);
            let ls_mae = mean_abs(&prep.w, &e0);
            let rw = reweight(
                objective,
                opts.reweight_iterations,
                &prep.w,
                (params.clone(), e0),
                &mut solve as &mut Solve<'_>,
                (!opts.lp_polish.is_empty())
                    .then_some((&opts.lp_polish[..], &mut pnorm_solve as &mut PnormSolve<'_>)),
                &mut accept,
            )?;
            rounds = rw.rounds;
            converged = rw.converged;
            final_termination = rw.termination.unwrap_or(final_termination);
            final_iterations = rw.lm_iterations;
            params = rw.params;
            path = rw.path;
            if objective == Objective::Minimax && !opts.max_mean_polish.is_empty() {
                let problem = RationalProblem {
                    model,
                    data: &prep,
                    phi: phi_all,
                    extra: None,
                    certified_steps: None,
                };
                let linear: Vec<usize> = (0..model.n_num).collect();
                // from the minimax fit and from the L_p polish's last solve
                let measure = |p: &[f64]| {
                    let e = model.errors(&prep, phi_all, p)?;
                    Some((max_abs(&prep.w, &e), mean_abs(&prep.w, &e)))
                };
                let polished = max_mean_path(
                    &problem,
                    &linear,
                    (&params, &path),
                    &opts.max_mean_polish,
                    &measure,
                    ls_mae,
                    &mut accept,
                )?;
                path.extend(polished);
            }
        }
    }

    let approximant = model.to_approximant(data, transforms, &prep, &params);
    let solver = SolverReport {
        method: format!(
            "multi-start {} (linearised LS, Sanathanan–Koerner, polynomial{}){}; best pole-certified start refined on all points{}",
            opts.method.label(),
            if opts.extra_starts.is_empty() { "" } else { ", supplied starts" },
            if sub.is_some() { format!(" on {} of {} points", ex.len(), prep.len()) } else { String::new() },
            match objective {
                Objective::LeastSquares => "",
                Objective::MeanAbsolute => "; then IRLS for mean absolute error",
                Objective::Minimax => "; then Lawson reweighting for minimax error",
            }
        ),
        termination: Some(final_termination),
        converged,
        iterations: final_iterations,
        reweighting_iterations: rounds,
        lawson_path: None,
        condition: None,
        exploration_points: ex.len(),
        starts: reports,
    };
    let mut result = FitResult::assess(
        form,
        approximant,
        data,
        objective,
        Some(solver),
        &opts.certify,
    )?
    .with_path(&path, data, &opts.certify, &|p| {
        model.to_approximant(data, transforms, &prep, p)
    })?;
    result.fit_seconds = start_time.elapsed().as_secs_f64();
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::poles::PoleVerdict;

    fn grid2(n: usize, f: impl Fn(f64, f64) -> f64) -> FitData {
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let vals = ax
            .iter()
            .flat_map(|&x| ax.iter().map(move |&y| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap()
    }

    #[test]
    fn recovers_an_exact_rational() {
        // (1 + x − y²) / (1 + 0.5 x + 0.3 x y): pole-free on [0,1]²
        let f = |x: f64, y: f64| (1.0 + x - y * y) / (1.0 + 0.5 * x + 0.3 * x * y);
        let data = grid2(20, f);
        let r = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            2,
            2,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        assert!(r.metrics.max_abs_error < 1e-10, "{:?}", r.metrics);
        assert!(
            matches!(r.poles, PoleVerdict::Certified { .. }),
            "{:?}",
            r.poles
        );
        let q = r.approximant.denominator.as_ref().unwrap();
        assert_eq!(q.coefficients[0], 1.0);
        // coefficients are the generating ones (unique up to the normalisation)
        assert!(
            (q.coefficients[1] - 0.5).abs() < 1e-8 && (q.coefficients[4] - 0.3).abs() < 1e-8,
            "{:?}",
            q.coefficients
        );
        assert!((r.eval(&[0.3, 0.7]) - f(0.3, 0.7)).abs() < 1e-10);
        assert_eq!(r.n_coefficients, 6 + 5);
        assert!(r.is_usable());
    }

    #[test]
    fn rational_beats_polynomial_near_a_pole_outside_the_domain() {
        // 1/(1.05 − x) has a pole just outside [0, 1]
        let ax: Vec<f64> = (0..200).map(|i| i as f64 / 199.0).collect();
        let data = FitData::from_grid(
            vec!["x".into()],
            std::slice::from_ref(&ax),
            ax.iter().map(|x| 1.0 / (1.05 - x)).collect(),
        )
        .unwrap();
        let r = fit_rational(
            &data,
            &[InputTransform::Identity],
            1,
            1,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        assert!(r.metrics.max_abs_error < 1e-9, "{:?}", r.metrics);
        assert!(r.is_usable(), "{:?}", r.poles);
    }

    #[test]
    fn minimax_lowers_max_error_and_stays_certified() {
        let data = grid2(16, |x, y| (1.0 + x).sqrt() * (2.0 - y * y).ln());
        let base = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            1,
            1,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        let mm = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            1,
            1,
            Objective::Minimax,
            &Default::default(),
        )
        .unwrap();
        assert!(
            mm.metrics.max_abs_error < base.metrics.max_abs_error,
            "{} vs {}",
            mm.metrics.max_abs_error,
            base.metrics.max_abs_error
        );
        assert!(mm.is_usable());
        let mae = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            1,
            1,
            Objective::MeanAbsolute,
            &Default::default(),
        )
        .unwrap();
        assert!(mae.metrics.mae < base.metrics.mae);
    }

    #[test]
    fn subsampled_exploration_then_full_refinement() {
        let data = grid2(60, |x, y| (1.0 + x * y) / (1.2 + x + y * y));
        let opts = RationalOptions {
            exploration_points: 500,
            ..Default::default()
        };
        let r = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            2,
            2,
            Objective::LeastSquares,
            &opts,
        )
        .unwrap();
        assert_eq!(r.solver.as_ref().unwrap().exploration_points, 500);
        assert!(r.metrics.max_abs_error < 1e-9, "{:?}", r.metrics);
    }

    #[test]
    fn json_round_trip_is_exact() {
        let data = grid2(10, |x, y| (1.0 + x) / (1.5 + y));
        let r = fit_rational(
            &data,
            &[InputTransform::Identity, InputTransform::Sqrt],
            1,
            1,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        let s = r.to_json().unwrap();
        let back = FitResult::from_json(&s).unwrap();
        assert_eq!(back.to_json().unwrap(), s);
        for (a, b) in back
            .approximant
            .numerator
            .coefficients
            .iter()
            .zip(&r.approximant.numerator.coefficients)
        {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        assert_eq!(
            back.eval(&[0.2, 0.4]).to_bits(),
            r.eval(&[0.2, 0.4]).to_bits()
        );
        assert!(FitResult::from_json("{\"form\": 3}")
            .unwrap_err()
            .to_string()
            .contains("FitResult::to_json"));
    }

    #[test]
    fn whole_fit_is_identical_for_any_thread_count() {
        // 70² points span two accumulation chunks; exploration subsampled to exercise that path too
        let data = grid2(70, |x, y| (1.0 + x * y).ln() / (1.3 + y));
        let opts = RationalOptions {
            exploration_points: 1000,
            ..Default::default()
        };
        let run = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| {
                    fit_rational(
                        &data,
                        &[InputTransform::Identity; 2],
                        2,
                        2,
                        Objective::LeastSquares,
                        &opts,
                    )
                    .unwrap()
                    .to_json()
                    .unwrap()
                })
        };
        assert_eq!(run(1), run(3));
    }

    #[test]
    fn previous_degree_seeds_the_next() {
        let data = grid2(12, |x, y| (x + 2.0 * y).exp() / (3.0 + x));
        let r1 = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            1,
            1,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        let opts = RationalOptions {
            extra_starts: vec![("degree 1".into(), r1.approximant.clone())],
            ..Default::default()
        };
        let r2 = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            2,
            2,
            Objective::LeastSquares,
            &opts,
        )
        .unwrap();
        let s = &r2.solver.as_ref().unwrap().starts;
        assert!(
            s.iter().any(|s| s.name == "degree 1" && s.cost.is_some()),
            "{s:?}"
        );
        assert!(r2.metrics.rmse <= r1.metrics.rmse);
    }
}
