//! The built-in material classes: the paper's Fig. 4 (conductor, glossy, thin and thick
//! dielectric; Sforza & Pellacini 2022, §3) plus rough diffuse, and their compensated BSDFs.
//!
//! | class | BSDF | compensated (white) | paper |
//! | --- | --- | --- | --- |
//! | conductor | ρ_ss = D G2 / (4 μo μi), F = 1 | ρ_ss·(1 + F0(1−E)/E) = ρ_ss/E at F0 = 1; ρ_ss + f_ms (Kulla–Conty, [`super::kulla_conty`]) | eqs. 7–9, 13 |
//! | glossy | F ρ_ss* + (1 − F(μo)) / π | F ρ_ss*/E_ss + (1 − E_spec)/π | eqs. 16–18 |
//! | thin dielectric | F ρ_ss* + (1 − F) ρ_ss*(mirrored) | (ρ_R + ρ_T)/E_ss | §3.4, eq. 19 |
//! | dielectric | F ρ_ss* + ρ_T (Walter eq. 21) | (ρ_R + ρ_T)/E; ρ_R + ρ_T + f_R + f_T (Kulla–Conty, [`super::kulla_conty_dielectric`]) | eq. 19 |
//! | rough diffuse | FON (EON paper eq. 10) | FON + Kulla–Conty lobe from E (EON eqs. 16, 19) | — |
//!
//! Glossy uses two albedos: the glossy E_spec(F0, r, μ) (eq. 17) and the conductor E_ss(r, μ) of
//! the same Smith form. Thin dielectrics use the conductor table (§3.4) at F0 = [`THIN_F0`].
//! Dielectric transmission is in energy form (no 1/η² radiance factor, E_R + E_T → 1 as α → 0)
//! unless the radiance form is asked for, the paper repository's convention.
//!
//! The rough-diffuse class is not in the paper: it compensates Fujii's Oren–Nayar (FON) with the
//! multiple-scattering lobe of EON (Portsmouth et al., eq. 19 — the Kulla–Conty form, eq. 4 of the
//! paper with F_ms = 1), f_ms = (1 − E(μo))(1 − E(μi)) / (π (1 − ⟨E⟩)), ⟨E⟩ = 2∫E μ dμ of the same
//! source. That lobe integrates to 1 − E(μo) by construction, so the compensated albedo is
//! Q_FON(μo) + 1 − E(μo) with Q_FON integrated by the test; where 1 − ⟨E⟩ ≤ 0 (a source at or
//! above 1 everywhere, e.g. r = 0) the lobe is off, as a renderer guarding the division would do.
//!
//! At r = 0 the GGX BSDFs are deltas, which no quadrature integrates: their exact albedos are used
//! (1 for the conductor, F(μo) for the glossy specular layer, F + (1 − F) for dielectrics).

use super::furnace::average_albedo;
use super::kulla_conty::KullaConty;
use super::kulla_conty_dielectric::KullaContyDielectric;
use super::{
    CompensatedBsdf, Compensation, Helper, HelperUse, Lobe, MaterialClass, MicrofacetLobe,
    Prepared, TableUse,
};
use crate::bsdf::diffuse::fon_brdf;
use crate::bsdf::{Family, ModelId, Side, Transmission};
use crate::math::{alpha_from_r, eta_from_f0, fresnel_dielectric, SmithForm};
use std::f64::consts::PI;
use std::sync::Arc;

/// F0 of the thin dielectric (η = 1.5), whose compensation table is the conductor's (§3.4).
pub const THIN_F0: f64 = 0.04;

/// Smallest albedo a compensation divides by: a renderer guards the division the same way; a
/// source this low (only a broken fit) shows up as a huge |1 − E|, never as a NaN.
pub const MIN_ALBEDO: f64 = 1e-6;

/// The built-in classes, in the order the registry lists them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    Conductor,
    ThinDielectric,
    Glossy,
    /// Rough dielectric interface (both sides).
    Dielectric,
    RoughDiffuse,
}

impl Kind {
    pub const ALL: [Kind; 5] = [
        Kind::Conductor,
        Kind::ThinDielectric,
        Kind::Glossy,
        Kind::Dielectric,
        Kind::RoughDiffuse,
    ];
}

impl MaterialClass for Kind {
    fn kind(&self) -> &'static str {
        match self {
            Kind::Conductor => "conductor",
            Kind::Glossy => "glossy",
            Kind::ThinDielectric => "thin-dielectric",
            Kind::Dielectric => "dielectric",
            Kind::RoughDiffuse => "rough-diffuse",
        }
    }

    fn summary(&self) -> String {
        match self {
            Kind::Conductor => "GGX conductor; multiple scattering restored by Turquin's scale 1 + F0(1 − E)/E (paper eq. 13)",
            Kind::Glossy => "GGX specular layer over a white diffuse base: ρ_ss/E_ss + (1 − E_spec) ρ_diff (paper eq. 18)",
            Kind::ThinDielectric => "thin GGX dielectric: reflection + mirrored transmission over E of the conductor table (paper §3.4, eq. 19)",
            Kind::Dielectric => "rough GGX dielectric interface: (ρ_R + ρ_T)/E with one table per side of the surface (paper eq. 19, §3.3)",
            Kind::RoughDiffuse => "Fujii's Oren–Nayar with EON's multiple-scattering lobe from E (EON paper eqs. 16, 19)",
        }
        .to_string()
    }

    fn noun(&self) -> String {
        match self {
            Kind::ThinDielectric => "thin dielectric (paper §3.4: it uses the conductor table)",
            Kind::RoughDiffuse => "rough-diffuse material",
            _ => self.kind(),
        }
        .to_string()
    }

    fn r_is_not_alpha(&self) -> Option<&'static str> {
        (*self == Kind::RoughDiffuse).then_some("the FON/EON roughness")
    }

    fn tables(&self, smith: SmithForm) -> Vec<TableUse> {
        let conductor = ModelId::ggx_conductor(smith);
        let use_ = HelperUse::new;
        match self {
            Kind::Conductor => vec![TableUse::new(
                conductor,
                vec![
                    use_(Helper::TurquinScale, &[]),
                    use_(Helper::KullaConty, &[]),
                ],
            )],
            // §3.4: a thin dielectric's reflection and transmission lobes share the conductor table
            Kind::ThinDielectric => vec![TableUse::new(
                conductor,
                vec![use_(
                    Helper::Normalization,
                    &[
                        "divide a thin dielectric's reflection + transmission by E",
                        "(Sforza & Pellacini 2022, §3.4 with eq. 19)",
                    ],
                )],
            )],
            Kind::Glossy => vec![
                TableUse::new(
                    ModelId::ggx_glossy(smith),
                    vec![use_(Helper::DiffuseWeight, &[])],
                ),
                TableUse::new(
                    conductor,
                    vec![use_(
                        Helper::Normalization,
                        &["the glossy specular layer ρ_ss/E_ss (eq. 18)"],
                    )],
                ),
            ],
            Kind::Dielectric => {
                let leaving = ModelId::ggx_dielectric(Side::Leaving, smith);
                let normalization = use_(
                    Helper::Normalization,
                    &[
                        "divide the single-scattering BSDF ρ_R + ρ_T by it",
                        "(Sforza & Pellacini 2022, eq. 19)",
                    ],
                );
                vec![
                    TableUse::new(
                        ModelId::ggx_dielectric(Side::Entering, smith),
                        vec![
                            normalization.clone(),
                            use_(Helper::Sided { leaving }, &[]),
                            use_(Helper::KullaContyDielectric { leaving }, &[]),
                        ],
                    ),
                    TableUse::new(leaving, vec![normalization]),
                ]
            }
            Kind::RoughDiffuse => {
                vec![TableUse::new(ModelId::new(Family::OREN_NAYAR_FON), vec![])]
            }
        }
    }

    fn compensated(
        &self,
        smith: SmithForm,
        transmission: Transmission,
    ) -> Vec<Arc<dyn CompensatedBsdf>> {
        let m = Material::new(*self, smith);
        match self {
            // the paper's 1/E, then Kulla & Conty's lobes (energy form only: in the radiance
            // form no white furnace applies to transmission)
            Kind::Dielectric => {
                let mut v: Vec<Arc<dyn CompensatedBsdf>> = vec![
                    Arc::new(m.with_transmission(transmission)),
                    Arc::new(m.leaving().with_transmission(transmission)),
                ];
                if transmission == Transmission::Energy {
                    v.push(Arc::new(KullaContyDielectric::new(Side::Entering, smith)));
                    v.push(Arc::new(KullaContyDielectric::new(Side::Leaving, smith)));
                }
                v
            }
            Kind::RoughDiffuse => vec![Arc::new(Material::new(
                Kind::RoughDiffuse,
                SmithForm::HeightCorrelated,
            ))],
            // Turquin's scale, then Kulla & Conty's lobe, white and coloured
            Kind::Conductor => vec![
                Arc::new(m),
                Arc::new(KullaConty::white(smith)),
                Arc::new(KullaConty::coloured(smith)),
            ],
            _ => vec![Arc::new(m)],
        }
    }
}

/// A built-in compensated BSDF: a kind seen from one side (dielectrics), with a Smith form and
/// a transmission convention.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Material {
    pub kind: Kind,
    /// Dielectrics: leaving sees the relative IOR 1/η; the others are entering.
    pub side: Side,
    /// Ignored by [`Kind::RoughDiffuse`].
    pub smith: SmithForm,
    /// Dielectrics only: radiance form (×1/η_rel²), as the paper's tables.
    pub transmission: Transmission,
}

impl Material {
    pub fn new(kind: Kind, smith: SmithForm) -> Material {
        Material {
            kind,
            side: Side::Entering,
            smith,
            transmission: Transmission::Energy,
        }
    }

    /// The dielectric seen from inside (relative IOR 1/η).
    pub fn leaving(self) -> Material {
        Material {
            side: Side::Leaving,
            ..self
        }
    }

    pub fn with_transmission(self, transmission: Transmission) -> Material {
        Material {
            transmission,
            ..self
        }
    }

    fn radiance(&self) -> bool {
        self.transmission == Transmission::Radiance
    }

    fn leaves(&self) -> bool {
        self.kind == Kind::Dielectric && self.side == Side::Leaving
    }

    fn suffix(&self) -> &'static str {
        match (self.kind, self.smith) {
            (Kind::RoughDiffuse, _) => "",
            (_, SmithForm::Separable) => "-separable",
            (_, SmithForm::HeightCorrelated) => "",
        }
    }

    /// The model whose albedo compensates this material (the table, LUT and fit are of it).
    pub fn albedo_model(&self) -> ModelId {
        match self.kind {
            Kind::Conductor | Kind::ThinDielectric => ModelId::ggx_conductor(self.smith),
            Kind::Glossy => ModelId::ggx_glossy(self.smith),
            Kind::Dielectric => {
                ModelId::ggx_dielectric(self.side, self.smith).with_transmission(self.transmission)
            }
            Kind::RoughDiffuse => ModelId::new(Family::OREN_NAYAR_FON),
        }
    }

    /// Whether points carry F0 as their first coordinate (the albedo model is 3-D).
    pub fn has_f0_axis(&self) -> bool {
        matches!(self.kind, Kind::Glossy | Kind::Dielectric)
    }

    /// (F0, r, μ) of a point in the albedo model's axes.
    fn coordinates(&self, x: &[f64]) -> (f64, f64, f64) {
        if self.has_f0_axis() {
            (x[0], x[1], x[2])
        } else {
            (THIN_F0, x[0], x[1])
        }
    }

    /// Relative IOR seen from ωo.
    fn eta(&self, f0: f64) -> f64 {
        let eta = eta_from_f0(f0);
        if self.leaves() {
            1.0 / eta
        } else {
            eta
        }
    }
}

impl CompensatedBsdf for Material {
    /// File-name stem ("thin-dielectric-separable").
    fn id(&self) -> String {
        let base = match self.kind {
            Kind::Dielectric if self.leaves() => "dielectric-inv",
            k => k.kind(),
        };
        let form = if self.radiance() { "-radiance" } else { "" };
        format!("{base}{}{form}", self.suffix())
    }

    /// Short human name ("thick dielectric, leaving, separable G, radiance form").
    fn label(&self) -> String {
        let base = match self.kind {
            Kind::Conductor => "conductor",
            Kind::Glossy => "glossy",
            Kind::ThinDielectric => "thin dielectric",
            Kind::Dielectric if self.leaves() => "thick dielectric, leaving",
            Kind::Dielectric => "thick dielectric, entering",
            Kind::RoughDiffuse => "rough diffuse (FON + EON lobe)",
        };
        let smith = match (self.kind, self.smith) {
            (Kind::RoughDiffuse, _) => "",
            (_, SmithForm::Separable) => ", separable G",
            (_, SmithForm::HeightCorrelated) => ", height-correlated G",
        };
        let form = if self.radiance() {
            ", radiance form"
        } else {
            ""
        };
        format!("{base}{smith}{form}")
    }

    /// The albedo model, and for glossy the conductor E_ss of the same Smith form.
    fn albedos(&self) -> Vec<ModelId> {
        let mut v = vec![self.albedo_model()];
        if self.kind == Kind::Glossy {
            v.push(ModelId::ggx_conductor(self.smith));
        }
        v
    }

    fn albedo_role(&self, k: usize) -> String {
        match k {
            0 => self.kind.kind().to_string(),
            _ => "conductor".to_string(),
        }
    }

    fn fixed_f0(&self) -> Option<f64> {
        (self.kind == Kind::ThinDielectric).then_some(THIN_F0)
    }

    /// The microfacet lobes (ρ_ss; F ρ_ss*; F ρ_ss* + (1 − F) ρ_ss* mirrored; ρ_R + ρ_T), then
    /// for glossy the white Lambert base and F(μo), for rough diffuse FON alone.
    fn lobes(&self, x: &[f64]) -> Vec<Lobe> {
        let (f0, r, mu_o) = self.coordinates(x);
        let alpha = alpha_from_r(r);
        let eta = self.eta(f0);
        let lobe = match self.kind {
            Kind::Conductor => Some(MicrofacetLobe::Conductor),
            Kind::Glossy => Some(MicrofacetLobe::Reflection { eta }),
            Kind::ThinDielectric => Some(MicrofacetLobe::Thin { eta }),
            Kind::Dielectric => Some(MicrofacetLobe::Dielectric {
                eta,
                radiance: self.radiance(),
            }),
            Kind::RoughDiffuse => None,
        };
        let mut out = Vec::new();
        if let Some(lobe) = lobe {
            if alpha == 0.0 {
                // delta BSDF: exact albedos of the smooth interface
                let f = fresnel_dielectric(mu_o, eta);
                out.push(Lobe::Exact(match lobe {
                    MicrofacetLobe::Conductor | MicrofacetLobe::Thin { .. } => 1.0,
                    MicrofacetLobe::Reflection { .. } => f,
                    MicrofacetLobe::Dielectric { radiance, .. } => {
                        f + (1.0 - f) / if radiance { eta * eta } else { 1.0 }
                    }
                }));
            } else {
                out.push(Lobe::Microfacet {
                    alpha,
                    mu_o,
                    smith: self.smith,
                    lobe,
                });
            }
        }
        match self.kind {
            Kind::Glossy => {
                out.push(Lobe::Diffuse {
                    mu_o,
                    brdf: Arc::new(|_, _, _| 1.0 / PI), // white Lambert
                });
                out.push(Lobe::Exact(fresnel_dielectric(mu_o, eta)));
            }
            Kind::RoughDiffuse => out.push(Lobe::Diffuse {
                mu_o,
                brdf: Arc::new(move |mu_i, mu_o, s| fon_brdf(r, mu_i, mu_o, s)),
            }),
            _ => {}
        }
        out
    }

    /// Rough diffuse: 1 − ⟨E⟩ of the source at each distinct r (the EON lobe is on where > 0).
    fn prepare(&self, compensation: &Compensation, points: &[Vec<f64>]) -> Prepared {
        let (Kind::RoughDiffuse, Compensation::With(albedos)) = (self.kind, compensation) else {
            return Prepared::default();
        };
        let mut rs: Vec<f64> = points.iter().map(|x| self.coordinates(x).1).collect();
        rs.sort_by(f64::total_cmp);
        rs.dedup();
        Prepared::new(
            rs.iter()
                .map(|&r| (r, 1.0 - average_albedo(albedos[0], r)))
                .collect(),
        )
    }

    fn albedo(
        &self,
        lobes: &[f64],
        x: &[f64],
        compensation: &Compensation,
        prepared: &Prepared,
    ) -> f64 {
        let guard = |e: f64| {
            if e.is_finite() {
                e.max(MIN_ALBEDO)
            } else {
                MIN_ALBEDO
            }
        };
        match (self.kind, compensation) {
            (Kind::Glossy, Compensation::None) => lobes[0] + (1.0 - lobes[2]) * lobes[1], // eq. 16
            (Kind::Glossy, Compensation::With(albedos)) => {
                let (_, r, mu) = self.coordinates(x);
                let e_ss = albedos.get(1).map_or(f64::NAN, |c| c.albedo(&[r, mu]));
                let e_spec = albedos[0].albedo(x);
                let e_spec = if e_spec.is_finite() { e_spec } else { 0.0 };
                lobes[0] / guard(e_ss) + (1.0 - e_spec) * lobes[1] // eq. 18
            }
            (Kind::RoughDiffuse, Compensation::None) => lobes[0],
            (Kind::RoughDiffuse, Compensation::With(albedos)) => {
                let (_, r, _) = self.coordinates(x);
                let e = albedos[0].albedo(x);
                let e = if e.is_finite() { e } else { 1.0 };
                // Kulla–Conty lobe (EON eq. 19): integrates to 1 − E(μo) when 1 − ⟨E⟩ > 0
                let on = prepared.get(r).is_some_and(|v| v > 0.0);
                lobes[0] + if on { 1.0 - e } else { 0.0 }
            }
            (_, Compensation::None) => lobes[0],
            (_, Compensation::With(albedos)) => lobes[0] / guard(albedos[0].albedo(x)), // eqs. 7, 13, 19
        }
    }
}
