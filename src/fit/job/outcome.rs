//! What a sweep produced ([`SweepOutcome`]): its rows, the best fit under each budget and the
//! Pareto front, and the `sweep.json` / `sweep.csv` files.

use serde::{Deserialize, Serialize};

use super::plan::paper_coefficients;
use super::record::{pole_word, FitRecord, FormKind};
use crate::error::Result;
use crate::fit::error::FitError;
use crate::fit::result::{Approximant, Form, Objective};
use crate::fit::source::{FittedOn, Source};
use crate::fit::sweep::{select_under_budget, Score, SkippedFit};

/// The paper's box of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperBox {
    /// [lo, hi] per variable.
    pub bounds: Vec<(f64, f64)>,
    /// In words, with the number of points.
    pub metrics_on: String,
}

/// One row of a sweep summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepRow {
    pub form: FormKind,
    pub degree: u32,
    /// A rational's denominator degree when it differs from `degree`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denominator_degree: Option<u32>,
    /// Transform names, one per variable.
    pub transforms: Vec<String>,
    pub objective: Objective,
    pub n_coefficients: usize,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub rmse: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub max_abs_error: f64,
    pub max_abs_error_at: Vec<f64>,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub max_rel_error: f64,
    /// MAE and max error on the table nodes inside the paper's box ([`SweepOutcome::paper_box`]);
    /// None without one. The fields above are on the whole domain.
    pub paper_box: Option<BoxMetrics>,
    /// MAE and max error at the off-grid check points ([`SweepOutcome::check`]); None without a
    /// check set. With one, these are the numbers the best fits are chosen by.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off_grid: Option<BoxMetrics>,
    /// On the Pareto front of (coefficients, max error, MAE) among the usable fits.
    #[serde(default)]
    pub pareto: bool,
    /// `certified`, `polynomial`, `pole`, `undecided` or `non-finite`.
    pub poles: String,
    pub usable: bool,
    pub converged: bool,
    /// The file name this fit would have as a single fit (`rational-4-mu_sqrt.json`).
    pub name: String,
    /// The form in words, with the variables' names ([`crate::fit::Form::label_with`]): what
    /// tells a low-rank sum or an exponent set apart from the plain rational of its degree.
    #[serde(default)]
    pub label: String,
    /// For an iterate of a minimax fit's Lawson path kept beside its end: which
    /// (`round 7`, `blend 0.75 round 3`; [`crate::fit::LawsonPathIterate`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lawson_iterate: Option<String>,
}

/// Errors of a fit on the points inside a sub-box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxMetrics {
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub max_abs_error: f64,
    pub max_abs_error_at: Vec<f64>,
}

/// The best usable fit under one coefficient budget.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BestUnderBudget {
    pub budget: usize,
    /// Index into the sweep's fits; None if no usable fit fits the budget.
    pub index: Option<usize>,
}

/// Everything a sweep produced.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    pub source: Source,
    /// The data's variable names.
    pub variables: Vec<String>,
    pub fitted_on: FittedOn,
    /// What the rows' `mae`, `max_abs_error`, … were measured on: every point (the whole domain).
    pub metrics_on: String,
    /// The paper's box inside the domain (r ≥ 0.035, μ ≥ 0.02, dielectrics μ ≤ 0.98: where
    /// the paper's tables are; [`crate::fit::paper::paper_box_in`]) and what the rows'
    /// `paper_box` metrics were measured on; None for data without variables `r` and `mu`.
    pub paper_box: Option<PaperBox>,
    /// What the rows' `off_grid` metrics were measured on; None without a check set.
    pub check: Option<String>,
    pub records: Vec<FitRecord>,
    pub rows: Vec<SweepRow>,
    pub skipped: Vec<SkippedFit>,
    pub best: Vec<BestUnderBudget>,
    /// Rows on the Pareto front of (coefficients, max error, MAE), by coefficients.
    pub pareto: Vec<usize>,
    /// The row of the paper's degree-3 rational refitted on this table (identity transforms,
    /// least squares), the floor of every best fit at budgets ≥ [`paper_coefficients`].
    pub paper_refit: Option<usize>,
    /// Wall time of each fit, parallel to `rows` (never written under `fits/`: see [`SweepTiming`]).
    pub fit_seconds: Vec<f64>,
    /// Wall time of the whole sweep, including measuring every fit on all points.
    pub seconds: f64,
}

#[derive(Serialize)]
struct SweepJson<'a> {
    tool: &'a str,
    tool_version: &'a str,
    source: &'a Source,
    fitted_on: &'a FittedOn,
    metrics_on: &'a str,
    paper_box: &'a Option<PaperBox>,
    #[serde(skip_serializing_if = "Option::is_none")]
    off_grid_on: &'a Option<String>,
    /// The summary rows; `fits[i]` holds row i's approximant.
    rows: &'a [SweepRow],
    best: &'a [BestUnderBudget],
    /// Row indices on the Pareto front (coefficients, max error, MAE).
    pareto: &'a [usize],
    paper_refit: Option<usize>,
    skipped: &'a [SkippedFit],
    fits: Vec<&'a Approximant>,
}

/// The best fit under each of `budgets` ([`select_under_budget`]), the fits `excluded` counted
/// as unusable; at budgets of at least [`paper_coefficients`] (of `d` variables) only among
/// fits no worse than `paper_refit` on either metric.
pub fn best_under_budgets(
    records: &[FitRecord],
    budgets: &[usize],
    paper_refit: Option<usize>,
    d: usize,
    excluded: &[usize],
) -> Vec<BestUnderBudget> {
    let scores: Vec<Score> = records
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let (max_abs_error, mae) = r.headline();
            Score {
                n_coefficients: r.fit.n_coefficients,
                max_abs_error,
                mae,
                usable: r.usable && !excluded.contains(&i),
            }
        })
        .collect();
    let paper_count = paper_coefficients(d);
    budgets
        .iter()
        .map(|&budget| BestUnderBudget {
            budget,
            index: select_under_budget(
                &scores,
                budget,
                paper_refit.filter(|_| budget >= paper_count),
            ),
        })
        .collect()
}

impl SweepOutcome {
    /// Chooses the best fits again with the fits `excluded` counted as unusable (e.g. those
    /// whose f32 code fails the stress test every emitted fit must pass); `sweep.json`'s best
    /// entries and the `best-<N>.json` files written from this outcome follow.
    pub fn choose_best_excluding(&mut self, excluded: &[usize]) {
        let budgets: Vec<usize> = self.best.iter().map(|b| b.budget).collect();
        self.best = best_under_budgets(
            &self.records,
            &budgets,
            self.paper_refit,
            self.variables.len(),
            excluded,
        );
    }
}

impl SweepOutcome {
    /// The record of the best fit under `budget`, if any.
    pub fn best_record(&self, budget: usize) -> Option<&FitRecord> {
        self.best
            .iter()
            .find(|b| b.budget == budget)
            .and_then(|b| b.index)
            .map(|i| &self.records[i])
    }

    /// `sweep.json`: provenance, summary rows, the best fit per budget, skipped fits, and every
    /// fit's approximant. No timings: identical inputs give identical bytes (timings go to a
    /// [`SweepTiming`] sidecar outside `fits/`).
    pub fn to_json(&self) -> Result<String> {
        let j = SweepJson {
            tool: "furnace",
            tool_version: crate::VERSION,
            source: &self.source,
            fitted_on: &self.fitted_on,
            metrics_on: &self.metrics_on,
            paper_box: &self.paper_box,
            off_grid_on: &self.check,
            rows: &self.rows,
            best: &self.best,
            pareto: &self.pareto,
            paper_refit: self.paper_refit,
            skipped: &self.skipped,
            fits: self.records.iter().map(|r| &r.fit.approximant).collect(),
        };
        Ok(format!(
            "{}\n",
            serde_json::to_string_pretty(&j).map_err(FitError::from)?
        ))
    }

    /// `sweep.csv`: one line per fit; the last column, the form's label, is quoted (it holds
    /// commas).
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "form,degree,transforms,objective,n_coefficients,mae,rmse,max_abs_error,max_rel_error,paper_box_mae,paper_box_max_abs_error,poles,usable,converged,denominator_degree,off_grid_mae,off_grid_max_abs_error,pareto,lawson_iterate,name,label\n",
        );
        for r in &self.rows {
            let (bm, bx) = r
                .paper_box
                .as_ref()
                .map_or((String::new(), String::new()), |b| {
                    (format!("{:e}", b.mae), format!("{:e}", b.max_abs_error))
                });
            let (om, ox) = r
                .off_grid
                .as_ref()
                .map_or((String::new(), String::new()), |b| {
                    (format!("{:e}", b.mae), format!("{:e}", b.max_abs_error))
                });
            s.push_str(&format!(
                "{},{},{},{},{},{:e},{:e},{:e},{:e},{bm},{bx},{},{},{},{},{om},{ox},{},{},{},\"{}\"\n",
                r.form.name(),
                r.degree,
                r.transforms.join(" "),
                objective_name(r.objective),
                r.n_coefficients,
                r.mae,
                r.rmse,
                r.max_abs_error,
                r.max_rel_error,
                r.poles,
                r.usable,
                r.converged,
                r.denominator_degree
                    .map_or(String::new(), |m| m.to_string()),
                r.pareto,
                r.lawson_iterate.as_deref().unwrap_or(""),
                r.name,
                r.label.replace('"', "\"\"")
            ));
        }
        s
    }
}

pub(super) fn row_of(rec: &FitRecord, paper_box: Option<BoxMetrics>) -> SweepRow {
    let f = &rec.fit;
    let (form, degree, denominator_degree) = match f.form {
        Form::Polynomial { degree } => (FormKind::Polynomial, degree, None),
        Form::Rational {
            numerator_degree,
            denominator_degree,
        } => (
            FormKind::Rational,
            numerator_degree,
            (denominator_degree != numerator_degree).then_some(denominator_degree),
        ),
        Form::Exponents { .. } if f.form.is_rational() => {
            (FormKind::Rational, f.form.numerator_degree(), None)
        }
        Form::Exponents { .. } => (FormKind::Polynomial, f.form.numerator_degree(), None),
    };
    SweepRow {
        form,
        degree,
        denominator_degree,
        transforms: f
            .approximant
            .transforms
            .iter()
            .map(|t| t.label(&f.approximant.variables))
            .collect(),
        objective: f.objective,
        n_coefficients: f.n_coefficients,
        mae: f.metrics.mae,
        rmse: f.metrics.rmse,
        max_abs_error: f.metrics.max_abs_error,
        max_abs_error_at: f.metrics.max_abs_error_at.clone(),
        max_rel_error: f.metrics.max_rel_error,
        paper_box,
        off_grid: rec.off_grid.as_ref().map(|o| BoxMetrics {
            mae: o.metrics.mae,
            max_abs_error: o.metrics.max_abs_error,
            max_abs_error_at: o.metrics.max_abs_error_at.clone(),
        }),
        pareto: false,
        poles: pole_word(f).into(),
        usable: rec.usable,
        converged: f.solver.as_ref().is_none_or(|s| s.converged),
        name: rec.file_name(),
        label: f.form.label_with(&f.approximant.variables),
        lawson_iterate: f
            .solver
            .as_ref()
            .and_then(|s| s.lawson_path.as_ref())
            .map(|it| it.label(" ", " ")),
    }
}

/// `lsq`, `mae`, `minimax`: the CLI's names.
pub fn objective_name(o: Objective) -> &'static str {
    match o {
        Objective::LeastSquares => "lsq",
        Objective::MeanAbsolute => "mae",
        Objective::Minimax => "minimax",
    }
}
