//! Cosine-weighted averages of Fresnel reflectance, F_avg = 2∫₀¹ F(μ) μ dμ (Kulla & Conty 2017,
//! "Revisiting Physically Based Shading at Imageworks", the F_avg of the multiple-scattering
//! colour F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg))), as models:
//!
//! * `fresnel-schlick` (axis f0): Schlick's F = F0 + (1 − F0)(1 − μ)⁵ (Schlick 1994), whose
//!   average is F0 + (1 − F0)/21;
//! * `fresnel-dielectric` (axis f0, relative IOR η = (1 + √F0)/(1 − √F0)) and
//!   `fresnel-dielectric-inv` (relative IOR 1/η, total internal reflection below the critical
//!   angle): the exact unpolarised Fresnel reflectance (Walter 2007, eq. 22);
//! * `fresnel-f82-tint` (axes f0, tint): the F82-tint conductor Fresnel of the Adobe Standard
//!   Material and OpenPBR (Kutz et al. 2021, "Novel aspects of the Adobe Standard Material"),
//!   F = F_s(μ) − b μ (1 − μ)⁶ with b = F_s(μ̄)(1 − tint)/(μ̄ (1 − μ̄)⁶), μ̄ = 1/7, so that
//!   F(μ̄) = tint·F_s(μ̄); clamped to [0, 1] (at low F0 and tint the formula dips below 0 around
//!   μ = 1/2, where a renderer clamps it too). Without the clamp the average is
//!   F0 + (1 − F0)/21 − b/126.
//!
//! Each is a 1-D Gauss–Legendre integral over μ on panels between the kinks of F (the critical
//! angle √(1 − η²) from inside, the zeros of the F82 formula), with the near-singularity of the
//! dielectric F at μ = ±i√(η² − 1) mapped when it comes close (η → 1).

use super::{AxisSpec, Family, Model, ModelId, Side, MAX_OUTPUTS};
use crate::math::{eta_from_f0, fresnel_dielectric};
use crate::quadrature::{panels_from_breaks, Break, Rules};

/// μ̄ = 1/7 (cos 81.79°), where F82-tint is pinned to tint·F_s (Kutz et al. 2021).
pub const F82_MU_BAR: f64 = 1.0 / 7.0;

/// Sample points of the F82 formula over [0, 1] searched for sign changes (its zeros are
/// where the clamp starts and ends); the formula is a degree-7 polynomial with at most two zeros
/// inside (0, 1), at least 1/50 apart when it has two.
const F82_SCAN: usize = 256;

/// Which Fresnel reflectance a model averages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FresnelKind {
    Schlick,
    Dielectric(Side),
    F82Tint,
}

/// F_avg of one Fresnel reflectance: see the module documentation.
#[derive(Clone, Copy, Debug)]
pub struct FresnelAverage {
    pub kind: FresnelKind,
}

/// Every Fresnel average, in the order `furnace models` lists them.
pub fn all() -> Vec<FresnelAverage> {
    [
        FresnelKind::Schlick,
        FresnelKind::Dielectric(Side::Entering),
        FresnelKind::Dielectric(Side::Leaving),
        FresnelKind::F82Tint,
    ]
    .into_iter()
    .map(|kind| FresnelAverage { kind })
    .collect()
}

/// Schlick's approximation F0 + (1 − F0)(1 − μ)⁵ (Schlick 1994, eq. 24).
#[inline]
pub fn schlick(f0: f64, mu: f64) -> f64 {
    let m = (1.0 - mu).clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (1.0 - f0) * m2 * m2 * m
}

/// b of F82-tint: F_s(μ̄)(1 − tint)/(μ̄(1 − μ̄)⁶) (Kutz et al. 2021).
#[inline]
pub fn f82_b(f0: f64, tint: f64) -> f64 {
    let m = 1.0 - F82_MU_BAR;
    schlick(f0, F82_MU_BAR) * (1.0 - tint) / (F82_MU_BAR * m.powi(6))
}

/// The F82-tint formula F_s(μ) − b μ (1 − μ)⁶ before the clamp (Kutz et al. 2021).
#[inline]
fn f82_unclamped(f0: f64, b: f64, mu: f64) -> f64 {
    schlick(f0, mu) - b * mu * (1.0 - mu).powi(6)
}

/// F82-tint clamped to [0, 1].
#[inline]
pub fn f82_tint(f0: f64, tint: f64, mu: f64) -> f64 {
    f82_unclamped(f0, f82_b(f0, tint), mu).clamp(0.0, 1.0)
}

impl FresnelAverage {
    /// F(μ) at the model's coordinates `x`.
    pub fn fresnel(&self, x: &[f64], mu: f64) -> f64 {
        match self.kind {
            FresnelKind::Schlick => schlick(x[0], mu),
            FresnelKind::Dielectric(side) => fresnel_dielectric(mu, self.eta(side, x[0])),
            FresnelKind::F82Tint => f82_tint(x[0], x[1], mu),
        }
    }

    fn eta(&self, side: Side, f0: f64) -> f64 {
        let eta = eta_from_f0(f0);
        match side {
            Side::Entering => eta,
            Side::Leaving => 1.0 / eta,
        }
    }

    /// The kinks and near-singular points of F(μ) on [0, 1].
    fn breaks(&self, x: &[f64]) -> Vec<Break> {
        let mut b = vec![Break::regular(0.0), Break::regular(1.0)];
        match self.kind {
            FresnelKind::Schlick => {}
            FresnelKind::Dielectric(side) => {
                let eta = self.eta(side, x[0]);
                if eta > 1.0 && eta.is_finite() {
                    // √(η² − 1 + μ²) has its branch points at μ = ±i√(η² − 1)
                    b[0] = Break::near_singular(0.0, (eta * eta - 1.0).sqrt());
                } else if eta < 1.0 {
                    // F = 1 below the critical angle (tir), square-root behaviour above it
                    b.push(Break::one_sided_sqrt((1.0 - eta * eta).sqrt(), true));
                }
            }
            FresnelKind::F82Tint => {
                let (f0, bb) = (x[0], f82_b(x[0], x[1]));
                let f = |mu: f64| f82_unclamped(f0, bb, mu);
                let node = |k: usize| k as f64 / F82_SCAN as f64;
                for k in 0..F82_SCAN {
                    let (mut lo, mut hi) = (node(k), node(k + 1));
                    if (f(lo) < 0.0) == (f(hi) < 0.0) {
                        continue;
                    }
                    while hi - lo > 1e-15 {
                        let mid = 0.5 * (lo + hi);
                        if (f(mid) < 0.0) == (f(lo) < 0.0) {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    b.push(Break::regular(0.5 * (lo + hi))); // a kink of the clamp
                }
            }
        }
        b
    }
}

impl Model for FresnelAverage {
    fn id(&self) -> ModelId {
        match self.kind {
            FresnelKind::Schlick => ModelId::new(Family::FRESNEL_SCHLICK),
            FresnelKind::Dielectric(side) => {
                ModelId::new(Family::FRESNEL_DIELECTRIC).with_side(side)
            }
            FresnelKind::F82Tint => ModelId::new(Family::FRESNEL_F82_TINT),
        }
    }

    fn summary(&self) -> String {
        let what = match self.kind {
            FresnelKind::Schlick => "Schlick's Fresnel F0 + (1 − F0)(1 − μ)⁵ (= F0 + (1 − F0)/21)",
            FresnelKind::Dielectric(Side::Entering) => {
                "exact dielectric Fresnel, relative IOR η = (1+√F0)/(1−√F0) (seen from outside)"
            }
            FresnelKind::Dielectric(Side::Leaving) => {
                "exact dielectric Fresnel, relative IOR 1/η (seen from inside, total internal reflection)"
            }
            FresnelKind::F82Tint => {
                "F82-tint conductor Fresnel of OpenPBR / the Adobe Standard Material (Kutz et al. 2021), clamped to [0, 1]"
            }
        };
        format!("cosine-weighted Fresnel average F_avg = 2∫₀¹ F(μ) μ dμ of {what}")
    }

    fn axes(&self) -> Vec<AxisSpec> {
        let f0 = |default: (f64, f64), valid: (f64, f64)| {
            AxisSpec::new("f0", default, valid, "normal-incidence reflectance F0")
        };
        match self.kind {
            FresnelKind::Schlick => vec![f0((0.0, 1.0), (0.0, 1.0))],
            FresnelKind::Dielectric(_) => vec![AxisSpec::new(
                "f0",
                (0.0, 0.25),
                (0.0, 0.99),
                "normal-incidence reflectance; relative IOR η = (1+√F0)/(1−√F0)",
            )],
            FresnelKind::F82Tint => vec![
                f0((0.0, 1.0), (0.0, 1.0)),
                AxisSpec::new(
                    "tint",
                    (0.0, 1.0),
                    (0.0, 1.0),
                    "F82 tint: F(μ̄ = 1/7) = tint·F_Schlick(μ̄) (OpenPBR specular_color)",
                ),
            ],
        }
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec!["F_avg"]
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        let mut breaks = self.breaks(x);
        let mut panels = Vec::new();
        panels_from_breaks(&mut breaks, &mut panels);
        let (mut mus, mut ws) = (Vec::with_capacity(64), Vec::with_capacity(64));
        for p in &panels {
            rules.inner.nodes_into(p, &mut mus, &mut ws);
        }
        let f_avg = mus
            .iter()
            .zip(&ws)
            .map(|(&mu, &w)| 2.0 * w * mu * self.fresnel(x, mu)) // Kulla & Conty 2017
            .sum();
        [f_avg, 0.0, 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::{QuadratureSettings, RuleCache};

    fn f_avg(kind: FresnelKind, x: &[f64]) -> f64 {
        let settings = QuadratureSettings {
            tolerance: 1e-13,
            ..QuadratureSettings::default()
        };
        let cache = RuleCache::new(&settings);
        let e = crate::bsdf::albedo(&FresnelAverage { kind }, x, &settings, &cache);
        assert!(e.converged, "{kind:?} at {x:?}: estimate {}", e.error);
        e.value[0]
    }

    #[test]
    fn schlick_and_f82_match_their_closed_forms() {
        for f0 in [0.0, 0.04, 0.37, 0.9, 1.0] {
            let exact = f0 + (1.0 - f0) / 21.0;
            assert!((f_avg(FresnelKind::Schlick, &[f0]) - exact).abs() < 1e-15);
            // tint ≥ F-positivity: the formula stays in [0, 1] and the clamp is idle
            for tint in [0.6, 0.8, 1.0] {
                let closed = exact - f82_b(f0, tint) / 126.0; // B(3, 7) = 1/252
                let v = f_avg(FresnelKind::F82Tint, &[f0, tint]);
                assert!((v - closed).abs() < 1e-14, "{f0} {tint}: {v} vs {closed}");
            }
        }
        // F82-tint is tint·F_s at μ̄
        let (f0, tint) = (0.3, 0.55);
        assert!((f82_tint(f0, tint, F82_MU_BAR) - tint * schlick(f0, F82_MU_BAR)).abs() < 1e-15);
    }

    /// Where the F82 formula dips below zero the clamp lifts the average above the closed form.
    #[test]
    fn f82_clamp_is_integrated_with_its_kinks() {
        let (f0, tint) = (0.0, 0.0);
        let closed = 1.0 / 21.0 - f82_b(f0, tint) / 126.0;
        let v = f_avg(FresnelKind::F82Tint, &[f0, tint]);
        assert!(v > closed + 1e-4, "{v} vs {closed}");
        // the positive part of the formula, integrated on a fine uniform grid
        let n = 400_000;
        let b = f82_b(f0, tint);
        let mid: f64 = (0..n)
            .map(|k| {
                let mu = (k as f64 + 0.5) / n as f64;
                2.0 * mu * f82_unclamped(f0, b, mu).max(0.0) / n as f64
            })
            .sum();
        assert!((v - mid).abs() < 1e-10, "{v} vs {mid}");
    }

    /// Stokes reciprocity of a smooth interface: the hemispherical transmittances from the two
    /// sides satisfy 1 − F_avg(1/η) = (1 − F_avg(η))/η².
    #[test]
    fn dielectric_averages_obey_reciprocity() {
        for f0 in [0.001, 0.0125, 0.04, 0.1, 0.25, 0.6] {
            let eta = eta_from_f0(f0);
            let outside = f_avg(FresnelKind::Dielectric(Side::Entering), &[f0]);
            let inside = f_avg(FresnelKind::Dielectric(Side::Leaving), &[f0]);
            let lhs = 1.0 - inside;
            let rhs = (1.0 - outside) / (eta * eta);
            assert!((lhs - rhs).abs() < 1e-13, "F0 {f0}: {lhs} vs {rhs}");
            // Kulla & Conty's fit (η − 1)/(4.08567 + 1.00071 η), quoted for 1 < η < 400
            let fit = (eta - 1.0) / (4.08567 + 1.00071 * eta);
            // (measured: within 6.1e-3 of it for η from 1.07 to 7.9)
            assert!(
                (outside - fit).abs() < 6.5e-3,
                "F0 {f0}: {outside} vs fit {fit}"
            );
        }
        assert_eq!(f_avg(FresnelKind::Dielectric(Side::Entering), &[0.0]), 0.0);
    }
}
