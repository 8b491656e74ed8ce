//! Kulla–Conty compensation of the GGX conductor, for the white furnace test (Kulla & Conty 2017,
//! "Revisiting Physically Based Shading at Imageworks"; Kelemen & Szirmay-Kalos 2001; the
//! derivation as in "Energy Compensation Pt. 1"): the single-scattering BRDF plus the lobe
//!
//!   f_ms(ωo, ωi) = F_ms (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)),
//!   F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)),
//!
//! the helpers `furnace emit` writes next to the conductor's albedo ([`crate::emit::helpers`]).
//!
//! What the test integrates, and how independently: the single-scattering lobe over ωi by the
//! material quadrature ([`super::microfacet`]); the f_ms lobe over ωi as 2∫(1 − E(μi)) μi dμi of
//! the albedo *source* under test (table, LUT or fit), by adaptive Gauss–Kronrod
//! ([`super::furnace::average_albedo`]); and E_avg = 2∫E μ dμ of the same source, as a renderer
//! computes its E_avg table from its E table. The lobe then restores exactly 1 − E(μo) of the
//! source, and |1 − E| of the white conductor measures how far the source's E(μo) is from the
//! single scattering the quadrature integrates: ≤ 1e-9 with the exact table at its nodes (a
//! bilinear table between them carries its interpolation error, in E and in E_avg alike).
//! Furnace's own E_avg ([`KullaConty::e_avg`], the `-avg` model of [`crate::bsdf::average`]) is
//! what the exact source's average is checked against.
//!
//! Coloured F0 (the Fresnel of a dielectric of that F0 on every microfacet, as the glossy
//! layer's): the compensated albedo is no longer 1; the lobe times F_ms must restore
//! F_ms (1 − E(μo)) on top of the single scattering E_ss(μo). The coloured row's value is the
//! compensated albedo over what exact quantities give, E_ss(μo) + F_ms (1 − E(μo)) with E_ss
//! and the white E(μo) integrated by the material quadrature and F_ms from the engine's E_avg,
//! so |1 − value| measures the source's E(μo) and its E_avg (through F_ms) together. (How well F_ms models a coloured conductor's true multiple scattering — Kulla & Conty's
//! assumption that each bounce scales the energy by F_avg — is not what this measures.)

use super::furnace::average_albedo;
use super::{CompensatedBsdf, Compensation, Lobe, MicrofacetLobe, Prepared};
use crate::bsdf::{self, ModelId};
use crate::math::{alpha_from_r, eta_from_f0, SmithForm};
use crate::quadrature::{QuadratureSettings, RuleCache};

/// Below this 1 − E_avg the lobe is off, as in the emitted helper
/// ([`crate::emit::helpers::KULLA_CONTY_FLOOR`]).
pub const FLOOR: f64 = 1e-6;

/// F0 of the coloured row (a channel of a coloured conductor: gold's green, about 0.5).
pub const COLOURED_F0: f64 = 0.5;

/// The GGX conductor compensated with Kulla & Conty's lobe, white (F0 = 1) or with the
/// dielectric Fresnel of `f0` on every microfacet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KullaConty {
    pub smith: SmithForm,
    /// 1 for the white conductor.
    pub f0: f64,
}

impl KullaConty {
    pub fn white(smith: SmithForm) -> KullaConty {
        KullaConty { smith, f0: 1.0 }
    }

    pub fn coloured(smith: SmithForm) -> KullaConty {
        KullaConty {
            smith,
            f0: COLOURED_F0,
        }
    }

    fn white_f(&self) -> bool {
        self.f0 >= 1.0
    }

    fn model(&self) -> ModelId {
        ModelId::ggx_conductor(self.smith)
    }

    /// F_avg = 2∫F μ dμ of the microfacets' Fresnel: 1 for the white conductor, else furnace's
    /// `fresnel-dielectric` model at `f0` ([`crate::bsdf::fresnel`]).
    pub fn f_avg(&self) -> f64 {
        if self.white_f() {
            return 1.0;
        }
        let settings = QuadratureSettings::default();
        let cache = RuleCache::new(&settings);
        let model = bsdf::lookup("fresnel-dielectric")
            .and_then(bsdf::get)
            .expect("fresnel-dielectric is a built-in model");
        bsdf::albedo(model.as_ref(), &[self.f0], &settings, &cache).value[0]
    }

    /// E_avg(r) of furnace's `-avg` model of the conductor, by the engine's quadrature.
    pub fn e_avg(&self, rs: &[f64]) -> Vec<f64> {
        let settings = QuadratureSettings::default();
        let cache = RuleCache::new(&settings);
        let model = bsdf::get(self.model().averaged()).expect("every GGX conductor has an average");
        rs.iter()
            .map(|&r| bsdf::albedo(model.as_ref(), &[r], &settings, &cache).value[0])
            .collect()
    }
}

/// F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)) (Kulla & Conty 2017).
pub fn f_ms(f_avg: f64, e_avg: f64) -> f64 {
    f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg)).max(super::builtin::MIN_ALBEDO)
}

impl CompensatedBsdf for KullaConty {
    fn id(&self) -> String {
        let smith = match self.smith {
            SmithForm::Separable => "-separable",
            SmithForm::HeightCorrelated => "",
        };
        if self.white_f() {
            format!("conductor-kulla-conty{smith}")
        } else {
            format!("conductor-kulla-conty-f0-{}{smith}", self.f0)
        }
    }

    fn label(&self) -> String {
        let smith = match self.smith {
            SmithForm::Separable => "separable G",
            SmithForm::HeightCorrelated => "height-correlated G",
        };
        if self.white_f() {
            format!("conductor + Kulla–Conty lobe, {smith}")
        } else {
            format!(
                "conductor + Kulla–Conty lobe, F0 = {} (value: E / (E_ss + F_ms (1 − E))), {smith}",
                self.f0
            )
        }
    }

    fn albedos(&self) -> Vec<ModelId> {
        vec![self.model()]
    }

    fn albedo_role(&self, _k: usize) -> String {
        "conductor".into()
    }

    fn fixed_f0(&self) -> Option<f64> {
        Some(self.f0)
    }

    /// The single-scattering lobe (F = 1, or the dielectric Fresnel of F0), exact at α = 0; for
    /// a coloured F0 also the white one (F = 1), the exact E(μo) the coloured value is set
    /// against.
    fn lobes(&self, x: &[f64]) -> Vec<Lobe> {
        let (r, mu_o) = (x[0], x[1]);
        let alpha = alpha_from_r(r);
        let lobe = if self.white_f() {
            MicrofacetLobe::Conductor
        } else {
            MicrofacetLobe::Reflection {
                eta: eta_from_f0(self.f0),
            }
        };
        if alpha == 0.0 {
            let f = if self.white_f() {
                1.0
            } else {
                crate::math::fresnel_dielectric(mu_o, eta_from_f0(self.f0))
            };
            return if self.white_f() {
                vec![Lobe::Exact(f)]
            } else {
                vec![Lobe::Exact(f), Lobe::Exact(1.0)]
            };
        }
        let mut out = vec![Lobe::Microfacet {
            alpha,
            mu_o,
            smith: self.smith,
            lobe,
        }];
        if !self.white_f() {
            out.push(Lobe::Microfacet {
                alpha,
                mu_o,
                smith: self.smith,
                lobe: MicrofacetLobe::Conductor,
            });
        }
        out
    }

    /// Per distinct r, with E_avg = 2∫E_src μ dμ of the source: F_ms · 2∫(1 − E_src) μ dμ /
    /// (1 − E_avg), 0 where 1 − E_avg < [`FLOOR`] (the lobe off); and for a coloured F0, under
    /// key −1 − r, F_ms of the engine's E_avg (for the exact prediction).
    fn prepare(&self, compensation: &Compensation, points: &[Vec<f64>]) -> Prepared {
        let Compensation::With(albedos) = compensation else {
            return Prepared::default();
        };
        let mut rs: Vec<f64> = points.iter().map(|x| x[0]).collect();
        rs.sort_by(f64::total_cmp);
        rs.dedup();
        let f_avg = self.f_avg();
        let exact_e_avg = if self.white_f() {
            vec![1.0; rs.len()]
        } else {
            self.e_avg(&rs)
        };
        let mut values = Vec::with_capacity(2 * rs.len());
        for (&r, &exact_e_avg) in rs.iter().zip(&exact_e_avg) {
            let e_avg = average_albedo(albedos[0], r); // 2∫E(μ) μ dμ of the source
            let fms = f_ms(f_avg, e_avg);
            let lost = 1.0 - e_avg; // 2∫(1 − E(μi)) μi dμi
            let lobe = if 1.0 - e_avg >= FLOOR {
                fms * lost / (1.0 - e_avg)
            } else {
                0.0
            };
            values.push((r, lobe));
            values.push((-1.0 - r, f_ms(f_avg, exact_e_avg)));
        }
        Prepared::new(values)
    }

    fn albedo(
        &self,
        lobes: &[f64],
        x: &[f64],
        compensation: &Compensation,
        prepared: &Prepared,
    ) -> f64 {
        let Compensation::With(albedos) = compensation else {
            return lobes[0];
        };
        let r = x[0];
        let e = albedos[0].albedo(x);
        let e = if e.is_finite() { e } else { 1.0 };
        let lobe = prepared.get(r).unwrap_or(0.0);
        let total = lobes[0] + (1.0 - e) * lobe; // ∫ f_ss + ∫ F_ms f_ms (Kulla & Conty 2017)
        if self.white_f() {
            return total;
        }
        let fms = prepared.get(-1.0 - r).unwrap_or(0.0);
        let predicted = lobes[0] + fms * (1.0 - lobes[1]);
        total / predicted.max(super::builtin::MIN_ALBEDO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at};
    use crate::material::Albedo;

    /// The exact table: E of the conductor model by the engine's quadrature at any point.
    struct Exact {
        model: std::sync::Arc<dyn bsdf::Model>,
        settings: QuadratureSettings,
        cache: RuleCache,
    }

    impl Exact {
        fn new(smith: SmithForm) -> Exact {
            let settings = QuadratureSettings::default();
            Exact {
                model: bsdf::get(ModelId::ggx_conductor(smith)).unwrap(),
                cache: RuleCache::new(&settings),
                settings,
            }
        }
    }

    impl Albedo for Exact {
        fn albedo(&self, x: &[f64]) -> f64 {
            let x = [x[0].clamp(0.0, 1.0), x[1].clamp(0.0, 1.0)];
            bsdf::albedo(self.model.as_ref(), &x, &self.settings, &self.cache).value[0]
        }
        fn dim(&self) -> usize {
            2
        }
    }

    fn points() -> Vec<Vec<f64>> {
        let mut v = Vec::new();
        for r in [0.0, 0.25, 0.5, 0.75, 1.0] {
            for mu in [0.0, 0.01, 0.1, 0.37, 0.8, 1.0] {
                v.push(vec![r, mu]);
            }
        }
        v
    }

    /// Kulla–Conty with exact E and E_avg keeps a white conductor's energy: |1 − E| ≤ 1e-6 at
    /// every point, grazing and r = 1 included, while the uncompensated conductor loses up to
    /// 1 − E(1, 0) ≈ 0.69.
    #[test]
    fn the_white_conductor_keeps_its_energy_with_exact_tables() {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            let m = KullaConty::white(smith);
            let pts = points();
            let lobes = lobe_integrals_at(&m, &pts);
            let exact = Exact::new(smith);
            let with = furnace_stats(
                &pts,
                &furnace_values(&m, &pts, &lobes, &Compensation::With(vec![&exact])),
            );
            let none = furnace_stats(&pts, &furnace_values(&m, &pts, &lobes, &Compensation::None));
            eprintln!(
                "{}: Kulla–Conty max |1 − E| {:.2e} at {:?}; uncompensated {:.2e}",
                m.label(),
                with.max_deviation,
                with.at,
                none.max_deviation
            );
            assert!(with.max_deviation <= 1e-6, "{with:?}");
            assert!(none.max_deviation > 0.5, "{none:?}");
        }
    }

    /// The exact source's E_avg, 2∫E μ dμ by adaptive Gauss–Kronrod over the engine's E, is the
    /// engine's `-avg` model to 1e-8.
    #[test]
    fn the_exact_average_is_the_engines_e_avg() {
        let m = KullaConty::white(SmithForm::HeightCorrelated);
        let exact = Exact::new(SmithForm::HeightCorrelated);
        let rs = [0.1, 0.5, 1.0];
        for (&r, e_avg) in rs.iter().zip(m.e_avg(&rs)) {
            let avg = average_albedo(&exact, r);
            assert!((avg - e_avg).abs() <= 1e-8, "r = {r}: {avg} vs {e_avg}");
        }
    }

    /// The colour factor: F_ms = 1 for a white conductor (every bounce reflects all), 0 for a
    /// black one, and the sum of the bounces F_avg^k E_avg (1 − E_avg)^(k−1), k ≥ 2, otherwise.
    #[test]
    fn f_ms_is_the_sum_of_the_bounces() {
        for e_avg in [0.3, 0.7, 0.95, 1.0] {
            assert!((f_ms(1.0, e_avg) - 1.0).abs() < 1e-15);
            assert_eq!(f_ms(0.0, e_avg), 0.0);
            for f in [0.2, 0.5, 0.9] {
                let series: f64 = (2..400)
                    .map(|k| f64::powi(f, k) * e_avg * (1.0 - e_avg).powi(k - 2))
                    .sum();
                // the lobe restores 1 − E_avg on average, so F_ms (1 − E_avg) is bounces ≥ 2
                assert!(
                    (f_ms(f, e_avg) * (1.0 - e_avg) - series * (1.0 - e_avg)).abs() < 1e-12,
                    "F_avg {f}, E_avg {e_avg}"
                );
            }
        }
    }

    /// A coloured conductor's lobe restores F_ms (1 − E(μo)) with exact tables: its compensated
    /// albedo over E_ss + F_ms (1 − E) is 1 to 1e-6.
    #[test]
    fn the_coloured_lobe_restores_f_ms_times_the_lost_energy() {
        let m = KullaConty::coloured(SmithForm::HeightCorrelated);
        let pts = points();
        let lobes = lobe_integrals_at(&m, &pts);
        let exact = Exact::new(SmithForm::HeightCorrelated);
        let v = furnace_values(&m, &pts, &lobes, &Compensation::With(vec![&exact]));
        let s = furnace_stats(&pts, &v);
        eprintln!(
            "{}: max |1 − value| {:.2e} at {:?}",
            m.label(),
            s.max_deviation,
            s.at
        );
        assert!(v.iter().all(|e| e.is_finite() && *e > 0.0));
        assert!(s.max_deviation <= 1e-6, "{s:?}");
        let f_avg = m.f_avg();
        // Kulla & Conty 2017's fit F_avg ≈ (η − 1)/(4.08567 + 1.00071 η), 1 < η < 400
        let eta = eta_from_f0(COLOURED_F0);
        let fit = (eta - 1.0) / (4.08567 + 1.00071 * eta);
        assert!(
            (f_avg - fit).abs() < 2e-3,
            "F_avg {f_avg}, Kulla & Conty's fit {fit}"
        );
    }
}
