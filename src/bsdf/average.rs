//! The cosine-weighted average of a model's albedo over the outgoing direction,
//! E_avg = 2∫₀¹ E(μ) μ dμ (Kulla & Conty 2017, "Revisiting Physically Based Shading at
//! Imageworks", eq. for E_avg; Kelemen & Szirmay-Kalos 2001, eq. 4), as a model of its own: the
//! base model's axes without `mu`, the base model's outputs, each averaged.
//!
//! # The integral
//! The μ integral is a Gauss–Legendre rule on panels between the base model's breakpoints in μ
//! ([`Model::mu_breaks`]: the grazing boundary layer of width ~α of a GGX model, the critical
//! angle of a dielectric seen from inside), and E at each node is the base model integrated
//! with the *same* rules. Both rules therefore refine together: the estimate |Q(order) −
//! Q(companion)| of an average covers the error of the μ rule and of every E it sums, and
//! refinement raises both until it meets the tolerance. Nothing is read from a table.
//!
//! Every registered model whose `mu` axis spans [0, 1] has its average registered beside it
//! (see [`super::register`]); its identity is the base's with [`ModelId::average`] set, its
//! name the base's with `-avg`.

use super::{AxisSpec, Model, ModelId, MAX_OUTPUTS};
use crate::quadrature::{panels_from_breaks, Break, Panel, Rules};
use std::sync::Arc;

/// The name of the axis an average integrates out.
pub const MU_AXIS: &str = "mu";

/// The loosest tolerance an average is refined to, whatever looser one is asked for. E_avg
/// enters the Kulla–Conty lobe as 1/(1 − E_avg), which amplifies its error where E_avg → 1
/// (r → 0), and its estimate |Q(order) − Q(companion)| sums the μ rule's and every E's: at the
/// engine's default 1e-7 the leaving dielectric's average is 1.3e-8 from an independent
/// integration (F0 = 0.04, r = 0.5), at 1e-10 within 1e-9 everywhere tested
/// (`averages_match_an_independent_integration_to_1e_9`).
pub const AVERAGE_TOLERANCE: f64 = 1e-9;

/// E_avg of `base`: see the module documentation.
pub struct AverageAlbedo {
    base: Arc<dyn Model>,
    /// Position of `mu` among the base's axes.
    mu_index: usize,
}

impl AverageAlbedo {
    /// The average of `base`, if it has a `mu` axis whose valid range is [0, 1] and at least one
    /// other axis (an average over the only axis would be a number, not a table), and no
    /// azimuth axis `phi` (its hemispherical average would integrate over φ as well).
    pub fn new(base: Arc<dyn Model>) -> Option<AverageAlbedo> {
        let axes = base.axes();
        let mu_index = axes.iter().position(|a| a.name == MU_AXIS)?;
        if axes[mu_index].valid_range != (0.0, 1.0)
            || axes.len() < 2
            || base.id().average
            || axes.iter().any(|a| a.name == "phi")
        {
            return None;
        }
        Some(AverageAlbedo { base, mu_index })
    }

    /// The model averaged.
    pub fn base(&self) -> &Arc<dyn Model> {
        &self.base
    }

    /// `x` (this model's coordinates) with μ inserted: the base model's coordinates.
    fn base_point(&self, x: &[f64], mu: f64) -> Vec<f64> {
        let mut p = Vec::with_capacity(x.len() + 1);
        p.extend_from_slice(&x[..self.mu_index]);
        p.push(mu);
        p.extend_from_slice(&x[self.mu_index..]);
        p
    }

    /// The μ panels at `x`, from the base model's breakpoints.
    fn mu_panels(&self, x: &[f64]) -> Vec<Panel> {
        let mut breaks = vec![];
        self.base.mu_breaks(&self.base_point(x, 0.0), &mut breaks);
        breaks.retain(|b| (0.0..=1.0).contains(&b.x));
        if !breaks.iter().any(|b| b.x == 0.0) {
            breaks.push(Break::sqrt(0.0));
        }
        if !breaks.iter().any(|b| b.x == 1.0) {
            breaks.push(Break::sqrt(1.0));
        }
        let mut panels = Vec::with_capacity(2 * breaks.len());
        panels_from_breaks(&mut breaks, &mut panels);
        panels
    }

    /// The μ nodes at `x` and their weights 2μ·w (the cosine weight of the average included).
    fn mu_nodes(&self, x: &[f64], rules: &Rules) -> (Vec<f64>, Vec<f64>) {
        let (mut mus, mut ws) = (Vec::with_capacity(64), Vec::with_capacity(64));
        for p in self.mu_panels(x) {
            rules.inner.nodes_into(&p, &mut mus, &mut ws);
        }
        for (w, &mu) in ws.iter_mut().zip(&mus) {
            *w *= 2.0 * mu; // E_avg = 2∫ E μ dμ (Kulla & Conty 2017)
        }
        (mus, ws)
    }
}

impl Model for AverageAlbedo {
    fn id(&self) -> ModelId {
        self.base.id().averaged()
    }

    fn integrator_revision(&self) -> u32 {
        self.base.integrator_revision()
    }

    fn summary(&self) -> String {
        format!(
            "cosine-weighted average over μ of {}: E_avg = 2∫₀¹ E(μ) μ dμ of each output (Kulla & Conty 2017)",
            self.base.id().key()
        )
    }

    fn axes(&self) -> Vec<AxisSpec> {
        let mut axes = self.base.axes();
        axes.remove(self.mu_index);
        axes
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.base.outputs()
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        let (mus, ws) = self.mu_nodes(x, rules);
        let mut acc = [0.0; MAX_OUTPUTS];
        let mut p = self.base_point(x, 0.0);
        for (&mu, &w) in mus.iter().zip(&ws) {
            p[self.mu_index] = mu;
            let e = self.base.integrate(&p, rules);
            for (a, v) in acc.iter_mut().zip(e) {
                *a += w * v;
            }
        }
        acc
    }

    fn parameters(&self) -> serde_json::Value {
        serde_json::json!({
            "base": self.base.parameters(),
            "tolerance_at_most": AVERAGE_TOLERANCE,
        })
    }

    fn tolerance(&self, requested: f64) -> f64 {
        requested.min(AVERAGE_TOLERANCE)
    }

    /// The base model's column sharing carries over when its μ breakpoints do not depend on
    /// the first axis either (checked on the column; otherwise point by point).
    fn shares_column_geometry(&self) -> bool {
        self.base.shares_column_geometry() && self.mu_index > 0
    }

    fn integrate_column(&self, xs: &[Vec<f64>], rules: &Rules, out: &mut [[f64; MAX_OUTPUTS]]) {
        let Some(first) = xs.first() else { return };
        let (mus, ws) = self.mu_nodes(first, rules);
        let same_nodes = self.shares_column_geometry()
            && xs[1..]
                .iter()
                .all(|x| self.mu_panels(x) == self.mu_panels(first));
        if !same_nodes {
            for (x, o) in xs.iter().zip(out.iter_mut()) {
                *o = self.integrate(x, rules);
            }
            return;
        }
        out.iter_mut().for_each(|o| *o = [0.0; MAX_OUTPUTS]);
        let mut column: Vec<Vec<f64>> = xs.iter().map(|x| self.base_point(x, 0.0)).collect();
        let mut values = vec![[0.0; MAX_OUTPUTS]; xs.len()];
        for (&mu, &w) in mus.iter().zip(&ws) {
            column.iter_mut().for_each(|p| p[self.mu_index] = mu);
            self.base.integrate_column(&column, rules, &mut values);
            for (o, v) in out.iter_mut().zip(&values) {
                for (a, e) in o.iter_mut().zip(v) {
                    *a += w * e;
                }
            }
        }
    }

    fn grazing_boundary_layer(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::diffuse::{fon_average_albedo, qon_average_albedo};
    use crate::quadrature::{QuadratureSettings, RuleCache};

    fn average_of(name: &str) -> AverageAlbedo {
        AverageAlbedo::new(crate::bsdf::find(name).unwrap()).unwrap()
    }

    /// A model with an azimuth axis has no μ-only average: neither a model nor a registry name.
    #[test]
    fn models_with_an_azimuth_are_not_averaged() {
        for name in ["ggx-conductor-aniso", "ggx-conductor-aniso-separable"] {
            assert!(AverageAlbedo::new(crate::bsdf::find(name).unwrap()).is_none());
            assert!(crate::bsdf::find(&format!("{name}-avg")).is_err());
        }
        assert!(AverageAlbedo::new(crate::bsdf::find("ggx-conductor").unwrap()).is_some());
    }

    /// The rough-diffuse averages against their closed forms (EON paper, eqs. 9 and 15).
    #[test]
    fn diffuse_averages_match_the_eon_paper() {
        let settings = QuadratureSettings {
            tolerance: 1e-11,
            ..QuadratureSettings::with_order(16)
        };
        let cache = RuleCache::new(&settings);
        for (name, exact) in [
            ("oren-nayar-qon", qon_average_albedo as fn(f64) -> f64),
            ("oren-nayar-fon", fon_average_albedo),
        ] {
            let m = average_of(name);
            for r in [0.0, 0.13, 0.5, 0.77, 1.0] {
                let e = crate::bsdf::albedo(&m, &[r], &settings, &cache);
                assert!(
                    (e.value[0] - exact(r)).abs() < 1e-10,
                    "{name} r = {r}: {} vs {}",
                    e.value[0],
                    exact(r)
                );
            }
        }
    }

    #[test]
    fn averages_drop_the_mu_axis_and_keep_the_outputs() {
        let m = average_of("ggx-dielectric-inv");
        assert_eq!(m.id().name(), "ggx-dielectric-inv-avg");
        let axes: Vec<String> = m.axes().into_iter().map(|a| a.name).collect();
        assert_eq!(axes, ["f0", "r"]);
        assert_eq!(m.outputs(), ["E", "E_R", "E_T"]);
        assert!(
            AverageAlbedo::new(Arc::new(m)).is_none(),
            "no average of an average"
        );
    }

    /// At r = 0 the conductor's E is 1 for every μ, so E_avg = 1; a smooth dielectric has
    /// E_R = F(μ), so its average E_R is the Fresnel average F_avg of either side.
    #[test]
    fn smooth_surface_averages() {
        let settings = QuadratureSettings {
            tolerance: 1e-12,
            ..QuadratureSettings::default()
        };
        let cache = RuleCache::new(&settings);
        let e = crate::bsdf::albedo(&average_of("ggx-conductor"), &[0.0], &settings, &cache);
        assert!((e.value[0] - 1.0).abs() < 1e-14, "{}", e.value[0]);
        let d = crate::bsdf::albedo(
            &average_of("ggx-dielectric"),
            &[0.04, 0.0],
            &settings,
            &cache,
        );
        assert!((d.value[0] - 1.0).abs() < 1e-12, "{}", d.value[0]);
        for (name, fresnel) in [
            ("ggx-dielectric", "fresnel-dielectric"),
            ("ggx-dielectric-inv", "fresnel-dielectric-inv"),
        ] {
            let d = crate::bsdf::albedo(&average_of(name), &[0.04, 0.0], &settings, &cache);
            let f = crate::bsdf::find(fresnel).unwrap();
            let f = crate::bsdf::albedo(f.as_ref(), &[0.04], &settings, &cache);
            assert!(
                (d.value[1] - f.value[0]).abs() < 1e-12,
                "{name}: {} vs {}",
                d.value[1],
                f.value[0]
            );
        }
    }

    /// E_avg against an independent integration of E over μ: adaptive Gauss–Kronrod
    /// (`material::quad`, not the engine's rules) of 2 E(μ) μ with the critical angle as an
    /// interval end, E by the engine at tolerance 1e-12, against the `-avg` model at the
    /// engine's default settings: within 1e-9 (the leaving dielectric's average, which the
    /// furnace test's plain [0, 1] rule misses by 1.6e-9 without that break, is the hardest).
    #[test]
    fn averages_match_an_independent_integration_to_1e_9() {
        use crate::material::quad::{integrate, Tolerance};
        let tight = QuadratureSettings {
            tolerance: 1e-12,
            ..QuadratureSettings::default()
        };
        let avg_settings = QuadratureSettings::default();
        let (c1, c2) = (RuleCache::new(&tight), RuleCache::new(&avg_settings));
        for (name, lead) in [
            ("ggx-conductor", vec![0.5]),
            ("ggx-conductor", vec![0.07]),
            ("ggx-conductor-separable", vec![0.93]),
            ("ggx-dielectric", vec![0.04, 0.5]),
            ("ggx-dielectric", vec![0.21, 0.13]),
            ("ggx-dielectric-inv", vec![0.04, 0.5]),
            ("ggx-dielectric-inv", vec![0.0125, 0.9]),
            ("ggx-dielectric-inv-separable", vec![0.25, 0.07]),
        ] {
            let base = crate::bsdf::find(name).unwrap();
            let avg = average_of(name);
            let mut breaks = vec![0.0, 1.0];
            if name.ends_with("-inv") {
                let eta = crate::math::eta_from_f0(lead[0]);
                breaks.insert(1, (1.0 - 1.0 / (eta * eta)).sqrt()); // critical angle
            }
            let independent = integrate(
                |mu: f64| {
                    let mut x = lead.clone();
                    x.push(mu);
                    2.0 * crate::bsdf::albedo(base.as_ref(), &x, &tight, &c1).value[0] * mu
                },
                &breaks,
                &Tolerance {
                    abs: 1e-12,
                    rel: 0.0,
                    max_intervals: 2000,
                },
            );
            let estimate = crate::bsdf::albedo(&avg, &lead, &avg_settings, &c2);
            assert!(
                estimate.converged && estimate.error <= AVERAGE_TOLERANCE,
                "{name}"
            );
            let engine = estimate.value[0];
            eprintln!(
                "{name} at {lead:?}: E_avg {engine:.13}, independent {:.13}, |diff| {:.1e}",
                independent.value,
                (engine - independent.value).abs()
            );
            assert!(independent.converged);
            assert!((engine - independent.value).abs() <= 1e-9, "{name}");
        }
    }
}
