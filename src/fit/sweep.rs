//! Degree sweeps (the paper's Fig. 3: polynomials and rationals of increasing degree, MAE
//! against number of coefficients) and the choice of the best certified fit under a budget.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::basis::n_terms;
use super::data::{FitData, InputTransform};
use super::error::Result;
use super::form::{fit_form, FitOptions};
use super::polynomial::{fit_polynomial, PolynomialOptions};
use super::rational::{fit_rational, RationalOptions};
use super::result::{FitResult, Form, Objective};

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    pub polynomial_degrees: Vec<u32>,
    /// Total degree n of P and Q (n/n rationals, as in the paper).
    pub rational_degrees: Vec<u32>,
    /// Rationals with unequal total degrees (numerator, denominator), e.g. (2, 1): 8
    /// coefficients in 2-D, the small budgets' natural candidates.
    pub rational_pairs: Vec<(u32, u32)>,
    /// Structured forms (per-variable degrees, split sums: [`Form::Exponents`]), each fitted
    /// with its own transforms after the transform sets' degree sweeps.
    pub forms: Vec<(Form, Vec<InputTransform>)>,
    /// Input-transform sets to try (one transform per variable each).
    pub transform_sets: Vec<Vec<InputTransform>>,
    pub objective: Objective,
    pub polynomial: PolynomialOptions,
    pub rational: RationalOptions,
    /// Seed each rational degree with the previous degree's result (recommended: the error
    /// then never grows with degree, up to the subsampled exploration).
    pub continue_degrees: bool,
}

impl SweepOptions {
    /// The paper's sweep (Sforza & Pellacini 2022, §3.5): 2D polynomials and rationals of degree
    /// 1–10; 3D polynomials 1–7 and rationals 1–5; 1D like 2D. Identity transforms.
    pub fn for_dimension(d: usize) -> SweepOptions {
        let (poly, rat) = if d >= 3 {
            (1..=7, 1..=5)
        } else {
            (1..=10, 1..=10)
        };
        SweepOptions {
            polynomial_degrees: poly.collect(),
            rational_degrees: rat.collect(),
            rational_pairs: Vec::new(),
            forms: Vec::new(),
            transform_sets: vec![vec![InputTransform::Identity; d]],
            objective: Objective::LeastSquares,
            polynomial: PolynomialOptions::default(),
            rational: RationalOptions::default(),
            continue_degrees: true,
        }
    }
}

/// A degree that was not fitted, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkippedFit {
    pub form: String,
    pub transforms: Vec<InputTransform>,
    pub reason: String,
}

/// All fits of a sweep plus the ones that could not be made.
#[derive(Clone, Debug)]
pub struct SweepReport {
    pub results: Vec<FitResult>,
    pub skipped: Vec<SkippedFit>,
}

/// Runs the sweep; degrees that cannot be fitted (too few points, singular, no feasible start)
/// are listed in `skipped` with the reason. Results are in the order transform set →
/// polynomials by degree → rationals by degree → unequal-degree rationals; each carries its fit time.
pub fn sweep_detailed(data: &FitData, opts: &SweepOptions) -> Result<SweepReport> {
    sweep_with_progress(data, opts, &mut |_| {})
}

/// One finished step of a sweep, for progress reports.
pub enum SweepEvent<'a> {
    Fitted(&'a FitResult),
    Skipped(&'a SkippedFit),
}

/// [`sweep_detailed`], calling `progress` after every fit made or skipped.
pub fn sweep_with_progress(
    data: &FitData,
    opts: &SweepOptions,
    progress: &mut dyn FnMut(SweepEvent<'_>),
) -> Result<SweepReport> {
    data.validate()?;
    let d = data.dim();
    let mut results = Vec::new();
    let mut skipped = Vec::new();
    for transforms in &opts.transform_sets {
        for &deg in &opts.polynomial_degrees {
            match fit_polynomial(data, transforms, deg, opts.objective, &opts.polynomial) {
                Ok(r) => {
                    progress(SweepEvent::Fitted(&r));
                    results.push(r);
                }
                Err(e) => {
                    let s = SkippedFit {
                        form: format!("polynomial of degree {deg}"),
                        transforms: transforms.clone(),
                        reason: e.to_string(),
                    };
                    progress(SweepEvent::Skipped(&s));
                    skipped.push(s);
                }
            }
        }
        let mut previous: Option<FitResult> = None;
        for &deg in &opts.rational_degrees {
            let form = format!("rational of degree {deg}/{deg}");
            let coefficients = 2 * n_terms(d, deg) - 1;
            if coefficients > data.n_weighted() {
                let reason = format!("{coefficients} coefficients but only {} data points; lower the degree or use a finer table", data.n_weighted());
                let s = SkippedFit {
                    form,
                    transforms: transforms.clone(),
                    reason,
                };
                progress(SweepEvent::Skipped(&s));
                skipped.push(s);
                continue;
            }
            let mut ro = opts.rational.clone();
            if opts.continue_degrees {
                if let Some(p) = previous.as_ref().filter(|p| p.is_usable()) {
                    ro.extra_starts.push((
                        format!("previous degree ({})", p.form.label()),
                        p.approximant.clone(),
                    ));
                }
            }
            let t = Instant::now();
            match fit_rational(data, transforms, deg, deg, opts.objective, &ro) {
                Ok(mut r) => {
                    r.fit_seconds = t.elapsed().as_secs_f64();
                    progress(SweepEvent::Fitted(&r));
                    previous = Some(r.clone());
                    results.push(r);
                }
                Err(e) => {
                    let s = SkippedFit {
                        form,
                        transforms: transforms.clone(),
                        reason: e.to_string(),
                    };
                    progress(SweepEvent::Skipped(&s));
                    skipped.push(s);
                }
            }
        }
        for &(n, m) in &opts.rational_pairs {
            let form = format!("rational of degree {n}/{m}");
            let coefficients = n_terms(d, n) + n_terms(d, m) - 1;
            if coefficients > data.n_weighted() {
                let reason = format!("{coefficients} coefficients but only {} data points; lower the degrees or use a finer table", data.n_weighted());
                let s = SkippedFit {
                    form,
                    transforms: transforms.clone(),
                    reason,
                };
                progress(SweepEvent::Skipped(&s));
                skipped.push(s);
                continue;
            }
            let t = Instant::now();
            match fit_rational(data, transforms, n, m, opts.objective, &opts.rational) {
                Ok(mut r) => {
                    r.fit_seconds = t.elapsed().as_secs_f64();
                    progress(SweepEvent::Fitted(&r));
                    results.push(r);
                }
                Err(e) => {
                    let s = SkippedFit {
                        form,
                        transforms: transforms.clone(),
                        reason: e.to_string(),
                    };
                    progress(SweepEvent::Skipped(&s));
                    skipped.push(s);
                }
            }
        }
    }
    let fit_opts = FitOptions {
        polynomial: opts.polynomial.clone(),
        rational: opts.rational.clone(),
        ..FitOptions::default()
    };
    for (form, transforms) in &opts.forms {
        let t = Instant::now();
        let made = fit_form(data, transforms, form, opts.objective, &fit_opts);
        match made {
            Ok(mut r) => {
                r.fit_seconds = t.elapsed().as_secs_f64();
                progress(SweepEvent::Fitted(&r));
                results.push(r);
            }
            Err(e) => {
                let s = SkippedFit {
                    form: form.label_with(&data.names),
                    transforms: transforms.clone(),
                    reason: e.to_string(),
                };
                progress(SweepEvent::Skipped(&s));
                skipped.push(s);
            }
        }
    }
    Ok(SweepReport { results, skipped })
}

/// Runs the sweep and returns the fits made (see [`sweep_detailed`] for the skipped ones).
pub fn sweep(data: &FitData, opts: &SweepOptions) -> Result<Vec<FitResult>> {
    Ok(sweep_detailed(data, opts)?.results)
}

/// The usable (pole-certified, finite) fit with at most `max_coefficients` coefficients and the
/// lowest maximum absolute error (ties: fewer coefficients, then earlier in the list).
pub fn best_under_budget(results: &[FitResult], max_coefficients: usize) -> Option<&FitResult> {
    results
        .iter()
        .filter(|r| r.is_usable() && r.n_coefficients <= max_coefficients)
        .min_by(|a, b| {
            a.metrics
                .max_abs_error
                .total_cmp(&b.metrics.max_abs_error)
                .then(a.n_coefficients.cmp(&b.n_coefficients))
        })
}

/// A fit's headline errors for selection: coefficients, max error and MAE (off-grid when the
/// sweep has a check set), and whether it may be used at all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Score {
    pub n_coefficients: usize,
    pub max_abs_error: f64,
    pub mae: f64,
    pub usable: bool,
}

/// A best fit's MAE may be at most this multiple of the lowest MAE under its budget: minimax
/// fits lower the max error by trading MAE (about 3× on the albedo tables), and a renderer
/// wants both small.
pub const MAE_TOLERANCE: f64 = 1.5;

/// The fit chosen under `budget`: among the usable fits with at most `budget` coefficients
/// whose MAE is within [`MAE_TOLERANCE`] of the lowest such MAE, the one with the lowest max
/// error (ties: fewer coefficients, then earlier). With a `floor` (the index of a reference fit
/// within the budget, e.g. the paper's form refitted), only fits no worse than it on either
/// metric are eligible; if none of those is within the MAE tolerance, the one of them with the
/// lowest max error is chosen (the floor itself qualifies, so a usable floor always yields one).
pub fn select_under_budget(scores: &[Score], budget: usize, floor: Option<usize>) -> Option<usize> {
    let within: Vec<usize> = (0..scores.len())
        .filter(|&i| {
            let s = &scores[i];
            s.usable
                && s.n_coefficients <= budget
                && s.max_abs_error.is_finite()
                && s.mae.is_finite()
        })
        .collect();
    let floor = floor.filter(|f| within.contains(f)).map(|f| scores[f]);
    let eligible: Vec<usize> = within
        .iter()
        .copied()
        .filter(|&i| {
            floor.is_none_or(|f| {
                scores[i].max_abs_error <= f.max_abs_error && scores[i].mae <= f.mae
            })
        })
        .collect();
    let lowest_mae = within
        .iter()
        .map(|&i| scores[i].mae)
        .fold(f64::INFINITY, f64::min);
    let by_max = |set: &mut dyn Iterator<Item = usize>| {
        set.min_by(|&a, &b| {
            scores[a]
                .max_abs_error
                .total_cmp(&scores[b].max_abs_error)
                .then(scores[a].n_coefficients.cmp(&scores[b].n_coefficients))
                .then(a.cmp(&b))
        })
    };
    by_max(
        &mut eligible
            .iter()
            .copied()
            .filter(|&i| scores[i].mae <= MAE_TOLERANCE * lowest_mae),
    )
    .or_else(|| by_max(&mut eligible.iter().copied()))
}

/// The Pareto front of the usable fits in (coefficients, max error, MAE): those no other usable
/// fit matches or beats on all three while beating on one. Sorted by coefficients, then max error.
pub fn pareto_front(scores: &[Score]) -> Vec<usize> {
    let ok = |s: &Score| s.usable && s.max_abs_error.is_finite() && s.mae.is_finite();
    let dominates = |a: &Score, b: &Score| {
        a.n_coefficients <= b.n_coefficients
            && a.max_abs_error <= b.max_abs_error
            && a.mae <= b.mae
            && (a.n_coefficients < b.n_coefficients
                || a.max_abs_error < b.max_abs_error
                || a.mae < b.mae)
    };
    let mut front: Vec<usize> = (0..scores.len())
        .filter(|&i| ok(&scores[i]))
        .filter(|&i| {
            !(0..scores.len())
                .any(|j| j != i && ok(&scores[j]) && dominates(&scores[j], &scores[i]))
        })
        .collect();
    front.sort_by(|&a, &b| {
        scores[a]
            .n_coefficients
            .cmp(&scores[b].n_coefficients)
            .then(scores[a].max_abs_error.total_cmp(&scores[b].max_abs_error))
            .then(a.cmp(&b))
    });
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(n: usize, max: f64, mae: f64) -> Score {
        Score {
            n_coefficients: n,
            max_abs_error: max,
            mae,
            usable: true,
        }
    }

    #[test]
    fn selection_keeps_the_mae_and_never_loses_to_the_floor() {
        let s = vec![
            score(19, 4e-3, 1e-3),   // 0: the floor
            score(19, 2e-3, 3e-3),   // 1: lower max, but MAE 3× the lowest
            score(15, 3e-3, 1.2e-3), // 2: within 1.5× of the lowest MAE
            score(40, 1e-4, 1e-5),   // 3: over the budget
            Score {
                usable: false,
                ..score(10, 1e-9, 1e-9)
            }, // 4: not usable
        ];
        assert_eq!(select_under_budget(&s, 20, None), Some(2));
        // fit 2 has the lower max but a higher MAE than the floor: not eligible with it
        assert_eq!(select_under_budget(&s, 20, Some(0)), Some(0));
        assert_eq!(select_under_budget(&s, 40, Some(0)), Some(3));
        assert_eq!(select_under_budget(&s, 9, None), None);
        // a fit worse than the floor on MAE is never chosen, even with the lowest max error
        let t = vec![score(19, 4e-3, 1e-3), score(19, 1e-3, 1.4e-3)];
        assert_eq!(select_under_budget(&t, 20, None), Some(1));
        assert_eq!(select_under_budget(&t, 20, Some(0)), Some(0));
        assert_eq!(pareto_front(&s), vec![2, 1, 0, 3]);
        assert_eq!(pareto_front(&t), vec![1, 0]);
    }

    #[test]
    fn sweep_and_budget() {
        let ax: Vec<f64> = (0..15).map(|i| i as f64 / 14.0).collect();
        let vals = ax
            .iter()
            .flat_map(|&x| ax.iter().map(move |&y| (x, y)))
            .map(|(x, y)| (1.0 + x * y).sqrt() / (1.1 + x))
            .collect();
        let data =
            FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap();
        let opts = SweepOptions {
            polynomial_degrees: vec![1, 2, 3, 4],
            rational_degrees: vec![1, 2, 3],
            transform_sets: vec![
                vec![InputTransform::Identity; 2],
                vec![InputTransform::Identity, InputTransform::Sqrt],
            ],
            ..SweepOptions::for_dimension(2)
        };
        let rep = sweep_detailed(&data, &opts).unwrap();
        assert_eq!(
            rep.results.len() + rep.skipped.len(),
            14,
            "{:?}",
            rep.skipped
        );
        // polynomial errors fall with degree
        let poly: Vec<f64> = rep.results[..4].iter().map(|r| r.metrics.rmse).collect();
        assert!(poly.windows(2).all(|w| w[1] <= w[0]), "{poly:?}");
        let best = best_under_budget(&rep.results, 11).unwrap();
        assert!(best.n_coefficients <= 11 && best.is_usable());
        assert!(rep
            .results
            .iter()
            .filter(|r| r.n_coefficients <= 11 && r.is_usable())
            .all(|r| r.metrics.max_abs_error >= best.metrics.max_abs_error));
        assert!(best_under_budget(&rep.results, 0).is_none());
    }
}
