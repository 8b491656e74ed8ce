//! The anisotropic GGX white conductor, E(r, aniso, μ, φ), in OpenPBR's parametrisation.
//!
//! # Axes
//! * `r` and `aniso`: α_t = r²·√(2/(1 + (1 − aniso)²)) along the tangent, α_b = (1 − aniso)·α_t
//!   along the bitangent (OpenPBR Surface, "Microfacet model"; [`anisotropic_alphas`]), so
//!   aniso = 0 is the isotropic `ggx-conductor` at α = r², and α_t² + α_b² = 2r⁴.
//! * `mu` = cos θo and `phi`, the azimuth of ωo measured from the tangent:
//!   ωo = (sin θo cos φ, sin θo sin φ, μo) in the frame (t, b, n).
//!
//! # Symmetries of φ
//! D and Smith's Λ depend on the tangential components only through their squares, so the mirror
//! images b → −b and t → −t map the BSDF to itself: E(φ) = E(−φ) = E(π − φ). Hence E has period
//! π, is even about 0 and π/2, and [0, π/2] covers every azimuth; the table spans it. Swapping the
//! two roughnesses turns the frame by π/2: E(α_x, α_y, φ) = E(α_y, α_x, φ + π/2). At μ = 1 the
//! azimuth is undefined and E does not depend on it.
//!
//! # Other renderers' anisotropy
//! docs/anisotropy.md gives the conversions of Blender's and Disney's parameters to (r, aniso)
//! and the direction φ is measured from; [`openpbr_roughness`] inverts any (α_t, α_b).
//!
//! [`anisotropic_alphas`]: crate::math::anisotropic_alphas
//! [`openpbr_roughness`]: crate::math::openpbr_roughness

use super::slope_aniso::AnisoSlopeIntegrand;
use super::{AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use crate::math::{anisotropic_alphas, SmithForm};
use crate::quadrature::{integrate_2d, Rules};
use std::f64::consts::{FRAC_PI_2, PI};

/// Largest `aniso` accepted: at 1 the bitangent roughness vanishes (a one-dimensional
/// distribution of grooves, which no quadrature here resolves).
pub const ANISO_MAX: f64 = 0.99;

/// Upper end of the default `aniso` range: Disney's and Blender's Principled anisotropy of 1 is
/// aniso = 0.9 here (docs/anisotropy.md), and 0.95 leaves room beyond it.
pub const ANISO_DEFAULT_MAX: f64 = 0.95;

/// Default resolution of a table (r, aniso, mu, phi): about 10⁶ cells.
pub const DEFAULT_RESOLUTION: [usize; 4] = [64, 16, 64, 16];

/// The anisotropic white conductor with Smith form `smith`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnisoConductor {
    pub smith: SmithForm,
}

impl AnisoConductor {
    /// Both Smith forms, height-correlated first.
    pub fn all() -> [AnisoConductor; 2] {
        [SmithForm::HeightCorrelated, SmithForm::Separable].map(|smith| AnisoConductor { smith })
    }

    /// The integrand at (r, aniso, μ, φ), or `None` at r = 0 (a smooth mirror, E = 1).
    pub fn integrand(&self, r: f64, aniso: f64, mu: f64, phi: f64) -> Option<AnisoSlopeIntegrand> {
        let (alpha_t, alpha_b) = anisotropic_alphas(r, aniso);
        (alpha_t > 0.0)
            .then(|| AnisoSlopeIntegrand::conductor(alpha_t, alpha_b, mu, phi, self.smith))
    }
}

impl Model for AnisoConductor {
    fn id(&self) -> ModelId {
        ModelId::new(Family::GGX_CONDUCTOR_ANISO).with_smith(self.smith)
    }

    fn summary(&self) -> String {
        let g = match self.smith {
            SmithForm::HeightCorrelated => "height-correlated Smith G2",
            SmithForm::Separable => "separable Smith G1·G1",
        };
        format!(
            "anisotropic GGX white conductor (F = 1), E(r, aniso, μ, φ) in OpenPBR's roughness convention; {g}"
        )
    }

    fn axes(&self) -> Vec<AxisSpec> {
        vec![
            AxisSpec::new(
                "r",
                (0.0, 1.0),
                (0.0, 1.0),
                "OpenPBR roughness: α_t = r²·√(2/(1 + (1 − aniso)²)), α_b = (1 − aniso)·α_t",
            ),
            AxisSpec::new(
                "aniso",
                (0.0, ANISO_DEFAULT_MAX),
                (0.0, ANISO_MAX),
                "OpenPBR anisotropy: α_b/α_t = 1 − aniso (0: isotropic)",
            ),
            AxisSpec::new(
                "mu",
                (0.0, 1.0),
                (0.0, 1.0),
                "cosine of the outgoing direction, μo = n·ωo",
            ),
            AxisSpec::new(
                "phi",
                (0.0, FRAC_PI_2),
                (-2.0 * PI, 2.0 * PI),
                "azimuth of ωo from the tangent (radians); E(φ) = E(−φ) = E(π − φ)",
            ),
        ]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec!["E"]
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        match self.integrand(x[0], x[1], x[2], x[3]) {
            Some(f) => [integrate_2d(&f, rules)[0], 0.0, 0.0],
            None => [1.0, 0.0, 0.0],
        }
    }

    /// One integrand (its outer panels found once) for every order of the estimate.
    fn integrate_orders(&self, x: &[f64], rules: &[&Rules]) -> Vec<[f64; MAX_OUTPUTS]> {
        match self.integrand(x[0], x[1], x[2], x[3]) {
            Some(f) => rules
                .iter()
                .map(|r| [integrate_2d(&f, r)[0], 0.0, 0.0])
                .collect(),
            None => vec![[1.0, 0.0, 0.0]; rules.len()],
        }
    }

    fn grazing_boundary_layer(&self) -> bool {
        true
    }

    fn default_resolution(&self) -> Vec<usize> {
        DEFAULT_RESOLUTION.to_vec()
    }

    fn parameters(&self) -> serde_json::Value {
        serde_json::json!({ "smith": self.smith, "roughness": "openpbr" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::ggx::{GgxKind, GgxModel};
    use crate::bsdf::{albedo, Transmission};
    use crate::math::rules::UnitRule;
    use crate::quadrature::{QuadratureSettings, RuleCache};

    const SMITHS: [SmithForm; 2] = [SmithForm::HeightCorrelated, SmithForm::Separable];

    /// E of the model by the refined estimate `furnace tabulate` uses, at the default settings.
    fn estimate(model: &dyn Model, x: &[f64]) -> f64 {
        let settings = QuadratureSettings::default();
        let cache = RuleCache::new(&settings);
        let e = albedo(model, x, &settings, &cache);
        assert!(e.converged, "{x:?}: not converged ({e:?})");
        e.value[0]
    }

    /// E at a fixed high order (48 points per panel and dimension), for comparisons at 1e-9.
    fn precise(model: &dyn Model, x: &[f64]) -> f64 {
        model.integrate(x, &Rules::new(48))[0]
    }

    /// Σ over [a, b] by Gauss–Legendre panels bisected until two levels agree to `tol`.
    fn adaptive(f: &mut dyn FnMut(f64) -> f64, a: f64, b: f64, tol: f64, rule: &UnitRule) -> f64 {
        fn panel(f: &mut dyn FnMut(f64) -> f64, a: f64, b: f64, rule: &UnitRule) -> f64 {
            let h = b - a;
            rule.nodes
                .iter()
                .zip(&rule.weights)
                .map(|(&t, &w)| w * h * f(a + h * t))
                .sum()
        }
        fn go(
            f: &mut dyn FnMut(f64) -> f64,
            a: f64,
            b: f64,
            whole: f64,
            tol: f64,
            depth: u32,
            rule: &UnitRule,
        ) -> f64 {
            let m = 0.5 * (a + b);
            let (l, r) = (panel(f, a, m, rule), panel(f, m, b, rule));
            if (l + r - whole).abs() <= tol || depth == 0 {
                return l + r;
            }
            go(f, a, m, l, 0.5 * tol, depth - 1, rule) + go(f, m, b, r, 0.5 * tol, depth - 1, rule)
        }
        let whole = panel(f, a, b, rule);
        go(f, a, b, whole, tol, 30, rule)
    }

    /// E by an integrand that shares nothing with the slope-space one: visible normals of the
    /// stretched configuration (Heitz 2018, "Sampling the GGX distribution of visible normals"),
    /// N on the lune {N_z > 0, N·V > 0} with density (N·V)/(π s), s = (1 + V_z)/2, unstretched
    /// to m = (α_x N_x, α_y N_y, N_z); weight G2/G1(ωo) or G1(ωi) with Λ of Heitz 2014, eq. 86.
    /// Horizon crossings along each line by a scan and bisection, both variables adaptive.
    fn vndf_reference(ax: f64, ay: f64, mu_o: f64, phi: f64, smith: SmithForm) -> f64 {
        let sin_o = (1.0 - mu_o * mu_o).sqrt();
        let wo = [sin_o * phi.cos(), sin_o * phi.sin(), mu_o];
        let lambda = |w: [f64; 3]| {
            let t2 = (w[0] * w[0] + w[1] * w[1]) / (w[2] * w[2]);
            let a2 = (w[0] * w[0] + w[1] * w[1]) / (ax * ax * w[0] * w[0] + ay * ay * w[1] * w[1]);
            if t2 == 0.0 {
                return 0.0;
            }
            0.5 * (-1.0 + (1.0 + 1.0 / (a2 / t2)).sqrt())
        };
        let weight = |wi: [f64; 3]| match smith {
            SmithForm::HeightCorrelated => (1.0 + lambda(wo)) / (1.0 + lambda(wo) + lambda(wi)),
            SmithForm::Separable => 1.0 / (1.0 + lambda(wi)),
        };
        // stretched view V = normalize(α_x ωo,x, α_y ωo,y, μo) and its horizontal direction u
        let (vx, vy) = (ax * wo[0], ay * wo[1]);
        let vh = vx.hypot(vy);
        let theta_v = vh.atan2(mu_o);
        let (ux, uy) = if vh > 0.0 {
            (vx / vh, vy / vh)
        } else {
            (1.0, 0.0)
        };
        let s = 0.5 * (1.0 + theta_v.cos());
        let half = |cb: f64, sb: f64, p: f64| {
            let (sp, cp) = p.sin_cos();
            // N = cos β cos φ u + sin β (z × u) + cos β sin φ z
            let n = [cb * cp * ux - sb * uy, cb * cp * uy + sb * ux, cb * sp];
            let m = [ax * n[0], ay * n[1], n[2]];
            let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            [m[0] / len, m[1] / len, m[2] / len]
        };
        let reflect = |h: [f64; 3]| {
            let c = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            [
                2.0 * c * h[0] - wo[0],
                2.0 * c * h[1] - wo[1],
                2.0 * c * h[2] - wo[2],
            ]
        };
        let phi_max = PI - theta_v;
        let rule = UnitRule::gauss_legendre(15);
        let mut outer = |beta: f64| {
            let (sb, cb) = beta.sin_cos();
            let mu_i = |p: f64| reflect(half(cb, sb, p))[2];
            const SCAN: usize = 400;
            let mut ends = vec![0.0];
            for k in 0..SCAN {
                let (mut lo, mut hi) = (
                    phi_max * k as f64 / SCAN as f64,
                    phi_max * (k + 1) as f64 / SCAN as f64,
                );
                let up = mu_i(lo) > 0.0;
                if up != (mu_i(hi) > 0.0) {
                    for _ in 0..80 {
                        let mid = 0.5 * (lo + hi);
                        if (mu_i(mid) > 0.0) == up {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    ends.push(0.5 * (lo + hi));
                }
            }
            ends.push(phi_max);
            let mut sum = 0.0;
            for w in ends.windows(2) {
                if mu_i(0.5 * (w[0] + w[1])) <= 0.0 {
                    continue;
                }
                let mut f = |p: f64| {
                    let wi = reflect(half(cb, sb, p));
                    if wi[2] <= 0.0 {
                        return 0.0;
                    }
                    // N·V = cos β sin(φ + θv); dω = cos β dβ dφ
                    cb * cb * (p + theta_v).sin() / (PI * s) * weight(wi)
                };
                sum += adaptive(&mut f, w[0], w[1], 1e-13, &rule);
            }
            sum
        };
        adaptive(&mut outer, -FRAC_PI_2, FRAC_PI_2, 1e-12, &rule)
    }

    /// Off-grid points of the default table's box (no coordinate on a node of any default axis),
    /// strong anisotropy and low μ included.
    const OFF_GRID: [[f64; 4]; 8] = [
        [0.61, 0.37, 0.43, 0.29],
        [0.93, 0.83, 0.27, 1.13],
        [0.37, 0.91, 0.61, 0.71],
        [0.77, 0.53, 0.07, 0.47],
        [0.21, 0.67, 0.17, 1.41],
        [0.99, 0.94, 0.83, 0.13],
        [0.47, 0.21, 0.91, 0.97],
        [0.87, 0.77, 0.033, 1.53],
    ];

    #[test]
    fn the_independent_visible_normal_integrand_agrees_off_grid() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            for x in OFF_GRID {
                let (ax, ay) = anisotropic_alphas(x[0], x[1]);
                let reference = vndf_reference(ax, ay, x[2], x[3], smith);
                let e = precise(&model, &x);
                assert!(
                    (e - reference).abs() < 1e-9,
                    "{smith:?} {x:?}: {e} vs {reference}"
                );
                // the table's value: its error estimate is held to 1e-7
                let tabulated = estimate(&model, &x);
                assert!(
                    (tabulated - reference).abs() < 1e-7,
                    "{smith:?} {x:?}: {tabulated}"
                );
            }
        }
    }

    #[test]
    fn aniso_zero_is_the_isotropic_conductor_at_every_phi() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            let iso = GgxModel::new(GgxKind::Conductor, smith, Transmission::Energy);
            for (r, mu) in [
                (0.13, 0.71),
                (0.57, 0.33),
                (0.83, 0.05),
                (1.0, 0.0),
                (0.31, 1.0),
            ] {
                let e_iso = precise(&iso, &[r, mu]);
                for phi in [0.0, 0.37, 0.79, 1.23, FRAC_PI_2] {
                    let e = precise(&model, &[r, 0.0, mu, phi]);
                    assert!(
                        (e - e_iso).abs() < 1e-9,
                        "{smith:?} r={r} μ={mu} φ={phi}: {e} vs {e_iso}"
                    );
                }
            }
        }
    }

    #[test]
    fn normal_incidence_at_r1_isotropic_is_one_minus_ln2() {
        for smith in SMITHS {
            for phi in [0.0, 0.6, FRAC_PI_2] {
                let e = estimate(&AnisoConductor { smith }, &[1.0, 0.0, 1.0, phi]);
                assert!(
                    (e - (1.0 - 2f64.ln())).abs() < 1e-10,
                    "{smith:?} φ={phi}: {e}"
                );
            }
        }
    }

    #[test]
    fn albedo_tends_to_one_as_alpha_vanishes() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            for aniso in [0.0, 0.5, 0.95] {
                for (mu, phi) in [(0.9, 0.3), (0.4, 1.1), (0.1, 0.7)] {
                    assert_eq!(
                        model.integrate(&[0.0, aniso, mu, phi], &Rules::new(12))[0],
                        1.0
                    );
                    let mut last = 0.0;
                    for r in [0.1, 0.03, 1e-3, 1e-8] {
                        let e = estimate(&model, &[r, aniso, mu, phi]);
                        assert!(
                            e > last && e <= 1.0 + 1e-11,
                            "{smith:?} r={r}: {e} after {last}"
                        );
                        last = e;
                    }
                    assert!(1.0 - last < 1e-9, "{smith:?} aniso={aniso} μ={mu}: {last}");
                }
            }
        }
    }

    #[test]
    fn normal_incidence_does_not_depend_on_phi() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            for (r, aniso) in [(0.43, 0.61), (0.91, 0.93), (0.17, 0.29)] {
                let e0 = estimate(&model, &[r, aniso, 1.0, 0.0]);
                for phi in [0.21, 0.77, 1.31, FRAC_PI_2] {
                    let e = estimate(&model, &[r, aniso, 1.0, phi]);
                    assert!(
                        (e - e0).abs() < 1e-10,
                        "{smith:?} r={r} aniso={aniso} φ={phi}"
                    );
                }
            }
        }
    }

    #[test]
    fn swapping_the_roughnesses_turns_phi_by_a_right_angle() {
        let rules = Rules::new(24);
        for smith in SMITHS {
            for (ax, ay, mu, phi) in [
                (0.6, 0.15, 0.4, 0.3),
                (1.2, 0.1, 0.1, 1.0),
                (0.3, 0.25, 0.8, 1.5),
            ] {
                let e = integrate_2d(
                    &AnisoSlopeIntegrand::conductor(ax, ay, mu, phi, smith),
                    &rules,
                )[0];
                let swapped = AnisoSlopeIntegrand::conductor(ay, ax, mu, phi + FRAC_PI_2, smith);
                let e_swapped = integrate_2d(&swapped, &rules)[0];
                assert!(
                    (e - e_swapped).abs() < 1e-10,
                    "{smith:?} {ax} {ay} {mu} {phi}"
                );
            }
        }
    }

    #[test]
    fn the_mirror_images_of_phi_agree() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            let [r, aniso, mu, phi] = [0.71, 0.81, 0.37, 0.43];
            let e = estimate(&model, &[r, aniso, mu, phi]);
            for p in [-phi, PI - phi, PI + phi, phi - PI] {
                let ep = estimate(&model, &[r, aniso, mu, p]);
                assert!((e - ep).abs() < 1e-10, "{smith:?} φ={p}: {ep} vs {e}");
            }
        }
    }

    #[test]
    fn doubling_the_order_changes_nothing_beyond_the_tolerance() {
        for smith in SMITHS {
            let model = AnisoConductor { smith };
            for x in OFF_GRID {
                let e = model.integrate(&x, &Rules::new(24))[0];
                let doubled = model.integrate(&x, &Rules::new(48))[0];
                assert!(
                    (e - doubled).abs() < 1e-9,
                    "{smith:?} {x:?}: {e} vs {doubled}"
                );
            }
        }
    }
}
