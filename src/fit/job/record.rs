//! The fit record: everything a fit file holds ([`FitRecord`]), its verdict and its file name.

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::fit::data::{FitData, InputTransform};
use crate::fit::error::FitError;
use crate::fit::metrics::measure;
use crate::fit::result::{FitResult, Form, Objective};
use crate::fit::source::{FitInput, FittedOn, Source};
use crate::fit::PoleVerdict;

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
    pub table: Option<crate::fit::source::TableRef>,
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
    pub metrics: crate::fit::metrics::Metrics,
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
        table: Option<crate::fit::source::TableRef>,
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
        let name = if let Form::Exponents { .. } = self.fit.form {
            name.replacen("rational-0", &self.fit.form.file_stem(), 1)
        } else if denominator == degree {
            name
        } else {
            // unequal degrees: `rational-2_1…`
            let head = format!("{}-{degree}", kind.name());
            format!("{head}_{denominator}{}", &name[head.len()..])
        };
        // an iterate of the Lawson path: `…-minimax-round7.json`, `…-minimax-blend0.75-round3.json`
        match self
            .fit
            .solver
            .as_ref()
            .and_then(|s| s.lawson_path.as_ref())
        {
            Some(it) => name.replacen(".json", &format!("-{}.json", it.label("-", "")), 1),
            None => name,
        }
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
                InputTransform::RootNormalize {
                    lo,
                    hi,
                    root,
                    linear,
                } => format!(
                    "root{root}_{lo}_{hi}{}",
                    if linear > 0.0 {
                        format!("_{linear}")
                    } else {
                        String::new()
                    }
                ),
                InputTransform::CriticalAngle { lo, hi } => format!("critical_{lo}_{hi}"),
                InputTransform::RootLayer { by, k, power } => format!(
                    "slayer_{}_{k}{}",
                    variables.get(by).map_or("x", String::as_str),
                    if power == 2 {
                        String::new()
                    } else {
                        format!("_{power}")
                    }
                ),
                InputTransform::GrazingLayer {
                    by,
                    k,
                    w,
                    root,
                    beta,
                } => format!(
                    "glayer_{}_{k}_{w}_{root}{}",
                    variables.get(by).map_or("x", String::as_str),
                    if beta > 0.0 {
                        format!("_{beta}")
                    } else {
                        String::new()
                    }
                ),
                InputTransform::ProjectedLayer {
                    r,
                    aniso,
                    phi,
                    k,
                    root,
                    beta,
                } => {
                    let n = |i: usize| variables.get(i).map_or("x", String::as_str);
                    format!(
                        "player_{}_{}_{}_{k}_{root}{}",
                        n(r),
                        n(aniso),
                        n(phi),
                        if beta > 0.0 {
                            format!("_{beta}")
                        } else {
                            String::new()
                        }
                    )
                }
                InputTransform::ProjectedRatio { aniso } => {
                    format!(
                        "pratio_{}",
                        variables.get(aniso).map_or("x", String::as_str)
                    )
                }
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
