//! The model trait, model identities and the registry of models.
//!
//! A model is a BSDF together with the parametrisation of its directional albedo
//! E(ω_o) = ∫ f(ω_o, ω_i) |n·ω_i| dω_i (Sforza & Pellacini 2022, eq. 2): the axes a table spans
//! and how to integrate at one point. Its identity is a [`ModelId`] (family, Smith form, side,
//! transmission convention), whose text form is the model's name. To add a BSDF, implement
//! [`Model`] and [`register`] it (see docs/models.md, "Adding a model"; a built-in one joins the
//! registry's built-in list, and `examples/custom_model.rs` registers one from outside the library).

pub mod average;
pub mod diffuse;
pub mod fresnel;
pub mod ggx;
pub mod ggx_aniso;
mod id;
pub mod kinks;
pub mod microfacet;
pub mod radziszewski;
mod registry;
pub mod slope;
pub mod slope_aniso;
pub mod slope_dielectric;
pub mod vndf;
pub mod weighted;

pub use id::{Family, ModelId, Side, Transmission};
pub use registry::{
    default_set, find, find_variant, get, known_names, listed, lookup, models, register,
    register_in_default_set,
};

use crate::error::{Error, Result};
use crate::quadrature::{refine, Break, Estimate, QuadratureSettings, RuleCache, Rules};

/// Most outputs a model reports at one point (E, and E_R, E_T for dielectrics).
pub const MAX_OUTPUTS: usize = 3;

/// One axis of a model's parameter space.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct AxisSpec {
    /// Name as it appears in CSV headers and JSON (`r`, `mu`, `f0`, `n`).
    pub name: String,
    /// Domain a default table spans.
    pub default_range: (f64, f64),
    /// Domain on which the model is defined; evaluation outside it is refused.
    pub valid_range: (f64, f64),
    /// What the axis means, one line.
    pub description: String,
}

impl AxisSpec {
    pub fn new(
        name: &str,
        default_range: (f64, f64),
        valid_range: (f64, f64),
        description: &str,
    ) -> AxisSpec {
        AxisSpec {
            name: name.into(),
            default_range,
            valid_range,
            description: description.into(),
        }
    }
}

/// A value of one axis where a model's albedo is degenerate ([`Model::degenerate_slices`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DegenerateSlice {
    /// Index of the axis.
    pub axis: usize,
    /// The axis value of the slice.
    pub value: f64,
    /// What happens there, for the error message.
    pub why: &'static str,
}

/// Refuses a fitting domain (one `(lo, hi)` per axis of `model`) that contains one of the
/// model's degenerate slices, naming the slice; `fix` says how to leave it out, given the axis
/// name and the model's default range of that axis.
pub fn check_no_degenerate_slice(
    model: &dyn Model,
    domain: &[(f64, f64)],
    fix: &dyn Fn(&str, (f64, f64)) -> String,
) -> Result<()> {
    let axes = model.axes();
    for s in model.degenerate_slices() {
        let (Some(&(lo, hi)), Some(a)) = (domain.get(s.axis), axes.get(s.axis)) else {
            continue;
        };
        if lo <= s.value && s.value <= hi {
            return Err(Error::InvalidInput(format!(
                "the {} domain includes {} = {} ({} ∈ [{lo}, {hi}]), where {}; no continuous fit or LUT follows that jump: {}",
                model.id().name(),
                a.name,
                s.value,
                a.name,
                s.why,
                fix(&a.name, a.default_range)
            )));
        }
    }
    Ok(())
}

/// A BSDF whose directional albedo furnace can integrate.
pub trait Model: Send + Sync {
    /// The model's identity; [`ModelId::name`] is how the CLI spells it and
    /// [`ModelId::key`] the folder under `data/` and `fits/`.
    fn id(&self) -> ModelId;
    /// One line: what the model is and where it comes from.
    fn summary(&self) -> String;
    /// The axes of the albedo, in table order.
    fn axes(&self) -> Vec<AxisSpec>;
    /// Output names; the first is always `E`.
    fn outputs(&self) -> Vec<&'static str>;
    /// The outputs at point `x` (one coordinate per axis, inside the valid ranges),
    /// integrated with `rules`. Entries past `outputs().len()` are ignored.
    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS];
    /// Parameters that change the model's values beyond its name (e.g. the transmission form),
    /// recorded in table sidecars and hashed into the cache key.
    fn parameters(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    /// Revision of how this model's albedo is integrated, raised whenever a change to its
    /// integrand, panels or maps can change its values: hashed into the cache key of its tables
    /// when not 0 ([`crate::table::TableSpec::content_hash`]), so that only its own cached
    /// tables (and what was fitted on them) are recomputed. Changes to the shared engine raise
    /// [`crate::table::ENGINE_VERSION`] instead.
    fn integrator_revision(&self) -> u32 {
        0
    }
    /// Outputs at `x` for several rule sets (the orders of one error estimate). Models whose
    /// setup is costly (breakpoints found by scanning) override this to set up once.
    fn integrate_orders(&self, x: &[f64], rules: &[&Rules]) -> Vec<[f64; MAX_OUTPUTS]> {
        rules.iter().map(|r| self.integrate(x, r)).collect()
    }
    /// Outputs at points that share every coordinate but the first (a column of a table along
    /// its first axis, e.g. f0), written to `out`. Models whose integrand geometry does not
    /// depend on the first axis override this to compute it once per column; the default
    /// integrates each point on its own.
    fn integrate_column(&self, xs: &[Vec<f64>], rules: &Rules, out: &mut [[f64; MAX_OUTPUTS]]) {
        for (x, o) in xs.iter().zip(out.iter_mut()) {
            *o = self.integrate(x, rules);
        }
    }
    /// Whether [`Model::integrate_column`] shares work across the column. When it does not,
    /// [`albedo_column`] takes the points one at a time through [`Model::integrate_orders`],
    /// so that a point's setup serves both orders of its estimate.
    fn shares_column_geometry(&self) -> bool {
        false
    }
    /// The tolerance [`albedo`] and [`albedo_column`] refine this model's estimates to when
    /// `requested` is asked for: `requested`, unless the model needs a tighter one (the
    /// averages, [`average::AVERAGE_TOLERANCE`]).
    fn tolerance(&self, requested: f64) -> f64 {
        requested
    }
    /// Whether E has a boundary layer at grazing μ whose width shrinks with roughness (GGX:
    /// E(r, μ) → g(μ/r²) as r → 0). Degree sweeps of such a model also try the boundary-layer
    /// input transform ([`crate::fit::InputTransform::BoundaryLayer`]); for the others it only
    /// costs time (the rough-diffuse models' best fits never used it: measured on every sweep).
    fn grazing_boundary_layer(&self) -> bool {
        false
    }
    /// Slices of the domain where the albedo is degenerate: a value of one axis where E jumps
    /// (the glossy layer at F0 = 0 has E = 0, against E → 1 at grazing angles beside it), so
    /// that no fit or LUT should span it ([`check_no_degenerate_slice`]). None by default.
    fn degenerate_slices(&self) -> Vec<DegenerateSlice> {
        Vec::new()
    }
    /// The breakpoints of the outputs as functions of μ (the axis named `mu`) at the other
    /// coordinates of `x` (its `mu` entry is ignored): kinks, and ends next to which E varies on
    /// a short scale, as [`Break`]s. The average over μ ([`average::AverageAlbedo`]) puts its
    /// panels between them. By default both ends are square-root points, which is safe for any
    /// E that is smooth inside (0, 1).
    fn mu_breaks(&self, _x: &[f64], out: &mut Vec<Break>) {
        out.extend([Break::sqrt(0.0), Break::sqrt(1.0)]);
    }
    /// Nodes per axis of a table when none is asked for: 1024 per axis in 2-D and 128 in 3-D (the
    /// paper's resolutions); a model with more axes names its own.
    fn default_resolution(&self) -> Vec<usize> {
        let d = self.axes().len();
        vec![if d <= 2 { 1024 } else { 128 }; d]
    }
}

/// E at one point with its error estimate, refined until it meets `settings.tolerance` (or the
/// model's tighter [`Model::tolerance`])
/// ([`refine`]; both orders of the first estimate through [`Model::integrate_orders`]).
pub fn albedo(
    model: &dyn Model,
    x: &[f64],
    settings: &QuadratureSettings,
    cache: &RuleCache,
) -> Estimate<MAX_OUTPUTS> {
    let settings = &QuadratureSettings {
        tolerance: model.tolerance(settings.tolerance),
        ..*settings
    };
    let first = model.integrate_orders(
        x,
        &[cache.get(settings.companion), cache.get(settings.order)],
    );
    refine(
        settings,
        cache,
        &first[..1],
        &first[1..2],
        |_, rules, out| out[0] = model.integrate(x, rules),
    )
    .remove(0)
}

/// E at points sharing all but the first coordinate, with per-point error estimates: the whole
/// column at the companion and base orders ([`Model::integrate_column`]), then the points whose
/// estimate exceeds the tolerance, together as a shorter column (they still share the
/// geometry), at higher orders ([`refine`]). Models that share nothing across a column take
/// their points one at a time ([`albedo`]).
pub fn albedo_column(
    model: &dyn Model,
    xs: &[Vec<f64>],
    settings: &QuadratureSettings,
    cache: &RuleCache,
) -> Vec<Estimate<MAX_OUTPUTS>> {
    let settings = &QuadratureSettings {
        tolerance: model.tolerance(settings.tolerance),
        ..*settings
    };
    if !model.shares_column_geometry() {
        return xs
            .iter()
            .map(|x| albedo(model, x, settings, cache))
            .collect();
    }
    let mut low = vec![[0.0; MAX_OUTPUTS]; xs.len()];
    let mut high = vec![[0.0; MAX_OUTPUTS]; xs.len()];
    model.integrate_column(xs, cache.get(settings.companion), &mut low);
    model.integrate_column(xs, cache.get(settings.order), &mut high);
    refine(settings, cache, &low, &high, |open, rules, out| {
        let sub: Vec<Vec<f64>> = open.iter().map(|&k| xs[k].clone()).collect();
        model.integrate_column(&sub, rules, out)
    })
}

/// Checks that `x` has one finite coordinate per axis, inside the valid range.
pub fn check_point(model: &dyn Model, x: &[f64]) -> std::result::Result<(), String> {
    let axes = model.axes();
    if x.len() != axes.len() {
        return Err(format!(
            "expected {} coordinates ({}), got {}",
            axes.len(),
            axis_names(model),
            x.len()
        ));
    }
    for (v, a) in x.iter().zip(&axes) {
        if !v.is_finite() {
            return Err(format!("{} = {v} is not a finite number", a.name));
        }
        if *v < a.valid_range.0 || *v > a.valid_range.1 {
            return Err(format!(
                "{} = {v} is outside the model's domain [{}, {}]",
                a.name, a.valid_range.0, a.valid_range.1
            ));
        }
    }
    Ok(())
}

/// `r,mu` or `f0,r,mu`: the axis names joined by commas.
pub fn axis_names(model: &dyn Model) -> String {
    model
        .axes()
        .iter()
        .map(|a| a.name.clone())
        .collect::<Vec<_>>()
        .join(",")
}
