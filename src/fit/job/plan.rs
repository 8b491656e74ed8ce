//! What a sweep fits ([`SweepPlan`]): forms, degrees, transforms, budgets and fitting points,
//! and the `--transform` syntax.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::fit::data::{FitData, InputTransform};
use crate::fit::result::{Form, Objective};
use crate::fit::sweep::SweepOptions;

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
    /// The p values of an L_p polish every minimax refit adds to its path
    /// ([`crate::fit::RationalOptions::lp_polish`]); empty (the default plan's): none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lp_polish: Vec<f64>,
    /// The λ values of a max–mean polish every minimax refit of a rational or structured form
    /// adds to its path ([`crate::fit::RationalOptions::max_mean_polish`]); empty: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub max_mean_polish: Vec<f64>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// A structured form of a sweep and the transforms it is fitted in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedForm {
    pub form: Form,
    pub transforms: Vec<InputTransform>,
    /// The p values of an L_p polish this form's minimax refit adds to its path in place of the
    /// plan's ([`SweepPlan::lp_polish`]); empty: the plan's.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lp_polish: Vec<f64>,
    /// Refit this form for minimax error whenever its least-squares fit is usable and could be
    /// chosen under its budget, not only when it ranks among the budget's best least-squares
    /// fits (a structured form's least-squares rank says little of its minimax error).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub minimax_refit: bool,
}

impl PlannedForm {
    /// `form` in `transforms`, with the plan's L_p polish.
    pub fn new(form: Form, transforms: Vec<InputTransform>) -> PlannedForm {
        PlannedForm {
            form,
            transforms,
            lp_polish: Vec::new(),
            minimax_refit: false,
        }
    }

    /// The same form, always refitted for minimax error ([`Self::minimax_refit`]).
    pub fn with_minimax_refit(mut self) -> PlannedForm {
        self.minimax_refit = true;
        self
    }

    /// The same form with an L_p polish of its own.
    pub fn with_lp_polish(mut self, ps: &[f64]) -> PlannedForm {
        self.lp_polish = ps.to_vec();
        self
    }
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
    2 * crate::fit::basis::n_terms(d, 3) - 1
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
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        }
    }

    /// Whether the plan asks for `form` in `transforms` to be refitted for minimax error
    /// whatever its least-squares rank ([`PlannedForm::minimax_refit`]).
    pub fn always_refit(&self, form: &Form, transforms: &[InputTransform]) -> bool {
        self.forms
            .iter()
            .any(|f| f.minimax_refit && &f.form == form && f.transforms == transforms)
    }

    /// The p values of the L_p polish of a minimax refit of `form` in `transforms`: the planned
    /// form's own, else the plan's.
    pub fn lp_polish_for(&self, form: &Form, transforms: &[InputTransform]) -> &[f64] {
        self.forms
            .iter()
            .find(|f| !f.lp_polish.is_empty() && &f.form == form && f.transforms == transforms)
            .map_or(&self.lp_polish, |f| &f.lp_polish)
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
        let n = crate::fit::basis::n_terms;
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
