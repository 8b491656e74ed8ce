//! Material recipes: how a renderer uses furnace's albedos to make a BSDF energy-preserving.
//!
//! One registry lists the material classes ([`register`], [`classes`]): the built-in ones of
//! [`builtin`] (Sforza & Pellacini 2022, Fig. 4, plus rough diffuse) and any a program adds. A
//! class says
//!
//! * which albedo tables it reads ([`MaterialClass::tables`]) — what a scene manifest's material
//!   of that kind needs tabulated, fitted and emitted;
//! * which helper functions the emitters write next to each albedo function ([`Helper`]);
//! * its compensated BSDFs ([`MaterialClass::compensated`]), in the form the white furnace test
//!   ([`furnace`]) integrates: uncompensated lobes f_k(ωo, ωi) ([`Lobe`]) and the rule that
//!   combines their integrals with an albedo source into the compensated albedo
//!   ([`CompensatedBsdf::albedo`]).
//!
//! Scenes, the report, the emitters and `furnace run` read these; none of them knows a material by
//! name.
//!
//! | kind | tables | helpers | compensated BSDF | paper |
//! | --- | --- | --- | --- | --- |
//! | conductor | ggx-conductor (r, μ) | Turquin scale; Kulla–Conty lobe, colour, diffuse weight | ρ_ss·(1 + F0(1−E)/E) = ρ_ss/E at F0 = 1; ρ_ss + F_ms f_ms ([`kulla_conty`]) | eqs. 7–9, 13; Kulla & Conty 2017 |
//! | glossy | ggx-glossy (f0, r, μ), ggx-conductor | 1 − E_spec; 1/E_ss | F ρ_ss*/E_ss + (1 − E_spec)/π | eqs. 16–18 |
//! | thin-dielectric | ggx-conductor (r, μ) | 1/E | (ρ_R + ρ_T)/E_ss | §3.4, eq. 19 |
//! | dielectric | ggx-dielectric, ggx-dielectric-inv (f0, r, μ) | 1/E, by side of the surface; Kulla–Conty reflection and transmission lobes | (ρ_R + ρ_T)/E; ρ_R + ρ_T + f_R + f_T ([`kulla_conty_dielectric`]) | eq. 19, §3.3; Kulla & Conty 2017 |
//! | rough-diffuse | oren-nayar-fon (r, μ) | — | FON + Kulla–Conty lobe from E | EON eqs. 16, 19 |
//! | anisotropic-conductor | ggx-conductor-aniso (r, aniso, μ, φ) | E and Turquin scale at the view direction in the tangent frame | ρ_ss/E at F0 = 1 ([`anisotropic`]) | eq. 13 |
//!
//! `examples/custom_model.rs` registers a model and a material class of its own and runs them
//! through tables, fits, emitted code, the report and a scene.

pub mod anisotropic;
pub mod builtin;
pub mod furnace;
pub mod kulla_conty;
pub mod kulla_conty_dielectric;
pub mod microfacet;
pub mod quad;
mod registry;

pub use microfacet::MicrofacetLobe;
pub use registry::{classes, compensated_for, find, helpers_for, known_kinds, register};

use crate::bsdf::{ModelId, Transmission};
use crate::math::SmithForm;
use std::sync::Arc;

/// A directional albedo E(x) a renderer would read to compensate a BSDF: a table, a LUT or a fit
/// (implemented in [`crate::report::albedo`]).
pub trait Albedo: Sync {
    /// E at `x` (the model's axes, in table order). Points outside the source's domain are
    /// clamped to it (as a texture lookup or a shader clamps its inputs).
    fn albedo(&self, x: &[f64]) -> f64;
    /// Number of axes.
    fn dim(&self) -> usize;
}

/// A function the emitters write next to an albedo function, calling it (Sforza & Pellacini
/// 2022): the factor a renderer multiplies a BSDF by.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Helper {
    /// 1 + F0·(1 − E)/E: the conductor's multiple-scattering scale (eq. 13, after Turquin 2019).
    TurquinScale,
    /// Kulla & Conty 2017: the multiple-scattering lobe f_ms(ωo, ωi) = (1 − E(μo))(1 − E(μi)) /
    /// (π(1 − E_avg)), its colour F_ms = F_avg² E_avg / (1 − F_avg(1 − E_avg)), and the weight
    /// 1 − (F_avg E(μo) + F_ms (1 − E(μo))) of a diffuse base under a dielectric layer.
    KullaConty,
    /// 1/E: the normalisation of a lobe whose albedo is E (eqs. 18, 19; §3.4).
    Normalization,
    /// 1 − E: the weight of a diffuse base under a specular layer of albedo E (eq. 18).
    DiffuseWeight,
    /// E and 1/E for the side of the surface ωo is on, from this table (entering) and the
    /// `leaving` one (§3.3: one table per direction of travel).
    Sided { leaving: ModelId },
    /// Turquin's scale 1 + F0·(1 − E)/E of an albedo over (…, μ, φ) (an anisotropic lobe) at a
    /// view direction given in the tangent frame: μ and φ (reduced by the lobe's mirror
    /// symmetries to [0, π/2]) are formed from it, and E at them is emitted too.
    TangentFrameTurquin,
    /// Kulla & Conty 2017's multiple-scattering lobe of a rough dielectric interface, in
    /// reflection and transmission on both sides, from this table (entering) and the `leaving`
    /// one, with the energy split that keeps the transmission reciprocal
    /// ([`kulla_conty_dielectric`]).
    KullaContyDielectric { leaving: ModelId },
}

/// A helper a material needs for one of its tables, and what the material does with it: the
/// lines the emitted doc comment gives for that use (the emitters join the uses of every class
/// that needs the helper).
#[derive(Clone, Debug, PartialEq)]
pub struct HelperUse {
    pub helper: Helper,
    pub purpose: Vec<String>,
}

impl HelperUse {
    pub fn new(helper: Helper, purpose: &[&str]) -> HelperUse {
        HelperUse {
            helper,
            purpose: purpose.iter().map(|l| l.to_string()).collect(),
        }
    }
}

/// One albedo table a material reads, and the helpers emitted for it.
#[derive(Clone, Debug, PartialEq)]
pub struct TableUse {
    pub model: ModelId,
    pub helpers: Vec<HelperUse>,
}

impl TableUse {
    pub fn new(model: ModelId, helpers: Vec<HelperUse>) -> TableUse {
        TableUse { model, helpers }
    }
}

/// A class of materials compensated with furnace's albedos.
pub trait MaterialClass: Send + Sync {
    /// The kind as scene manifests spell it (`thin-dielectric`): unique in the registry.
    fn kind(&self) -> &'static str;
    /// One line: what the material is and how it is compensated.
    fn summary(&self) -> String;
    /// How manifest errors name a material of this class ("a {noun} has no IOR axis").
    fn noun(&self) -> String {
        format!("{} material", self.kind())
    }
    /// `None` when the `r` axis is GGX's (α = r², so a manifest may give `alpha`); else what `r`
    /// is, for the error that refuses `alpha`.
    fn r_is_not_alpha(&self) -> Option<&'static str> {
        None
    }
    /// The albedo tables a material of this class reads when the scene's GGX tables use Smith
    /// form `smith` (classes without microfacets ignore it), with the helpers of each.
    fn tables(&self, smith: SmithForm) -> Vec<TableUse>;
    /// The compensated BSDFs the white furnace test checks: one per table that compensates a
    /// lobe of its own (a dielectric has two, entering and leaving). `transmission` is the
    /// convention of dielectric tables.
    fn compensated(
        &self,
        smith: SmithForm,
        transmission: Transmission,
    ) -> Vec<Arc<dyn CompensatedBsdf>>;
}

/// One uncompensated lobe f_k(ωo, ωi) at a point, as the furnace test integrates it: ∫ f |μi| dωi.
#[derive(Clone)]
pub enum Lobe {
    /// An integral known in closed form (a delta lobe at α = 0; F(μo) of a weight).
    Exact(f64),
    /// GGX microfacet lobes at α > 0, integrated over microfacet normals
    /// ([`microfacet::microfacet_albedo`]).
    Microfacet {
        alpha: f64,
        mu_o: f64,
        smith: SmithForm,
        lobe: MicrofacetLobe,
    },
    /// An isotropic diffuse BRDF f(μi, μo, s), s = sin θi sin θo cos φ, even in φ, with kinks
    /// at μi = μo and φ = π/2 at most (EON paper eqs. 4, 11).
    Diffuse {
        mu_o: f64,
        brdf: Arc<dyn Fn(f64, f64, f64) -> f64 + Send + Sync>,
    },
    /// The albedo of a registered model at `x` by its own integrand at fixed quadrature
    /// `orders` (the value at the last, the error estimate the spread): for lobes this module
    /// has no rule of its own for (the anisotropic GGX conductor, [`anisotropic`]).
    Model {
        model: ModelId,
        x: Vec<f64>,
        orders: Vec<usize>,
    },
    /// Any BSDF: `f(ωi)` = f(ωo, ωi) for ωo = (sin θo, 0, μo), over the upper hemisphere (or
    /// the whole sphere when `transmits`), with optional kinks in μi = n·ωi.
    Directional {
        mu_o: f64,
        f: Arc<dyn Fn([f64; 3]) -> f64 + Send + Sync>,
        transmits: bool,
        mu_breaks: Vec<f64>,
    },
}

/// Which albedos a compensation reads.
#[derive(Clone)]
pub enum Compensation<'a> {
    /// The single-scattering BSDF as is (the paper's Fig. 4, top row).
    None,
    /// Compensated with one source per model of [`CompensatedBsdf::albedos`], in that order.
    With(Vec<&'a dyn Albedo>),
}

/// What a compensation precomputes over a set of points (e.g. per-r averages of its albedo).
#[derive(Clone, Debug, Default)]
pub struct Prepared {
    /// (key, value) pairs sorted by key.
    values: Vec<(f64, f64)>,
    /// (key, values) pairs with keys of several coordinates, sorted lexicographically.
    keyed: Vec<(Vec<f64>, Vec<f64>)>,
}

/// Lexicographic total order of two keys.
fn key_order(a: &[f64], b: &[f64]) -> std::cmp::Ordering {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.total_cmp(y))
        .find(|o| o.is_ne())
        .unwrap_or_else(|| a.len().cmp(&b.len()))
}

impl Prepared {
    /// From (key, value) pairs; keys are sorted and must be distinct.
    pub fn new(mut values: Vec<(f64, f64)>) -> Prepared {
        values.sort_by(|a, b| a.0.total_cmp(&b.0));
        Prepared {
            values,
            keyed: Vec::new(),
        }
    }

    /// From (key, values) pairs whose keys have several coordinates (e.g. (F0, r)); keys must
    /// be distinct.
    pub fn keyed(mut keyed: Vec<(Vec<f64>, Vec<f64>)>) -> Prepared {
        keyed.sort_by(|a, b| key_order(&a.0, &b.0));
        Prepared {
            values: Vec::new(),
            keyed,
        }
    }

    /// The values stored for a key of several coordinates, if any.
    pub fn get_keyed(&self, key: &[f64]) -> Option<&[f64]> {
        self.keyed
            .binary_search_by(|p| key_order(&p.0, key))
            .ok()
            .map(|k| self.keyed[k].1.as_slice())
    }

    /// The value stored for `key`, if any.
    pub fn get(&self, key: f64) -> Option<f64> {
        self.values
            .binary_search_by(|p| p.0.total_cmp(&key))
            .ok()
            .map(|k| self.values[k].1)
    }
}

/// A compensated BSDF in the form the white furnace test integrates: its lobes at a point are
/// integrated once ([`furnace::lobe_integrals`]) and combined with each albedo source. The
/// compensations of the paper scale lobes by factors of ωo alone, so the integral of a
/// compensated lobe is the factor times the lobe's integral.
pub trait CompensatedBsdf: Send + Sync {
    /// File-name stem of its furnace images (`thin-dielectric-separable`).
    fn id(&self) -> String;
    /// Short human name ("thick dielectric, leaving, separable G").
    fn label(&self) -> String;
    /// The albedo models the compensation reads, the primary one first: points are in its axes
    /// and the test runs on its table's nodes.
    fn albedos(&self) -> Vec<ModelId>;
    /// How notes name the k-th albedo of [`CompensatedBsdf::albedos`] ("conductor").
    fn albedo_role(&self, k: usize) -> String {
        self.albedos()[k].name()
    }
    /// F0 fixed by the material rather than a table axis (shown in captions).
    fn fixed_f0(&self) -> Option<f64> {
        None
    }
    /// The uncompensated lobes at `x` (the primary model's axes).
    fn lobes(&self, x: &[f64]) -> Vec<Lobe>;
    /// What [`CompensatedBsdf::albedo`] needs precomputed for `compensation` over `points`.
    fn prepare(&self, _compensation: &Compensation, _points: &[Vec<f64>]) -> Prepared {
        Prepared::default()
    }
    /// The albedo of the compensated BSDF at `x` from the integrals of its lobes (in the order
    /// of [`CompensatedBsdf::lobes`]): the white furnace value, 1 for a perfect compensation.
    fn albedo(
        &self,
        lobes: &[f64],
        x: &[f64],
        compensation: &Compensation,
        prepared: &Prepared,
    ) -> f64;
}
