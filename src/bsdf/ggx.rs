//! GGX microfacet models: white conductor, dielectric interface (entering and leaving) and the
//! glossy (specular-over-diffuse) ratio, each with both Smith forms: what each tabulates, its
//! axes and outputs, and which integrand integrates a cell — the conductor's and the
//! dielectrics' in slope space ([`super::slope`], [`super::slope_dielectric`]), the glossy
//! model's over visible normals ([`super::vndf`]).

use super::microfacet::Lobes;
use super::slope::SlopeIntegrand;
use super::slope_dielectric::SlopeDielectric;
use super::vndf::VndfIntegrand;
use super::{AxisSpec, Model, ModelId, Side, Transmission, MAX_OUTPUTS};
use crate::math::{alpha_from_r, eta_from_f0, fresnel_dielectric, SmithForm};
use crate::quadrature::{integrate_2d, Break, Rules, CHANNELS};

/// Default F0 range of the glossy models: η from 1.25 to 3, as the dielectrics'
/// (Sforza & Pellacini 2022, §4: F0 from 0.0125 to 0.25), away from the degenerate slice
/// F0 = 0 where the specular layer vanishes.
pub const GLOSSY_F0_DEFAULT: (f64, f64) = (0.0125, 0.25);

/// Which microfacet albedo a model tabulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GgxKind {
    /// White conductor: F = 1 (paper eqs. 14–15).
    Conductor,
    /// Dielectric interface seen from outside (relative IOR η = (1+√F0)/(1−√F0)), or from inside
    /// (relative IOR 1/η, with total internal reflection) when `inverse` (paper eqs. 20–23).
    Dielectric { inverse: bool },
    /// Glossy: Fresnel-weighted specular albedo over the conductor albedo (paper eq. 17).
    Glossy,
}

/// A GGX model: a kind, a Smith form and the transmission convention.
#[derive(Clone, Debug)]
pub struct GgxModel {
    pub kind: GgxKind,
    pub smith: SmithForm,
    /// Transmission in radiance form (×1/η² entering, ×η² leaving) instead of energy form.
    pub radiance_transmission: bool,
}

/// Every GGX kind and Smith form, energy-form transmission, in the order `furnace models` lists them.
pub fn all() -> Vec<GgxModel> {
    let mut v = Vec::new();
    for kind in [
        GgxKind::Conductor,
        GgxKind::Dielectric { inverse: false },
        GgxKind::Dielectric { inverse: true },
        GgxKind::Glossy,
    ] {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            v.push(GgxModel::new(kind, smith, Transmission::Energy));
        }
    }
    v
}

/// The dielectrics with radiance-form transmission (the paper's tables).
pub fn radiance_variants() -> Vec<GgxModel> {
    all()
        .into_iter()
        .filter(|m| matches!(m.kind, GgxKind::Dielectric { .. }))
        .map(|m| GgxModel::new(m.kind, m.smith, Transmission::Radiance))
        .collect()
}

impl GgxModel {
    pub fn new(kind: GgxKind, smith: SmithForm, transmission: Transmission) -> GgxModel {
        GgxModel {
            kind,
            smith,
            radiance_transmission: transmission == Transmission::Radiance,
        }
    }

    /// Relative IOR of the interface at normal reflectance `f0` as seen from ωo.
    fn eta(&self, f0: f64) -> f64 {
        let eta = eta_from_f0(f0);
        match self.kind {
            GgxKind::Dielectric { inverse: true } => 1.0 / eta,
            _ => eta,
        }
    }

    /// The lobes of the integrand at normal reflectance `f0`.
    fn lobes(&self, f0: f64) -> Lobes {
        match self.kind {
            GgxKind::Conductor => Lobes::Conductor,
            GgxKind::Dielectric { .. } => Lobes::Dielectric { eta: self.eta(f0) },
            GgxKind::Glossy => Lobes::Glossy { eta: self.eta(f0) },
        }
    }

    /// The model's outputs from its two integrals at normal reflectance `f0`.
    fn outputs_from_integrals(&self, f0: f64, c: [f64; CHANNELS]) -> [f64; MAX_OUTPUTS] {
        match self.kind {
            GgxKind::Conductor => [c[0], 0.0, 0.0],
            GgxKind::Dielectric { .. } => {
                let t = if self.radiance_transmission {
                    let eta = self.eta(f0);
                    c[1] / (eta * eta)
                } else {
                    c[1]
                };
                [c[0] + t, c[0], t]
            }
            GgxKind::Glossy => [if c[1] > 0.0 { c[0] / c[1] } else { 0.0 }, 0.0, 0.0],
        }
    }

    /// The albedo integrals at (f0, r, μo): channels [E_R, E_T] (dielectric),
    /// [E_R·F, E_R without F] (glossy) or [E, 0] (conductor).
    pub fn integrals(&self, f0: f64, r: f64, mu_o: f64, rules: &Rules) -> [f64; CHANNELS] {
        self.cell(f0, r, mu_o).integrate(rules)
    }

    /// The integrand of the cell at (f0, r, μo), set up once for every order of its estimate.
    fn cell(&self, f0: f64, r: f64, mu_o: f64) -> Cell {
        let alpha = alpha_from_r(r);
        let lobes = self.lobes(f0);
        if alpha == 0.0 {
            return Cell::Smooth(smooth_interface(lobes, mu_o));
        }
        match (self.kind, lobes) {
            (_, Lobes::Conductor) => {
                Cell::Conductor(SlopeIntegrand::conductor(alpha, mu_o, self.smith))
            }
            (GgxKind::Dielectric { .. }, Lobes::Dielectric { eta }) if eta < 1.0 => Cell::Leaving {
                conductor: SlopeIntegrand::conductor(alpha, mu_o, self.smith),
                cap: SlopeDielectric::deficit(alpha, mu_o, eta, self.smith),
            },
            (GgxKind::Dielectric { .. }, Lobes::Dielectric { eta }) => {
                Cell::Dielectric(SlopeDielectric::new(alpha, mu_o, eta, self.smith))
            }
            _ => Cell::VisibleNormals(VndfIntegrand::new(alpha, mu_o, self.smith, lobes)),
        }
    }
}

/// The integrand of one cell, by parametrisation.
enum Cell {
    /// r = 0: the smooth interface's exact values.
    Smooth([f64; CHANNELS]),
    /// The white conductor in slope space.
    Conductor(SlopeIntegrand),
    /// A dielectric interface in slope space.
    Dielectric(SlopeDielectric),
    /// Leaving the denser medium: E_R is the white conductor's albedo less the reflection
    /// deficit of the critical-angle cap, E_T the cap's transmission.
    Leaving {
        conductor: SlopeIntegrand,
        cap: SlopeDielectric,
    },
    /// Over visible normals (the glossy model).
    VisibleNormals(VndfIntegrand),
}

impl Cell {
    fn integrate(&self, rules: &Rules) -> [f64; CHANNELS] {
        match self {
            Cell::Smooth(v) => *v,
            Cell::Conductor(f) => integrate_2d(f, rules),
            Cell::Dielectric(f) => integrate_2d(f, rules),
            Cell::Leaving { conductor, cap } => {
                leaving(integrate_2d(conductor, rules)[0], integrate_2d(cap, rules))
            }
            Cell::VisibleNormals(f) => integrate_2d(f, rules),
        }
    }
}

/// Leaving the denser medium: [E_R, E_T] from the white conductor's albedo `e` and the
/// critical-angle cap's integrals [∫(1 − F)·R, E_T] ([`SlopeDielectric::deficit`]).
fn leaving(e: f64, cap: [f64; CHANNELS]) -> [f64; CHANNELS] {
    [e - cap[0], cap[1]]
}

/// The r = 0 (α = 0) column: a smooth interface, whose BSDF is a delta and whose albedo is
/// exact — E = 1 (conductor), E_R = F(μo), E_T = 1 − F(μo) (dielectric). This also defines the
/// corner (r, μ) = (0, 0), where E is discontinuous (its limit depends on the path).
fn smooth_interface(lobes: Lobes, mu_o: f64) -> [f64; CHANNELS] {
    match lobes {
        Lobes::Conductor => [1.0, 0.0],
        Lobes::Dielectric { eta } => {
            let f = fresnel_dielectric(mu_o, eta);
            [f, 1.0 - f]
        }
        Lobes::Glossy { eta } => [fresnel_dielectric(mu_o, eta), 1.0],
    }
}

/// [`Model::integrator_revision`] of the dielectrics seen from inside (the critical-angle cap,
/// [`SlopeDielectric::deficit`]): its ψ panels map the branch points behind their ends (the
/// tangent's, the neighbouring square roots') with the longer sinh pieces such singularities
/// allow.
pub const LEAVING_INTEGRATOR_REVISION: u32 = 1;

impl Model for GgxModel {
    fn integrator_revision(&self) -> u32 {
        match self.kind {
            GgxKind::Dielectric { inverse: true } => LEAVING_INTEGRATOR_REVISION,
            _ => 0,
        }
    }

    fn id(&self) -> ModelId {
        match self.kind {
            GgxKind::Conductor => ModelId::ggx_conductor(self.smith),
            GgxKind::Glossy => ModelId::ggx_glossy(self.smith),
            GgxKind::Dielectric { inverse } => ModelId::ggx_dielectric(
                if inverse {
                    Side::Leaving
                } else {
                    Side::Entering
                },
                self.smith,
            )
            .with_transmission(if self.radiance_transmission {
                Transmission::Radiance
            } else {
                Transmission::Energy
            }),
        }
    }

    fn summary(&self) -> String {
        let g = match self.smith {
            SmithForm::HeightCorrelated => "height-correlated Smith G2",
            SmithForm::Separable => "separable Smith G1·G1 (the paper's renderer)",
        };
        let what = match self.kind {
            GgxKind::Conductor => "GGX white conductor (F = 1), E(r, μ)",
            GgxKind::Dielectric { inverse: false } => {
                "GGX rough dielectric seen from outside (η = (1+√F0)/(1−√F0)), E = E_R + E_T"
            }
            GgxKind::Dielectric { inverse: true } => {
                "GGX rough dielectric seen from inside (relative IOR 1/η, total internal reflection), E = E_R + E_T"
            }
            GgxKind::Glossy => "GGX glossy: Fresnel-weighted specular albedo / conductor albedo (paper eq. 17)",
        };
        let form = if self.radiance_transmission {
            "; transmission in radiance form (×1/η_rel²)"
        } else {
            ""
        };
        format!("{what}; {g}{form}")
    }

    fn axes(&self) -> Vec<AxisSpec> {
        let r = AxisSpec::new(
            "r",
            (0.0, 1.0),
            (0.0, 1.0),
            "square root of GGX alpha (alpha = r²)",
        );
        let mu = AxisSpec::new(
            "mu",
            (0.0, 1.0),
            (0.0, 1.0),
            "cosine of the outgoing direction, μo = n·ωo",
        );
        match self.kind {
            GgxKind::Conductor => vec![r, mu],
            GgxKind::Dielectric { inverse } => vec![
                AxisSpec::new(
                    "f0",
                    (0.0125, 0.25),
                    (0.0, 0.99),
                    if inverse {
                        "normal-incidence reflectance F0 of the interface (the same from either side: pass the material's F0); the light leaves the medium of relative IOR η = (1+√F0)/(1−√F0) (1.25 … 3 by default), so this side sees 1/η"
                    } else {
                        "normal-incidence reflectance F0 of the interface; the light enters the medium of relative IOR η = (1+√F0)/(1−√F0) (1.25 … 3 by default)"
                    },
                ),
                r,
                mu,
            ],
            // F0 ∈ [0.0125, 0.25] (η 1.25 … 3, the dielectrics' range) by default: the
            // slice F0 = 0 is degenerate (no specular layer, E = 0 against E → 1 beside it),
            // and no LUT or fit should spend itself on the layer next to it. The paper's
            // glossy table spans [0, 1] (data/paper/README.md): `compare-paper` asks for that
            // domain explicitly.
            GgxKind::Glossy => vec![
                AxisSpec::new(
                    "f0",
                    (GLOSSY_F0_DEFAULT.0, GLOSSY_F0_DEFAULT.1),
                    (0.0, 1.0),
                    "normal-incidence reflectance F0 of the specular layer (0.0125 … 0.25, η 1.25 … 3, by default)",
                ),
                r,
                mu,
            ],
        }
    }

    fn outputs(&self) -> Vec<&'static str> {
        match self.kind {
            GgxKind::Dielectric { .. } => vec!["E", "E_R", "E_T"],
            _ => vec!["E"],
        }
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        let (f0, r, mu) = match self.kind {
            GgxKind::Conductor => (0.0, x[0], x[1]),
            _ => (x[0], x[1], x[2]),
        };
        self.outputs_from_integrals(f0, self.integrals(f0, r, mu, rules))
    }

    fn integrate_orders(&self, x: &[f64], rules: &[&Rules]) -> Vec<[f64; MAX_OUTPUTS]> {
        let (f0, r, mu) = match self.kind {
            GgxKind::Conductor => (0.0, x[0], x[1]),
            _ => (x[0], x[1], x[2]),
        };
        let cell = self.cell(f0, r, mu);
        rules
            .iter()
            .map(|r| self.outputs_from_integrals(f0, cell.integrate(r)))
            .collect()
    }

    /// Conductors and dielectrics: E(r → 0, μ) collapses onto one value at r = 0, as the
    /// boundary-layer coordinate does. Not the glossy layer: its r = 0 row is the specular
    /// layer's Fresnel reflectance F(η, μ), which varies with μ, and the coordinate would map
    /// that whole row to one point.
    fn grazing_boundary_layer(&self) -> bool {
        !matches!(self.kind, GgxKind::Glossy)
    }

    /// Glossy: the slice F0 = 0 (η = 1: no specular layer, E = 0) next to E(F0 → 0⁺, r, μ → 0)
    /// ≈ 1 (the Fresnel layer of width ~F0^¼ at η → 1; docs/fitting.md).
    ///
    /// Dielectrics, both sides: at η = 1 every microfacet refracts ωo into −ωo, and near grazing
    /// angles the albedo on the slice is not the limit F0 → 0⁺ of its neighbours' (measured with
    /// `furnace eval --model`, r = 0.3, μ = 10⁻³: entering height-correlated 0.506 at F0 = 0
    /// against 0.905 at F0 = 10⁻⁶, separable 0.022 against 0.279; at μ = 0, 0 against 1.000
    /// and 0.263).
    fn degenerate_slices(&self) -> Vec<super::DegenerateSlice> {
        match self.kind {
            GgxKind::Glossy => vec![super::DegenerateSlice {
                axis: 0,
                value: 0.0,
                why: "the glossy albedo is 0 on the slice (η = 1 reflects nothing) but tends to 1 at grazing angles just beside it",
            }],
            GgxKind::Dielectric { .. } => vec![super::DegenerateSlice {
                axis: 0,
                value: 0.0,
                why: "η = 1 (no interface) refracts every direction straight through, and at grazing angles the albedo on the slice jumps away from its values just beside it (e.g. from 0.51 to 0.90 at r = 0.3, μ = 0.001)",
            }],
            GgxKind::Conductor => Vec::new(),
        }
    }

    /// E(μ) has a square-root end and a boundary layer at grazing μ of width ~α (the masking
    /// weight's branch points at μ = ±iα/√(1 − α²)), and seen from inside a dielectric the critical angle
    /// μc = √(1 − η²) of the relative IOR η < 1, a square-root kink of the smooth interface that
    /// roughness smooths over a width ~α·η (the spread of microfacet normals in μ there), and
    /// μ = η, where the kinks change topology. μ = 1 is a square-root end seen from inside
    /// (measured); it is mapped as one for every GGX model, which costs nothing where E is
    /// analytic there.
    fn mu_breaks(&self, x: &[f64], out: &mut Vec<Break>) {
        let (f0, r) = match self.kind {
            GgxKind::Conductor => (0.0, x[0]),
            _ => (x[0], x[1]),
        };
        let alpha = alpha_from_r(r).min(1.0);
        // μ = 0 is a square-root point of E for α > 0 (measured: the plain rule converges like
        // n⁻⁶ there at r = 1, the square-root map geometrically)
        out.push(if alpha > 0.0 {
            Break::sqrt(0.0).with_delta(alpha / (1.0 - alpha * alpha).max(0.0).sqrt())
        } else {
            Break::regular(0.0)
        });
        out.push(Break::sqrt(1.0));
        if let GgxKind::Dielectric { inverse: true } = self.kind {
            let eta = self.eta(f0);
            if eta < 1.0 {
                let mu_c = (1.0 - eta * eta).sqrt();
                if alpha > 0.0 {
                    out.push(Break::near_singular(mu_c, alpha * eta));
                    // μo = η: the critical-angle curve (ωo·h)² = 1 − η² touches the rim of the
                    // microfacet hemisphere (h_z = 0, where ωo·h ≤ sin θo), a change of topology
                    // of the integrand's kinks
                    out.push(Break::sqrt(eta));
                } else {
                    out.push(Break::one_sided_sqrt(mu_c, true)); // F = 1 below μc (tir)
                }
            }
        }
    }

    /// The entering dielectric and glossy models share their kinks across a column of IORs,
    /// the leaving dielectric its white conductor's albedo.
    fn shares_column_geometry(&self) -> bool {
        matches!(self.kind, GgxKind::Dielectric { .. } | GgxKind::Glossy)
    }

    fn integrate_column(&self, xs: &[Vec<f64>], rules: &Rules, out: &mut [[f64; MAX_OUTPUTS]]) {
        let shares_geometry = self.shares_column_geometry();
        let (r, mu) = match xs.first() {
            Some(x) if x.len() == 3 => (x[1], x[2]),
            _ => (0.0, 0.0),
        };
        if !shares_geometry || xs.is_empty() || alpha_from_r(r) == 0.0 {
            for (x, o) in xs.iter().zip(out.iter_mut()) {
                *o = self.integrate(x, rules);
            }
            return;
        }
        debug_assert!(
            xs.iter().all(|x| x[1] == r && x[2] == mu),
            "a column shares r and mu"
        );
        let etas: Vec<f64> = xs.iter().map(|x| self.eta(x[0])).collect();
        let alpha = alpha_from_r(r);
        let mut c = vec![0.0; 2 * etas.len()];
        match self.kind {
            GgxKind::Glossy => {
                let lobes = Lobes::Glossy { eta: 1.0 };
                let f = VndfIntegrand::column(alpha, mu, self.smith, lobes, &etas);
                crate::quadrature::integrate_2d_into(&f, rules, &mut c);
            }
            GgxKind::Dielectric { inverse: true } => {
                let e = integrate_2d(&SlopeIntegrand::conductor(alpha, mu, self.smith), rules)[0];
                for (k, &eta) in etas.iter().enumerate() {
                    let v = if eta < 1.0 {
                        let cap = SlopeDielectric::deficit(alpha, mu, eta, self.smith);
                        leaving(e, integrate_2d(&cap, rules))
                    } else {
                        // F0 = 0: no interface
                        integrate_2d(&SlopeDielectric::new(alpha, mu, eta, self.smith), rules)
                    };
                    c[2 * k] = v[0];
                    c[2 * k + 1] = v[1];
                }
            }
            _ => {
                let f = SlopeDielectric::column(alpha, mu, &etas, self.smith);
                crate::quadrature::integrate_2d_into(&f, rules, &mut c);
            }
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.outputs_from_integrals(xs[k][0], [c[2 * k], c[2 * k + 1]]);
        }
    }

    fn parameters(&self) -> serde_json::Value {
        serde_json::json!({
            "smith": self.smith,
            "transmission": if self.radiance_transmission { "radiance" } else { "energy" },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_glossy_domain_with_the_slice_f0_0_is_refused_and_the_others_pass() {
        let glossy = GgxModel::new(
            GgxKind::Glossy,
            SmithForm::HeightCorrelated,
            Transmission::Energy,
        );
        let fix = |a: &str, (lo, hi): (f64, f64)| format!("use {a}={lo}:{hi}");
        let whole = [(0.0, 1.0), (0.0, 1.0), (0.0, 1.0)];
        let err = crate::bsdf::check_no_degenerate_slice(&glossy, &whole, &fix)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("includes f0 = 0") && err.contains("use f0=0.0125:0.25"),
            "{err}"
        );
        let default: Vec<(f64, f64)> = glossy.axes().iter().map(|a| a.default_range).collect();
        assert!(crate::bsdf::check_no_degenerate_slice(&glossy, &default, &fix).is_ok());
        // the dielectrics' F0 = 0 too (both sides, both Smith forms), and their default
        // domains pass
        for inverse in [false, true] {
            for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
                let dielectric =
                    GgxModel::new(GgxKind::Dielectric { inverse }, smith, Transmission::Energy);
                let err = crate::bsdf::check_no_degenerate_slice(&dielectric, &whole, &fix)
                    .unwrap_err()
                    .to_string();
                assert!(
                    err.contains("includes f0 = 0") && err.contains("η = 1"),
                    "{err}"
                );
                let default: Vec<(f64, f64)> =
                    dielectric.axes().iter().map(|a| a.default_range).collect();
                assert!(
                    crate::bsdf::check_no_degenerate_slice(&dielectric, &default, &fix).is_ok()
                );
            }
        }
    }

    /// The jump the dielectrics' degenerate slice names: at grazing angles the albedo at F0 = 0
    /// is far from its value at F0 = 10⁻⁶.
    #[test]
    fn the_dielectric_slice_f0_0_jumps_at_grazing_angles() {
        let rules = Rules::new(16);
        for (smith, on, beside) in [
            (SmithForm::HeightCorrelated, 0.506, 0.905),
            (SmithForm::Separable, 0.022, 0.279),
        ] {
            let m = GgxModel::new(
                GgxKind::Dielectric { inverse: false },
                smith,
                Transmission::Energy,
            );
            let e = |f0: f64| m.integrate(&[f0, 0.3, 1e-3], &rules)[0];
            let (a, b) = (e(0.0), e(1e-6));
            assert!(
                (a - on).abs() < 2e-3 && (b - beside).abs() < 2e-3,
                "{smith:?}: {a} {b}"
            );
        }
    }
    use crate::quadrature::Rules;

    fn conductor(smith: SmithForm) -> GgxModel {
        GgxModel {
            kind: GgxKind::Conductor,
            smith,
            radiance_transmission: false,
        }
    }

    #[test]
    fn conductor_at_r1_mu1_is_one_minus_ln2() {
        let rules = Rules::new(32);
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            let e = conductor(smith).integrate(&[1.0, 1.0], &rules)[0];
            assert!((e - (1.0 - 2f64.ln())).abs() < 1e-12, "{smith:?}: {e}");
        }
    }
}
