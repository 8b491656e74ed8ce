//! Fit jobs: one fit or a degree sweep of a [`FitInput`], recorded with provenance as a
//! [`FitRecord`] — the content of `fits/<model>/<form>-<degree>.json`, `best-20.json`, … .
//!
//! Large tables are fitted on an even subset of their nodes when the caller asks for it
//! (`max_fit_points`); metrics are then measured again on *every* point of the input, so the
//! numbers in a record always describe the whole table.

use serde::{Deserialize, Serialize};

use super::compare::paper_box_in;
use super::data::{FitData, InputTransform};
use super::error::FitError;
use super::metrics::{measure, measure_with_subset};
use super::polynomial::{fit_polynomial, PolynomialOptions};
use super::rational::{fit_rational, RationalOptions};
use super::result::{Approximant, FitResult, Form, Objective};
use super::source::{FitInput, FittedOn, Source};
use super::sweep::{
    pareto_front, select_under_budget, sweep_with_progress, Score, SkippedFit, SweepEvent,
    SweepOptions,
};
use super::PoleVerdict;
use crate::error::{Error, Result};

/// Polynomial or rational (n/n, the paper's form).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FormKind {
    Polynomial,
    Rational,
}

impl FormKind {
    pub fn name(self) -> &'static str {
        match self {
            FormKind::Polynomial => "polynomial",
            FormKind::Rational => "rational",
        }
    }
}

/// One fit to make.
#[derive(Clone, Debug)]
pub struct FitRequest {
    pub form: FormKind,
    /// Total degree (of P and of Q for a rational).
    pub degree: u32,
    pub objective: Objective,
    /// One per variable.
    pub transforms: Vec<InputTransform>,
    /// Most points the solver sees (0 = all); see [`FitInput::reduced`].
    pub max_fit_points: usize,
}

/// A fit with everything needed to trust, reproduce and use it: the content of every fit file
/// (read and checked by [`super::file`]). Serialised deterministically (no timings), so the same
/// inputs give the same bytes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitRecord {
    pub tool: String,
    pub tool_version: String,
    /// Proved pole-free on the whole domain and finite at every point: safe to emit.
    pub usable: bool,
    /// One sentence: why the fit is or is not usable.
    pub verdict: String,
    /// Non-fatal problems (not converged, not certified), also printed by the CLI.
    pub warnings: Vec<String>,
    pub source: Source,
    /// The furnace table fitted, when the data was one (None for a user's CSV, EXR or JSON
    /// grid, and for published coefficients): what emit measures the f32 code on and LUTs are
    /// tabulated from.
    #[serde(default)]
    pub table: Option<super::file::TableRef>,
    pub fitted_on: FittedOn,
    /// What `fit.metrics` were measured on.
    pub metrics_on: String,
    pub fit: FitResult,
    /// The fit's errors at the off-grid check points of its table ([`super::check`]), when the
    /// data was a model's table: the headline numbers ([`FitRecord::headline`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off_grid: Option<OffGrid>,
}

/// A fit's errors at points between the table nodes, against the model's exact values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OffGrid {
    /// What the points are (count, layers, version).
    pub on: String,
    pub metrics: super::metrics::Metrics,
}

/// The verdict sentence and usability of a fit.
pub fn verdict(fit: &FitResult) -> (bool, String) {
    let usable = fit.is_usable();
    let s = if fit.metrics.non_finite > 0 {
        format!(
            "NOT usable: the fit is not finite at {} of the data points",
            fit.metrics.non_finite
        )
    } else {
        match &fit.poles {
            PoleVerdict::NoDenominator => "usable: a polynomial has no poles".into(),
            PoleVerdict::Certified { min_lower_bound, .. } => {
                format!("usable: the denominator is proved ≥ {min_lower_bound:.3e} > 0 on the whole domain (Bernstein certificate)")
            }
            PoleVerdict::PoleFound { at } => format!("NOT usable: the denominator vanishes in the domain, near {at:?}; do not emit this fit"),
            PoleVerdict::Undecided { reason, .. } => format!("NOT usable: freedom from poles could not be proved ({reason})"),
        }
    };
    (usable, s)
}

/// Short verdict for tables: `certified`, `polynomial`, `pole`, `undecided`, `non-finite`.
pub fn pole_word(fit: &FitResult) -> &'static str {
    if fit.metrics.non_finite > 0 {
        return "non-finite";
    }
    match fit.poles {
        PoleVerdict::NoDenominator => "polynomial",
        PoleVerdict::Certified { .. } => "certified",
        PoleVerdict::PoleFound { .. } => "pole",
        PoleVerdict::Undecided { .. } => "undecided",
    }
}

impl FitRecord {
    /// Wraps a fit of `input` (metrics already on all of `input`).
    pub fn new(fit: FitResult, input: &FitInput, fitted_on: FittedOn) -> FitRecord {
        FitRecord::from_source(fit, input.source.clone(), input.table.clone(), fitted_on)
    }

    /// Wraps a fit of the data `source` describes (`source.points` points, on which the
    /// metrics were measured) and, if it is a furnace table, `table`.
    pub fn from_source(
        fit: FitResult,
        source: Source,
        table: Option<super::file::TableRef>,
        fitted_on: FittedOn,
    ) -> FitRecord {
        let (usable, verdict) = verdict(&fit);
        let mut warnings = Vec::new();
        if !usable {
            warnings.push(format!("{}: {verdict}", fit.form.label()));
        }
        if let Some(s) = fit.solver.as_ref().filter(|s| !s.converged) {
            let how = match s.termination {
                Some(t) => format!(
                    "last {} run: {t:?}, {} reweighting rounds",
                    if s.method
                        .contains(crate::fit::LsqMethod::TrustRegion.label())
                    {
                        crate::fit::LsqMethod::TrustRegion.label()
                    } else {
                        crate::fit::LsqMethod::LevenbergMarquardt.label()
                    },
                    s.reweighting_iterations
                ),
                None => format!(
                    "{} reweighting rounds of {} without meeting its tolerance",
                    s.reweighting_iterations, s.method
                ),
            };
            warnings.push(format!(
                "{}: the solver did not report convergence ({how}); the coefficients are its best iterate, with the metrics recorded here",
                fit.form.label(),
            ));
        }
        FitRecord {
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            usable,
            verdict,
            warnings,
            metrics_on: format!("all {} points of the source", source.points),
            source,
            table,
            fitted_on,
            fit,
            off_grid: None,
        }
    }

    /// Adds the fit's errors at the check points `check` (described by `on`).
    pub fn with_off_grid(mut self, check: Option<(&FitData, &str)>) -> FitRecord {
        if let Some((data, on)) = check {
            self.off_grid = Some(OffGrid {
                on: on.into(),
                metrics: measure(&self.fit.approximant, data),
            });
        }
        self
    }

    /// The headline (max abs error, MAE): off-grid when measured, else on the data's points.
    pub fn headline(&self) -> (f64, f64) {
        let m = self
            .off_grid
            .as_ref()
            .map_or(&self.fit.metrics, |o| &o.metrics);
        (m.max_abs_error, m.mae)
    }

    /// Pretty JSON with a final newline (deterministic).
    pub fn to_json(&self) -> Result<String> {
        let s = serde_json::to_string_pretty(self).map_err(FitError::from)?;
        Ok(format!("{s}\n"))
    }

    /// Reads a fit file: a [`FitRecord`], or a bare [`FitResult`] as the library writes it.
    pub fn from_json(text: &str) -> std::result::Result<FitRecord, String> {
        match serde_json::from_str::<FitRecord>(text) {
            Ok(r) => {
                r.fit.approximant.validate().map_err(|e| e.to_string())?;
                Ok(r)
            }
            Err(record_err) => match FitResult::from_json(text) {
                Ok(fit) => {
                    let (usable, verdict) = verdict(&fit);
                    Ok(FitRecord {
                        tool: "furnace".into(),
                        tool_version: String::new(),
                        usable,
                        verdict,
                        warnings: Vec::new(),
                        source: Source {
                            kind: "unknown".into(),
                            model: None,
                            path: None,
                            content_hash: String::new(),
                            resolution: None,
                            channel: "E".into(),
                            points: fit.metrics.n_points,
                            restricted_to: None,
                        },
                        table: None,
                        fitted_on: FittedOn {
                            points: fit.metrics.n_points,
                            selection: "unknown".into(),
                        },
                        metrics_on: "unknown".into(),
                        fit,
                        off_grid: None,
                    })
                }
                Err(_) => Err(format!(
                    "not a furnace fit file ({record_err}); write one with `furnace fit`"
                )),
            },
        }
    }

    /// The file name under `fits/<model>/`: see [`fit_file_name`].
    pub fn file_name(&self) -> String {
        let a = &self.fit.approximant;
        let (kind, degree, denominator) = match self.fit.form {
            Form::Polynomial { degree } => (FormKind::Polynomial, degree, degree),
            Form::Rational {
                numerator_degree,
                denominator_degree,
            } => (FormKind::Rational, numerator_degree, denominator_degree),
            Form::Exponents { .. } => (FormKind::Rational, 0, 0),
        };
        let name = fit_file_name(
            kind,
            degree,
            &a.variables,
            &a.transforms,
            self.fit.objective,
        );
        if let Form::Exponents { .. } = self.fit.form {
            return name.replacen("rational-0", &self.fit.form.file_stem(), 1);
        }
        if denominator == degree {
            return name;
        }
        // unequal degrees: `rational-2_1…`
        let head = format!("{}-{degree}", kind.name());
        format!("{head}_{denominator}{}", &name[head.len()..])
    }
}

/// `rational-3.json`; non-identity transforms add `-<variable>_<transform>` and objectives other
/// than least squares `-mae` / `-minimax`: `rational-4-mu_sqrt-minimax.json`.
pub fn fit_file_name(
    form: FormKind,
    degree: u32,
    variables: &[String],
    transforms: &[InputTransform],
    objective: Objective,
) -> String {
    let mut s = format!("{}-{degree}", form.name());
    for (v, t) in variables.iter().zip(transforms) {
        if *t != InputTransform::Identity {
            let t = match *t {
                InputTransform::ClampNormalize { lo, hi } => format!("clamp_{lo}_{hi}"),
                InputTransform::BoundaryLayer { by, k } => format!(
                    "layer_{}_{k}",
                    variables.get(by).map_or("x", String::as_str)
                ),
                InputTransform::RootNormalize { lo, hi, root } => format!("root{root}_{lo}_{hi}"),
                InputTransform::GrazingLayer { by, k, w, root } => format!(
                    "glayer_{}_{k}_{w}_{root}",
                    variables.get(by).map_or("x", String::as_str)
                ),
                other => other.name(),
            };
            s.push_str(&format!("-{v}_{t}"));
        }
    }
    match objective {
        Objective::LeastSquares => {}
        Objective::MeanAbsolute => s.push_str("-mae"),
        Objective::Minimax => s.push_str("-minimax"),
    }
    s.push_str(".json");
    s
}

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

/// What a sweep fits. Serialised into `sweep-inputs.json`, whose JSON text is the reuse key.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepPlan {
    pub polynomial_degrees: Vec<u32>,
    pub rational_degrees: Vec<u32>,
    /// Rationals with unequal total degrees (numerator, denominator).
    #[serde(default)]
    pub rational_pairs: Vec<(u32, u32)>,
    /// Structured forms, each with its transforms (one per variable).
    #[serde(default)]
    pub forms: Vec<PlannedForm>,
    pub transform_sets: Vec<Vec<InputTransform>>,
    pub objective: Objective,
    /// Most points the solver sees (0 = all).
    pub max_fit_points: usize,
    /// Per variable, the exponent p grading a downsampled grid's nodes towards the variable's
    /// low end ([`super::source::graded_indices`]); empty or 1: an even subset.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fit_grading: Vec<f64>,
    /// Exact off-grid training points ([`super::check::training_points`]) the solver sees
    /// besides the table's nodes (0 = none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub training_points: usize,
    /// Coefficient budgets of the `best-<budget>.json` files.
    pub budgets: Vec<usize>,
    /// After a least-squares sweep, refit the most promising fits of each budget with the
    /// minimax objective (see [`sweep_fits`]).
    pub minimax_refits: bool,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// A structured form of a sweep and the transforms it is fitted in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedForm {
    pub form: Form,
    pub transforms: Vec<InputTransform>,
}

/// Least-squares fits per budget refitted for minimax error: the best by max error, and the
/// best by MAE if different.
pub const MINIMAX_REFITS_BY_MAX: usize = 2;

/// Coefficient budgets of a sweep's `best-<N>.json` files: 8 (2-D and 1-D only: a 3-D form
/// needs more), 20, 40, 80 and 160.
pub fn default_budgets(d: usize) -> Vec<usize> {
    let mut b = if d <= 2 { vec![8] } else { Vec::new() };
    b.extend([20, 40, 80, 160]);
    b
}

/// Coefficients of the paper's degree-3 rational (Sforza & Pellacini 2022, §3.5) in `d`
/// variables: 19 in 2-D, 39 in 3-D. No best fit under a budget at least this large may be worse
/// than that form refitted on the same table (see [`sweep_fits_checked`]).
pub fn paper_coefficients(d: usize) -> usize {
    2 * super::basis::n_terms(d, 3) - 1
}

/// Default points the solver sees in a sweep: 2D 256² (of 1024²), 3D 32³ (of 128³), 1D 4096.
pub fn default_sweep_points(d: usize) -> usize {
    match d {
        1 => 4096,
        2 => 256 * 256,
        _ => 32 * 32 * 32,
    }
}

/// Scales k of the boundary-layer transform the sweep tries (t = (μ(1 + k r²) + τ)/(μ + k r² + τ),
/// [`InputTransform::BoundaryLayer`]): both in 2D, the first in 3D (where fits cost more).
/// Measured on the 1024² tables, whole square (`furnace fit … --transform r=square,mu=layer:r:K
/// --objective minimax --fit-points 65536`): separable conductor 3/3 max error 4.2e-3 (k = 1)
/// vs 6.5e-3 (k = 0.5), 4/4 5.1e-4 vs 4.3e-4; height-correlated 4/4 3.1e-3 vs 2.2e-3.
pub const LAYER_SCALES: [f64; 2] = [1.0, 0.5];

/// Input transforms a sweep tries besides the identity:
/// - √ of the variables named `mu` (grazing angles, where albedos vary like √μ) and `f0`
///   (η = (1+√F0)/(1−√F0)), alone and together, if their domain starts at ≥ 0;
/// - with variables `r` before `mu` (μ ⊂ [0, 1], r ≥ 0): r² (= α) and the boundary-layer
///   coordinate of μ scaled by r² ([`InputTransform::BoundaryLayer`], k in [`LAYER_SCALES`]),
///   which makes the grazing layer of width ~α and the corner r = μ = 0 smooth; with `f0`
///   also with √F0.
///
/// 1 − x is not tried: a total-degree polynomial space is invariant under affine maps of a
/// variable, so it gives the same fit as the identity.
pub fn default_transform_sets(data: &FitData) -> Vec<Vec<InputTransform>> {
    let d = data.dim();
    let id = vec![InputTransform::Identity; d];
    let find = |name: &str| data.names.iter().position(|n| n.eq_ignore_ascii_case(name));
    let sqrtable = |name: &str| find(name).filter(|&k| data.domain[k].0 >= 0.0);
    let mut sets = vec![id.clone()];
    let mu = sqrtable("mu");
    let f0 = sqrtable("f0");
    let with = |ks: &[usize]| {
        let mut t = id.clone();
        for &k in ks {
            t[k] = InputTransform::Sqrt;
        }
        t
    };
    if let Some(m) = mu {
        sets.push(with(&[m]));
    }
    if let Some(f) = f0 {
        if let Some(m) = mu {
            sets.push(with(&[f, m]));
        } else {
            sets.push(with(&[f]));
        }
    }
    if let (Some(r), Some(m)) = (find("r"), mu) {
        if r < m && data.domain[r].0 >= 0.0 && data.domain[m].1 <= 1.0 {
            let scales = if d >= 3 {
                &LAYER_SCALES[..1]
            } else {
                &LAYER_SCALES[..]
            };
            for &k in scales {
                let mut t = id.clone();
                t[r] = InputTransform::Square;
                t[m] = InputTransform::BoundaryLayer { by: r, k };
                if let Some(f) = f0 {
                    let mut with_f0 = t.clone();
                    with_f0[f] = InputTransform::Sqrt;
                    sets.push(t);
                    sets.push(with_f0);
                } else {
                    sets.push(t);
                }
            }
        }
    }
    sets
}

impl SweepPlan {
    /// The paper's Fig. 3 degrees (2D: polynomials and rationals 1–10; 3D: polynomials 1–7,
    /// rationals 1–5), capped at `max_degree`, with [`default_transform_sets`] plus `extra`.
    pub fn paper(
        data: &FitData,
        max_degree: Option<u32>,
        extra: Option<Vec<InputTransform>>,
        objective: Objective,
    ) -> SweepPlan {
        let d = data.dim();
        let base = SweepOptions::for_dimension(d);
        let cap = |v: Vec<u32>| {
            v.into_iter()
                .filter(|&g| max_degree.is_none_or(|m| g <= m))
                .collect::<Vec<_>>()
        };
        let mut polynomial_degrees = cap(base.polynomial_degrees);
        let mut rational_degrees = cap(base.rational_degrees);
        if let Some(m) = max_degree {
            // an explicit cap above the paper's range extends it
            if polynomial_degrees.last().is_some_and(|&l| l < m) {
                polynomial_degrees.extend(polynomial_degrees.last().copied().unwrap_or(0) + 1..=m);
            }
            if rational_degrees.last().is_some_and(|&l| l < m) {
                rational_degrees.extend(rational_degrees.last().copied().unwrap_or(0) + 1..=m);
            }
        }
        let mut transform_sets = default_transform_sets(data);
        if let Some(t) = extra {
            if !transform_sets.contains(&t) {
                transform_sets.push(t);
            }
        }
        SweepPlan {
            polynomial_degrees,
            rational_degrees,
            rational_pairs: Vec::new(),
            forms: Vec::new(),
            transform_sets,
            objective,
            max_fit_points: default_sweep_points(d),
            fit_grading: Vec::new(),
            training_points: 0,
            budgets: default_budgets(d),
            minimax_refits: true,
        }
    }

    /// Refuses a plan the data cannot support, naming the cause: a transform set of the wrong
    /// length, no budget, a budget no form of the plan fits into, or a form with more
    /// coefficients than the data has points.
    pub fn validate(&self, data: &FitData) -> Result<()> {
        let d = data.dim();
        if let Some(t) = self
            .transform_sets
            .iter()
            .chain(self.forms.iter().map(|f| &f.transforms))
            .find(|t| t.len() != d)
        {
            return Err(Error::InvalidInput(format!(
                "a transform set has {} entries for {d} variables",
                t.len()
            )));
        }
        if self.transform_sets.is_empty() {
            return Err(Error::InvalidInput(
                "the sweep plan has no transform set; give at least the identity".into(),
            ));
        }
        let n = super::basis::n_terms;
        let sizes: Vec<usize> = self
            .polynomial_degrees
            .iter()
            .map(|&g| n(d, g))
            .chain(self.rational_degrees.iter().map(|&g| 2 * n(d, g) - 1))
            .chain(
                self.rational_pairs
                    .iter()
                    .map(|&(p, q)| n(d, p) + n(d, q) - 1),
            )
            .chain(self.forms.iter().map(|f| f.form.n_coefficients(d)))
            .collect();
        let smallest = sizes.iter().copied().min().ok_or_else(|| {
            Error::InvalidInput("the sweep plan has no polynomial or rational degree".into())
        })?;
        if smallest > data.n_weighted() {
            return Err(Error::InvalidInput(format!(
                "every form of the sweep has more coefficients (at least {smallest}) than the data has points ({}); use a finer table or lower degrees",
                data.n_weighted()
            )));
        }
        if let Some(&b) = self.budgets.iter().find(|&&b| b < smallest) {
            return Err(Error::InvalidInput(format!(
                "budget {b}: the smallest form of the sweep has {smallest} coefficients; drop the budget or add lower degrees"
            )));
        }
        Ok(())
    }

    /// Drops the transform sets that use the boundary layer, except `keep` (a set the user
    /// asked for): for data without a grazing layer (see `Model::grazing_boundary_layer`).
    pub fn without_boundary_layer(mut self, keep: Option<&[InputTransform]>) -> SweepPlan {
        self.transform_sets.retain(|t| {
            keep == Some(t.as_slice())
                || !t
                    .iter()
                    .any(|x| matches!(x, InputTransform::BoundaryLayer { .. }))
        });
        self
    }
}

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
    #[serde(with = "super::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "super::metrics::finite_or_string")]
    pub rmse: f64,
    #[serde(with = "super::metrics::finite_or_string")]
    pub max_abs_error: f64,
    pub max_abs_error_at: Vec<f64>,
    #[serde(with = "super::metrics::finite_or_string")]
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
}

/// Errors of a fit on the points inside a sub-box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxMetrics {
    #[serde(with = "super::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "super::metrics::finite_or_string")]
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
    /// the paper's tables are; [`super::compare::paper_box_in`]) and what the rows'
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

    /// `sweep.csv`: one line per fit.
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "form,degree,transforms,objective,n_coefficients,mae,rmse,max_abs_error,max_rel_error,paper_box_mae,paper_box_max_abs_error,poles,usable,converged,denominator_degree,off_grid_mae,off_grid_max_abs_error,pareto\n",
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
                "{},{},{},{},{},{:e},{:e},{:e},{:e},{bm},{bx},{},{},{},{},{om},{ox},{}\n",
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
                r.pareto
            ));
        }
        s
    }
}

fn row_of(rec: &FitRecord, paper_box: Option<BoxMetrics>) -> SweepRow {
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
        objective_name(r.objective),
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
/// under that budget or any larger one.
fn minimax_candidates(records: &[FitRecord], budgets: &[usize]) -> Vec<usize> {
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
        for i in minimax_candidates(&records, &plan.budgets) {
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
                    let mut ro = RationalOptions::default();
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
                    progress(&progress_line(&fit));
                    fit_seconds.push(fit.fit_seconds);
                    let (fit, on_box) = measured(fit, input, reduced.is_some(), boxed.as_deref());
                    let rec = FitRecord::new(fit, input, fitted_on.clone()).with_off_grid(check);
                    rows.push(row_of(&rec, on_box));
                    records.push(rec);
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
    let paper_count = paper_coefficients(d);
    let best = plan
        .budgets
        .iter()
        .map(|&budget| BestUnderBudget {
            budget,
            index: select_under_budget(
                &scores,
                budget,
                paper_refit.filter(|_| budget >= paper_count),
            ),
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

/// Timings of a fit or a sweep: the sidecar `<data-dir>/timing/<fits folder>/sweep-timing.json`
/// (or `<fit file stem>-timing.json` for one fit). Wall and CPU times depend on the machine,
/// its load and the thread count, so they never go into files under `fits/`, which must be
/// byte-identical for identical inputs; `data/` is not committed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    pub tool: String,
    pub tool_version: String,
    /// The fit or sweep file these times belong to (`fits/<name>/sweep.json`, …).
    pub fits_file: String,
    /// Content hash of the fitted data's source (as in the fit file's `source`).
    pub source_content_hash: String,
    /// Points the solver saw (metrics are always measured on all points).
    pub fitted_points: usize,
    /// Rayon worker threads.
    pub threads: usize,
    /// 1-, 5- and 15-minute load averages when the run ended (`/proc/loadavg`; None elsewhere).
    pub load_average: Option<[f64; 3]>,
    /// Wall time of the whole job: every fit, and measuring each on all points.
    pub wall_seconds: f64,
    /// CPU time (user + system, all threads) the process spent in the job (`/proc/self/stat`;
    /// None elsewhere). Less sensitive to other processes than the wall time.
    pub cpu_seconds: Option<f64>,
    /// Wall time of each fit's solve, in the order of the sweep's rows.
    pub fits: Vec<FitTime>,
}

/// Wall time of one fit's solve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitTime {
    /// The fit's file name as a single fit (`rational-4-mu_sqrt-minimax.json`): with
    /// `n_coefficients` it identifies the row of `sweep.json`.
    pub name: String,
    pub n_coefficients: usize,
    pub seconds: f64,
}

/// A running job's clock: wall time and process CPU time since [`Stopwatch::start`].
#[derive(Clone, Copy, Debug)]
pub struct Stopwatch {
    wall: std::time::Instant,
    cpu: Option<f64>,
}

impl Stopwatch {
    pub fn start() -> Stopwatch {
        Stopwatch {
            wall: std::time::Instant::now(),
            cpu: process_cpu_seconds(),
        }
    }

    pub fn wall_seconds(&self) -> f64 {
        self.wall.elapsed().as_secs_f64()
    }

    pub fn cpu_seconds(&self) -> Option<f64> {
        Some(process_cpu_seconds()? - self.cpu?)
    }
}

/// Clock ticks per second of `/proc/self/stat` (Linux's USER_HZ, 100 on every architecture's ABI).
const USER_HZ: f64 = 100.0;

/// User + system CPU time of this process (all threads), from `/proc/self/stat` fields 14–15.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // the command name (field 2) is in parentheses and may contain spaces: skip past it
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // rest starts at field 3 (state): utime is field 14, stime field 15
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / USER_HZ)
}

/// The 1-, 5- and 15-minute load averages from `/proc/loadavg`.
pub fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let v: Vec<f64> = text
        .split_whitespace()
        .take(3)
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    Some([*v.first()?, *v.get(1)?, *v.get(2)?])
}

impl Timing {
    /// The timing record of a job measured by `clock`, for the file `fits_file`.
    pub fn new(
        fits_file: &str,
        source: &Source,
        fitted_on: &FittedOn,
        clock: &Stopwatch,
        fits: Vec<FitTime>,
    ) -> Timing {
        Timing {
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            fits_file: fits_file.into(),
            source_content_hash: source.content_hash.clone(),
            fitted_points: fitted_on.points,
            threads: rayon::current_num_threads(),
            load_average: load_average(),
            wall_seconds: clock.wall_seconds(),
            cpu_seconds: clock.cpu_seconds(),
            fits,
        }
    }

    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> Result<String> {
        Ok(format!(
            "{}\n",
            serde_json::to_string_pretty(self).map_err(FitError::from)?
        ))
    }
}

impl SweepOutcome {
    /// Every fit's solve time, in row order.
    pub fn fit_times(&self) -> Vec<FitTime> {
        self.rows
            .iter()
            .zip(&self.fit_seconds)
            .map(|(r, &seconds)| FitTime {
                name: r.name.clone(),
                n_coefficients: r.n_coefficients,
                seconds,
            })
            .collect()
    }
}

/// Parses `mu=sqrt,f0=sqrt` into one transform per variable (unnamed variables: identity).
/// Transforms: `identity`, `sqrt`, `one_minus`, `square`, `clamp:lo:hi`, `layer:<variable>:<k>`
/// ([`InputTransform::BoundaryLayer`], e.g. `mu=layer:r:1`).
pub fn parse_transforms(text: &str, names: &[String]) -> Result<Vec<InputTransform>> {
    let mut out = vec![InputTransform::Identity; names.len()];
    let mut seen = vec![false; names.len()];
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (var, tr) = part.split_once('=').ok_or_else(|| {
            Error::InvalidInput(format!("--transform '{part}': write variable=transform, e.g. mu=sqrt (transforms: identity, sqrt, one_minus, square, clamp:lo:hi, layer:<variable>:<k>)"))
        })?;
        let (var, tr) = (var.trim(), tr.trim());
        let k = names.iter().position(|n| n == var).ok_or_else(|| {
            Error::InvalidInput(format!(
                "--transform '{part}': unknown variable '{var}'; the data's variables are {}",
                names.join(", ")
            ))
        })?;
        if seen[k] {
            return Err(Error::InvalidInput(format!(
                "--transform gives variable '{var}' twice"
            )));
        }
        seen[k] = true;
        out[k] = match tr {
            "identity" | "id" => InputTransform::Identity,
            "sqrt" => InputTransform::Sqrt,
            "one_minus" | "1-x" => InputTransform::OneMinus,
            "square" => InputTransform::Square,
            t if t.starts_with("clamp:") => {
                let f: Vec<&str> = t["clamp:".len()..].split(':').collect();
                let nums: Option<Vec<f64>> = f.iter().map(|s| s.trim().parse::<f64>().ok().filter(|v| v.is_finite())).collect();
                match nums.as_deref() {
                    Some(&[lo, hi]) if lo < hi => InputTransform::ClampNormalize { lo, hi },
                    _ => return Err(Error::InvalidInput(format!("--transform '{part}': write clamp:lo:hi with finite lo < hi, e.g. f0=clamp:0.0125:0.25"))),
                }
            }
            t if t.starts_with("layer:") => {
                let usage = || Error::InvalidInput(format!("--transform '{part}': write layer:<variable>:<k> with a variable before '{var}' and a finite k > 0, e.g. mu=layer:r:1"));
                let (by, scale) = t["layer:".len()..].split_once(':').ok_or_else(usage)?;
                let by = names.iter().position(|n| n == by.trim()).filter(|&b| b < k).ok_or_else(usage)?;
                let scale = scale.trim().parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0).ok_or_else(usage)?;
                InputTransform::BoundaryLayer { by, k: scale }
            }
            other => match InputTransform::parse_more(other, names, k) {
                Some(t) => t.map_err(|m| Error::InvalidInput(format!("--transform '{part}': {m}")))?,
                None => {
                    return Err(Error::InvalidInput(format!(
                        "--transform '{part}': unknown transform '{other}'; use identity, sqrt, one_minus, square, clamp:lo:hi, layer:<variable>:<k>, {}",
                        InputTransform::MORE_SYNTAX
                    )))
                }
            },
        };
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

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
