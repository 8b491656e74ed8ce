//! The paper's published fits against furnace's tables and fits (`furnace compare-paper`).
//!
//! For each of the paper's four fits (Sforza & Pellacini 2022, Appendix A) the published
//! degree-3 rational is evaluated on furnace's table of the same model with separable Smith G
//! (the paper's renderer), next to furnace's own degree-3 rational (same 19/39 coefficients,
//! same variables and transforms) and furnace's best certified fit with ≤ 40 coefficients.
//! Dielectric tables are compared in the paper's *radiance* form of transmission (E_T × 1/η²
//! entering, × η² leaving), since that is what its coefficients approximate; the caller supplies
//! tables computed that way. A second part repeats the paper's own measurement on its 32-point
//! tables, with furnace's degree-3 rational fitted to the same data.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::data::FitData;
use super::job::{pole_word, verdict, FitRecord};
use super::paper::{load_coefficients, load_table, PaperModel};
use super::poles::CertifyOptions;
use super::rational::{fit_rational, RationalOptions};
use super::result::{FitResult, Form, Objective};
use super::source::FitInput;
use crate::error::Result;

/// One of the paper's fits and the furnace model it approximates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PaperPair {
    pub paper: PaperModel,
    /// File stem under `coefficients/` and `tables/`.
    pub paper_name: &'static str,
    /// furnace model (separable Smith G, as the paper's renderer).
    pub model: &'static str,
    /// The table must be in radiance form of transmission (dielectrics).
    pub radiance: bool,
}

/// The paper's four fits.
pub const PAPER_PAIRS: [PaperPair; 4] = [
    PaperPair { paper: PaperModel::Conductors, paper_name: "conductors", model: "ggx-conductor-separable", radiance: false },
    PaperPair { paper: PaperModel::Glossy, paper_name: "glossy", model: "ggx-glossy-separable", radiance: false },
    PaperPair { paper: PaperModel::Dielectrics, paper_name: "dielectrics", model: "ggx-dielectric-separable", radiance: true },
    PaperPair { paper: PaperModel::DielectricsInvEta, paper_name: "dielectrics_inv_eta", model: "ggx-dielectric-inv-separable", radiance: true },
];

/// One fit's line of the comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareLine {
    /// `paper 3/3`, `furnace 3/3`, `furnace best ≤ 40`.
    pub fit: String,
    pub form: String,
    /// Transform names, one per variable.
    pub transforms: Vec<String>,
    pub n_coefficients: usize,
    #[serde(with = "super::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "super::metrics::finite_or_string")]
    pub max_abs_error: f64,
    pub max_abs_error_at: Vec<f64>,
    /// `certified`, `polynomial`, `pole`, `undecided`, `non-finite`.
    pub poles: String,
    pub verdict: String,
}

impl CompareLine {
    pub fn of(fit: &str, r: &FitResult) -> CompareLine {
        CompareLine {
            fit: fit.into(),
            form: r.form.label(),
            transforms: r.approximant.transforms.iter().map(|t| t.name()).collect(),
            n_coefficients: r.n_coefficients,
            mae: r.metrics.mae,
            max_abs_error: r.metrics.max_abs_error,
            max_abs_error_at: r.metrics.max_abs_error_at.clone(),
            poles: pole_word(r).into(),
            verdict: verdict(r).1,
        }
    }
}

/// The comparison for one model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareEntry {
    pub paper_fit: String,
    pub model: String,
    /// Radiance or energy form of transmission in the furnace table.
    pub transmission: Option<String>,
    pub table_resolution: Option<Vec<usize>>,
    pub table_content_hash: String,
    /// Points of the table the 3/3 fit saw (metrics are on all of them).
    pub furnace_fit_points: usize,
    pub on_furnace_table: Vec<CompareLine>,
    /// The paper's fit and furnace's 3/3 on the paper's own 32-point table.
    pub on_paper_table: Vec<CompareLine>,
}

/// The paper's approximant measured on `input` (variables renamed to the table's).
pub fn paper_fit_on(paper_dir: &Path, pair: &PaperPair, data: &FitData) -> Result<FitResult> {
    let mut a = load_coefficients(&paper_dir.join("coefficients").join(format!("{}.csv", pair.paper_name)), pair.paper)?;
    a.variables = data.names.clone();
    a.domain = data.domain.clone();
    Ok(FitResult::assess(Form::Rational { numerator_degree: 3, denominator_degree: 3 }, a, data, Objective::LeastSquares, None, &CertifyOptions::default())?)
}

/// Compares one model: `input` is furnace's table of `pair.model` (radiance form for
/// dielectrics), `same_form` furnace's degree-3 rational of it (see [`same_form_request`]),
/// `best` its best fit with ≤ 40 coefficients, if known.
pub fn compare_model(paper_dir: &Path, pair: &PaperPair, input: &FitInput, same_form: &FitRecord, best: Option<&FitRecord>) -> Result<CompareEntry> {
    let paper = paper_fit_on(paper_dir, pair, &input.data)?;
    let mut on_furnace_table = vec![CompareLine::of("paper 3/3 (published)", &paper), CompareLine::of("furnace 3/3 (same form)", &same_form.fit)];
    if let Some(b) = best {
        on_furnace_table.push(CompareLine::of("furnace best ≤ 40 coefficients", &b.fit));
    }
    // the paper's own table, unclamped coordinates as it fitted them
    let table = load_table(&paper_dir.join("tables").join(format!("{}.csv", pair.paper_name)), pair.paper)?;
    let theirs = paper_fit_on(paper_dir, pair, &table)?;
    let ours = fit_rational(&table, &pair.paper.transforms(), 3, 3, Objective::LeastSquares, &RationalOptions::default())?;
    Ok(CompareEntry {
        paper_fit: pair.paper_name.into(),
        model: pair.model.into(),
        transmission: pair.radiance.then(|| "radiance (E_T × 1/η² entering, × η² leaving), as the paper's tables".to_string()),
        table_resolution: input.source.resolution.clone(),
        table_content_hash: input.source.content_hash.clone(),
        furnace_fit_points: same_form.fitted_on.points,
        on_furnace_table,
        on_paper_table: vec![CompareLine::of("paper 3/3 (published)", &theirs), CompareLine::of("furnace 3/3 (same form)", &ours)],
    })
}

/// furnace's fit in the paper's form: degree-3 rational, the paper's variables and transforms.
pub fn same_form_request(pair: &PaperPair, max_fit_points: usize) -> super::job::FitRequest {
    super::job::FitRequest {
        form: super::job::FormKind::Rational,
        degree: 3,
        objective: Objective::LeastSquares,
        transforms: pair.paper.transforms(),
        max_fit_points,
    }
}

/// The whole comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareReport {
    pub tool: String,
    pub tool_version: String,
    pub paper: String,
    pub entries: Vec<CompareEntry>,
}

impl CompareReport {
    pub fn new(entries: Vec<CompareEntry>) -> CompareReport {
        CompareReport {
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            paper: "Sforza & Pellacini 2022, Enforcing Energy Preservation in Microfacet Models (published coefficients, Appendix A)".into(),
            entries,
        }
    }

    pub fn to_json(&self) -> Result<String> {
        Ok(format!("{}\n", serde_json::to_string_pretty(self).map_err(super::FitError::from)?))
    }

    /// A Markdown report: one table per model.
    pub fn to_markdown(&self) -> String {
        let mut s = String::from("# furnace vs. the paper's published fits\n\n");
        s.push_str(&format!(
            "{}; furnace {}. Errors are |fit − table| over every node of the table (MAE, max). \
Dielectric tables use the paper's radiance form of transmission. Pole verdicts are proofs on the whole domain box \
(Bernstein certificate), not checks at the nodes.\n",
            self.paper, self.tool_version
        ));
        for e in &self.entries {
            let res = e.table_resolution.as_ref().map_or("?".into(), |r| r.iter().map(|n| n.to_string()).collect::<Vec<_>>().join("×"));
            s.push_str(&format!("\n## {} — `{}` ({res} table", e.paper_fit, e.model));
            if e.transmission.is_some() {
                s.push_str(", radiance-form transmission");
            }
            s.push_str(&format!(", hash {})\n\n", &e.table_content_hash[..e.table_content_hash.len().min(12)]));
            table_md(&mut s, &e.on_furnace_table);
            if e.furnace_fit_points < e.table_resolution.as_ref().map_or(0, |r| r.iter().product()) {
                s.push_str(&format!("\nfurnace 3/3 fitted on {} table nodes (even subset, endpoints kept); all metrics on every node.\n", e.furnace_fit_points));
            }
            s.push_str("\nOn the paper's own 32-point table (its unclamped coordinates):\n\n");
            table_md(&mut s, &e.on_paper_table);
        }
        s
    }
}

fn table_md(s: &mut String, lines: &[CompareLine]) {
    s.push_str("| fit | form | transforms | coefficients | MAE | max error | poles |\n|---|---|---|---:|---:|---:|---|\n");
    for l in lines {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.3e} | {:.3e} | {} |\n",
            l.fit,
            l.form,
            l.transforms.join(", "),
            l.n_coefficients,
            l.mae,
            l.max_abs_error,
            l.poles
        ));
    }
}
