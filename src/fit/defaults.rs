//! The default sweep of a table: what `furnace run` and `furnace fit --sweep` fit when told
//! nothing else. The paper's degrees and furnace's transform sets ([`SweepPlan::paper`]), the
//! unequal-degree rationals of [`default_rational_pairs`], the budgets of
//! [`super::job::default_budgets`], and only the transforms right for the data: the
//! boundary-layer coordinate only where the model has a grazing layer that collapses onto one
//! value at r = 0 (`Model::grazing_boundary_layer`).

use super::basis::ExponentSet;
use super::data::{FitData, InputTransform};
use super::form::{parse_form, split_form};
use super::job::{PlannedForm, SweepPlan};
use super::result::{Form, Objective};

/// Rationals with unequal total degrees (numerator, denominator) a default sweep adds.
/// - 1-D and 2-D: (2, 1) and (1, 2), 8 coefficients in 2-D (the budget of `best-8`), and
///   (3, 2), (2, 3), 15 coefficients.
/// - 3-D: (4, 3), 54 coefficients, between the n/n rationals' 39 and 69.
pub fn default_rational_pairs(d: usize) -> Vec<(u32, u32)> {
    if d <= 2 {
        vec![(2, 1), (1, 2), (3, 2), (2, 3)]
    } else {
        vec![(4, 3)]
    }
}

/// The default plan for `data`: [`SweepPlan::paper`] (capped or extended by `max_degree`, with
/// `extra` as one more transform set), [`default_rational_pairs`] within the degree cap, and
/// without the boundary-layer transform sets unless `grazing_layer` (the model's say-so; a
/// user's table may have one) — `extra` is kept whatever it is.
pub fn default_plan(
    data: &FitData,
    max_degree: Option<u32>,
    extra: Option<Vec<InputTransform>>,
    objective: Objective,
    grazing_layer: bool,
) -> SweepPlan {
    let mut plan = SweepPlan::paper(data, max_degree, extra.clone(), objective);
    if !grazing_layer {
        plan = plan.without_boundary_layer(extra.as_deref());
    }
    plan.fit_grading = default_fit_grading(data);
    plan.training_points = default_training_points(data);
    if data.dim() >= 2 {
        plan.max_mean_polish = MAX_MEAN_POLISH.to_vec();
    }
    plan.rational_pairs = default_rational_pairs(data.dim())
        .into_iter()
        .filter(|&(n, m)| max_degree.is_none_or(|c| n <= c && m <= c))
        .collect();
    if let Some(t) = physics_transforms(data, grazing_layer) {
        if !plan.transform_sets.contains(&t) {
            plan.transform_sets.push(t.clone());
        }
        plan.forms = structured_forms(data, &t)
            .into_iter()
            .filter(|f| max_degree.is_none_or(|c| top_degree(&f.form) <= c))
            .collect();
    }
    plan
}

/// Grading exponents of the sweep's fitting nodes ([`SweepPlan::fit_grading`]): in 3-D, the
/// axes `mu` (p = 2: of 32 of 128 nodes, the first 9 are all kept) and `r` (p = 1.5) graded
/// towards their low ends (the grazing and low-roughness layers); nothing elsewhere. Measured
/// in docs/fitting.md ("Fitting points").
pub fn default_fit_grading(data: &FitData) -> Vec<f64> {
    if data.dim() != 3 {
        return Vec::new();
    }
    data.names
        .iter()
        .map(|n| match n.to_ascii_lowercase().as_str() {
            "mu" => 2.0,
            "r" => 1.5,
            _ => 1.0,
        })
        .collect()
}

/// Exact off-grid training points a default sweep fits on besides the table's nodes
/// ([`SweepPlan::training_points`], [`super::check::training_points`]): 8192 in 2-D and 3-D,
/// twice the table's nodes up to 32 768 in 4-D, none in 1-D. In 2-D the 256² even subset of a
/// 1024² table has a node every 0.004 in μ, coarser than the grazing layer μ ≲ α = r² at
/// r < 0.06; the training points sit in it. Measured on the height-correlated conductor
/// (docs/fitting.md, "Fitting points"). In 4-D the nodes of a 16 × 8 × 16 × 8 table leave the
/// projected layer μ ≲ α_o unsampled; with 32 768 training points the anisotropic conductor's
/// best-80 and best-160 have 1.64e-2 and 1.15e-2 at the check points, against 3.63e-2 and
/// 2.13e-2 on the nodes alone (docs/anisotropy.md, "Shipped fits").
pub fn default_training_points(data: &FitData) -> usize {
    match data.dim() {
        2 | 3 => 8192,
        4 => (2 * data.len()).min(32_768),
        _ => 0,
    }
}

/// The highest total degree of a form's numerator or denominator.
fn top_degree(form: &Form) -> u32 {
    match form {
        Form::Polynomial { degree } => *degree,
        Form::Rational {
            numerator_degree,
            denominator_degree,
        } => (*numerator_degree).max(*denominator_degree),
        Form::Exponents {
            numerator,
            denominator,
            ..
        } => numerator
            .total
            .max(denominator.as_ref().map_or(0, |q| q.total)),
    }
}

/// The transforms that carry the physics of a GGX albedo, measured best in docs/fitting.md:
/// r² (= α) and √L, the square root of the boundary-layer coordinate of μ
/// ([`InputTransform::GrazingLayer`] with w = 0, n = 2), where the model has a grazing layer
/// that collapses at r = 0; √μ where it has not (the glossy layer); and F0^¼
/// ([`InputTransform::RootNormalize`]) for a variable `f0` whose domain starts at ≥ 0. In 4-D
/// with variables `aniso` and `phi` (anisotropic GGX), the layer of μ is scaled by the
/// projected roughness instead ([`InputTransform::ProjectedLayer`], k =
/// [`PROJECTED_LAYER_SCALE`], n = 2, no log term: β = 3 wins only for the rational 4/4, not at
/// 69, 74 or 150 coefficients, docs/anisotropy.md, "Fits") and φ becomes α_o/α_t, the projected roughness relative
/// to the tangent's ([`InputTransform::ProjectedRatio`]).
/// None for data without variables `r` and `mu` (r before mu, both within [0, 1]).
pub fn physics_transforms(data: &FitData, grazing_layer: bool) -> Option<Vec<InputTransform>> {
    let find = |n: &str| data.names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let (r, mu) = (find("r")?, find("mu")?);
    let unit = |k: usize| data.domain[k].0 >= 0.0 && data.domain[k].1 <= 1.0;
    if r >= mu || !unit(r) || !unit(mu) {
        return None;
    }
    let mut t = vec![InputTransform::Identity; data.dim()];
    if grazing_layer {
        t[r] = InputTransform::Square;
        t[mu] = InputTransform::GrazingLayer {
            by: r,
            k: 1.0,
            w: 0.0,
            root: 2,
            beta: 0.0,
        };
    } else {
        t[mu] = InputTransform::Sqrt;
    }
    if let Some((aniso, phi)) = grazing_layer
        .then(|| anisotropic_axes(data, r, mu))
        .flatten()
    {
        t[mu] = InputTransform::ProjectedLayer {
            r,
            aniso,
            phi,
            k: PROJECTED_LAYER_SCALE,
            root: 2,
            beta: 0.0,
        };
        t[phi] = InputTransform::ProjectedRatio { aniso };
    }
    if let Some(f) = find("f0").filter(|&f| data.domain[f].0 >= 0.0) {
        t[f] = InputTransform::RootNormalize {
            lo: data.domain[f].0,
            hi: data.domain[f].1,
            root: 4,
            linear: 0.0,
        };
    }
    Some(t)
}

/// k of the projected-roughness layer of an anisotropic albedo ([`physics_transforms`]): on
/// the 16 × 8 × 16 × 8 table of `ggx-conductor-aniso` a 3/3 rational (69 coefficients) in
/// (r², aniso, √L_k(μ; α_o), sin²φ) has an off-grid max error of 5.9e-2 (MAE 3.4e-3) at k = 2,
/// against 8.2e-2 (MAE 7.1e-3) with the isotropic layer √L(μ; r²) and φ untransformed
/// (docs/anisotropy.md, "Fits").
pub const PROJECTED_LAYER_SCALE: f64 = 2.0;

/// The variables `aniso` and `phi` of an anisotropic albedo E(r, aniso, μ, φ) (besides r and μ),
/// when their domains suit [`InputTransform::ProjectedLayer`]: 0 ≤ aniso < 1, φ ⊂ [0, π/2].
fn anisotropic_axes(data: &FitData, r: usize, mu: usize) -> Option<(usize, usize)> {
    let find = |n: &str| data.names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let (aniso, phi) = (find("aniso")?, find("phi")?);
    let (al, ah) = data.domain[aniso];
    let (pl, ph) = data.domain[phi];
    (data.dim() == 4
        && ![aniso, phi].contains(&r)
        && ![aniso, phi].contains(&mu)
        && al >= 0.0
        && ah < 1.0
        && pl >= 0.0
        && ph <= std::f64::consts::FRAC_PI_2)
        .then_some((aniso, phi))
}

/// Per-variable degrees (r, μ) over (r, μ) a 2-D sweep fits in the boundary-layer variable
/// `layer:r:k` ([`structured_forms`]), with k. Measured off-grid on the 1024² tables (23 552
/// check points, minimax, 256² fit points; docs/fitting.md, "Structured forms"): 2,3/2,2 (20
/// coefficients) in (r², layer:r:2) max 4.2e-3 / MAE 1.5e-3 on the height-correlated conductor,
/// where the 3/3 rational (19) has 8.9e-3 / 2.6e-3; 3,4/3,3 (35) in (r², layer:r:1) 3.1e-4 /
/// 1.3e-4 on the separable one. (More tensors in L have a lower least-squares MAE but, refitted
/// for minimax, a higher one than √L's 4,4/3,3, so the 1.5×-MAE rule of `best-40` would lose
/// that fit on the height-correlated conductor.)
pub const LAYER_TENSOR_FORMS: [(&str, f64); 3] = [
    ("tensor:2,3/2,2", 1.0),
    ("tensor:2,3/2,2", 2.0),
    ("tensor:3,4/3,3", 1.0),
];

/// Per-variable degrees (r, μ) over (r, μ) a 2-D sweep fits in the log-corrected layer variable
/// `glayer:r:1:0:1:β` ([`InputTransform::GrazingLayer`] with β > 0: the μ ln μ fall of a
/// height-correlated albedo at grazing angles), with β. Measured on the height-correlated
/// conductor (`furnace fit --model ggx-conductor --sweep`, off-grid at 23 552 check points;
/// docs/fitting.md, "The logarithmic grazing term"): 2,3/2,2 (20 coefficients) minimax
/// 1.16e-3 / MAE 5.9e-4, where the same form in `layer:r:2` has 4.4e-3 / 1.5e-3; 3,5/3,3 (39)
/// 2.1e-4 / 8.2e-5, where the best in √L (40) has 6.2e-4 / 2.1e-4.
pub const LOG_LAYER_FORMS: [(&str, f64); 2] = [("tensor:2,3/2,2", 3.0), ("tensor:3,5/3,3", 3.0)];

/// The total-degree rational 4/2 (15 + 5 = 20 coefficients) a 2-D sweep fits in the
/// log-corrected layer variable `glayer:r:1:0:1:2`, always refitted for minimax error and
/// polished in L_p with [`LAYER_20_LP_POLISH`]. Measured on the separable conductor (one form
/// per sweep, the sweep's fitting points, off-grid at the 23 552 check points; docs/fitting.md,
/// "The logarithmic grazing term"): least squares 4.38e-3 / MAE 4.39e-4, minimax 1.41e-3 /
/// 6.56e-4, where tensor 2,3/2,2 at β = 3 has 2.27e-3 / 1.09e-3; at (k, β) = (1.25, 2) and
/// (1.5, 2) 1.35e-3 / 7.21e-4 and 1.40e-3 / 7.64e-4, at β = 3 and 4 1.75e-3 and 2.29e-3. On
/// the height-correlated conductor 2.12e-3 / 9.72e-4 (its tensor at β = 3 keeps best-20).
pub const LOG_LAYER_RATIONAL: (&str, f64, f64) = ("rational:4/2", 1.0, 2.0);

/// The p values of the L_p polish of [`LOG_LAYER_RATIONAL`]: on the separable conductor p = 16 /
/// 24 / 32 / 48 give 1.74e-3 / 5.92e-4, 1.60e-3 / 6.15e-4, 1.54e-3 / 6.28e-4 and 1.47e-3 /
/// 6.40e-4 (`furnace run`'s sweep), between its least-squares fit's MAE and its minimax fit's
/// max error: below 2e-3 inside the best-fit rule's 1.5× of the lowest MAE at 20.
pub const LAYER_20_LP_POLISH: [f64; 4] = [16.0, 24.0, 32.0, 48.0];

/// (k, β) of the log-corrected layer variable `glayer:r:k:0:1:β` in which a 3-D sweep fits
/// `lowrank:f0:2:2:4/1` (40 coefficients) a second time, besides √L ([`structured_forms`]).
/// Measured on the 128³ `ggx-dielectric` table (`furnace fit --model ggx-dielectric --sweep`,
/// off-grid at the 26 112 check points; docs/fitting.md, "Budget 40: the logarithmic layer in
/// 3-D"): minimax 9.99e-3 / 3.07e-3, where the same form in √L has 1.61e-2 / 2.70e-3.
pub const LOG_LAYER_LOWRANK: (f64, f64) = (2.0, 3.0);

/// The low-rank separations `lowrank:f0:<K>:<p>:<n>/<m>` a 3-D sweep fits a second time with μ in
/// the log-corrected layer variable `glayer:r:k:0:1:β`, where μ is in the grazing-layer variable,
/// each with its (k, β) and the p values of the L_p polish its minimax refit adds (none,
/// [`LOWRANK_LP_POLISH`], [`LOWRANK_160_LP_POLISH_FINE`] or [`LOWRANK_40_LP_POLISH`]): 40
/// coefficients (K, p, n, m) = (2, 2, 4, 1) at (k, β) = (2, 3) ([`LOG_LAYER_LOWRANK`]) and,
/// polished, at (1.25, 2); 160, (4, 4, 5, 4), at (2, 3), (1, 3) and (1.5, 2.5), polished. Measured
/// on the 128³ `ggx-dielectric-inv` table (the sweep's fitting points, off-grid at the 26 112 check
/// points; docs/fitting.md, "Budget 160: the logarithmic layer"): the 160-term form's Lawson path
/// at k = 2 keeps 5.51e-3 / MAE 4.86e-4 (blended branch) and ends at 3.84e-3 / 1.08e-3; its L_p
/// polish at p = 4 / 6 has 4.92e-3 / 6.05e-4 and 4.43e-3 / 7.18e-4, at k = 1 4.55e-3 / 5.88e-4 and
/// 3.59e-3 / 6.94e-4, where the sweep's best-160 in √L had 8.71e-3 / 7.91e-4. The polished 40-term
/// form: [`LOWRANK_40_LP_POLISH`].
pub const LOG_LAYER_LOWRANK_FORMS: [(&str, f64, f64, &[f64]); 5] = [
    ("2:2:4/1", LOG_LAYER_LOWRANK.0, LOG_LAYER_LOWRANK.1, &[]),
    ("2:2:4/1", 1.25, 2.0, &LOWRANK_40_LP_POLISH),
    (
        "4:4:5/4",
        LOG_LAYER_LOWRANK.0,
        LOG_LAYER_LOWRANK.1,
        &LOWRANK_LP_POLISH,
    ),
    ("4:4:5/4", 1.0, LOG_LAYER_LOWRANK.1, &LOWRANK_LP_POLISH),
    ("4:4:5/4", 1.5, 2.5, &LOWRANK_160_LP_POLISH_FINE),
];

/// The p values of the L_p polish of the 40-term separation of [`LOG_LAYER_LOWRANK_FORMS`] at
/// (k, β) = (1.25, 2). On the 128³ `ggx-dielectric` table (one form per sweep, off-grid at the
/// 26 112 check points; docs/fitting.md, "Budget 40: the L_p polish in the log-corrected
/// layer"): least squares 2.11e-2 / 1.87e-3, minimax 1.03e-2 / 2.86e-3, the polish at p = 8 …
/// 12 from 1.07e-2 / 2.63e-3 to 9.56e-3 / 2.85e-3 (p = 10, 11: 9.91e-3 / 2.76e-3, 9.71e-3 /
/// 2.80e-3), where the unpolished form at (2, 3) has 9.99e-3 / 3.07e-3 and its polish at
/// p = 12 1.07e-2 / 2.98e-3.
pub const LOWRANK_40_LP_POLISH: [f64; 5] = [8.0, 9.0, 10.0, 11.0, 12.0];

/// The λ values of the max–mean polish ([`crate::fit::RationalOptions::max_mean_polish`]) of
/// every minimax refit of a rational or structured form in a sweep of 2 or more variables: the
/// exact best numerators in max error + λ·mean error with the minimax fit's denominators held
/// (and the L_p polish's, when it has one). λ = 2 stays near the fit's max error and lowers its
/// MAE, λ = 8 trades a little max error for more: on the 128³ `ggx-dielectric-separable` table
/// the split sum `split:f0:2:3/3` in (F0^⅛, r², `layer:r:1.5`) goes from its minimax
/// 1.03e-2 / 2.99e-3 off grid to 9.81e-3 / 2.78e-3 (λ = 2) and 9.82e-3 / 2.78e-3 (λ = 8)
/// (docs/fitting.md, "The max–mean polish").
pub const MAX_MEAN_POLISH: [f64; 2] = [2.0, 8.0];

/// The p values of the L_p polish ([`crate::fit::RationalOptions::lp_polish`]) of the 160-term
/// separations of [`LOG_LAYER_LOWRANK_FORMS`]. Their Lawson paths have no iterate between the
/// least-squares fit and the minimax end on the off-grid front (docs/fitting.md, "Budget 160:
/// the L_p polish"); the polish fills it: on the 128³ `ggx-dielectric-inv-separable` table
/// (k = 2) p = 4 / 5 / 6 / 8 give 4.20e-3 / 4.82e-4, 3.72e-3 / 5.22e-4, 3.23e-3 / 5.60e-4 and
/// 3.03e-3 / 6.18e-4, against the blended branch's 5.37e-3 / 3.77e-4 and Lawson's end
/// 5.32e-3 / 7.17e-4.
pub const LOWRANK_LP_POLISH: [f64; 4] = [4.0, 5.0, 6.0, 8.0];

/// The p values of the L_p polish of the 160-term separation of [`LOG_LAYER_LOWRANK_FORMS`] at
/// (k, β) = (1.5, 2.5). On the 128³ `ggx-dielectric-inv` table (one form per sweep, off-grid at
/// the 26 112 check points; docs/fitting.md, "Budget 160: the L_p polish"): p = 4 / 4.5 / 5 / 6
/// give 4.35e-3 / 5.66e-4, 4.10e-3 / 5.90e-4, 3.78e-3 / 6.22e-4 and 3.57e-3 / 6.61e-4, below
/// the front of (1, 3) (p 5 4.07e-3 / 6.47e-4, p 6 3.63e-3 / 7.14e-4).
pub const LOWRANK_160_LP_POLISH_FINE: [f64; 4] = [4.0, 4.5, 5.0, 6.0];

/// The low-rank separations `lowrank:aniso:<K>:<p>:<n>/<m>`, Σ_k u_k(aniso)·P_k/Q_k over
/// (r², √L(μ; α_o), α_o/α_t), a 4-D sweep of an anisotropic albedo fits besides
/// [`ANISO_EXPONENT_FORMS`]: (K, p, n, m) = (2, 2, 3, 2) (64 coefficients) and (3, 3, 4, 2)
/// (144). The anisotropy separates best after the azimuth: the truncated SVD of E over
/// aniso × (r, μ, φ) leaves 7.4e-3 at rank 3 and 2.3e-3 at rank 4 (docs/anisotropy.md, "How
/// separable the albedo is").
pub const ANISO_LOWRANK_FORMS: [&str; 2] = ["2:2:3/2", "3:3:4/2"];

/// Unequal degrees a 4-D sweep of an anisotropic albedo fits in (r², aniso, √L(μ; α_o), α_o/α_t)
/// ([`physics_transforms`]): numerator total degree n with caps (r, aniso, μ, φ), denominator
/// total degree m with caps — high in r and μ, low in aniso and the azimuth. Measured minimax on
/// the layer-resolving points of docs/aniso_points.py (training 28 × 10 × 32 × 10, check at its
/// 10 000 independent points; docs/anisotropy.md, "Fits"): 4 (4, 2, 4, 1) / 3 (3, 1, 3, 1),
/// 74 coefficients, 2.2e-2 (MAE 1.8e-3) with β = 0, where sin²φ for the azimuth gives 3.3e-2
/// (3.8e-3); 5 (5, 2, 5, 2) / 3 (3, 1, 3, 1), 120 coefficients, 1.6e-2 (2.6e-2 in sin²φ);
/// 6 (6, 2, 6, 1) / 4 (4, 1, 4, 1), 150 coefficients, 1.2e-2 (MAE 1.3e-3), the lowest measured
/// at ≤ 160.
pub const ANISO_EXPONENT_FORMS: [(u32, [u32; 4], u32, [u32; 4]); 3] = [
    (4, [4, 2, 4, 1], 3, [3, 1, 3, 1]),
    (5, [5, 2, 5, 2], 3, [3, 1, 3, 1]),
    (6, [6, 2, 6, 1], 4, [4, 1, 4, 1]),
];

/// k of the boundary-layer variable `layer:r:k` ([`InputTransform::BoundaryLayer`], no square
/// root, no log term) in which a 3-D sweep with a grazing boundary layer fits `split:f0:2:3/3`
/// (39 coefficients) a second time, besides √L, with F0 as F0^(1/n), n =
/// [`SPLIT_LAYER_F0_ROOT`] ([`structured_forms`]). Measured on the 128³
/// `ggx-dielectric-separable` table (one form per sweep: 32³ graded nodes + 8 192 training
/// points, least squares, the minimax refit and its Lawson iterates; off-grid max / MAE at the
/// 26 112 check points; docs/fitting.md, "Budget 40 of the separable dielectric"), minimax in
/// F0^⅛: 1.02e-2 / 2.98e-3 at k = 1.5, 1.11e-2 / 3.04e-3 at k = 1.25, 1.07e-2 / 3.03e-3 at
/// k = 1.75, 1.21e-2 / 3.42e-3 at k = 1, 1.14e-2 / 3.12e-3 at k = 2 (in F0^¼ 1.08e-2 / 2.98e-3
/// at k = 1.5), where the same form in √L has 4.17e-2 / 3.68e-3 (least squares) and the
/// sweep's best at 40 was the rational 3/3 in (F0, r², `layer:r:1`), 1.36e-2 / 3.49e-3.
pub const SPLIT_LAYER_SCALE: f64 = 1.5;

/// n of F0^(1/n) ([`InputTransform::RootNormalize`]) in the split sum of [`SPLIT_LAYER_SCALE`]:
/// at every k measured (1 … 2) its minimax max error is 2–6 % below F0^¼'s, at the same MAE
/// (± 1 %) for k = 1.25 … 2.
pub const SPLIT_LAYER_F0_ROOT: u32 = 8;

/// k of the root-layer variable `slayer:r:k:e` ([`InputTransform::RootLayer`]: √μ outside the
/// layer μ ≲ k·rᵉ, linear in μ inside it, e = [`GLOSSY_ROOT_LAYER_POWER`]) in which a 3-D sweep
/// without a grazing boundary layer (the glossy albedo, whose row r = 0 is F(η, μ)) fits
/// `split:f0:2:3/3` (39 coefficients) a second time, besides √μ ([`structured_forms`]), with
/// the L_p polish [`GLOSSY_SPLIT_LP_POLISH`]. Measured one form per sweep (off-grid max / MAE at
/// the 26 112 check points; docs/fitting.md, "The glossy grazing layer"), the polish's lowest
/// max error: at e = 4, k = 40, on `ggx-glossy` 9.64e-3 / 3.23e-3 (p = 12) and on
/// `ggx-glossy-separable` 9.71e-3 / 3.25e-3 (p = 12); k = 20, 30 and 80 give 9.80e-3 / 3.51e-3,
/// 9.89e-3 / 3.46e-3 and 1.08e-2 / 3.63e-3 (`ggx-glossy`, p = 24); e = 3 at k = 3 and 20,
/// 1.08e-2 / 3.55e-3 and 1.03e-2 / 3.80e-3; e = 2 at k = 1, 1.12e-2 / 3.69e-3 (p = 16) and on
/// `ggx-glossy-separable` 1.04e-2 / 3.71e-3 (p = 24).
pub const GLOSSY_ROOT_LAYER_SCALE: f64 = 40.0;

/// e of the root layer's width k·rᵉ ([`GLOSSY_ROOT_LAYER_SCALE`]): r⁴ = α² keeps the layer
/// thin at small roughness and spreads it over μ at large roughness.
pub const GLOSSY_ROOT_LAYER_POWER: u32 = 4;

/// n and b of the glossy split sum's F0 variable, t ∝ F0^(1/n) + b·F0
/// ([`InputTransform::RootNormalize`]), in the root layer ([`GLOSSY_ROOT_LAYER_SCALE`]): a
/// glossy albedo's F0 dependence is close to a + c·F0 + d·ln F0, which 1, t, t² follow far
/// better than powers of F0^¼. Measured one form per sweep with the polish
/// [`GLOSSY_SPLIT_LP_POLISH`] (off-grid max / MAE at the 26 112 check points; docs/fitting.md,
/// "The F0 variable of the glossy split sum"), the lowest max error of the polish, on
/// `ggx-glossy`: b = 0.15, 0.2, 0.25, 0.3, 0.4 and 0.5 give 9.40e-3 / 3.10e-3, 9.38e-3 /
/// 2.97e-3, 9.51e-3 / 2.91e-3, 9.64e-3 / 2.83e-3 (p = 10), 9.91e-3 / 2.88e-3 (p = 10) and
/// 1.01e-2 / 3.15e-3 (p = 16; the others p = 12), against 9.64e-3 / 3.23e-3 in F0^¼; on
/// `ggx-glossy-separable` at b = 0.25 9.52e-3 / 2.91e-3 (F0^¼: 9.71e-3 / 3.25e-3).
pub const GLOSSY_F0_ROOT: u32 = 8;

/// b of [`GLOSSY_F0_ROOT`].
pub const GLOSSY_F0_LINEAR: f64 = 0.25;

/// The p values of the L_p polish of the split sum in the root-layer variable
/// ([`GLOSSY_ROOT_LAYER_SCALE`]), which a glossy sweep always refits for minimax error
/// ([`PlannedForm::minimax_refit`]): its least-squares fit need not rank among the two a sweep
/// refits by rank at 40 coefficients (at k = 3 on `ggx-glossy-separable` it ranks third,
/// 2.52e-2 / 3.06e-3, and without it the sweep's best-40 is the √μ rational 3/3's first
/// Lawson round, 1.79e-2 / 3.63e-3), and its polish reaches lower max errors than Lawson's
/// path at the same MAE: at k = 1, e = 2 on `ggx-glossy-separable` p = 8 / 12 / 16 / 24 give
/// 1.23e-2 / 3.33e-3, 1.09e-2 / 3.49e-3, 1.06e-2 / 3.60e-3 and 1.04e-2 / 3.71e-3, against
/// Lawson's end 1.23e-2 / 3.78e-3.
pub const GLOSSY_SPLIT_LP_POLISH: [f64; 6] = [4.0, 6.0, 8.0, 12.0, 16.0, 24.0];

/// A root variable of F0 ([`InputTransform::RootNormalize`]) with another root n and linear
/// weight b on the same interval; any other transform is left as it is.
fn with_f0_root(t: &mut InputTransform, root: u32, linear: f64) {
    if let InputTransform::RootNormalize { lo, hi, .. } = *t {
        *t = InputTransform::RootNormalize {
            lo,
            hi,
            root,
            linear,
        };
    }
}

/// The log-corrected layer variable `glayer:<by>:k:0:1:β` of μ ([`InputTransform::GrazingLayer`]
/// with w = 0 and n = 1), scaled by the variable `by`.
fn log_corrected_layer(by: usize, k: f64, beta: f64) -> InputTransform {
    InputTransform::GrazingLayer {
        by,
        k,
        w: 0.0,
        root: 1,
        beta,
    }
}

/// Structured forms a default sweep fits in `transforms` ([`physics_transforms`]):
/// - 2-D with a grazing layer: [`LAYER_TENSOR_FORMS`] with μ in the boundary-layer variable,
///   and [`LOG_LAYER_FORMS`] and [`LOG_LAYER_RATIONAL`] with μ in the log-corrected one;
/// - 2-D: per-variable degrees 4,4 over 3,3 (40 coefficients) and 1,3 over 1,0 (9), and
///   [`linear_in_r_form`] (8) and [`vanishing_in_r_forms`] (7 and 8) in the untransformed
///   variables;
/// - 3-D with a variable `f0`: the split sums Σ_{a ≤ k} t_f0^a·P_a(r, μ)/Q(r, μ) with
///   (k, n, m) = (2, 3, 3) (39 coefficients), (2, 4, 3) (54), (2, 5, 4) (77) and (3, 6, 6)
///   (139), one near the top of each budget 40, 80, 160 (measured in docs/fitting.md), and the
///   low-rank separations Σ_k u_k(f0)·P_k(r, μ)/Q_k(r, μ) with K terms, u_k of degree p,
///   P_k/Q_k of degrees n/m: (K, p, n, m) = (2, 2, 4, 1) (40), (3, 3, 4, 2) (72) and
///   (4, 4, 5, 4) (160) where μ is in the grazing-layer variable, else (4, 4, 5, 3) (140);
///   where it is, (2, 2, 4, 1) at two scales and (4, 4, 5, 4) at three (four of the five with
///   an L_p polish) also with μ in the log-corrected layer variable ([`LOG_LAYER_LOWRANK`],
///   [`LOG_LAYER_LOWRANK_FORMS`]) and (k, n, m) = (2, 3, 3)
///   also with μ in the plain boundary-layer variable and F0 as F0^⅛ ([`SPLIT_LAYER_SCALE`]);
///   where μ is in √μ (no boundary layer: the glossy albedo),
///   (k, n, m) = (2, 3, 3) also with μ in the root-layer variable
///   ([`GLOSSY_ROOT_LAYER_SCALE`]) and F0 as F0^⅛ + F0/4 ([`GLOSSY_F0_ROOT`]);
/// - 4-D with μ in the projected layer: [`ANISO_EXPONENT_FORMS`] (74, 120 and 150 coefficients)
///   and [`ANISO_LOWRANK_FORMS`] (64 and 144).
pub fn structured_forms(data: &FitData, transforms: &[InputTransform]) -> Vec<PlannedForm> {
    let d = data.dim();
    let planned = |form| PlannedForm::new(form, transforms.to_vec());
    match d {
        2 => {
            let tensor = |t: &str| parse_form(t, &data.names).ok();
            let mut out: Vec<PlannedForm> = Vec::new();
            // the grazing-layer variable of `transforms` (μ) and the variable it scales by (r)
            let layer = transforms.iter().enumerate().find_map(|(k, t)| match *t {
                InputTransform::GrazingLayer { by, .. } => Some((k, by)),
                _ => None,
            });
            if let Some((mu, by)) = layer {
                for (f, k) in LAYER_TENSOR_FORMS {
                    let mut t = transforms.to_vec();
                    t[mu] = InputTransform::BoundaryLayer { by, k };
                    out.extend(tensor(f).map(|form| PlannedForm::new(form, t)));
                }
                for (f, beta) in LOG_LAYER_FORMS {
                    let mut t = transforms.to_vec();
                    t[mu] = log_corrected_layer(by, 1.0, beta);
                    out.extend(tensor(f).map(|form| PlannedForm::new(form, t)));
                }
                let (f, k, beta) = LOG_LAYER_RATIONAL;
                let mut t = transforms.to_vec();
                t[mu] = log_corrected_layer(by, k, beta);
                out.extend(tensor(f).map(|form| {
                    PlannedForm::new(form, t)
                        .with_lp_polish(&LAYER_20_LP_POLISH)
                        .with_minimax_refit()
                }));
            }
            out.extend(tensor("tensor:4,4/3,3").map(planned));
            out.extend(tensor("tensor:1,3/1,0").map(planned));
            for form in linear_in_r_form(data)
                .into_iter()
                .chain(vanishing_in_r_forms(data))
            {
                out.push(PlannedForm::new(form, vec![InputTransform::Identity; 2]));
            }
            out
        }
        3 => match data.names.iter().position(|x| x.eq_ignore_ascii_case("f0")) {
            Some(f) => {
                let mut v = vec![
                    planned(split_form(3, f, 2, 3, 3)),
                    planned(split_form(3, f, 2, 4, 3)),
                    planned(split_form(3, f, 2, 5, 4)),
                    planned(split_form(3, f, 3, 6, 6)),
                ];
                // low-rank separations (docs/fitting.md, "Sums of terms"): 40, 72 and, with a
                // grazing layer, 160 coefficients (Q_k of degree 4), else 140 (degree 3: the
                // glossy fit of degree 4 keeps a Q_k constant that cannot be normalised to 1,
                // 161 stored numbers, beyond the budget 160)
                let x = &data.names[f];
                let layer = transforms
                    .iter()
                    .any(|t| matches!(t, InputTransform::GrazingLayer { .. }));
                let q = if layer { 4 } else { 3 };
                for spec in [
                    format!("lowrank:{x}:2:2:4/1"),
                    format!("lowrank:{x}:3:3:4/2"),
                    format!("lowrank:{x}:4:4:5/{q}"),
                ] {
                    v.extend(parse_form(&spec, &data.names).ok().map(planned));
                }
                // the 40- and 160-coefficient separations once more with μ in the
                // log-corrected layer variable (docs/fitting.md, "Budget 40: the logarithmic
                // layer in 3-D", "Budget 160: the logarithmic layer")
                let log_layer = transforms.iter().enumerate().find_map(|(k, t)| match *t {
                    InputTransform::GrazingLayer { by, .. } => Some((k, by)),
                    _ => None,
                });
                if let Some((mu, by)) = log_layer {
                    for (spec, k, beta, polish) in LOG_LAYER_LOWRANK_FORMS {
                        let mut t = transforms.to_vec();
                        t[mu] = log_corrected_layer(by, k, beta);
                        v.extend(
                            parse_form(&format!("lowrank:{x}:{spec}"), &data.names)
                                .ok()
                                .map(|form| PlannedForm::new(form, t).with_lp_polish(polish)),
                        );
                    }
                    // the 39-coefficient split sum once more with μ in the plain boundary-layer
                    // variable (docs/fitting.md, "Budget 40 of the separable dielectric")
                    let mut t = transforms.to_vec();
                    t[mu] = InputTransform::BoundaryLayer {
                        by,
                        k: SPLIT_LAYER_SCALE,
                    };
                    with_f0_root(&mut t[f], SPLIT_LAYER_F0_ROOT, 0.0);
                    v.push(PlannedForm::new(split_form(3, f, 2, 3, 3), t));
                }
                // the 39-coefficient split sum once more with √μ replaced by the root-layer
                // variable (docs/fitting.md, "The glossy grazing layer") and F0^¼ by
                // F0^⅛ + F0/4 ("The F0 variable of the glossy split sum")
                let find = |n: &str| data.names.iter().position(|x| x.eq_ignore_ascii_case(n));
                if let (Some(r), Some(mu)) = (find("r"), find("mu")) {
                    if transforms.get(mu) == Some(&InputTransform::Sqrt) && r < mu {
                        let mut t = transforms.to_vec();
                        t[mu] = InputTransform::RootLayer {
                            by: r,
                            k: GLOSSY_ROOT_LAYER_SCALE,
                            power: GLOSSY_ROOT_LAYER_POWER,
                        };
                        with_f0_root(&mut t[f], GLOSSY_F0_ROOT, GLOSSY_F0_LINEAR);
                        v.push(
                            PlannedForm::new(split_form(3, f, 2, 3, 3), t)
                                .with_lp_polish(&GLOSSY_SPLIT_LP_POLISH)
                                .with_minimax_refit(),
                        );
                    }
                }
                v
            }
            None => Vec::new(),
        },
        4 => {
            let mut v: Vec<PlannedForm> = aniso_exponent_forms(transforms)
                .into_iter()
                .map(planned)
                .collect();
            // the low-rank separations in the anisotropy (docs/anisotropy.md, "Low-rank forms in
            // the anisotropy"), beside the exponent forms
            let aniso = transforms.iter().find_map(|t| match *t {
                InputTransform::ProjectedLayer { aniso, .. } => Some(aniso),
                _ => None,
            });
            if let Some(a) = aniso {
                let x = &data.names[a];
                for spec in ANISO_LOWRANK_FORMS {
                    v.extend(
                        parse_form(&format!("lowrank:{x}:{spec}"), &data.names)
                            .ok()
                            .map(planned),
                    );
                }
            }
            v
        }
        _ => Vec::new(),
    }
}

/// The [`ANISO_EXPONENT_FORMS`] of a 4-D albedo whose μ is in the projected layer
/// ([`InputTransform::ProjectedLayer`], which names the r, aniso and φ variables), their caps
/// placed on those variables; none without a projected layer.
pub fn aniso_exponent_forms(transforms: &[InputTransform]) -> Vec<Form> {
    // caps in the order (r, aniso, μ, φ) of the projected layer's variables
    let Some((r, aniso, mu, phi)) = transforms.iter().enumerate().find_map(|(k, t)| match *t {
        InputTransform::ProjectedLayer { r, aniso, phi, .. } => Some((r, aniso, k, phi)),
        _ => None,
    }) else {
        return Vec::new();
    };
    let set = |total: u32, c: [u32; 4]| {
        let mut caps = vec![0; transforms.len()];
        for (i, v) in [r, aniso, mu, phi].into_iter().zip(c) {
            caps[i] = v;
        }
        ExponentSet {
            total,
            caps,
            in_total: vec![true; transforms.len()],
            free_of: None,
        }
    };
    ANISO_EXPONENT_FORMS
        .iter()
        .map(|&(n, cn, m, cm)| Form::Exponents {
            numerator: set(n, cn),
            denominator: Some(set(m, cm)),
            structure: None,
        })
        .collect()
}

/// P/Q with P of degree ≤ 1 in r and total degree ≤ 3 (a cubic in μ plus r times a quadratic),
/// Q = 1 + q r: 8 coefficients, the shape of the FON albedo E = (1 + r G_F(μ)/π)/(1 + c₁ r)
/// (EON paper, eq. 12). None for data without variables `r` and `mu`.
pub fn linear_in_r_form(data: &FitData) -> Option<Form> {
    let find = |n: &str| data.names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let (r, _mu) = (find("r")?, find("mu")?);
    let mut caps = vec![3; data.dim()];
    caps[r] = 1;
    let mut q_caps = vec![0; data.dim()];
    q_caps[r] = 1;
    Some(Form::Exponents {
        numerator: ExponentSet {
            total: 3,
            caps,
            in_total: vec![true; data.dim()],
            free_of: None,
        },
        denominator: Some(ExponentSet::tensor(&q_caps)),
        structure: None,
    })
}

/// P/Q with P = c + r·(b₀ + b₁μ + … + b_k μ^k) and Q = 1 + q r, k = 4 and 5 (7 and 8
/// coefficients): the FON albedo E = (1 + r G_F(μ)/π)/(1 + c₁ r) (EON paper, eq. 12) with
/// G_F a polynomial of degree k, so E(r = 0) is the constant c with no μ-terms spent on it
/// (`tensor:1,k@r:0/1,0`). Empty for data without variables `r` and `mu`.
pub fn vanishing_in_r_forms(data: &FitData) -> Vec<Form> {
    let find = |n: &str| data.names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let (Some(r), Some(mu)) = (find("r"), find("mu")) else {
        return Vec::new();
    };
    [4, 5]
        .into_iter()
        .map(|k| {
            let mut caps = vec![0; data.dim()];
            caps[r] = 1;
            caps[mu] = k;
            let mut q_caps = vec![0; data.dim()];
            q_caps[r] = 1;
            Form::Exponents {
                numerator: ExponentSet::tensor(&caps).free_of(r, 0),
                denominator: Some(ExponentSet::tensor(&q_caps)),
                structure: None,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::result::Structure;

    fn data(names: &[&str]) -> FitData {
        let ax: Vec<f64> = (0..5).map(|i| i as f64 / 4.0).collect();
        let axes = vec![ax; names.len()];
        let n = 5usize.pow(names.len() as u32);
        FitData::from_grid(
            names.iter().map(|s| s.to_string()).collect(),
            &axes,
            vec![0.5; n],
        )
        .unwrap()
    }

    #[test]
    fn plans_are_model_aware_and_serialise() {
        let d2 = data(&["r", "mu"]);
        let p = default_plan(&d2, None, None, Objective::LeastSquares, true);
        assert_eq!(p.budgets, vec![8, 20, 40, 80, 160]);
        assert!(p.rational_pairs.contains(&(2, 1)));
        let layer = |p: &SweepPlan| {
            p.transform_sets
                .iter()
                .flatten()
                .any(|t| matches!(t, InputTransform::BoundaryLayer { .. }))
        };
        assert!(layer(&p));
        let glossy = default_plan(&d2, None, None, Objective::LeastSquares, false);
        assert!(!layer(&glossy));
        let d3 = data(&["f0", "r", "mu"]);
        let p3 = default_plan(&d3, Some(4), None, Objective::LeastSquares, true);
        assert_eq!(p3.budgets, vec![20, 40, 80, 160]);
        assert_eq!(p3.rational_pairs, vec![(4, 3)]);
        // 3-D: graded nodes in r and mu (not f0) and exact training points; 2-D: training
        // points only; 1-D: neither
        assert_eq!(p3.fit_grading, vec![1.0, 1.5, 2.0]);
        assert_eq!(p3.training_points, 8192);
        assert!(p.fit_grading.is_empty() && p.training_points == 8192);
        let p1 = default_plan(&data(&["mu"]), None, None, Objective::LeastSquares, false);
        assert!(p1.fit_grading.is_empty() && p1.training_points == 0);
        // the max–mean polish in 2-D and 3-D sweeps, not in 1-D
        assert_eq!(p3.max_mean_polish, MAX_MEAN_POLISH.to_vec());
        assert_eq!(p.max_mean_polish, MAX_MEAN_POLISH.to_vec());
        assert!(p1.max_mean_polish.is_empty());
        assert!(!serde_json::to_string(&p1)
            .unwrap()
            .contains("training_points"));
        let json = serde_json::to_string(&p3).unwrap();
        let back: SweepPlan = serde_json::from_str(&json).unwrap();
        assert_eq!(back, p3);
        // the degree cap 4 keeps the polished 40-term separation, not the 160-term ones
        assert_eq!(json.matches("\"lp_polish\"").count(), 1, "{json}");
        // in 2-D only the log-layer rational 4/2 carries a polish, and no plan without a layer
        let json2 = serde_json::to_string(&p).unwrap();
        assert_eq!(json2.matches("\"lp_polish\"").count(), 1, "{json2}");
        assert!(!serde_json::to_string(&glossy)
            .unwrap()
            .contains("lp_polish"));
        assert_ne!(json, serde_json::to_string(&p).unwrap());
        // the physics transforms: r², √L with a grazing layer, √μ without; F0^¼ in 3-D
        let t = physics_transforms(&d3, true).unwrap();
        assert!(matches!(
            t[0],
            InputTransform::RootNormalize { root: 4, .. }
        ));
        assert!(matches!(t[2], InputTransform::GrazingLayer { by: 1, .. }));
        assert_eq!(
            physics_transforms(&d2, false).unwrap()[1],
            InputTransform::Sqrt
        );
        let full = default_plan(&d3, None, None, Objective::LeastSquares, true);
        let sizes: Vec<usize> = full
            .forms
            .iter()
            .map(|f| f.form.n_coefficients(3))
            .collect();
        assert_eq!(
            sizes,
            vec![39, 54, 77, 139, 40, 72, 160, 40, 40, 160, 160, 160, 39]
        );
        let json = serde_json::to_string(&full).unwrap();
        assert_eq!(json.matches("\"lp_polish\"").count(), 4, "{json}");
        // then the 40- and 160-coefficient separations in the log-corrected layer
        // variable, the same forms as the √L ones, at two and three (k, β), four polished
        let (k0, b0) = LOG_LAYER_LOWRANK;
        let p40: &[f64] = &LOWRANK_40_LP_POLISH;
        let p160: &[f64] = &LOWRANK_LP_POLISH;
        let p160f: &[f64] = &LOWRANK_160_LP_POLISH_FINE;
        for (i, j, k, beta, polish) in [
            (7, 4, k0, b0, &[][..]),
            (8, 4, 1.25, 2.0, p40),
            (9, 6, k0, b0, p160),
            (10, 6, 1.0, b0, p160),
            (11, 6, 1.5, 2.5, p160f),
        ] {
            assert_eq!(full.forms[i].form, full.forms[j].form);
            assert_eq!(full.forms[i].lp_polish, polish);
            assert!(full.forms[j].lp_polish.is_empty());
            // a refit looks its polish up by form and transforms; forms without one keep the
            // plan's (none), and a plan's JSON names the polish only where a form has one
            let (f, t) = (&full.forms[i].form, &full.forms[i].transforms);
            assert_eq!(full.lp_polish_for(f, t), polish);
            assert!(full.lp_polish_for(f, &full.forms[j].transforms).is_empty());
            assert_eq!(
                full.forms[i].transforms[2],
                InputTransform::GrazingLayer {
                    by: 1,
                    k,
                    w: 0.0,
                    root: 1,
                    beta
                }
            );
        }
        // the last: the 39-coefficient split sum in the plain boundary-layer variable, F0 as
        // F0^⅛ on the same interval, r as in the physics set
        let last = full.forms.last().unwrap();
        assert_eq!(last.form, full.forms[0].form);
        assert_eq!(
            last.transforms[2],
            InputTransform::BoundaryLayer {
                by: 1,
                k: SPLIT_LAYER_SCALE
            }
        );
        let InputTransform::RootNormalize { lo, hi, .. } = t[0] else {
            panic!("{:?}", t[0])
        };
        assert_eq!(
            last.transforms[0],
            InputTransform::RootNormalize {
                lo,
                hi,
                root: SPLIT_LAYER_F0_ROOT,
                linear: 0.0
            }
        );
        assert_eq!(last.transforms[1], t[1]);
        assert_eq!(full.forms[4].transforms, t);
        let glossy3 = default_plan(&d3, None, None, Objective::LeastSquares, false);
        let sizes: Vec<usize> = glossy3
            .forms
            .iter()
            .map(|f| f.form.n_coefficients(3))
            .collect();
        assert_eq!(sizes, vec![39, 54, 77, 139, 40, 72, 140, 39]);
        let low_rank = &glossy3.forms[6];
        assert_eq!(low_rank.transforms[2], InputTransform::Sqrt);
        // the last: the 39-coefficient split sum in the root-layer variable, the rest as √μ's
        let last = glossy3.forms.last().unwrap();
        assert_eq!(last.form, glossy3.forms[0].form);
        assert_eq!(
            last.transforms[2],
            InputTransform::RootLayer {
                by: 1,
                k: GLOSSY_ROOT_LAYER_SCALE,
                power: GLOSSY_ROOT_LAYER_POWER
            }
        );
        // F0 as F0^⅛ + F0/4 on the same interval, r as in the physics set
        let InputTransform::RootNormalize { lo, hi, .. } = low_rank.transforms[0] else {
            panic!("{:?}", low_rank.transforms[0])
        };
        assert_eq!(
            last.transforms[0],
            InputTransform::RootNormalize {
                lo,
                hi,
                root: GLOSSY_F0_ROOT,
                linear: GLOSSY_F0_LINEAR
            }
        );
        assert_eq!(last.transforms[1], low_rank.transforms[1]);
        // polished, and refitted for minimax error whatever its least-squares rank; no other
        // planned form of either plan is
        let p_glossy: &[f64] = &GLOSSY_SPLIT_LP_POLISH;
        assert_eq!(last.lp_polish, p_glossy);
        assert!(last.minimax_refit);
        assert!(glossy3.always_refit(&last.form, &last.transforms));
        assert!(!glossy3.always_refit(&last.form, &glossy3.forms[0].transforms));
        let n = glossy3.forms.len();
        assert!(!glossy3.forms[..n - 1].iter().any(|f| f.minimax_refit));
        assert!(!full.forms.iter().any(|f| f.minimax_refit));
        assert_eq!(full.transform_sets.last(), Some(&t));
        assert!(physics_transforms(&data(&["x", "y"]), true).is_none());
        // 4-D anisotropic: μ in the projected-roughness layer, φ as α_o/α_t (φ ∈ [0, 1] ⊂ [0, π/2])
        let mut d4 = data(&["r", "aniso", "mu", "phi"]);
        d4.domain[1] = (0.0, 0.95);
        let t4 = physics_transforms(&d4, true).unwrap();
        assert_eq!(
            t4,
            vec![
                InputTransform::Square,
                InputTransform::Identity,
                InputTransform::ProjectedLayer {
                    r: 0,
                    aniso: 1,
                    phi: 3,
                    k: PROJECTED_LAYER_SCALE,
                    root: 2,
                    beta: 0.0
                },
                InputTransform::ProjectedRatio { aniso: 1 }
            ]
        );
        // and the unequal-degree forms in them, 74, 120 and 150 coefficients, then the low-rank
        // separations in aniso, 64 and 144
        let f4 = structured_forms(&d4, &t4);
        let sizes: Vec<usize> = f4.iter().map(|f| f.form.n_coefficients(4)).collect();
        assert_eq!(sizes, [74, 120, 150, 64, 144]);
        assert!(f4[3..].iter().all(|f| matches!(
            f.form,
            Form::Exponents {
                structure: Some(Structure::LowRank { variable: 1, .. }),
                ..
            }
        )));
        assert!(f4.iter().all(|f| f.transforms == t4));
        // aniso = 1 (α_b = 0) is outside the layer's domain: the isotropic layer instead
        let mut d4b = d4.clone();
        d4b.domain[1] = (0.0, 1.0);
        assert!(matches!(
            physics_transforms(&d4b, true).unwrap()[2],
            InputTransform::GrazingLayer { by: 0, .. }
        ));
        // 2-D: the layer tensors in √L and in layer:r:1, layer:r:2 only with a grazing layer
        let forms2 = |p: &SweepPlan| {
            p.forms
                .iter()
                .map(|f| (f.form.n_coefficients(2), f.transforms[1]))
                .collect::<Vec<_>>()
        };
        let with = forms2(&p);
        assert_eq!(
            with.len(),
            LAYER_TENSOR_FORMS.len() + LOG_LAYER_FORMS.len() + 6
        );
        let log = |beta| InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 0.0,
            root: 1,
            beta,
        };
        assert!(with.contains(&(20, log(3.0))));
        assert!(with.contains(&(39, log(3.0))));
        assert!(with.contains(&(20, log(2.0))));
        assert!(with.contains(&(20, InputTransform::BoundaryLayer { by: 0, k: 2.0 })));
        assert!(with.contains(&(35, InputTransform::BoundaryLayer { by: 0, k: 1.0 })));
        assert!(with.contains(&(8, InputTransform::Identity)));
        assert!(with.contains(&(7, InputTransform::Identity)));
        let without = forms2(&glossy);
        assert_eq!(
            without,
            vec![
                (40, InputTransform::Sqrt),
                (9, InputTransform::Sqrt),
                (8, InputTransform::Identity),
                (7, InputTransform::Identity),
                (8, InputTransform::Identity)
            ]
        );
    }

    #[test]
    fn linear_in_r_form_is_exact_for_the_fon_shape() {
        // E = (1 + r g(μ))/(1 + c r) with a quadratic g (the shape of the EON paper's eq. 12)
        let ax: Vec<f64> = (0..17).map(|i| i as f64 / 16.0).collect();
        let g = |m: f64| 0.05 + (1.0 - m) * (0.2 - 0.1 * m);
        let vals = ax
            .iter()
            .flat_map(|&r| ax.iter().map(move |&m| (1.0 + r * g(m)) / (1.0 + 0.29 * r)))
            .collect();
        let d = FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
        let form = linear_in_r_form(&d).unwrap();
        assert_eq!(form.n_coefficients(2), 8);
        let fit = crate::fit::fit_form(
            &d,
            &[InputTransform::Identity; 2],
            &form,
            Objective::LeastSquares,
            &crate::fit::FitOptions::default(),
        )
        .unwrap();
        assert!(
            fit.metrics.max_abs_error < 1e-9,
            "{}",
            fit.metrics.max_abs_error
        );
        assert!(fit.is_usable());
        // off the nodes too
        let x = [0.37, 0.61];
        let exact = (1.0 + x[0] * g(x[1])) / (1.0 + 0.29 * x[0]);
        assert!((fit.eval(&x) - exact).abs() < 1e-9);
        assert!(linear_in_r_form(&data(&["x", "y"])).is_none());
    }

    #[test]
    fn vanishing_in_r_forms_beat_the_eon_papers_fon_fit_off_the_grid() {
        use crate::bsdf::diffuse::fon_albedo_analytic;
        // the FON albedo (EON paper, eq. 12) on a 64² table of [0, 1]²
        let n = 64;
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let vals = ax
            .iter()
            .flat_map(|&r| ax.iter().map(move |&m| fon_albedo_analytic(r, m)))
            .collect();
        let d = FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
        // off the grid: the centres of the cells, and the edges' midpoints
        let mut points = Vec::new();
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                points.push([(i as f64 + 0.5) / 63.0, (j as f64 + 0.5) / 63.0]);
            }
            points.push([(i as f64 + 0.5) / 63.0, 1.0]);
            points.push([1.0, (i as f64 + 0.5) / 63.0]);
            points.push([0.0, (i as f64 + 0.5) / 63.0]);
        }
        let forms = vanishing_in_r_forms(&d);
        let mut maxima = Vec::new();
        for (form, bound) in forms.iter().zip([4.7e-4, 2.0e-4]) {
            let fit = crate::fit::fit_form(
                &d,
                &[InputTransform::Identity; 2],
                form,
                Objective::Minimax,
                &crate::fit::FitOptions::default(),
            )
            .unwrap();
            assert!(fit.is_usable());
            let max = points
                .iter()
                .map(|x| (fit.eval(x) - fon_albedo_analytic(x[0], x[1])).abs())
                .fold(0.0f64, f64::max);
            // the EON paper's 4-coefficient fit of the FON albedo: max error 4.7e-4
            assert!(
                max < bound,
                "{} coefficients: off-grid max {max:.3e}",
                fit.n_coefficients
            );
            // at r = 0 the fit is one constant (no μ-terms without r)
            let e0 = fit.eval(&[0.0, 0.0]);
            assert!((0..20).all(|j| fit.eval(&[0.0, j as f64 / 19.0]) == e0));
            assert!((e0 - 1.0).abs() < bound);
            // the fit file round trip keeps the form and the coefficients
            let json = fit.to_json().unwrap();
            let back = crate::fit::FitResult::from_json(&json).unwrap();
            assert_eq!(
                (&back.form, &back.approximant),
                (&fit.form, &fit.approximant)
            );
            assert_eq!(back.to_json().unwrap(), json);
            maxima.push((fit.n_coefficients, max));
        }
        eprintln!("off-grid max (coefficients, error): {maxima:?}");
        assert_eq!(maxima.iter().map(|m| m.0).collect::<Vec<_>>(), vec![7, 8]);
        assert!(vanishing_in_r_forms(&data(&["x", "y"])).is_empty());
    }
}
