//! GGX (Trowbridge–Reitz) microfacet distribution, Smith masking and exact dielectric Fresnel.
//!
//! Conventions (docs/models.md): the table axis is `r`, the GGX parameter is `alpha = r²`
//! ([`alpha_from_r`]); directions live in the local frame with the normal `n = (0, 0, 1)`.

/// α = r² (Turquin 2019 / Sforza–Pellacini 2022 parametrisation): the one place it is converted.
#[inline]
pub fn alpha_from_r(r: f64) -> f64 {
    r * r
}

/// OpenPBR's anisotropic GGX roughness (OpenPBR Surface specification, "Microfacet model"):
/// α_t = r²·√(2/(1 + (1 − aniso)²)) along the tangent and α_b = (1 − aniso)·α_t along the
/// bitangent, so that α_t² + α_b² = 2r⁴ (the isotropic α = r² at aniso = 0) and
/// α_b/α_t = 1 − aniso. Returns (α_t, α_b); α_t exceeds r² (up to √2·r²) as aniso → 1.
#[inline]
pub fn anisotropic_alphas(r: f64, aniso: f64) -> (f64, f64) {
    let b = 1.0 - aniso;
    let alpha_t = alpha_from_r(r) * (2.0 / (1.0 + b * b)).sqrt();
    (alpha_t, b * alpha_t)
}

/// The inverse of [`anisotropic_alphas`]: (r, aniso) of roughnesses α_t ≥ α_b ≥ 0 (one of them
/// positive), r = ((α_t² + α_b²)/2)^¼ and aniso = 1 − α_b/α_t. A renderer whose larger roughness
/// lies along its bitangent swaps the two and measures φ from its bitangent instead.
/// `None` when α_b > α_t or either is negative or not finite.
pub fn openpbr_roughness(alpha_t: f64, alpha_b: f64) -> Option<(f64, f64)> {
    if !(alpha_t.is_finite() && alpha_b.is_finite() && alpha_b >= 0.0 && alpha_t >= alpha_b) {
        return None;
    }
    if alpha_t == 0.0 {
        return Some((0.0, 0.0));
    }
    let r = (0.5 * (alpha_t * alpha_t + alpha_b * alpha_b))
        .sqrt()
        .sqrt();
    Some((r, 1.0 - alpha_b / alpha_t))
}

/// Smith's a(ω) = √(μ² + α_x² ω_x² + α_y² ω_y²) of anisotropic GGX, so that
/// Λ(ω) = (a/|μ| − 1)/2 (Heitz 2014, "Understanding the masking-shadowing function": GGX's Λ
/// with the projected roughness α(φ) = √(α_x² cos²φ + α_y² sin²φ) of ω's azimuth).
/// Equal to [`smith_a`] for α_x = α_y and a unit ω.
#[inline]
pub fn smith_a_aniso(w: [f64; 3], alpha_x: f64, alpha_y: f64) -> f64 {
    let (x, y) = (alpha_x * w[0], alpha_y * w[1]);
    (w[2] * w[2] + x * x + y * y).sqrt()
}

/// Relative index of refraction from normal-incidence reflectance, η = (1+√F0)/(1−√F0)
/// (inverse of F0 = ((η−1)/(η+1))²). Returns `f64::INFINITY` for `f0 = 1`.
#[inline]
pub fn eta_from_f0(f0: f64) -> f64 {
    let s = f0.max(0.0).sqrt();
    if s >= 1.0 {
        f64::INFINITY
    } else {
        (1.0 + s) / (1.0 - s)
    }
}

/// `sqrt(μ² + α²(1−μ²))`, the stable core of Smith's Λ for GGX: Λ(μ) = (a/|μ| − 1)/2
/// (Heitz 2014, eq. 72 with tan²θ = (1−μ²)/μ²). Finite at μ = 0, where it equals α.
#[inline]
pub fn smith_a(mu: f64, alpha: f64) -> f64 {
    let mu2 = mu * mu;
    (mu2 + alpha * alpha * (1.0 - mu2)).max(0.0).sqrt()
}

/// GGX Smith Λ(μ) (Heitz 2014, eq. 72). Infinite at μ = 0 (for α > 0).
#[inline]
pub fn smith_lambda(mu: f64, alpha: f64) -> f64 {
    let mu = mu.abs();
    (smith_a(mu, alpha) / mu - 1.0) * 0.5
}

/// Smith G1(μ) = 1/(1+Λ) = 2|μ| / (|μ| + a(μ)) (Heitz 2014, eq. 43), written so that μ = 0 gives 0.
#[inline]
pub fn smith_g1(mu: f64, alpha: f64) -> f64 {
    let mu = mu.abs();
    let den = mu + smith_a(mu, alpha);
    if den > 0.0 {
        2.0 * mu / den
    } else {
        1.0 // α = 0 and μ = 0: the smooth-surface limit
    }
}

/// Which bidirectional shadowing–masking term a model uses.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum SmithForm {
    /// Height-correlated G2 = 1/(1+Λo+Λi) (Heitz 2014, eq. 99), used for reflection and
    /// transmission alike (as pbrt-v4 does).
    #[default]
    HeightCorrelated,
    /// Separable ("uncorrelated") G2 = G1(o)·G1(i) (Heitz 2014, eq. 98); the paper's renderer.
    Separable,
}

impl SmithForm {
    /// G2(o, i) / G1(o): the weight of a visible-normal sample (Heitz 2018, eq. 19),
    /// as a function of μo = |o·n| and μi = |i·n|.
    ///
    /// Height-correlated: (1+Λo)/(1+Λo+Λi) = (μo + ao)·μi / (ao·μi + ai·μo), which stays finite
    /// at μo = 0 and μi = 0 (where it tends to 0).
    #[inline]
    pub fn g2_over_g1(self, mu_o: f64, mu_i: f64, alpha: f64) -> f64 {
        let (mu_o, mu_i) = (mu_o.abs(), mu_i.abs());
        match self {
            SmithForm::Separable => smith_g1(mu_i, alpha),
            SmithForm::HeightCorrelated => {
                let a_o = smith_a(mu_o, alpha);
                let a_i = smith_a(mu_i, alpha);
                let den = a_o * mu_i + a_i * mu_o;
                if den > 0.0 {
                    (mu_o + a_o) * mu_i / den
                } else {
                    // α = 0 with μo = 0 or μi = 0: a measure-zero set; the smooth limit.
                    if mu_i > 0.0 {
                        1.0
                    } else {
                        0.0
                    }
                }
            }
        }
    }

    /// Full G2(o, i) for directions with μo, μi > 0.
    #[inline]
    pub fn g2(self, mu_o: f64, mu_i: f64, alpha: f64) -> f64 {
        self.g2_over_g1(mu_o, mu_i, alpha) * smith_g1(mu_o, alpha)
    }
}

/// GGX normal distribution D(h) for a unit half vector with cosine `cos_h` (Walter 2007, eq. 33).
#[inline]
pub fn ggx_d(cos_h: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let c2 = cos_h * cos_h;
    let t = c2 * (a2 - 1.0) + 1.0;
    a2 / (std::f64::consts::PI * t * t)
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface (Walter 2007, eq. 22),
/// for the cosine `cos_i > 0` of the angle between the incident direction and the microfacet
/// normal and the relative index of refraction `eta` = η_transmitted / η_incident.
/// Returns 1 under total internal reflection and for `eta = ∞` (a perfect mirror).
#[inline]
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    if !eta.is_finite() {
        return 1.0;
    }
    if eta == 1.0 {
        return 0.0; // no interface (F0 = 0): nothing reflects, even at grazing incidence
    }
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0; // tir
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Fresnel reflectance from both cosines (Walter 2007, eq. 22), for integrands that share
/// cos θt with the refraction that needs it anyway (no TIR or η checks: see
/// [`fresnel_dielectric`]).
#[inline]
pub fn fresnel_from_cosines(cos_i: f64, cos_t: f64, eta: f64) -> f64 {
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Mirror reflection of `wo` about `h` (both unit): wi = 2(wo·h)h − wo.
#[inline]
pub fn reflect(wo: [f64; 3], h: [f64; 3]) -> [f64; 3] {
    let c = dot(wo, h);
    [
        2.0 * c * h[0] - wo[0],
        2.0 * c * h[1] - wo[1],
        2.0 * c * h[2] - wo[2],
    ]
}

/// Refraction of `wo` through the microfacet `h` (with wo·h > 0) for relative IOR `eta`
/// (Walter 2007, eq. 40). `None` under total internal reflection.
#[inline]
pub fn refract(wo: [f64; 3], h: [f64; 3], eta: f64) -> Option<[f64; 3]> {
    let c = dot(wo, h);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return None; // tir
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let k = c / eta - cos_t;
    Some([
        -wo[0] / eta + k * h[0],
        -wo[1] / eta + k * h[1],
        -wo[2] / eta + k * h[2],
    ])
}

#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_normal_incidence_matches_f0() {
        for f0 in [0.0125, 0.04, 0.1, 0.25] {
            let eta = eta_from_f0(f0);
            assert!((fresnel_dielectric(1.0, eta) - f0).abs() < 1e-14);
            assert!((fresnel_dielectric(1.0, 1.0 / eta) - f0).abs() < 1e-14);
        }
    }

    #[test]
    fn fresnel_without_interface_is_zero() {
        for c in [0.0, 0.3, 1.0] {
            assert_eq!(fresnel_dielectric(c, 1.0), 0.0);
        }
    }

    #[test]
    fn fresnel_grazing_and_tir() {
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-14);
        // critical angle of 1/1.5: sin θc = 1/1.5
        let cos_c = (1.0f64 - 1.0 / 2.25).sqrt();
        assert_eq!(fresnel_dielectric(cos_c * 0.999, 1.0 / 1.5), 1.0);
        assert!(fresnel_dielectric(cos_c * 1.001, 1.0 / 1.5) < 1.0);
    }

    #[test]
    fn smith_forms_agree_at_normal_incidence_limits() {
        let alpha = 0.3;
        assert!((smith_g1(1.0, alpha) - 1.0).abs() < 1e-15);
        assert_eq!(smith_g1(0.0, alpha), 0.0);
        // height-correlated G2 = 1/(1+Λo+Λi)
        let (mo, mi) = (0.4, 0.7);
        let g2 = 1.0 / (1.0 + smith_lambda(mo, alpha) + smith_lambda(mi, alpha));
        assert!((SmithForm::HeightCorrelated.g2(mo, mi, alpha) - g2).abs() < 1e-14);
        let sep = smith_g1(mo, alpha) * smith_g1(mi, alpha);
        assert!((SmithForm::Separable.g2(mo, mi, alpha) - sep).abs() < 1e-14);
    }

    #[test]
    fn refraction_obeys_snell() {
        let wo = [0.6, 0.0, 0.8];
        let h = [0.0, 0.0, 1.0];
        let wi = refract(wo, h, 1.5).unwrap();
        assert!((wi[0].hypot(wi[1]) - 0.6 / 1.5).abs() < 1e-14);
        assert!(wi[2] < 0.0);
        assert!((dot(wi, wi) - 1.0).abs() < 1e-14);
    }
}
