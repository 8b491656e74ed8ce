//! Fit jobs: one fit or a degree sweep of a [`FitInput`], recorded with provenance as a
//! [`FitRecord`] — the content of `fits/<model>/<form>-<degree>.json`, `best-20.json`, … .
//!
//! Large tables are fitted on an even subset of their nodes when the caller asks for it
//! (`max_fit_points`); metrics are then measured again on *every* point of the input, so the
//! numbers in a record always describe the whole table.

mod outcome;
mod plan;
mod record;
mod timing;

pub use outcome::*;
pub use plan::*;
pub use record::*;
pub use timing::*;

use super::data::{FitData, InputTransform};
use super::metrics::{measure, measure_with_subset};
use super::paper::paper_box_in;
use super::polynomial::{fit_polynomial, PolynomialOptions};
use super::rational::{fit_rational, RationalOptions};
use super::result::{FitResult, Form, Objective};
use super::source::{FitInput, FittedOn};
use super::sweep::{
    pareto_front, sweep_with_progress, Score, SkippedFit, SweepEvent, SweepOptions,
};
use crate::error::{Error, Result};

/// The data the solver sees and how it was chosen.
fn fitting_data(input: &FitInput, max_fit_points: usize) -> Result<(Option<FitData>, FittedOn)> {
    fitting_data_graded(input, max_fit_points, &[])
}

/// [`fitting_data`] with a grid's nodes graded per axis ([`FitInput::reduced_graded`]).
fn fitting_data_graded(
    input: &FitInput,
    max_fit_points: usize,
    grading: &[f64],
) -> Result<(Option<FitData>, FittedOn)> {
    Ok(match input.reduced_graded(max_fit_points, grading)? {
        Some((d, on)) => (Some(d), on),
        None => (
            None,
            FittedOn {
                points: input.data.len(),
                selection: "all points".into(),
            },
        ),
    })
}

/// Re-measures a fit on every point of `input` if it was fitted on fewer.
fn remeasure(mut fit: FitResult, input: &FitInput, reduced: bool) -> FitResult {
    if reduced {
        fit.metrics = measure(&fit.approximant, &input.data);
    }
    fit
}

/// Makes one fit.
pub fn fit_one(input: &FitInput, req: &FitRequest) -> Result<FitRecord> {
    fit_one_with(input, req, &RationalOptions::default())
}

/// [`fit_one`] with the rational fit's settings (e.g. its least-squares solver,
/// [`RationalOptions::method`]).
pub fn fit_one_with(
    input: &FitInput,
    req: &FitRequest,
    rational: &RationalOptions,
) -> Result<FitRecord> {
    if req.transforms.len() != input.data.dim() {
        return Err(Error::InvalidInput(format!(
            "{} transforms for the {} variables {}",
            req.transforms.len(),
            input.data.dim(),
            input.data.names.join(",")
        )));
    }
    let (reduced, fitted_on) = fitting_data(input, req.max_fit_points)?;
    let data = reduced.as_ref().unwrap_or(&input.data);
    let fit = match req.form {
        FormKind::Polynomial => fit_polynomial(
            data,
            &req.transforms,
            req.degree,
            req.objective,
            &PolynomialOptions::default(),
        )?,
        FormKind::Rational => fit_rational(
            data,
            &req.transforms,
            req.degree,
            req.degree,
            req.objective,
            rational,
        )?,
    };
    Ok(FitRecord::new(
        remeasure(fit, input, reduced.is_some()),
        input,
        fitted_on,
    ))
}

/// Makes one fit of any [`Form`] ([`super::fit_form`]) on at most `max_fit_points` points
/// (0 = all), measured on all of them.
pub fn fit_one_form(
    input: &FitInput,
    form: &Form,
    objective: Objective,
    transforms: &[InputTransform],
    max_fit_points: usize,
    opts: &super::FitOptions,
) -> Result<FitRecord> {
    let (reduced, fitted_on) = fitting_data(input, max_fit_points)?;
    let data = reduced.as_ref().unwrap_or(&input.data);
    let fit = super::fit_form(data, transforms, form, objective, opts)?;
    Ok(FitRecord::new(
        remeasure(fit, input, reduced.is_some()),
        input,
        fitted_on,
    ))
}

fn progress_line(r: &FitResult) -> String {
    format!(
        "{:<26} [{}] {:<7} n={:<3} MAE {:.2e} max {:.2e} (on the fitted points) {:>7.2} s {}",
        r.form.label(),
        r.approximant
            .transforms
            .iter()
            .map(|t| t.label(&r.approximant.variables))
            .collect::<Vec<_>>()
            .join(" "),
        match r.solver.as_ref().and_then(|s| s.lawson_path.as_ref()) {
            Some(it) => format!("{} {}", objective_name(r.objective), it.label(" ", " ")),
            None => objective_name(r.objective).to_string(),
        },
        r.n_coefficients,
        r.metrics.mae,
        r.metrics.max_abs_error,
        r.fit_seconds,
        pole_word(r)
    )
}

/// Indices of the least-squares fits worth refitting for minimax error: per budget, the
/// [`MINIMAX_REFITS_BY_MAX`] usable ones with the lowest max error and the one with the lowest
/// MAE (the least-squares fit with the most accuracy to trade for a lower maximum).
///
/// A fit whose MAE is already beyond [`super::sweep::MAE_TOLERANCE`] × the lowest MAE under
/// the smallest budget it fits in is not refitted: a minimax refit trades MAE for max error
/// (its MAE is 1.6–3× the least-squares one on the albedo tables), so it could not be chosen
/// under that budget or any larger one. After these, in record order, every other usable
/// least-squares fit within that bound that `always` names (the plan's forms marked
/// [`PlannedForm::minimax_refit`]).
fn minimax_candidates(
    records: &[FitRecord],
    budgets: &[usize],
    always: impl Fn(&FitRecord) -> bool,
) -> Vec<usize> {
    let lowest_mae = |budget: usize| {
        records
            .iter()
            .filter(|r| r.usable && r.fit.n_coefficients <= budget)
            .map(|r| r.headline().1)
            .fold(f64::INFINITY, f64::min)
    };
    let hopeful = |i: usize| {
        let n = records[i].fit.n_coefficients;
        budgets.iter().filter(|&&b| b >= n).min().is_some_and(|&b| {
            records[i].headline().1 <= super::sweep::MAE_TOLERANCE * lowest_mae(b)
        })
    };
    let mut chosen: Vec<usize> = Vec::new();
    for &budget in budgets {
        let mut c: Vec<usize> = (0..records.len())
            .filter(|&i| {
                let f = &records[i].fit;
                records[i].usable
                    && f.objective == Objective::LeastSquares
                    && f.n_coefficients <= budget
                    && hopeful(i)
            })
            .collect();
        c.sort_by(|&a, &b| {
            records[a]
                .headline()
                .0
                .total_cmp(&records[b].headline().0)
                .then(a.cmp(&b))
        });
        let by_mae = c.iter().copied().min_by(|&a, &b| {
            records[a]
                .headline()
                .1
                .total_cmp(&records[b].headline().1)
                .then(a.cmp(&b))
        });
        for i in c.into_iter().take(MINIMAX_REFITS_BY_MAX).chain(by_mae) {
            if !chosen.contains(&i) {
                chosen.push(i);
            }
        }
    }
    for (i, r) in records.iter().enumerate() {
        if r.usable
            && r.fit.objective == Objective::LeastSquares
            && hopeful(i)
            && always(r)
            && !chosen.contains(&i)
        {
            chosen.push(i);
        }
    }
    chosen
}

/// Which points of `data` lie inside `bounds`, or None if none do.
fn points_in(data: &FitData, bounds: &[(f64, f64)]) -> Option<Vec<bool>> {
    let mask: Vec<bool> = (0..data.len())
        .map(|i| {
            data.point(i)
                .iter()
                .zip(bounds)
                .all(|(v, (lo, hi))| v >= lo && v <= hi)
        })
        .collect();
    mask.contains(&true).then_some(mask)
}

/// A fit's metrics on every point of `input` (measured again if it was fitted on fewer) and
/// on the points of `mask`, in one pass.
fn measured(
    mut fit: FitResult,
    input: &FitInput,
    reduced: bool,
    mask: Option<&[bool]>,
) -> (FitResult, Option<BoxMetrics>) {
    if !reduced && mask.is_none() {
        return (fit, None);
    }
    let (all, sub) = measure_with_subset(&fit.approximant, &input.data, mask);
    if reduced {
        fit.metrics = all;
    }
    (
        fit,
        sub.map(|m| BoxMetrics {
            mae: m.mae,
            max_abs_error: m.max_abs_error,
            max_abs_error_at: m.max_abs_error_at,
        }),
    )
}

/// Runs a sweep; `progress` gets one line per fit made or skipped.
///
/// 1. The paper's sweep ([`sweep_with_progress`]) for every transform set, on the reduced data.
/// 2. With `minimax_refits` and a least-squares sweep: the [`minimax_candidates`] are fitted
///    again with the minimax objective (Lawson reweighting started from the least-squares
///    coefficients), since "best under a budget" is judged by max error — objective switching.
/// 3. Every fit is measured on all points; the best usable fit per budget is the one with the
///    lowest max error ([`best_under_budget`]).
pub fn sweep_fits(
    input: &FitInput,
    plan: &SweepPlan,
    progress: &mut dyn FnMut(&str),
) -> Result<SweepOutcome> {
    sweep_fits_checked(input, plan, None, progress)
}

/// [`sweep_fits`] with an off-grid check set (`check`: the points as data, and what they are):
/// every fit is also measured there, and the best fits are chosen by those errors.
///
/// The best fit under each budget is [`select_under_budget`]'s: the lowest max error among the
/// usable fits whose MAE is within [`super::sweep::MAE_TOLERANCE`] of the lowest; at budgets of
/// at least [`paper_coefficients`], only among fits no worse than the paper's degree-3 rational
/// refitted on the same table (identity transforms, least squares) on either metric.
pub fn sweep_fits_checked(
    input: &FitInput,
    plan: &SweepPlan,
    check: Option<(&FitData, &str)>,
    progress: &mut dyn FnMut(&str),
) -> Result<SweepOutcome> {
    sweep_fits_trained(input, plan, check, None, progress)
}

/// The fitting data with `training` points appended (their values exact, weight 1).
fn with_training(data: &FitData, training: &FitData) -> Result<FitData> {
    if training.names != data.names {
        return Err(Error::InvalidInput(format!(
            "the training set's variables {} are not the data's {}",
            training.names.join(","),
            data.names.join(",")
        )));
    }
    let mut coords = data.coords.clone();
    coords.extend_from_slice(&training.coords);
    let mut values = data.values.clone();
    values.extend_from_slice(&training.values);
    let mut out = FitData::new(data.names.clone(), coords, values, data.domain.clone())?;
    out.weights = data.weights.as_ref().map(|w| {
        let mut w = w.clone();
        w.resize(w.len() + training.len(), 1.0);
        w
    });
    Ok(out)
}

/// [`sweep_fits_checked`] whose solver also sees `training`: exact off-grid points (the
/// points as data, and what they are; [`super::check::training_get_or_compute`]) appended to the
/// table's fitting nodes. Every fit is still measured on all the table's nodes and on `check`.
pub fn sweep_fits_trained(
    input: &FitInput,
    plan: &SweepPlan,
    check: Option<(&FitData, &str)>,
    training: Option<(&FitData, &str)>,
    progress: &mut dyn FnMut(&str),
) -> Result<SweepOutcome> {
    let start = std::time::Instant::now();
    plan.validate(&input.data)?;
    if let Some((c, _)) = check {
        if c.names != input.data.names {
            return Err(Error::InvalidInput(format!(
                "the check set's variables {} are not the data's {}",
                c.names.join(","),
                input.data.names.join(",")
            )));
        }
    }
    let d = input.data.dim();
    if let Some(t) = plan.transform_sets.iter().find(|t| t.len() != d) {
        return Err(Error::InvalidInput(format!(
            "a transform set has {} entries for {d} variables",
            t.len()
        )));
    }
    let (mut reduced, mut fitted_on) =
        fitting_data_graded(input, plan.max_fit_points, &plan.fit_grading)?;
    if let Some((t, what)) = training {
        let joined = with_training(reduced.as_ref().unwrap_or(&input.data), t)?;
        fitted_on = FittedOn {
            points: joined.len(),
            selection: format!("{}, and {what}", fitted_on.selection),
        };
        reduced = Some(joined);
    }
    let data = reduced.as_ref().unwrap_or(&input.data);
    let (boxed, paper_box) = match paper_box_in(
        &input.data.names,
        &input.data.domain,
        input.source.model.as_deref(),
    ) {
        Some(bounds) => {
            let b = points_in(&input.data, &bounds);
            let text = input
                .data
                .names
                .iter()
                .zip(&bounds)
                .map(|(n, (lo, hi))| format!("{n} ∈ [{lo}, {hi}]"))
                .collect::<Vec<_>>()
                .join(", ");
            let on = format!(
                "the {} points with {text} (the paper's box: where its tables are)",
                b.as_ref().map_or(0, |m| m.iter().filter(|&&x| x).count())
            );
            (
                b,
                Some(PaperBox {
                    bounds,
                    metrics_on: on,
                }),
            )
        }
        None => (None, None),
    };
    let opts = SweepOptions {
        polynomial_degrees: plan.polynomial_degrees.clone(),
        rational_degrees: plan.rational_degrees.clone(),
        rational_pairs: plan.rational_pairs.clone(),
        forms: plan
            .forms
            .iter()
            .map(|f| (f.form.clone(), f.transforms.clone()))
            .collect(),
        transform_sets: plan.transform_sets.clone(),
        objective: plan.objective,
        ..SweepOptions::for_dimension(d)
    };
    let mut on_event = |e: SweepEvent<'_>| match e {
        SweepEvent::Fitted(r) => progress(&progress_line(r)),
        SweepEvent::Skipped(s) => progress(&format!("{:<26} skipped: {}", s.form, s.reason)),
    };
    let mut report = sweep_with_progress(data, &opts, &mut on_event)?;
    let mut records = Vec::with_capacity(report.results.len());
    let mut rows = Vec::with_capacity(report.results.len());
    let mut fit_seconds = Vec::with_capacity(report.results.len());
    for fit in report.results {
        fit_seconds.push(fit.fit_seconds);
        let (fit, on_box) = measured(fit, input, reduced.is_some(), boxed.as_deref());
        let rec = FitRecord::new(fit, input, fitted_on.clone()).with_off_grid(check);
        rows.push(row_of(&rec, on_box));
        records.push(rec);
    }
    if plan.minimax_refits && plan.objective == Objective::LeastSquares {
        let always = |r: &FitRecord| plan.always_refit(&r.fit.form, &r.fit.approximant.transforms);
        for i in minimax_candidates(&records, &plan.budgets, always) {
            let ls = &records[i].fit;
            let transforms = ls.approximant.transforms.clone();
            let t = std::time::Instant::now();
            let fitted = match ls.form.clone() {
                Form::Polynomial { degree } => fit_polynomial(
                    data,
                    &transforms,
                    degree,
                    Objective::Minimax,
                    &PolynomialOptions::default(),
                ),
                Form::Rational {
                    numerator_degree,
                    denominator_degree,
                } => {
                    let mut ro = RationalOptions {
                        lp_polish: plan.lp_polish_for(&ls.form, &transforms).to_vec(),
                        max_mean_polish: plan.max_mean_polish.clone(),
                        ..RationalOptions::default()
                    };
                    ro.extra_starts.push((
                        "least-squares fit of the sweep".into(),
                        ls.approximant.clone(),
                    ));
                    fit_rational(
                        data,
                        &transforms,
                        numerator_degree,
                        denominator_degree,
                        Objective::Minimax,
                        &ro,
                    )
                }
                form @ Form::Exponents { .. } => {
                    let mut opts = super::FitOptions::default();
                    let polish = plan.lp_polish_for(&form, &transforms);
                    opts.rational.lp_polish = polish.to_vec();
                    opts.structured.lp_polish = polish.to_vec();
                    opts.rational.max_mean_polish = plan.max_mean_polish.clone();
                    opts.structured.max_mean_polish = plan.max_mean_polish.clone();
                    opts.rational.extra_starts.push((
                        "least-squares fit of the sweep".into(),
                        ls.approximant.clone(),
                    ));
                    super::fit_form(data, &transforms, &form, Objective::Minimax, &opts)
                }
            };
            match fitted {
                Ok(mut fit) => {
                    fit.fit_seconds = t.elapsed().as_secs_f64();
                    // the Lawson path's other iterates are rows of their own (solved with it)
                    let path = std::mem::take(&mut fit.path);
                    for fit in std::iter::once(fit).chain(path) {
                        progress(&progress_line(&fit));
                        fit_seconds.push(fit.fit_seconds);
                        let (fit, on_box) =
                            measured(fit, input, reduced.is_some(), boxed.as_deref());
                        let rec =
                            FitRecord::new(fit, input, fitted_on.clone()).with_off_grid(check);
                        rows.push(row_of(&rec, on_box));
                        records.push(rec);
                    }
                }
                Err(e) => {
                    let s = SkippedFit {
                        form: format!("{} (minimax)", ls.form.label()),
                        transforms,
                        reason: e.to_string(),
                    };
                    progress(&format!("{:<26} skipped: {}", s.form, s.reason));
                    report.skipped.push(s);
                }
            }
        }
    }
    let paper_refit = records.iter().position(|r| {
        r.fit.objective == Objective::LeastSquares
            && r.fit.form
                == Form::Rational {
                    numerator_degree: 3,
                    denominator_degree: 3,
                }
            && r.fit
                .approximant
                .transforms
                .iter()
                .all(|t| *t == InputTransform::Identity)
    });
    let best = best_under_budgets(&records, &plan.budgets, paper_refit, d, &[]);
    let scores: Vec<Score> = records
        .iter()
        .map(|r| {
            let (max_abs_error, mae) = r.headline();
            Score {
                n_coefficients: r.fit.n_coefficients,
                max_abs_error,
                mae,
                usable: r.usable,
            }
        })
        .collect();
    let pareto = pareto_front(&scores);
    for &i in &pareto {
        rows[i].pareto = true;
    }
    Ok(SweepOutcome {
        source: input.source.clone(),
        variables: input.data.names.clone(),
        fitted_on,
        metrics_on: format!(
            "all {} points of the source (the whole domain)",
            input.data.len()
        ),
        paper_box: paper_box.filter(|_| boxed.is_some()),
        check: check.map(|c| c.1.to_string()),
        records,
        rows,
        skipped: report.skipped,
        best,
        pareto,
        paper_refit,
        fit_seconds,
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::source::Source;

    #[test]
    fn boundary_layer_sets_drop_unless_asked_for() {
        let (r, mu): (Vec<f64>, Vec<f64>) = (0..16)
            .map(|k| ((k / 4) as f64 / 3.0, (k % 4) as f64 / 3.0))
            .unzip();
        let coords: Vec<f64> = r.iter().zip(&mu).flat_map(|(&a, &b)| [a, b]).collect();
        let data = FitData::new(
            vec!["r".into(), "mu".into()],
            coords,
            vec![0.5; 16],
            vec![(0.0, 1.0); 2],
        )
        .unwrap();
        let is_layer = |t: &Vec<InputTransform>| {
            t.iter()
                .any(|x| matches!(x, InputTransform::BoundaryLayer { .. }))
        };
        let plan = SweepPlan::paper(&data, None, None, Objective::LeastSquares);
        assert_eq!(
            plan.transform_sets.iter().filter(|t| is_layer(t)).count(),
            2,
            "{:?}",
            plan.transform_sets
        );
        let n = plan.transform_sets.len();
        let kept = plan.clone().without_boundary_layer(None);
        assert_eq!(kept.transform_sets.len(), n - 2);
        assert!(!kept.transform_sets.iter().any(is_layer));
        let asked = plan
            .transform_sets
            .iter()
            .find(|t| is_layer(t))
            .unwrap()
            .clone();
        let kept = plan.without_boundary_layer(Some(&asked));
        assert_eq!(
            kept.transform_sets
                .iter()
                .filter(|t| is_layer(t))
                .collect::<Vec<_>>(),
            vec![&asked]
        );
    }

    /// A sweep fitted on graded nodes plus training points: the solver sees both, the fit is
    /// measured on every node, and a layer between the subset's nodes is resolved better.
    #[test]
    fn training_points_join_the_graded_fitting_nodes() {
        let ax: Vec<f64> = (0..17).map(|i| i as f64 / 16.0).collect();
        let names: Vec<String> = ["f0", "r", "mu"].iter().map(|s| s.to_string()).collect();
        // a thin layer in mu: e^(−40μ)
        let e = |x: &[f64]| 0.5 + 0.3 * x[0] - 0.2 * x[1] + 0.4 * (-40.0 * x[2]).exp();
        let mut values = Vec::new();
        for &a in &ax {
            for &b in &ax {
                for &c in &ax {
                    values.push(e(&[a, b, c]));
                }
            }
        }
        let data = FitData::from_grid(names.clone(), &[ax.clone(), ax.clone(), ax.clone()], values)
            .unwrap();
        let input = FitInput {
            source: Source {
                kind: "json_grid".into(),
                model: None,
                path: None,
                content_hash: "test".into(),
                resolution: Some(vec![17; 3]),
                channel: "E".into(),
                points: data.len(),
                restricted_to: None,
            },
            data,
            grid: Some(vec![ax.clone(), ax.clone(), ax]),
            table: None,
        };
        let domain = vec![(0.0, 1.0); 3];
        let coords = super::super::check::training_points(&names, &domain, 400);
        let values: Vec<f64> = coords.chunks(3).map(e).collect();
        let training = FitData::new(names.clone(), coords, values, domain.clone()).unwrap();
        let check_coords = super::super::check::check_points(&names, &domain);
        let check_values: Vec<f64> = check_coords.chunks(3).map(e).collect();
        let check = FitData::new(names, check_coords, check_values, domain).unwrap();
        let plan = SweepPlan {
            polynomial_degrees: vec![4],
            rational_degrees: Vec::new(),
            rational_pairs: Vec::new(),
            forms: Vec::new(),
            transform_sets: vec![vec![InputTransform::Identity; 3]],
            objective: Objective::LeastSquares,
            max_fit_points: 6 * 6 * 6,
            fit_grading: vec![1.0, 1.0, 2.0],
            training_points: 400,
            budgets: vec![40],
            minimax_refits: false,
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        };
        let run = |training: Option<(&FitData, &str)>, grading: Vec<f64>| {
            let plan = SweepPlan {
                fit_grading: grading,
                ..plan.clone()
            };
            sweep_fits_trained(
                &input,
                &plan,
                Some((&check, "check")),
                training,
                &mut |_| {},
            )
            .unwrap()
        };
        let even = run(None, Vec::new());
        let trained = run(
            Some((&training, "400 training points")),
            plan.fit_grading.clone(),
        );
        assert_eq!(even.fitted_on.points, 216);
        assert_eq!(trained.fitted_on.points, 216 + 400);
        assert!(trained.fitted_on.selection.contains("graded"));
        assert!(trained.fitted_on.selection.contains("400 training points"));
        // measured on all 17³ nodes either way
        assert!(trained.records[0].fit.metrics.max_abs_error_at.len() == 3);
        let off = |o: &SweepOutcome| {
            o.records[0]
                .off_grid
                .as_ref()
                .unwrap()
                .metrics
                .max_abs_error
        };
        assert!(
            off(&trained) < off(&even),
            "{} vs {}",
            off(&trained),
            off(&even)
        );
        // a training set of other variables is refused
        let other = FitData::new(
            vec!["a".into(), "b".into(), "c".into()],
            vec![0.5; 3],
            vec![0.5],
            vec![(0.0, 1.0); 3],
        )
        .unwrap();
        let e = sweep_fits_trained(&input, &plan, None, Some((&other, "x")), &mut |_| {});
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("training set's variables"));
    }

    /// A table over (r, μ) on the n × n grid of [0, 1]² with E = `e(r, μ)`, as a sweep reads it.
    fn grid_input_2d(n: usize, e: impl Fn(f64, f64) -> f64) -> FitInput {
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let values = ax
            .iter()
            .flat_map(|&r| ax.iter().map(move |&mu| (r, mu)))
            .map(|(r, mu)| e(r, mu))
            .collect();
        let data = FitData::from_grid(
            vec!["r".into(), "mu".into()],
            &[ax.clone(), ax.clone()],
            values,
        )
        .unwrap();
        FitInput {
            source: Source {
                kind: "json_grid".into(),
                model: None,
                path: None,
                content_hash: "test".into(),
                resolution: Some(vec![n; 2]),
                channel: "E".into(),
                points: data.len(),
                restricted_to: None,
            },
            data,
            grid: Some(vec![ax.clone(), ax]),
            table: None,
        }
    }

    /// A best fit counted unusable afterwards (its f32 code failed the stress test) gives way to
    /// the next under the rule, and a budget whose every fit is excluded has none.
    #[test]
    fn excluded_best_fits_give_way() {
        let input = grid_input_2d(9, |r, mu| 1.0 / (1.2 + r * mu) + 0.1 * r * r);
        let plan = SweepPlan {
            polynomial_degrees: vec![1, 2, 3, 4],
            rational_degrees: Vec::new(),
            rational_pairs: Vec::new(),
            forms: Vec::new(),
            transform_sets: vec![vec![InputTransform::Identity; 2]],
            objective: Objective::LeastSquares,
            max_fit_points: 0,
            fit_grading: Vec::new(),
            training_points: 0,
            budgets: vec![20],
            minimax_refits: false,
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        };
        let mut outcome = sweep_fits(&input, &plan, &mut |_| {}).unwrap();
        let first = outcome.best[0].index.unwrap();
        outcome.choose_best_excluding(&[first]);
        let second = outcome.best[0].index.unwrap();
        assert_ne!(first, second);
        assert!(
            outcome.records[second].headline().0 >= outcome.records[first].headline().0,
            "the rule's first choice had the lowest max error"
        );
        let all: Vec<usize> = (0..outcome.records.len()).collect();
        outcome.choose_best_excluding(&all);
        assert_eq!(outcome.best[0].index, None);
        assert!(outcome.best_record(20).is_none());
    }

    /// A planned form marked for its minimax refit gets one whatever its least-squares rank;
    /// the other refits stay as they were.
    #[test]
    fn a_form_marked_for_minimax_is_refitted_whatever_its_rank() {
        let input = grid_input_2d(11, |r, mu| {
            1.0 / (1.2 + r * mu) + 0.1 * (2.0 * r).sin() * mu.sqrt()
        });
        let names = input.data.names.clone();
        let identity = vec![InputTransform::Identity; 2];
        let forms: Vec<PlannedForm> = ["tensor:2,5", "tensor:3,5", "tensor:4,5", "tensor:5,5"]
            .iter()
            .map(|s| PlannedForm::new(crate::fit::parse_form(s, &names).unwrap(), identity.clone()))
            .collect();
        let plan = SweepPlan {
            polynomial_degrees: vec![3],
            rational_degrees: Vec::new(),
            rational_pairs: Vec::new(),
            forms,
            transform_sets: vec![identity.clone()],
            objective: Objective::LeastSquares,
            max_fit_points: 0,
            fit_grading: Vec::new(),
            training_points: 0,
            budgets: vec![40],
            minimax_refits: true,
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        };
        let refitted = |o: &SweepOutcome, form: &Form| {
            o.records
                .iter()
                .filter(|r| r.fit.objective == Objective::Minimax && &r.fit.form == form)
                .count()
        };
        let plain = sweep_fits(&input, &plan, &mut |_| {}).unwrap();
        // a planned form the rank leaves out, though its MAE would let it be chosen
        let lowest = plain
            .records
            .iter()
            .map(|r| r.fit.metrics.mae)
            .fold(f64::INFINITY, f64::min);
        let skipped = plan
            .forms
            .iter()
            .position(|f| {
                refitted(&plain, &f.form) == 0
                    && plain.records.iter().any(|r| {
                        r.fit.form == f.form
                            && r.fit.metrics.mae <= super::super::sweep::MAE_TOLERANCE * lowest
                    })
            })
            .expect("a hopeful planned form left out by rank");
        let mut marked = plan.clone();
        marked.forms[skipped] = marked.forms[skipped].clone().with_minimax_refit();
        assert!(serde_json::to_string(&marked)
            .unwrap()
            .contains("\"minimax_refit\":true"));
        assert!(!serde_json::to_string(&plan)
            .unwrap()
            .contains("\"minimax_refit\":"));
        let both = sweep_fits(&input, &marked, &mut |_| {}).unwrap();
        // its minimax fit and the kept iterates of its Lawson path are rows of their own
        let extra = refitted(&both, &plan.forms[skipped].form);
        assert!(extra >= 1);
        assert_eq!(both.records.len(), plain.records.len() + extra);
        for f in &plan.forms {
            if f.form != plan.forms[skipped].form {
                assert_eq!(refitted(&both, &f.form), refitted(&plain, &f.form));
            }
        }
    }

    /// A solver that stopped short is reported as what it was: Lawson reweighting of a
    /// polynomial fit has no Levenberg–Marquardt run to name.
    #[test]
    fn the_non_convergence_warning_names_the_solver_that_ran() {
        let ax: Vec<f64> = (0..9).map(|i| i as f64 / 8.0).collect();
        let vals = ax.iter().map(|&x| (3.0 * x).sin()).collect();
        let data = FitData::from_grid(vec!["x".into()], &[ax], vals).unwrap();
        let mut fit = fit_polynomial(
            &data,
            &[InputTransform::Identity],
            2,
            Objective::Minimax,
            &PolynomialOptions::default(),
        )
        .unwrap();
        let solver = fit.solver.as_mut().unwrap();
        solver.converged = false;
        assert!(solver.termination.is_none());
        let source = Source {
            kind: "csv".into(),
            model: None,
            path: None,
            content_hash: String::new(),
            resolution: None,
            channel: "E".into(),
            points: 9,
            restricted_to: None,
        };
        let on = FittedOn {
            points: 9,
            selection: "all points".into(),
        };
        let rec = FitRecord::from_source(fit, source, None, on);
        let w = rec.warnings.join("\n");
        assert!(
            w.contains("reweighting rounds of Lawson") && !w.contains("Levenberg"),
            "{w}"
        );
    }

    #[test]
    fn file_names() {
        let v = vec!["r".to_string(), "mu".to_string()];
        assert_eq!(
            fit_file_name(
                FormKind::Rational,
                3,
                &v,
                &[InputTransform::Identity; 2],
                Objective::LeastSquares
            ),
            "rational-3.json"
        );
        assert_eq!(
            fit_file_name(
                FormKind::Rational,
                4,
                &v,
                &[InputTransform::Identity, InputTransform::Sqrt],
                Objective::Minimax
            ),
            "rational-4-mu_sqrt-minimax.json"
        );
    }

    #[test]
    fn transforms_parse() {
        let v = vec!["f0".to_string(), "r".to_string(), "mu".to_string()];
        let t = parse_transforms("mu=sqrt, f0=clamp:0.0125:0.25", &v).unwrap();
        assert_eq!(
            t,
            vec![
                InputTransform::ClampNormalize {
                    lo: 0.0125,
                    hi: 0.25
                },
                InputTransform::Identity,
                InputTransform::Sqrt
            ]
        );
        assert!(parse_transforms("x=sqrt", &v)
            .unwrap_err()
            .to_string()
            .contains("unknown variable 'x'"));
        assert!(parse_transforms("mu=log", &v)
            .unwrap_err()
            .to_string()
            .contains("unknown transform"));
        assert!(parse_transforms("mu=sqrt,mu=square", &v).is_err());
        let t = parse_transforms("mu=layer:r:0.5,r=square", &v).unwrap();
        assert_eq!(
            t,
            vec![
                InputTransform::Identity,
                InputTransform::Square,
                InputTransform::BoundaryLayer { by: 1, k: 0.5 }
            ]
        );
        assert_eq!(
            fit_file_name(FormKind::Rational, 4, &v, &t, Objective::LeastSquares),
            "rational-4-r_square-mu_layer_r_0.5.json"
        );
        for bad in [
            "mu=layer:r",
            "mu=layer:q:1",
            "mu=layer:r:0",
            "r=layer:mu:1",
            "mu=layer:r:inf",
        ] {
            assert!(
                parse_transforms(bad, &v)
                    .unwrap_err()
                    .to_string()
                    .contains("layer:<variable>:<k>"),
                "{bad}"
            );
        }
    }
}
