//! GGX reflection weighted by a function of ωo·h: the split-sum terms of image-based lighting and
//! Blender Cycles' generalised-Schlick factors.
//!
//! * `ggx-split-sum` (r, μ; both Smith forms): Karis 2013 ("Real Shading in Unreal Engine 4",
//!   eq. 8) splits the albedo of a GGX reflection with Schlick's Fresnel into
//!   E = F0·A + B, A = ∫ (1 − Fc) f cos, B = ∫ Fc f cos, Fc = (1 − ωo·h)⁵, f the white GGX BRDF;
//!   A + B is the white conductor's albedo. With the height-correlated G2 this is Filament's DFG
//!   (Filament's `DFV`: its visibility V = G2/(4 μo μi) is the height-correlated Smith term).
//! * `ggx-gen-schlick` (z, r, μ) and `ggx-gen-schlick-ior` (f0, r, μ): the interpolation factor s
//!   of a generalised-Schlick Fresnel F = F0 + (F90 − F0)·s, averaged over the visible normals
//!   whose mirror direction lies above the horizon, S = ∫ D_ωo(h) s(ωo·h) [μi > 0] dh — the
//!   definition of Cycles' `ggx_gen_schlick_s` and `ggx_gen_schlick_ior_s` tables
//!   (`cycles_precompute.cpp`: the mean of eval.x/eval.y over visible-normal samples, invalid
//!   samples counting 0). Note that this is not the albedo-weighted ratio ∫ s f cos / ∫ f cos:
//!   the masking G2/G1(ωo) of each sample's weight is not in it. For `ggx-gen-schlick`,
//!   s = (1 − ωo·h)^p with p = 5(1 − z)/z (z = 1/2 is Schlick's 5); for `-ior`,
//!   s = (F(ωo·h, η) − F0)/(1 − F0) with the exact dielectric F and η = (1 + √F0)/(1 − √F0).
//!
//! # The integral
//! The half vector is parametrised about ωo: h = cos β ωo + sin β (cos φ e1 + sin φ e2), with
//! e1 = (−μo, 0, sin θo) in the plane of incidence and e2 = (0, 1, 0), so that ωo·h = cos β is a
//! function of the outer variable alone and dω_h = sin β dβ dφ. The reflection μi = 2(ωo·h)h_z − μo
//! lies above the horizon when cos φ > κ(β) = −cot 2β · cot θo, so that:
//!
//! * for β < β₁ = π/4 − θo/2 every φ reflects above the horizon, for β₁ < β < β₂ = π/4 + θo/2 the
//!   range |φ| < acos κ does, beyond β₂ none does: the horizon is the end of every line, and β₁,
//!   β₂ (square-root ends of that range) are outer panel ends;
//! * the GGX peak h = n sits at (β, φ) = (θo, 0), with the poles of D at complex distance ~α: a
//!   near-singular break in both variables;
//! * the masking weight of the albedo form varies on the scale μi ~ α next to the horizon: the
//!   ends of the lines and β₁, β₂ are near-singular at that scale;
//! * the weight's own singularities lie at ωo·h = 1 (β = 0: a fractional power (2 sin²(β/2))^p,
//!   graded geometrically by the sinh map) and, for large p or η → 1, near ωo·h = 0.
//!
//! Panel ends and maps come from [`crate::quadrature::panels_from_breaks`]; each panel's rule is
//! then Gauss–Legendre on an analytic function. The white case of the split sum, A + B, must
//! equal the conductor albedo of [`super::slope`], integrated in an unrelated parametrisation:
//! the tests check that to 1e-9 across the domain, grazing and low roughness included.

use super::microfacet::{ALPHA_MIN, GRAZING_RATIO};
use super::{AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use crate::math::{alpha_from_r, eta_from_f0, fresnel_dielectric, smith_a, SmithForm};
use crate::quadrature::{
    integrate_2d, panels_from_breaks, Break, Integrand2D, Panel, Rules, CHANNELS, MIN_DELTA,
};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Schlick's exponent (Schlick 1994, eq. 24): z = 1/2 on Cycles' exponent axis.
pub const SCHLICK_EXPONENT: f64 = 5.0;

/// The exponent p = 5(1 − z)/z of Cycles' `ggx_gen_schlick_s` axis z ∈ (0, 1].
pub fn exponent_from_z(z: f64) -> f64 {
    SCHLICK_EXPONENT * (1.0 - z) / z
}

/// What weights the reflection, as a function of c = ωo·h.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weight {
    /// Two channels: 1 − Fc and Fc, Fc = (1 − c)⁵ (Karis 2013, eq. 8).
    SplitSum,
    /// (1 − c)^p.
    Power { p: f64 },
    /// (F(c, η) − F0)/(1 − F0), the exact dielectric F remapped to [0, 1] (η > 1).
    Dielectric { eta: f64, f0: f64 },
}

impl Weight {
    /// The channels at c = cos β; `one_minus_c` = 1 − c computed without cancellation.
    #[inline]
    fn at(&self, c: f64, one_minus_c: f64) -> [f64; CHANNELS] {
        match *self {
            Weight::SplitSum => {
                let m2 = one_minus_c * one_minus_c;
                let fc = m2 * m2 * one_minus_c; // Schlick's (1 − ωo·h)⁵
                [1.0 - fc, fc]
            }
            Weight::Power { p } => [if p == 0.0 { 1.0 } else { one_minus_c.powf(p) }, 0.0],
            Weight::Dielectric { eta, f0 } => {
                let f = fresnel_dielectric(c, eta);
                [((f - f0) / (1.0 - f0)).clamp(0.0, 1.0), 0.0]
            }
        }
    }

    /// Where the weight has a kink: the remapped dielectric F of a dense medium dips below F0
    /// between Brewster's angle and normal incidence (r_p passes through 0), and the clamp to
    /// [0, 1] (Cycles' `saturatef`) bends it where F = F0 again; returned as β = acos c.
    fn kink(&self) -> Option<f64> {
        let Weight::Dielectric { eta, f0 } = *self else {
            return None;
        };
        const SCAN: usize = 1024;
        let g = |c: f64| fresnel_dielectric(c, eta) - f0;
        let first_below = (1..SCAN).find(|&k| g(k as f64 / SCAN as f64) < 0.0)?;
        let (mut lo, mut hi) = (
            (first_below - 1) as f64 / SCAN as f64,
            first_below as f64 / SCAN as f64,
        );
        while hi - lo > 1e-15 {
            let mid = 0.5 * (lo + hi);
            if g(mid) < 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some((0.5 * (lo + hi)).acos())
    }

    /// Whether the weight is analytic at c = 1 (β = 0).
    fn analytic_at_normal(&self) -> bool {
        match *self {
            Weight::Power { p } => p.fract() == 0.0,
            _ => true,
        }
    }

    /// Distance in β, from β = π/2 − `gap`, to the weight's nearest singularity near c = 0
    /// (the scale 1/p of (1 − c)^p = e^{p ln(1 − c)} there; the dielectric F's branch points and
    /// poles).
    fn grazing_delta(&self, gap: f64) -> f64 {
        match *self {
            Weight::SplitSum => f64::INFINITY,
            Weight::Power { p } if p > 1.0 => 1.0 / p,
            Weight::Power { .. } => f64::INFINITY,
            Weight::Dielectric { eta, .. } => {
                // the branch points c = ±i√(η² − 1) and the poles of r_p,
                // η²c + √(η² − 1 + c²) = 0 at c = ±i/√(η² + 1)
                let near = (eta * eta - 1.0)
                    .max(0.0)
                    .sqrt()
                    .min(1.0 / (eta * eta + 1.0).sqrt());
                gap.hypot(near)
            }
        }
    }
}

/// How each microfacet is weighted besides the Fresnel weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Masking {
    /// The albedo: D·G2(ωo, ωi)/μo (the reflection's share of the white BRDF times μi).
    Albedo(SmithForm),
    /// The visible-normal density D·G1(ωo)/μo (Heitz 2014, eq. 14), nothing on ωi.
    Visible,
}

/// One cell of a weighted reflection integral: see the module documentation.
pub struct WeightedReflection {
    alpha: f64,
    mu_o: f64,
    sin_o: f64,
    theta_o: f64,
    masking: Masking,
    weight: Weight,
    /// a(μo) = √(μo² + α²(1 − μo²)).
    a_o: f64,
    /// G1(μo)/μo = 2/(μo + a(μo)).
    g1_o_over_mu_o: f64,
}

/// Per-line data: cos β, the weight's channels, and μi, 1 − h_z as functions of φ.
pub struct WeightedLine {
    /// cos β, the Jacobian-and-weight factor 2·sin β·cos β·w (φ is integrated over [0, φend]).
    scale: [f64; CHANNELS],
    /// μi = mi0 + mi1·cos φ.
    mi0: f64,
    mi1: f64,
    /// h_z = hz0 + hz1·cos φ and 1 − h_z = d0 + d1·sin²(φ/2).
    hz0: f64,
    hz1: f64,
    d0: f64,
    d1: f64,
}

impl WeightedReflection {
    /// The integral at roughness α > 0 and μo ∈ [0, 1]. α below [`ALPHA_MIN`] is integrated
    /// at ALPHA_MIN and μo below [`GRAZING_RATIO`]·α at μo = 0, as the other GGX integrands do.
    pub fn new(alpha: f64, mu_o: f64, masking: Masking, weight: Weight) -> WeightedReflection {
        let alpha = alpha.max(ALPHA_MIN);
        let mu_o = if mu_o < GRAZING_RATIO * alpha {
            0.0
        } else {
            mu_o.min(1.0)
        };
        let a_o = smith_a(mu_o, alpha);
        let sin_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        WeightedReflection {
            alpha,
            mu_o,
            sin_o,
            theta_o: sin_o.atan2(mu_o),
            masking,
            weight,
            a_o,
            g1_o_over_mu_o: 2.0 / (mu_o + a_o),
        }
    }

    /// β₁ and β₂: where the lines stop being full circles and where they vanish.
    fn beta_range(&self) -> (f64, f64) {
        (
            (FRAC_PI_4 - 0.5 * self.theta_o).max(0.0),
            FRAC_PI_4 + 0.5 * self.theta_o,
        )
    }

    /// The φ at which the line at β leaves the horizon: `None` for an empty line, π for a full one.
    fn phi_end(&self, beta: f64) -> Option<f64> {
        let (c, s) = (beta.cos(), beta.sin());
        let (beta1, beta2) = self.beta_range();
        if beta >= beta2 {
            return None;
        }
        if beta <= beta1 || self.sin_o == 0.0 || s == 0.0 {
            return Some(PI);
        }
        // cos φ > κ = μo(1 − 2c²)/(2 c s sin θo)
        let kappa = self.mu_o * (1.0 - 2.0 * c * c) / (2.0 * c * s * self.sin_o);
        if kappa >= 1.0 {
            None
        } else if kappa <= -1.0 {
            Some(PI)
        } else {
            Some(kappa.acos())
        }
    }

    fn make_line(&self, beta: f64) -> WeightedLine {
        let (c, s) = (beta.cos(), beta.sin());
        let half = 0.5 * beta;
        let one_minus_c = 2.0 * half.sin() * half.sin();
        let w = self.weight.at(c, one_minus_c);
        let dh = 0.5 * (beta - self.theta_o);
        let jac = 2.0 * s * c; // dω_h = sin β dβ dφ, φ over both signs; ωo·h = c
        WeightedLine {
            scale: [jac * w[0], jac * w[1]],
            mi0: 2.0 * c * c * self.mu_o - self.mu_o,
            mi1: 2.0 * c * s * self.sin_o,
            hz0: c * self.mu_o,
            hz1: s * self.sin_o,
            d0: 2.0 * dh.sin() * dh.sin(),
            d1: 2.0 * s * self.sin_o,
        }
    }

    /// D(h)·(masking) at φ on `line`.
    #[inline]
    fn density(&self, line: &WeightedLine, phi: f64) -> f64 {
        let cos_phi = phi.cos();
        let mu_i = (line.mi0 + line.mi1 * cos_phi).max(0.0);
        let h_z = line.hz0 + line.hz1 * cos_phi;
        let sh = (0.5 * phi).sin();
        let one_minus_hz = (line.d0 + line.d1 * sh * sh).max(0.0);
        let a2 = self.alpha * self.alpha;
        let t = one_minus_hz * (1.0 + h_z) + a2 * h_z * h_z; // 1 − h_z²(1 − α²)
        let d = a2 / (PI * t * t); // GGX D (Walter 2007, eq. 33)
        let m = match self.masking {
            Masking::Visible => self.g1_o_over_mu_o,
            Masking::Albedo(SmithForm::HeightCorrelated) => {
                // G2/μo = 2μi/(a(μo)μi + a(μi)μo) (Heitz 2014, eq. 99)
                let den = self.a_o * mu_i + smith_a(mu_i, self.alpha) * self.mu_o;
                if den > 0.0 {
                    2.0 * mu_i / den
                } else {
                    0.0
                }
            }
            Masking::Albedo(SmithForm::Separable) => {
                // G1(μo)G1(μi)/μo (Heitz 2014, eq. 98)
                let den = mu_i + smith_a(mu_i, self.alpha);
                if den > 0.0 {
                    self.g1_o_over_mu_o * 2.0 * mu_i / den
                } else {
                    0.0
                }
            }
        };
        d * m
    }

    /// The scale in μi on which the masking weight varies next to the horizon: the branch
    /// points μi = ±iα of a(μi), and for the height-correlated G2 its pole μi = −μo (where
    /// a(μo)μi + a(μi)μo = 0).
    fn horizon_scale(&self) -> f64 {
        match self.masking {
            Masking::Visible => f64::INFINITY,
            Masking::Albedo(SmithForm::Separable) => self.alpha,
            Masking::Albedo(SmithForm::HeightCorrelated) => self.alpha.min(self.mu_o),
        }
    }

    /// The inner breaks of the line at β ending at `phi_end`.
    fn inner_breaks(&self, beta: f64, line: &WeightedLine, phi_end: f64) -> [Break; 2] {
        let a = self.alpha;
        let scale = self.horizon_scale();
        // D's poles, 1 − h_z ≈ −α²/4: sin²(φ/2) = −(α²/4 + sin²((β − θo)/2))/(sin β sin θo)
        let peak = if line.d1 > 0.0 {
            let dh = 0.5 * (beta - self.theta_o);
            2.0 * ((0.25 * a * a + dh.sin() * dh.sin()) / (0.5 * line.d1)).sqrt()
        } else {
            f64::INFINITY
        };
        let start = Break::near_singular(0.0, peak.max(MIN_DELTA));
        let end = match self.masking {
            Masking::Visible => Break::regular(phi_end),
            Masking::Albedo(_) if line.mi1 <= 0.0 => Break::regular(phi_end),
            Masking::Albedo(_) => {
                let b = line.mi1;
                let delta = if phi_end >= PI {
                    // μi's minimum m at φ = π: μi ≈ m + b ε²/2 = ±iα
                    let m = (line.mi0 - b).max(0.0);
                    (2.0 * m.hypot(scale) / b).sqrt()
                } else {
                    (scale / (b * phi_end.sin())).min((2.0 * scale / b).sqrt())
                };
                Break::near_singular(phi_end, delta.max(MIN_DELTA))
            }
        };
        [start, end]
    }
}

impl Integrand2D for WeightedReflection {
    type Line = WeightedLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        let (beta1, beta2) = self.beta_range();
        out.extend([0.0, beta1, beta2]);
    }

    fn line(&self, beta: f64, breaks: &mut Vec<f64>) -> WeightedLine {
        let line = self.make_line(beta);
        if let Some(end) = self.phi_end(beta) {
            breaks.extend([0.0, end]);
        }
        line
    }

    fn eval(&self, line: &WeightedLine, phi: f64) -> [f64; CHANNELS] {
        let d = self.density(line, phi);
        [line.scale[0] * d, line.scale[1] * d]
    }

    fn panels_all_active(&self) -> bool {
        true
    }

    fn outer_panels(&self, out: &mut Vec<Panel>) {
        let a = self.alpha;
        let (beta1, beta2) = self.beta_range();
        let horizon = 0.5 * self.horizon_scale(); // |dμi/dβ| = 2 at β₁ and β₂
        let mut breaks = Vec::with_capacity(5);
        breaks.push(if self.weight.analytic_at_normal() {
            Break::regular(0.0)
        } else {
            Break::near_singular(0.0, MIN_DELTA) // (2 sin²(β/2))^p: graded geometrically
        });
        // κ(β) = −cot 2β·cot θo is singular at β = 0 and π/2, at distance β₁ = π/2 − β₂
        // from the ends of the partial range: a short scale at grazing μo
        // (at μo = 0, β₁ = 0: the mirror directions of h near ωo graze the horizon there)
        if beta1 < beta2 {
            let near = if beta1 > 0.0 {
                horizon.min(beta1)
            } else {
                horizon
            };
            breaks.push(Break::sqrt(beta1).with_delta(near.max(MIN_DELTA)));
        }
        let gap = FRAC_PI_2 - beta2;
        let grazing =
            self.weight
                .grazing_delta(gap)
                .min(if beta1 > 0.0 { gap } else { f64::INFINITY });
        if let Some(k) = self.weight.kink().filter(|&k| k > 0.0 && k < beta2) {
            breaks.push(Break::regular(k));
        }
        // the peak: inside, or at an end (θo = 0 at normal incidence, θo = β₂ = π/2 at μo = 0)
        let peak_at_end = self.theta_o >= beta2;
        let end_delta = horizon
            .min(grazing)
            .min(if peak_at_end { a } else { f64::INFINITY });
        breaks.push(Break::sqrt(beta2).with_delta(end_delta.max(MIN_DELTA)));
        if self.theta_o > 0.0 && !peak_at_end {
            breaks.push(Break::near_singular(self.theta_o, a.max(MIN_DELTA)));
        } else if self.theta_o == 0.0 {
            breaks[0] = breaks[0].with_delta(a.max(MIN_DELTA));
        }
        panels_from_breaks(&mut breaks, out);
    }

    fn line_panels(&self, beta: f64, out: &mut Vec<Panel>) -> WeightedLine {
        let line = self.make_line(beta);
        if let Some(end) = self.phi_end(beta) {
            if end > 0.0 {
                let mut b = self.inner_breaks(beta, &line, end);
                panels_from_breaks(&mut b, out);
            }
        }
        line
    }
}

/// Which weighted reflection a model tabulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightedKind {
    /// A and B of the split sum, with a Smith form.
    SplitSum(SmithForm),
    /// Cycles' `ggx_gen_schlick_s`: s = (1 − ωo·h)^p, p = 5(1 − z)/z.
    GenSchlick,
    /// Cycles' `ggx_gen_schlick_ior_s`: s = (F − F0)/(1 − F0), exact dielectric F.
    GenSchlickIor,
}

/// A model over (r, μ) or (z | f0, r, μ) of a weighted reflection: see the module documentation.
#[derive(Clone, Copy, Debug)]
pub struct WeightedModel {
    pub kind: WeightedKind,
}

/// Every weighted-reflection model, in the order `furnace models` lists them.
pub fn all() -> Vec<WeightedModel> {
    [
        WeightedKind::SplitSum(SmithForm::HeightCorrelated),
        WeightedKind::SplitSum(SmithForm::Separable),
        WeightedKind::GenSchlick,
        WeightedKind::GenSchlickIor,
    ]
    .into_iter()
    .map(|kind| WeightedModel { kind })
    .collect()
}

impl WeightedModel {
    /// (first coordinate or 0, r, μ) of a point.
    fn split(&self, x: &[f64]) -> (f64, f64, f64) {
        match self.kind {
            WeightedKind::SplitSum(_) => (0.0, x[0], x[1]),
            _ => (x[0], x[1], x[2]),
        }
    }

    /// Masking and weight at the first coordinate `q` (z or f0).
    fn integrand_parts(&self, q: f64) -> (Masking, Weight) {
        match self.kind {
            WeightedKind::SplitSum(smith) => (Masking::Albedo(smith), Weight::SplitSum),
            WeightedKind::GenSchlick => (
                Masking::Visible,
                Weight::Power {
                    p: exponent_from_z(q),
                },
            ),
            WeightedKind::GenSchlickIor => (
                Masking::Visible,
                Weight::Dielectric {
                    eta: eta_from_f0(q),
                    f0: q,
                },
            ),
        }
    }

    /// The outputs at (q, r, μ) with `rules`.
    pub fn values(&self, q: f64, r: f64, mu: f64, rules: &Rules) -> [f64; CHANNELS] {
        let (masking, weight) = self.integrand_parts(q);
        let alpha = alpha_from_r(r);
        if alpha == 0.0 {
            // a smooth surface: h = n, ωo·h = μ, every direction reflects (E = 1)
            let mu = mu.clamp(0.0, 1.0);
            return weight.at(mu, 1.0 - mu);
        }
        integrate_2d(&WeightedReflection::new(alpha, mu, masking, weight), rules)
    }
}

impl Model for WeightedModel {
    fn id(&self) -> ModelId {
        match self.kind {
            WeightedKind::SplitSum(smith) => ModelId::new(Family::GGX_SPLIT_SUM).with_smith(smith),
            WeightedKind::GenSchlick => ModelId::new(Family::GGX_GEN_SCHLICK),
            WeightedKind::GenSchlickIor => ModelId::new(Family::GGX_GEN_SCHLICK_IOR),
        }
    }

    fn summary(&self) -> String {
        match self.kind {
            WeightedKind::SplitSum(smith) => format!(
                "GGX split-sum terms (Karis 2013): E = F0·A + B for Schlick's Fresnel, A + B the white conductor's E; {} (height-correlated: Filament's DFG)",
                match smith {
                    SmithForm::HeightCorrelated => "height-correlated Smith G2",
                    SmithForm::Separable => "separable Smith G1·G1",
                }
            ),
            WeightedKind::GenSchlick => "GGX visible-normal average of the generalised-Schlick factor s = (1 − ωo·h)^p, p = 5(1 − z)/z, over mirror directions above the horizon (Cycles' ggx_gen_schlick_s)".into(),
            WeightedKind::GenSchlickIor => "GGX visible-normal average of s = (F(ωo·h, η) − F0)/(1 − F0), exact dielectric F, over mirror directions above the horizon (Cycles' ggx_gen_schlick_ior_s)".into(),
        }
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
            WeightedKind::SplitSum(_) => vec![r, mu],
            WeightedKind::GenSchlick => vec![
                AxisSpec::new(
                    "z",
                    (1e-4, 1.0),
                    (1e-6, 1.0),
                    "exponent p = 5(1 − z)/z of s = (1 − ωo·h)^p (z = 1/2: Schlick's 5; Cycles' axis)",
                ),
                r,
                mu,
            ],
            WeightedKind::GenSchlickIor => vec![
                AxisSpec::new(
                    "f0",
                    (0.0125, 0.25),
                    (0.0, 0.99),
                    "normal-incidence reflectance; relative IOR η = (1+√F0)/(1−√F0)",
                ),
                r,
                mu,
            ],
        }
    }

    fn outputs(&self) -> Vec<&'static str> {
        match self.kind {
            WeightedKind::SplitSum(_) => vec!["A", "B"],
            _ => vec!["s"],
        }
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        let (q, r, mu) = self.split(x);
        let v = self.values(q, r, mu, rules);
        [v[0], v[1], 0.0]
    }

    fn grazing_boundary_layer(&self) -> bool {
        true
    }

    /// As for the other GGX models: a square-root end and a boundary layer of width ~α at
    /// grazing μ, and μ = 1 mapped as a square-root end.
    fn mu_breaks(&self, x: &[f64], out: &mut Vec<Break>) {
        let (_, r, _) = self.split(x);
        let alpha = alpha_from_r(r).min(1.0);
        out.push(if alpha > 0.0 {
            Break::sqrt(0.0).with_delta(alpha / (1.0 - alpha * alpha).max(0.0).sqrt())
        } else {
            Break::regular(0.0)
        });
        out.push(Break::sqrt(1.0));
    }

    fn parameters(&self) -> serde_json::Value {
        match self.kind {
            WeightedKind::SplitSum(smith) => serde_json::json!({ "smith": smith }),
            _ => serde_json::Value::Null,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::{QuadratureSettings, RuleCache};

    fn point(m: &dyn Model, x: &[f64], tolerance: f64) -> [f64; MAX_OUTPUTS] {
        let settings = QuadratureSettings {
            tolerance,
            ..QuadratureSettings::default()
        };
        let cache = RuleCache::new(&settings);
        let e = crate::bsdf::albedo(m, x, &settings, &cache);
        assert!(e.converged, "{} at {x:?}: estimate {}", m.id(), e.error);
        e.value
    }

    /// A + B is the white conductor's albedo, which the slope-space integrand computes in an
    /// unrelated parametrisation.
    #[test]
    fn split_sum_adds_up_to_the_conductor_albedo() {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            let split = WeightedModel {
                kind: WeightedKind::SplitSum(smith),
            };
            let conductor = crate::bsdf::get(ModelId::ggx_conductor(smith)).unwrap();
            let mut worst: f64 = 0.0;
            for r in [0.003, 0.021, 0.093, 0.31, 0.57, 0.84, 1.0] {
                for mu in [0.0, 1e-4, 0.0071, 0.043, 0.2, 0.49, 0.77, 0.95, 1.0] {
                    let ab = point(&split, &[r, mu], 1e-11);
                    let e = point(conductor.as_ref(), &[r, mu], 1e-11)[0];
                    worst = worst.max((ab[0] + ab[1] - e).abs());
                    assert!(
                        (ab[0] + ab[1] - e).abs() < 1e-9,
                        "{smith:?} r {r} mu {mu}: A + B = {} vs E = {e}",
                        ab[0] + ab[1]
                    );
                }
            }
            eprintln!("{smith:?}: max |A + B − E| = {worst:.1e}");
        }
    }

    /// At normal incidence and r = 1 the GGX conductor albedo is 1 − ln 2; B there against a
    /// brute-force midpoint rule over the visible-normal parametrisation.
    #[test]
    fn split_sum_at_a_closed_form_point() {
        let split = WeightedModel {
            kind: WeightedKind::SplitSum(SmithForm::HeightCorrelated),
        };
        let ab = point(&split, &[1.0, 1.0], 1e-12);
        assert!((ab[0] + ab[1] - (1.0 - 2f64.ln())).abs() < 1e-12);
        // α = 1, μo = 1: D = 1/π, h uniform in solid angle; ωo·h = h_z = cos t; ωi at 2t;
        // E_w = ∫ D G2 w(cos t) cos t dω_h with G2 = 2μi/(μi + a(μi)) at μo = 1 (a(1) = 1)
        let n = 200_000;
        let b: f64 = (0..n)
            .map(|k| {
                let t = (k as f64 + 0.5) / n as f64 * FRAC_PI_4;
                let mu_i = (2.0 * t).cos();
                let g2 = 2.0 * mu_i / (mu_i + 1.0); // a(μi) = 1 at α = 1
                let fc = (1.0 - t.cos()).powi(5);
                2.0 * PI * t.sin() / PI * g2 * fc * t.cos() * FRAC_PI_4 / n as f64
            })
            .sum();
        assert!((ab[1] - b).abs() < 1e-9, "B = {} vs {b}", ab[1]);
    }

    /// s ≡ 1 (z = 1, p = 0) gives the visible fraction of mirror directions above the horizon:
    /// 1 at normal incidence for α → 0; the smooth surface gives s(μ) itself.
    #[test]
    fn gen_schlick_limits() {
        let g = WeightedModel {
            kind: WeightedKind::GenSchlick,
        };
        let one = point(&g, &[1.0, 0.01, 0.9], 1e-10)[0];
        assert!((one - 1.0).abs() < 1e-7, "{one}"); // GGX's tail: ~α²/tan²(32°) below the horizon
        let half = point(&g, &[1.0, 1.0, 0.5], 1e-10)[0];
        assert!(half > 0.5 && half < 1.0, "{half}");
        let smooth = point(&g, &[0.5, 0.0, 0.3], 1e-10)[0];
        assert!((smooth - 0.7f64.powi(5)).abs() < 1e-15);
        let ior = WeightedModel {
            kind: WeightedKind::GenSchlickIor,
        };
        let s = point(&ior, &[0.04, 0.0, 0.3], 1e-10)[0];
        let f = fresnel_dielectric(0.3, 1.5);
        assert!((s - (f - 0.04) / 0.96).abs() < 1e-12);
    }
}
