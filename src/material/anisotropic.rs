//! The anisotropic conductor: a GGX conductor with different roughnesses along the tangent and
//! the bitangent (OpenPBR's r and aniso, docs/anisotropy.md), compensated with Turquin's scale
//! 1 + F0·(1 − E)/E (Sforza & Pellacini 2022, eq. 13, after Turquin 2019) where E is the 4-D
//! albedo E(r, aniso, μ, φ) of `ggx-conductor-aniso`: the energy an anisotropic lobe loses
//! depends on the azimuth φ of ωo as well as on μ, so the isotropic table cannot supply it.
//!
//! Its emitted helpers take the view direction in the tangent frame and form μ and the reduced
//! azimuth themselves ([`Helper::TangentFrameTurquin`]).
//!
//! # The white furnace test
//! At F0 = 1 the compensated BRDF is ρ_ss/E, whose albedo is E_exact(ωo)/E_source(ωo). The lobe
//! integral E_exact is [`Lobe::Model`]: the model's slope-space integrand at fixed orders, not
//! this module's own adaptive rule, which does not resolve the narrow stretched lobe at low
//! roughness; the engine's integrand agrees with an independent visible-normal one to 1e-9
//! (`cargo test --release --lib ggx_aniso`), and at a fixed order it is not the table's refined
//! estimate, so the exact-table furnace still measures the table.

use super::builtin::MIN_ALBEDO;
use super::{
    CompensatedBsdf, Compensation, Helper, HelperUse, Lobe, MaterialClass, Prepared, TableUse,
};
use crate::bsdf::{Family, ModelId, Transmission};
use crate::math::SmithForm;
use std::sync::Arc;

/// Orders of the lobe integral (the value at the larger, the error estimate their difference):
/// at 24 the slope-space integrand is within 1e-9 of order 48 at the off-grid points of the
/// model's tests.
pub const LOBE_ORDERS: [usize; 2] = [16, 24];

/// The `anisotropic-conductor` material class.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AnisotropicConductor;

/// The albedo model of an anisotropic conductor of Smith form `smith`.
pub fn albedo_model(smith: SmithForm) -> ModelId {
    ModelId::new(Family::GGX_CONDUCTOR_ANISO).with_smith(smith)
}

impl MaterialClass for AnisotropicConductor {
    fn kind(&self) -> &'static str {
        "anisotropic-conductor"
    }

    fn summary(&self) -> String {
        "anisotropic GGX conductor (OpenPBR r, aniso); Turquin's scale 1 + F0(1 − E)/E from the 4-D E(r, aniso, μ, φ) at the view direction in the tangent frame (paper eq. 13)".into()
    }

    fn noun(&self) -> String {
        "anisotropic conductor".into()
    }

    fn r_is_not_alpha(&self) -> Option<&'static str> {
        Some("OpenPBR's roughness, α_t = r²·√(2/(1 + (1 − aniso)²)), α_b = (1 − aniso)·α_t")
    }

    fn tables(&self, smith: SmithForm) -> Vec<TableUse> {
        vec![TableUse::new(
            albedo_model(smith),
            vec![HelperUse::new(Helper::TangentFrameTurquin, &[])],
        )]
    }

    fn compensated(
        &self,
        smith: SmithForm,
        _transmission: Transmission,
    ) -> Vec<Arc<dyn CompensatedBsdf>> {
        vec![Arc::new(Compensated { smith })]
    }
}

/// The white (F0 = 1) anisotropic conductor compensated by 1/E: ρ_ss/E (paper eqs. 7, 13).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Compensated {
    pub smith: SmithForm,
}

impl CompensatedBsdf for Compensated {
    fn id(&self) -> String {
        match self.smith {
            SmithForm::HeightCorrelated => "anisotropic-conductor".into(),
            SmithForm::Separable => "anisotropic-conductor-separable".into(),
        }
    }

    fn label(&self) -> String {
        match self.smith {
            SmithForm::HeightCorrelated => "anisotropic conductor, height-correlated G".into(),
            SmithForm::Separable => "anisotropic conductor, separable G".into(),
        }
    }

    fn albedos(&self) -> Vec<ModelId> {
        vec![albedo_model(self.smith)]
    }

    fn albedo_role(&self, _k: usize) -> String {
        "anisotropic conductor".into()
    }

    /// ρ_ss at (r, aniso, μ, φ); a smooth mirror (r = 0) reflects everything.
    fn lobes(&self, x: &[f64]) -> Vec<Lobe> {
        if x[0] == 0.0 {
            return vec![Lobe::Exact(1.0)];
        }
        vec![Lobe::Model {
            model: albedo_model(self.smith),
            x: x.to_vec(),
            orders: LOBE_ORDERS.to_vec(),
        }]
    }

    fn albedo(
        &self,
        lobes: &[f64],
        x: &[f64],
        compensation: &Compensation,
        _prepared: &Prepared,
    ) -> f64 {
        match compensation {
            Compensation::None => lobes[0],
            Compensation::With(albedos) => {
                let e = albedos[0].albedo(x);
                let e = if e.is_finite() {
                    e.max(MIN_ALBEDO)
                } else {
                    MIN_ALBEDO
                };
                lobes[0] / e // paper eqs. 7, 13 at F0 = 1
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::furnace::lobe_integrals;
    use crate::material::Albedo;

    /// E by the model's refined estimate (what a table stores).
    struct Estimate(ModelId);
    impl Albedo for Estimate {
        fn albedo(&self, x: &[f64]) -> f64 {
            let model = crate::bsdf::get(self.0).unwrap();
            let settings = crate::quadrature::QuadratureSettings::default();
            let cache = crate::quadrature::RuleCache::new(&settings);
            crate::bsdf::albedo(model.as_ref(), x, &settings, &cache).value[0]
        }
        fn dim(&self) -> usize {
            4
        }
    }

    #[test]
    fn compensated_with_the_exact_albedo_passes_the_furnace_test_and_loses_energy_without() {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            let m = Compensated { smith };
            let exact = Estimate(albedo_model(smith));
            for x in [
                [0.83, 0.71, 0.27, 1.31],
                [0.45, 0.3, 0.9, 0.2],
                [0.0, 0.5, 0.5, 0.5],
            ] {
                let l = lobe_integrals(&m, &x);
                assert!(l.converged && l.error < 1e-8, "{x:?}: {l:?}");
                let none = m.albedo(&l.values, &x, &Compensation::None, &Prepared::default());
                let with = m.albedo(
                    &l.values,
                    &x,
                    &Compensation::With(vec![&exact]),
                    &Prepared::default(),
                );
                assert!((with - 1.0).abs() < 1e-7, "{smith:?} {x:?}: {with}");
                if x[0] > 0.5 {
                    assert!(
                        none < 0.9,
                        "{smith:?} {x:?}: rough lobes lose energy: {none}"
                    );
                }
            }
        }
    }
}
