//! Fit input: scattered points in 1–4 variables, values, optional weights, the domain box, and
//! per-variable input transforms applied before the basis.

use serde::{Deserialize, Serialize};

use super::error::{FitError, Result};

/// Most variables a fit may have (the paper's tables have 2 or 3; the anisotropic conductor 4).
pub const MAX_DIM: usize = 4;

/// Largest |value| a fit accepts (10¹⁰⁰): far beyond any albedo, and small enough that the
/// squares of the errors, their sums over every point and the normal equations stay finite in
/// f64. Larger values are refused with the advice to rescale them.
pub const MAX_VALUE: f64 = 1e100;

/// τ of [`InputTransform::BoundaryLayer`]: 2⁻¹⁰⁰, exact in f32 and f64. It only decides the
/// corner x = y = 0 (t = τ/τ = 1) and changes t by less than τ/(x + k y²) elsewhere, i.e.
/// nowhere a table node or an f32 input away from the corner can see.
pub const LAYER_TAU: f64 = 7.888609052210118e-31;

/// A monotone map applied to a variable before the polynomial basis: the fitted function is
/// P(t)/Q(t) with t_k = transform_k(x). Recorded in every result so the emitted code can apply it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum InputTransform {
    /// t = x
    Identity,
    /// t = √x (x ≥ 0): resolves square-root behaviour at x = 0, e.g. grazing μ.
    Sqrt,
    /// t = 1 − x
    OneMinus,
    /// t = x²
    Square,
    /// t = (clamp(x, lo, hi) − lo)/(hi − lo): the paper's dielectric F0 normalisation
    /// (Sforza & Pellacini 2022, Appendix A, with lo = 0.0125, hi = 0.25).
    ClampNormalize { lo: f64, hi: f64 },
    /// t = (x(1 + k y²) + τ)/(x + k y² + τ), y = variable number `by` (untransformed, earlier
    /// in the variable list), τ = [`LAYER_TAU`]: the boundary-layer coordinate of grazing angles.
    ///
    /// Why: GGX masking depends on the outgoing direction only through a = μ/(α √(1 − μ²))
    /// (Heitz 2014, "Understanding the Masking-Shadowing Function", eqs. 72 and 86), so for
    /// α = r² → 0 the albedo tends to a function of μ/α alone: E(r, c r²) → g(c), with g
    /// from E(μ → 0⁺) (0.936 separable, 1 height-correlated) through a dip (≈ 0.88 at c ≈ 1)
    /// to 1. In (r, μ) that is a layer of width ~α at μ = 0 and a discontinuity at the corner
    /// r = μ = 0, which no polynomial or rational in (r, μ) follows; in (r, t) with x = μ,
    /// y = r it is smooth: t ≈ c k⁻¹/(1 + c k⁻¹) for small r, t = 1 at μ = 1 (the map is onto
    /// [0, 1] for x, y ∈ [0, 1]), and the corner takes the r = 0 value t = 1, as the tables do.
    /// t increases with x and, for x ≤ 1, decreases with y.
    BoundaryLayer { by: usize, k: f64 },
    /// t = (q(clamp(x, lo, hi)) − q(lo))/(q(hi) − q(lo)), q(x) = x^(1/n) + b·x, n = `root` ∈
    /// {2, 4, 8} (the n-th root taken as repeated square roots, in the fit and in emitted
    /// code), b = `linear` ≥ 0 (0 by default: t ∝ x^(1/n)), onto [0, 1] on [lo, hi] ⊂ [0, ∞).
    ///
    /// Why: a dielectric's albedo depends on F0 through η = (1 + √F0)/(1 − √F0) and the
    /// Fresnel factor, steepest at small F0; F0^¼ spreads that end out, so a few powers of
    /// t follow the F0 dependence at every (r, μ) (measurements in docs/fitting.md,
    /// "Structured forms"). A glossy albedo's F0 dependence at each (r, μ) is close to
    /// a + c·F0 + d·ln F0: projected on those three functions of F0, every (r, μ) column of
    /// the 128³ `ggx-glossy` table is off by 4.7e-3 at most (mean 2.0e-4), against 7.9e-3
    /// (1.3e-3) on 1, F0^¼, √F0. With x^(1/n) ≈ 1 + ln(x)/n, q = F0^⅛ + b·F0 carries both in
    /// one coordinate: on 1, t, t² at b = 1/4 it is off by 5.3e-3 (7.1e-4), where F0^⅛ alone
    /// is off by 1.4e-2 (docs/fitting.md, "The F0 variable of the glossy split sum").
    RootNormalize {
        lo: f64,
        hi: f64,
        root: u32,
        #[serde(default, skip_serializing_if = "is_zero")]
        linear: f64,
    },
    /// t = (μ_c(clamp(x, lo, hi)) − μ_c(lo))/(μ_c(hi) − μ_c(lo)), 0 ≤ lo < hi ≤ 1, with
    /// μ_c(F0) = 2·F0^¼/(1 + √F0) the cosine of the critical angle of an interface of normal
    /// reflectance F0 seen from its denser side: with η = (1 + √F0)/(1 − √F0) (Fresnel at
    /// normal incidence), μ_c = √(1 − 1/η²) = 2√s/(1 + s), s = √F0.
    ///
    /// Why: an albedo from inside a dielectric has its total-internal-reflection edge at
    /// μ = μ_c(F0), and its F0 dependence at every (r, μ) follows μ_c rather than F0^¼: a
    /// polynomial of degree 4 in t fitted at each (r, μ) node of the 128³ leaving-dielectric
    /// table is off by 2.8e-3 at most, against 5.2e-3 in F0^¼ (docs/fitting.md, "The F0
    /// variable of the leaving dielectric"). F0^¼ stays the better variable entering
    /// (8.5e-5 against 1.9e-3). In f32 the roots are correctly rounded square roots and the
    /// rest one add, one multiply and one divide of positive numbers.
    CriticalAngle { lo: f64, hi: f64 },
    /// t = ((1 − w)·L + w·x)^(1/n), L = (x(1 + k y²) + τ)/(x + k y² + τ) the boundary-layer
    /// coordinate of [`InputTransform::BoundaryLayer`] (y = variable number `by`, earlier in
    /// the list), 0 ≤ w < 1, n = `root` ∈ {1, 2, 4} (repeated square roots): the grazing-layer
    /// variable of a glossy albedo (w > 0), and with n = 2 of any albedo that also falls like
    /// √μ at grazing angles where α is large.
    ///
    /// Why: L resolves the grazing layer μ ≲ α at small r (for α = r² → 0 it depends on μ/α
    /// only) but maps the whole row r = 0 to t = 1, which is right when E(0, μ) is constant (a
    /// conductor: 1) and wrong for a glossy layer, whose E(0, μ) = F(η, μ) varies. The blend
    /// keeps the layer in t ∈ [0, 1 − w + w·x] and maps the row r = 0 one to one onto
    /// [1 − w, 1] (t = 1 − w + w μ before the root), so both are resolved. For large α the
    /// albedo falls like √μ at μ → 0 while L ≈ μ(1 + k y²)/(k y²) is linear in μ: the root
    /// n = 2 turns that into a linear fall in t. t increases with x and, for x ≤ 1, decreases
    /// with y, onto [0, 1] for x, y ∈ [0, 1]. In f32 every step adds, multiplies, divides or
    /// takes the square root of non-negative numbers, so t carries a few ulp of relative error
    /// (emit's stress test and bound measure it).
    ///
    /// With β = `beta` > 0, x is first replaced by the log-corrected
    /// v = (x + b·λ(x))/(1 + b·λ(1)), b = β y⁴ (β α² for y = r), λ(x) ≈ x·ln(1 + 1/x)
    /// ([`log_term`]). Why: with the height-correlated masking-shadowing
    /// G2 = 1/(1 + Λ(ωo) + Λ(ωi)) (Heitz 2014, eq. 99) and Λ(a) ≈ 1/(2a) as a → 0 (eq. 86 for
    /// GGX), the grazing outgoing direction couples to the grazing incident ones and the albedo
    /// falls like 1 − E ≈ μ·(α ln(1/μ) + D(α)) as μ → 0 (measured with `furnace eval --model
    /// ggx-conductor`: D(1) ≈ 0, D → 0.21/α as α → 0; docs/fitting.md, "The logarithmic
    /// grazing term"), a μ ln μ singularity no polynomial or rational in μ or L follows. v
    /// carries it: v ∝ μ(1 + β α² ln(1/μ)) as μ → 0, and v → x as α → 0, where the layer is
    /// linear in μ/α. v increases with x, v(0) = 0, v(1) = 1.
    GrazingLayer {
        by: usize,
        k: f64,
        w: f64,
        #[serde(default = "one")]
        root: u32,
        #[serde(default, skip_serializing_if = "is_zero")]
        beta: f64,
    },
    /// t = (√(x + s) − √s)/(√(1 + s) − √s), s = k·yᵉ, e = `power` ∈ {2, 3, 4} (y = variable
    /// number `by`, earlier in the list, untransformed: s = kα for y = r and e = 2), computed
    /// without cancellation as t = x·(√(1 + s) + √s)/(√(x + s) + √s + τ), τ = [`LAYER_TAU`]
    /// (only decides 0/0 at x = y = 0, where t = 0): the grazing-layer variable of a glossy
    /// albedo, `slayer:<y>:<k>[:<e>]`.
    ///
    /// Why: a glossy albedo's row r = 0 is the Fresnel factor E(0, μ) = F(η, μ)
    /// (Sforza & Pellacini 2022, eq. 17, with a mirror lobe), smooth in √μ, while at small
    /// r > 0 it bends away from F in a layer μ ≲ α (masking depends on μ/α only; Heitz 2014,
    /// eqs. 72 and 86). Unlike the boundary-layer coordinate L, whose departure from μ reaches
    /// far outside the layer (L → 1 only like 1 − kα/μ), t departs from √μ only where μ ≲ s:
    /// t = √μ exactly at y = 0, t ≈ x·(1 + O(√s))/(2√s) (linear in μ/√α) for x ≪ s, and
    /// t − √x = O(√s) for x ≫ s. t increases with x, decreases with y (from √x to x as
    /// s → ∞), t(0) = 0, t(1) = 1; onto [0, 1] for x ∈ [0, 1]. In f32 every step adds,
    /// multiplies, divides or takes the square root of non-negative numbers.
    ///
    /// A higher e with a larger k keeps the layer thin at small y and widens it at large y
    /// (s = 40 α² against s = α at y = r; docs/fitting.md, "The glossy grazing layer").
    RootLayer {
        by: usize,
        k: f64,
        #[serde(default = "two", skip_serializing_if = "is_two")]
        power: u32,
    },
    /// t = sin²x on x ∈ [0, π/2] (an azimuth): increasing there, 0 at 0, 1 at π/2.
    ///
    /// Why: an albedo of a surface whose roughness is mirror-symmetric about its tangent and
    /// bitangent is even in φ and in π − φ (docs/anisotropy.md, "Symmetries of φ"), so it is a
    /// function of cos 2φ = 1 − 2 sin²φ, and the projected roughness of a direction is
    /// α_t²(1 − (1 − (α_b/α_t)²)·sin²φ) (Heitz 2014, "Understanding the Masking-Shadowing
    /// Function", eq. 80): a polynomial in sin²φ follows both where one in φ needs a degree
    /// per flat end. Emitted code forms it without a sine: (1 + sin u)/2 with u = 2x − π/2 and
    /// sin u by its Taylor series to u¹⁵ ([`sin_squared_series`], within 1e-11 of sin²x).
    SinSquared,
    /// t = L^(1/n), L = (x(1 + k α_o) + τ)/(x + k α_o + τ), the boundary-layer coordinate of
    /// [`InputTransform::BoundaryLayer`] scaled by the projected roughness α_o of the direction
    /// (x = μ = cos θ, azimuth φ = variable `phi`) on an anisotropic GGX surface in OpenPBR's
    /// parametrisation (variables `r` and `aniso`, all three untransformed):
    /// α_t = r²·√(2/(1 + (1 − aniso)²)) (OpenPBR specification, "Microfacet model") and
    /// α_o = α_t·√(1 − (1 − (1 − aniso)²)·sin²φ) (α_o² = α_t² cos²φ + α_b² sin²φ, the projected roughness of Heitz
    /// 2014, eq. 80), n = `root` ∈ {1, 2, 4}.
    ///
    /// Why: Smith masking depends on ωo only through a = μ/(α_o √(1 − μ²)) (Heitz 2014,
    /// eqs. 72 and 86), so the grazing layer of the albedo has the width α_o of the *projected*
    /// roughness, which at strong anisotropy ranges from α_t (φ = 0) to α_b = (1 − aniso)·α_t
    /// (φ = π/2). A layer scaled by r² alone is 20 times too wide along the bitangent at
    /// aniso = 0.95. t increases with x (on [0, 1]) and decreases with α_o.
    ///
    /// With β = `beta` > 0, x is first replaced by the log-corrected
    /// v = (x + b·λ(x))/(1 + b·λ(1)) of [`InputTransform::GrazingLayer`] with b = β α_o² (the
    /// isotropic layer's β α² with α the projected roughness): the μ ln μ fall of the
    /// height-correlated albedo at grazing angles (Heitz 2014, eq. 99), whose weight follows the
    /// roughness the grazing direction sees.
    ProjectedLayer {
        r: usize,
        aniso: usize,
        phi: usize,
        k: f64,
        root: u32,
        #[serde(default, skip_serializing_if = "is_zero")]
        beta: f64,
    },
    /// t = α_o/α_t = √(max(1 − (1 − (1 − aniso)²)·sin²x, (1 − aniso)²)) for an azimuth
    /// x = φ ∈ [0, π/2] (variable `aniso` another, untransformed variable in [0, 1)): the
    /// projected roughness of the direction relative to the tangent's on an anisotropic GGX
    /// surface, α_o² = α_t² cos²φ + α_b² sin²φ with α_b = (1 − aniso)·α_t (Heitz 2014,
    /// "Understanding the Masking-Shadowing Function", eq. 80; OpenPBR specification,
    /// "Microfacet model").
    ///
    /// Why: the albedo follows α_o, and at strong anisotropy α_o/α_t = √(cos²φ + (1 − aniso)² sin²φ)
    /// has a corner of width ~(1 − aniso) at φ = π/2 (it tends to cos φ = √(1 − sin²φ) as
    /// aniso → 1, a square-root end point in sin²φ) that no low-degree polynomial in sin²φ
    /// follows; in t it is linear. t decreases with x from 1 (φ = 0) to 1 − aniso (φ = π/2) and
    /// is 1 at aniso = 0, where the albedo does not depend on φ. The argument of the root is
    /// held ≥ (1 − aniso)², its exact lower bound, so that f32 rounding of sin²φ near 1 never
    /// takes it to 0 or below: t carries a relative error of a few ulp/(1 − aniso)².
    ProjectedRatio { aniso: usize },
}

impl InputTransform {
    /// t_k, the transform of variable `k` at the point `x` (original variables, all of them).
    #[inline]
    pub fn apply(&self, k: usize, x: &[f64]) -> f64 {
        let v = x[k];
        match *self {
            InputTransform::Identity => v,
            // guard: x may round to a tiny negative value at a domain edge of 0
            InputTransform::Sqrt => v.max(0.0).sqrt(),
            InputTransform::OneMinus => 1.0 - v,
            InputTransform::Square => v * v,
            InputTransform::ClampNormalize { lo, hi } => (v.clamp(lo, hi) - lo) / (hi - lo),
            // (a `by` out of range — only in an unvalidated approximant — gives NaN, not a panic)
            InputTransform::BoundaryLayer { by, k: scale } => {
                layer(v, x.get(by).copied().unwrap_or(f64::NAN), scale)
            }
            InputTransform::RootNormalize {
                lo,
                hi,
                root,
                linear,
            } => {
                // (with b = 0, adding 0·x to a root ≥ 0 changes no bit: the plain root's value)
                let q = |x: f64| root_linear(x, root, linear);
                (q(v.clamp(lo, hi)) - q(lo)) / (q(hi) - q(lo))
            }
            InputTransform::GrazingLayer {
                by,
                k: scale,
                w,
                root,
                beta,
            } => grazing(
                v,
                x.get(by).copied().unwrap_or(f64::NAN),
                scale,
                w,
                root,
                beta,
            ),
            InputTransform::RootLayer {
                by,
                k: scale,
                power,
            } => root_layer(v, x.get(by).copied().unwrap_or(f64::NAN), scale, power),
            InputTransform::CriticalAngle { lo, hi } => {
                (critical_cosine(v.clamp(lo, hi)) - critical_cosine(lo))
                    / (critical_cosine(hi) - critical_cosine(lo))
            }
            // guard: x may lie a rounding error outside [0, π/2]
            InputTransform::SinSquared => sin_squared(v),
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k: scale,
                root,
                beta,
            } => {
                let at = |i: usize| x.get(i).copied().unwrap_or(f64::NAN);
                let alpha = projected_alpha(at(r), at(aniso), at(phi));
                let v = if beta > 0.0 {
                    log_corrected(v, beta * alpha * alpha)
                } else {
                    v
                };
                nth_root(layer_scaled(v, scale * alpha), root)
            }
            InputTransform::ProjectedRatio { aniso } => {
                projected_ratio(x.get(aniso).copied().unwrap_or(f64::NAN), v)
            }
        }
    }

    /// The variable `k` with transform(x)_k = t, given the other variables of x already in
    /// original form (only those a layer scales by are read); used to report locations.
    pub fn inverse(&self, k: usize, t: f64, x: &[f64]) -> f64 {
        match *self {
            InputTransform::Identity => t,
            InputTransform::Sqrt => t * t,
            InputTransform::OneMinus => 1.0 - t,
            InputTransform::Square => t.max(0.0).sqrt(),
            InputTransform::ClampNormalize { lo, hi } => lo + t * (hi - lo),
            InputTransform::BoundaryLayer { by, k } => {
                // t (x + s) = x (1 + s) (τ neglected) ⇒ x = t s / (1 + s − t)
                let y = x.get(by).copied().unwrap_or(f64::NAN);
                let s = k * y * y;
                let den = 1.0 + s - t;
                if den > 0.0 {
                    t * s / den
                } else {
                    1.0
                }
            }
            InputTransform::RootNormalize {
                lo,
                hi,
                root,
                linear,
            } => {
                if linear == 0.0 {
                    let (a, b) = (nth_root(lo, root), nth_root(hi, root));
                    let u = a + t * (b - a);
                    (0..root.trailing_zeros()).fold(u, |v, _| v * v)
                } else {
                    // q is increasing on [lo, hi]: bisection (only to report locations)
                    let q = |x: f64| root_linear(x, root, linear);
                    let want = q(lo) + t.clamp(0.0, 1.0) * (q(hi) - q(lo));
                    let (mut a, mut b) = (lo, hi);
                    for _ in 0..60 {
                        let m = 0.5 * (a + b);
                        if q(m) < want {
                            a = m;
                        } else {
                            b = m;
                        }
                    }
                    0.5 * (a + b)
                }
            }
            InputTransform::GrazingLayer {
                by,
                k,
                w,
                root,
                beta,
            } => {
                // t is increasing in x on [0, 1]: bisection (only to report locations)
                let y = x.get(by).copied().unwrap_or(f64::NAN);
                let (mut a, mut b) = (0.0f64, 1.0f64);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if grazing(m, y, k, w, root, beta) < t {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                0.5 * (a + b)
            }
            InputTransform::RootLayer { by, k, power } => {
                // √(x + s) = √s + t·(√(1 + s) − √s) ⇒ x = u² − s, u that root
                let y = x.get(by).copied().unwrap_or(f64::NAN);
                let s = k * layer_power(y, power);
                let u = s.sqrt() + t.clamp(0.0, 1.0) * ((1.0 + s).sqrt() - s.sqrt());
                (u * u - s).clamp(0.0, 1.0)
            }
            InputTransform::CriticalAngle { lo, hi } => {
                // μ_c = 2q/(1 + q²), q = F0^¼ ∈ [0, 1] ⇒ q = (1 − √(1 − μ_c²))/μ_c
                let (a, b) = (critical_cosine(lo), critical_cosine(hi));
                let m = (a + t * (b - a)).clamp(0.0, 1.0);
                let q = if m > 0.0 {
                    (1.0 - (1.0 - m * m).sqrt()) / m
                } else {
                    0.0
                };
                q.powi(4)
            }
            InputTransform::SinSquared => t.clamp(0.0, 1.0).sqrt().asin(),
            InputTransform::ProjectedRatio { aniso } => {
                // t² = 1 − (1 − b²) sin²φ ⇒ sin²φ = (1 − t²)/(1 − b²); any φ at aniso = 0
                let b = 1.0 - x.get(aniso).copied().unwrap_or(f64::NAN);
                let c = 1.0 - b * b;
                if c > 0.0 {
                    ((1.0 - t * t) / c).clamp(0.0, 1.0).sqrt().asin()
                } else {
                    0.0
                }
            }
            InputTransform::ProjectedLayer { .. } => {
                // t is increasing in x on [0, 1]: bisection (only to report locations)
                let (mut a, mut b) = (0.0f64, 1.0f64);
                let mut y = [0.0; MAX_DIM];
                let n = x.len().min(MAX_DIM);
                y[..n].copy_from_slice(&x[..n]);
                if k >= MAX_DIM {
                    return f64::NAN;
                }
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    y[k] = m;
                    if self.apply(k, &y) < t {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                0.5 * (a + b)
            }
        }
    }

    /// The `--transform` syntax of the transforms [`InputTransform::parse_more`] reads.
    pub const MORE_SYNTAX: &'static str =
        "root:<n>:lo:hi[:<b>] (n = 2, 4, 8; t ∝ x^(1/n) + b·x, b ≥ 0), glayer:<variable>:<k>:<w>[:<n>[:<beta>]] (0 ≤ w < 1, n = 1, 2, 4, beta ≥ 0), critical:lo:hi (0 ≤ lo < hi ≤ 1), slayer:<variable>:<k> (k > 0), sin2 (an azimuth in [0, π/2]), player:<r>:<aniso>:<phi>:<k>[:<n>[:<beta>]] (n = 1, 2, 4, beta ≥ 0), pratio:<aniso> (an azimuth in [0, π/2])";

    /// Parses `root:<n>:lo:hi[:<b>]` ([`InputTransform::RootNormalize`]),
    /// `glayer:<variable>:<k>:<w>[:<n>[:<beta>]]` ([`InputTransform::GrazingLayer`]),
    /// `critical:lo:hi` ([`InputTransform::CriticalAngle`]), `slayer:<variable>:<k>`
    /// ([`InputTransform::RootLayer`]), `sin2` ([`InputTransform::SinSquared`]),
    /// `player:<r>:<aniso>:<phi>:<k>[:<n>[:<beta>]]` ([`InputTransform::ProjectedLayer`]) and
    /// `pratio:<aniso>` ([`InputTransform::ProjectedRatio`]) for variable number `k` of `names`; None if `text`
    /// is none of these, an error naming the syntax if it is malformed.
    pub fn parse_more(
        text: &str,
        names: &[String],
        k: usize,
    ) -> Option<std::result::Result<InputTransform, String>> {
        let num = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        if let Some(rest) = text.strip_prefix("root:") {
            let f: Vec<&str> = rest.split(':').collect();
            let parsed = match f.as_slice() {
                [n, lo, hi, more @ ..] if more.len() <= 1 => {
                    let linear = more.first().map_or(Some(0.0), |b| num(b));
                    match (n.trim().parse::<u32>().ok(), num(lo), num(hi), linear) {
                        (Some(root @ (2 | 4 | 8)), Some(lo), Some(hi), Some(linear))
                            if 0.0 <= lo && lo < hi && linear >= 0.0 =>
                        {
                            Some(InputTransform::RootNormalize {
                                lo,
                                hi,
                                root,
                                linear,
                            })
                        }
                        _ => None,
                    }
                }
                _ => None,
            };
            return Some(parsed.ok_or_else(|| {
                "write root:<n>:lo:hi[:<b>] with n = 2, 4 or 8, finite 0 ≤ lo < hi and a finite b ≥ 0, e.g. f0=root:4:0.0125:0.25 or f0=root:8:0.0125:0.25:0.25".to_string()
            }));
        }
        if let Some(rest) = text.strip_prefix("critical:") {
            let parsed = match rest.split(':').collect::<Vec<_>>().as_slice() {
                [lo, hi] => match (num(lo), num(hi)) {
                    (Some(lo), Some(hi)) if 0.0 <= lo && lo < hi && hi <= 1.0 => {
                        Some(InputTransform::CriticalAngle { lo, hi })
                    }
                    _ => None,
                },
                _ => None,
            };
            return Some(parsed.ok_or_else(|| {
                "write critical:lo:hi with finite 0 ≤ lo < hi ≤ 1 (the F0 range), e.g. f0=critical:0.0125:0.25".to_string()
            }));
        }
        if let Some(rest) = text.strip_prefix("glayer:") {
            let f: Vec<&str> = rest.split(':').collect();
            let parsed = match f.as_slice() {
                [by, scale, w, more @ ..] if more.len() <= 2 => {
                    let by = names.iter().position(|n| n == by.trim()).filter(|&b| b < k);
                    let root = match more.first() {
                        Some(n) => n.trim().parse::<u32>().ok(),
                        None => Some(1),
                    };
                    let beta = more.get(1).map_or(Some(0.0), |b| num(b));
                    match (by, num(scale), num(w), root, beta) {
                        (Some(by), Some(scale), Some(w), Some(root @ (1 | 2 | 4)), Some(beta))
                            if scale > 0.0 && (0.0..1.0).contains(&w) && beta >= 0.0 =>
                        {
                            Some(InputTransform::GrazingLayer {
                                by,
                                k: scale,
                                w,
                                root,
                                beta,
                            })
                        }
                        _ => None,
                    }
                }
                _ => None,
            };
            return Some(parsed.ok_or_else(|| {
                "write glayer:<variable>:<k>:<w>[:<n>[:<beta>]] with a variable before this one, a finite k > 0, 0 ≤ w < 1, n = 1, 2 or 4 and a finite beta ≥ 0, e.g. mu=glayer:r:1:0.5 or mu=glayer:r:1:0:1:3".to_string()
            }));
        }
        if let Some(rest) = text.strip_prefix("slayer:") {
            let f: Vec<&str> = rest.split(':').collect();
            let parsed = match f.as_slice() {
                [by, scale] | [by, scale, _] => {
                    let by = names.iter().position(|n| n == by.trim()).filter(|&b| b < k);
                    let power = match f.get(2) {
                        None => Some(2),
                        Some(e) => e.trim().parse::<u32>().ok().filter(|e| (2..=4).contains(e)),
                    };
                    match (by, num(scale), power) {
                        (Some(by), Some(scale), Some(power)) if scale > 0.0 => {
                            Some(InputTransform::RootLayer {
                                by,
                                k: scale,
                                power,
                            })
                        }
                        _ => None,
                    }
                }
                _ => None,
            };
            return Some(parsed.ok_or_else(|| {
                "write slayer:<variable>:<k>[:<e>] with a variable before this one, a finite k > 0 and e = 2, 3 or 4 (the layer's width k·yᵉ; 2 when left out), e.g. mu=slayer:r:1".to_string()
            }));
        }
        if text == "sin2" {
            return Some(Ok(InputTransform::SinSquared));
        }
        if let Some(rest) = text.strip_prefix("player:") {
            let f: Vec<&str> = rest.split(':').collect();
            let find = |v: &str| names.iter().position(|n| n == v.trim()).filter(|&i| i != k);
            let parsed = match f.as_slice() {
                [r, a, p, scale, more @ ..] if more.len() <= 2 => {
                    let root = match more.first() {
                        Some(n) => n.trim().parse::<u32>().ok(),
                        None => Some(1),
                    };
                    let beta = more.get(1).map_or(Some(0.0), |b| num(b));
                    match (find(r), find(a), find(p), num(scale), root, beta) {
                        (
                            Some(r),
                            Some(aniso),
                            Some(phi),
                            Some(scale),
                            Some(root @ (1 | 2 | 4)),
                            Some(beta),
                        ) if scale > 0.0 && beta >= 0.0 => Some(InputTransform::ProjectedLayer {
                            r,
                            aniso,
                            phi,
                            k: scale,
                            root,
                            beta,
                        }),
                        _ => None,
                    }
                }
                _ => None,
            };
            return Some(parsed.ok_or_else(|| {
                "write player:<r>:<aniso>:<phi>:<k>[:<n>[:<beta>]] with three other variables, a finite k > 0, n = 1, 2 or 4 and a finite beta ≥ 0, e.g. mu=player:r:aniso:phi:2:2 or mu=player:r:aniso:phi:2:2:3".to_string()
            }));
        }
        if let Some(rest) = text.strip_prefix("pratio:") {
            let aniso = names
                .iter()
                .position(|n| n == rest.trim())
                .filter(|&i| i != k);
            return Some(aniso.map(|aniso| InputTransform::ProjectedRatio { aniso }).ok_or_else(|| {
                "write pratio:<aniso> with another variable, the anisotropy in [0, 1), e.g. phi=pratio:aniso".to_string()
            }));
        }
        None
    }

    /// Short name for reports and file names ("sqrt", "one_minus", "layer:#0:1", …); see
    /// [`InputTransform::label`] for one with variable names.
    pub fn name(&self) -> String {
        match *self {
            InputTransform::Identity => "identity".into(),
            InputTransform::Sqrt => "sqrt".into(),
            InputTransform::OneMinus => "one_minus".into(),
            InputTransform::Square => "square".into(),
            InputTransform::ClampNormalize { lo, hi } => format!("clamp_normalize({lo}, {hi})"),
            InputTransform::BoundaryLayer { by, k } => format!("layer:#{by}:{k}"),
            InputTransform::RootNormalize {
                lo,
                hi,
                root,
                linear,
            } => format!("root:{root}:{lo}:{hi}{}", positive_suffix(linear)),
            InputTransform::GrazingLayer {
                by,
                k,
                w,
                root,
                beta,
            } => format!("glayer:#{by}:{k}:{w}:{root}{}", positive_suffix(beta)),
            InputTransform::CriticalAngle { lo, hi } => format!("critical:{lo}:{hi}"),
            InputTransform::RootLayer { by, k, power } => {
                format!("slayer:#{by}:{k}{}", power_suffix(power))
            }
            InputTransform::SinSquared => "sin2".into(),
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k,
                root,
                beta,
            } => format!(
                "player:#{r}:#{aniso}:#{phi}:{k}:{root}{}",
                positive_suffix(beta)
            ),
            InputTransform::ProjectedRatio { aniso } => format!("pratio:#{aniso}"),
        }
    }

    /// [`InputTransform::name`] with variable names: `layer:r:1` (the `--transform` syntax).
    pub fn label(&self, names: &[String]) -> String {
        match *self {
            InputTransform::BoundaryLayer { by, k } => match names.get(by) {
                Some(n) => format!("layer:{n}:{k}"),
                None => self.name(),
            },
            InputTransform::GrazingLayer {
                by,
                k,
                w,
                root,
                beta,
            } => match names.get(by) {
                Some(n) => format!("glayer:{n}:{k}:{w}:{root}{}", positive_suffix(beta)),
                None => self.name(),
            },
            InputTransform::RootLayer { by, k, power } => match names.get(by) {
                Some(n) => format!("slayer:{n}:{k}{}", power_suffix(power)),
                None => self.name(),
            },
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k,
                root,
                beta,
            } => match (names.get(r), names.get(aniso), names.get(phi)) {
                (Some(r), Some(a), Some(p)) => {
                    format!("player:{r}:{a}:{p}:{k}:{root}{}", positive_suffix(beta))
                }
                _ => self.name(),
            },
            InputTransform::ProjectedRatio { aniso } => match names.get(aniso) {
                Some(a) => format!("pratio:{a}"),
                None => self.name(),
            },
            _ => self.name(),
        }
    }

    /// The transform of variable `k` as a formula in the variable names: `sqrt(mu)`, or for a
    /// boundary layer `(mu*(1 + 1*r*r) + 2^-100)/(mu + 1*r*r + 2^-100)`.
    pub fn formula(&self, k: usize, names: &[String]) -> String {
        let x = names.get(k).map_or("x", String::as_str);
        match *self {
            InputTransform::Identity => x.to_string(),
            InputTransform::BoundaryLayer { by, k: scale } => {
                let y = names.get(by).map_or("y", String::as_str);
                format!("({x}*(1 + {scale}*{y}*{y}) + 2^-100)/({x} + {scale}*{y}*{y} + 2^-100)")
            }
            InputTransform::RootNormalize {
                lo,
                hi,
                root,
                linear,
            } => {
                let x = if x.chars().all(|c| c.is_alphanumeric() || c == '_') {
                    x.to_string()
                } else {
                    format!("({x})")
                };
                if linear == 0.0 {
                    format!("(clamp({x}, {lo}, {hi})^(1/{root}) - {lo}^(1/{root}))/({hi}^(1/{root}) - {lo}^(1/{root}))")
                } else {
                    format!("(q(clamp({x}, {lo}, {hi})) - q({lo}))/(q({hi}) - q({lo})), q(z) = z^(1/{root}) + {linear}*z")
                }
            }
            InputTransform::CriticalAngle { lo, hi } => {
                let x = if x.chars().all(|c| c.is_alphanumeric() || c == '_') {
                    x.to_string()
                } else {
                    format!("({x})")
                };
                let (a, b) = (critical_cosine(lo), critical_cosine(hi));
                format!("(2*q/(1 + q*q) - {a})/({b} - {a}), q = clamp({x}, {lo}, {hi})^(1/4)")
            }
            InputTransform::GrazingLayer {
                by,
                k: scale,
                w,
                root,
                beta,
            } => {
                let y = names.get(by).map_or("y", String::as_str);
                let (v, def) = if beta > 0.0 {
                    let n = LOG_ROOT_ORDER;
                    (
                        "v".to_string(),
                        format!(
                            " with v = ({x} + b*l({x}))/(1 + b*l(1)), b = {beta}*{y}^4, l(z) = {n}*z^({m}/{n})*((1 + z)^(1/{n}) - z^(1/{n}))",
                            m = n - 1
                        ),
                    )
                } else {
                    (x.to_string(), String::new())
                };
                format!(
                    "({}*({v}*(1 + {scale}*{y}*{y}) + 2^-100)/({v} + {scale}*{y}*{y} + 2^-100) + {w}*{v})^(1/{root}){def}",
                    1.0 - w
                )
            }
            InputTransform::RootLayer {
                by,
                k: scale,
                power,
            } => {
                let y = names.get(by).map_or("y", String::as_str);
                let ys = vec![y; power as usize].join("*");
                format!("{x}*(sqrt(1 + s) + sqrt(s))/(sqrt({x} + s) + sqrt(s) + 2^-100), s = {scale}*{ys}")
            }
            InputTransform::SinSquared => format!("sin({x})^2"),
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k: scale,
                root,
                beta,
            } => {
                let n = |i: usize| names.get(i).map_or("y", String::as_str);
                let (r, a, p) = (n(r), n(aniso), n(phi));
                let alpha = format!(
                    "{r}*{r}*sqrt(2/(1 + (1 - {a})^2))*sqrt(1 - (1 - (1 - {a})^2)*sin({p})^2)"
                );
                if beta > 0.0 {
                    let n = LOG_ROOT_ORDER;
                    format!(
                        "((v*(1 + {scale}*a_o) + 2^-100)/(v + {scale}*a_o + 2^-100))^(1/{root}) with a_o = {alpha}, v = ({x} + b*l({x}))/(1 + b*l(1)), b = {beta}*a_o^2, l(z) = {n}*z^({m}/{n})*((1 + z)^(1/{n}) - z^(1/{n}))",
                        m = n - 1
                    )
                } else {
                    format!(
                        "(({x}*(1 + {scale}*{alpha}) + 2^-100)/({x} + {scale}*{alpha} + 2^-100))^(1/{root})"
                    )
                }
            }
            InputTransform::ProjectedRatio { aniso } => {
                let a = names.get(aniso).map_or("y", String::as_str);
                format!("sqrt(max(1 - (1 - (1 - {a})^2)*sin({x})^2, (1 - {a})^2))")
            }
            _ => format!("{}({x})", self.name()),
        }
    }

    /// Checks the transform of variable `k` is defined and monotone on the box `domain`
    /// (one [lo, hi] per variable) and returns the image interval of t_k.
    pub fn image(&self, k: usize, names: &[String], domain: &[(f64, f64)]) -> Result<(f64, f64)> {
        let (lo, hi) = domain[k];
        let bad = |reason: &'static str| FitError::InvalidTransform {
            transform: self.label(names),
            name: names.get(k).cloned().unwrap_or_default(),
            lo,
            hi,
            reason,
        };
        let (ta, tb) = match *self {
            InputTransform::Sqrt if lo < 0.0 => return Err(bad("sqrt needs a domain with x ≥ 0")),
            InputTransform::Square if lo < 0.0 => return Err(bad(
                "x² is not monotone on a domain containing negative x; shift the variable first",
            )),
            InputTransform::ClampNormalize { lo: a, hi: b }
                if !(a.is_finite() && b.is_finite() && a < b) =>
            {
                return Err(bad("clamp_normalize needs finite bounds lo < hi"))
            }
            InputTransform::RootNormalize {
                lo: a,
                hi: b,
                root,
                linear,
            } => {
                if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b) {
                    return Err(bad("root_normalize needs finite bounds 0 ≤ lo < hi"));
                }
                if !(linear.is_finite() && linear >= 0.0) {
                    return Err(bad("root_normalize needs a finite linear weight b ≥ 0"));
                }
                if !matches!(root, 2 | 4 | 8) {
                    return Err(bad("root_normalize takes the 2nd, 4th or 8th root (repeated square roots); use clamp:lo:hi for the identity"));
                }
                let at = |v: f64| {
                    let mut x = [0.0; MAX_DIM];
                    x[0] = v;
                    self.apply(0, &x)
                };
                (at(lo), at(hi))
            }
            InputTransform::CriticalAngle { lo: a, hi: b }
                if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b && b <= 1.0) =>
            {
                return Err(bad(
                    "critical needs finite bounds 0 ≤ lo < hi ≤ 1 (an F0 range)",
                ));
            }
            InputTransform::GrazingLayer {
                by,
                k: scale,
                w,
                root,
                beta,
            } => {
                if !(0.0..1.0).contains(&w) {
                    return Err(bad("a grazing layer needs a blend weight 0 ≤ w < 1"));
                }
                if !matches!(root, 1 | 2 | 4) {
                    return Err(bad("a grazing layer takes the root n = 1, 2 or 4"));
                }
                if !(beta >= 0.0 && beta.is_finite()) {
                    return Err(bad("a grazing layer needs a finite log weight beta ≥ 0"));
                }
                let inner = InputTransform::BoundaryLayer { by, k: scale };
                inner.image(k, names, domain)?;
                let (ylo, yhi) = domain[by];
                // v increases with x and with b = β y⁴ (for x ≤ 1), the rest increases with v
                // and decreases with y: bounds from the smallest and largest b on the box
                let y4 = |y: f64| y.powi(4);
                let (b_min, b_max) = if ylo <= 0.0 && yhi >= 0.0 {
                    (0.0, beta * y4(ylo).max(y4(yhi)))
                } else {
                    let (a, b) = (beta * y4(ylo), beta * y4(yhi));
                    (a.min(b), a.max(b))
                };
                (
                    grazing_of(log_corrected(lo, b_min), yhi, scale, w, root),
                    grazing_of(log_corrected(hi, b_max), ylo, scale, w, root),
                )
            }
            InputTransform::RootLayer {
                by,
                k: scale,
                power,
            } => {
                if by >= domain.len() || by == k {
                    return Err(bad("a root layer needs another variable to scale by"));
                }
                if !(scale > 0.0 && scale.is_finite()) {
                    return Err(bad("a root layer needs a finite scale k > 0"));
                }
                if !(2..=4).contains(&power) {
                    return Err(bad("a root layer's width k·yᵉ needs e = 2, 3 or 4"));
                }
                let (ylo, yhi) = domain[by];
                if !(lo >= 0.0 && hi.is_finite() && ylo.is_finite() && yhi.is_finite()) {
                    return Err(bad(
                        "a root layer needs x ≥ 0 and a finite variable to scale by",
                    ));
                }
                // t increases with x and decreases with s = k yᵉ: bounds at the extreme s (a
                // root layer over a negative y needs an even e)
                if power % 2 == 1 && ylo < 0.0 {
                    return Err(bad(
                        "a root layer with an odd power e needs a variable to scale by that is ≥ 0",
                    ));
                }
                let (y2min, y2max) = if ylo <= 0.0 && yhi >= 0.0 {
                    (0.0, layer_power(ylo, power).max(layer_power(yhi, power)))
                } else {
                    let (a, b) = (layer_power(ylo, power), layer_power(yhi, power));
                    (a.min(b), a.max(b))
                };
                (
                    root_layer_of(lo, scale * y2max),
                    root_layer_of(hi, scale * y2min),
                )
            }
            InputTransform::SinSquared => {
                if !(lo >= 0.0 && hi <= std::f64::consts::FRAC_PI_2) {
                    return Err(bad(
                        "sin² is increasing only on [0, π/2]; reduce the azimuth to it by its symmetries",
                    ));
                }
                (sin_squared(lo), sin_squared(hi))
            }
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k: scale,
                root,
                beta,
            } => {
                let d = domain.len();
                if [r, aniso, phi].iter().any(|&i| i >= d || i == k)
                    || r == aniso
                    || r == phi
                    || aniso == phi
                {
                    return Err(bad(
                        "a projected layer needs three other, distinct variables r, aniso and phi",
                    ));
                }
                if !(scale > 0.0 && scale.is_finite()) {
                    return Err(bad("a projected layer needs a finite scale k > 0"));
                }
                if !matches!(root, 1 | 2 | 4) {
                    return Err(bad("a projected layer takes the root n = 1, 2 or 4"));
                }
                if !(beta >= 0.0 && beta.is_finite()) {
                    return Err(bad("a projected layer needs a finite log weight beta ≥ 0"));
                }
                if !(lo >= 0.0 && hi <= 1.0) {
                    return Err(bad(
                        "a projected layer needs 0 ≤ x ≤ 1 (it is monotone there)",
                    ));
                }
                let (rl, rh) = domain[r];
                let (al, ah) = domain[aniso];
                let (pl, ph) = domain[phi];
                if !(rl >= 0.0 && rh.is_finite() && al >= 0.0 && ah < 1.0 && pl >= 0.0)
                    || ph > std::f64::consts::FRAC_PI_2
                {
                    return Err(bad(
                        "a projected layer needs r ≥ 0, 0 ≤ aniso < 1 and phi in [0, π/2]",
                    ));
                }
                // α_o is monotone in each of r, aniso and φ: its extremes lie at corners
                let mut amin = f64::INFINITY;
                let mut amax = 0.0f64;
                for rr in [rl, rh] {
                    for aa in [al, ah] {
                        for pp in [pl, ph] {
                            let a = projected_alpha(rr, aa, pp);
                            amin = amin.min(a);
                            amax = amax.max(a);
                        }
                    }
                }
                // v increases with x and with b = β α_o² (for x ≤ 1), t increases with v and
                // decreases with α_o: bounds from the smallest v at the largest α_o and back
                let v = |x: f64, a: f64| {
                    if beta > 0.0 {
                        log_corrected(x, beta * a * a)
                    } else {
                        x
                    }
                };
                let (vlo, vhi) = (v(lo, amin), v(hi, amax));
                (
                    nth_root(layer_scaled(vlo, scale * amax), root),
                    nth_root(layer_scaled(vhi, scale * amin), root),
                )
            }
            InputTransform::ProjectedRatio { aniso } => {
                if aniso >= domain.len() || aniso == k {
                    return Err(bad(
                        "a projected ratio needs another variable, the anisotropy aniso",
                    ));
                }
                let (al, ah) = domain[aniso];
                if !(al >= 0.0 && ah < 1.0) {
                    return Err(bad(
                        "a projected ratio needs 0 ≤ aniso < 1 (α_b = (1 − aniso)·α_t > 0)",
                    ));
                }
                if !(lo >= 0.0 && hi <= std::f64::consts::FRAC_PI_2) {
                    return Err(bad(
                        "a projected ratio is monotone only for an azimuth in [0, π/2]; reduce the azimuth to it by its symmetries",
                    ));
                }
                // decreasing in φ and in aniso: extremes at opposite corners
                (projected_ratio(ah, hi), projected_ratio(al, lo))
            }
            InputTransform::BoundaryLayer { by, k: scale } => {
                if by >= k {
                    return Err(bad(
                        "a boundary layer scales by a variable that comes before it (e.g. mu by r)",
                    ));
                }
                if !(scale > 0.0 && scale.is_finite()) {
                    return Err(bad("a boundary layer needs a finite scale k > 0"));
                }
                if !(lo >= 0.0 && hi <= 1.0) {
                    return Err(bad(
                        "a boundary layer needs 0 ≤ x ≤ 1 (it is monotone there)",
                    ));
                }
                let (ylo, yhi) = domain[by];
                if ylo < 0.0 {
                    return Err(bad(
                        "a boundary layer needs the variable it scales by to be ≥ 0",
                    ));
                }
                // increasing in x, decreasing in y (x ≤ 1): the extremes are at opposite corners
                (layer(lo, yhi, scale), layer(hi, ylo, scale))
            }
            _ => {
                let at = |v: f64| {
                    let mut x = [0.0; MAX_DIM];
                    x[0] = v;
                    self.apply(0, &x)
                };
                (at(lo), at(hi))
            }
        };
        let (t0, t1) = if ta <= tb { (ta, tb) } else { (tb, ta) };
        if !(t0 < t1) {
            return Err(bad("the transform maps the whole domain to a single value; adjust its bounds or the domain"));
        }
        Ok((t0, t1))
    }
}

/// [`InputTransform::BoundaryLayer`]: t = (x(1 + k y²) + τ)/(x + k y² + τ).
#[inline]
fn layer(x: f64, y: f64, k: f64) -> f64 {
    let s = k * y * y;
    (x * (1.0 + s) + LAYER_TAU) / (x + s + LAYER_TAU)
}

/// [`InputTransform::RootLayer`]: t = x·(√(1 + s) + √s)/(√(x + s) + √s + τ), s = k yᵉ.
#[inline]
fn root_layer(x: f64, y: f64, k: f64, e: u32) -> f64 {
    root_layer_of(x, k * layer_power(y, e))
}

/// yᵉ of a root layer's width, e ∈ {2, 3, 4}, by multiplications left to right (y·y, y·y·y,
/// y·y·y·y), as the emitted code forms it.
#[inline]
fn layer_power(y: f64, e: u32) -> f64 {
    (1..e).fold(y, |p, _| p * y)
}

/// (√(x + s) − √s)/(√(1 + s) − √s) without cancellation, x clamped to ≥ 0, τ =
/// [`LAYER_TAU`] deciding 0/0 at x = s = 0.
#[inline]
fn root_layer_of(x: f64, s: f64) -> f64 {
    let x = x.max(0.0);
    let rs = s.sqrt();
    x * ((1.0 + s).sqrt() + rs) / ((x + s).sqrt() + rs + LAYER_TAU)
}

/// [`InputTransform::GrazingLayer`]: t = ((1 − w)·L(v, y) + w·v)^(1/n), v the log-corrected x
/// ([`log_corrected`], b = β y⁴; v = x for β = 0).
#[inline]
fn grazing(x: f64, y: f64, k: f64, w: f64, n: u32, beta: f64) -> f64 {
    let v = if beta > 0.0 {
        log_corrected(x, beta * (y * y) * (y * y))
    } else {
        x
    };
    grazing_of(v, y, k, w, n)
}

/// ((1 − w)·L(v, y) + w·v)^(1/n).
#[inline]
fn grazing_of(v: f64, y: f64, k: f64, w: f64, n: u32) -> f64 {
    nth_root((1.0 - w) * layer(v, y, k) + w * v, n)
}

/// Order n of the logarithm in [`log_term`]: ln z ≈ n·(z^(1/n) − 1) (the Box–Cox transform,
/// → ln z as n → ∞), z^(1/16) by four square roots. Measured on the height-correlated
/// conductor's tensor 2,3/2,2 (docs/fitting.md, "The logarithmic grazing term"): the same
/// off-grid max as the exact logarithm within 4 %.
pub const LOG_ROOT_ORDER: u32 = 16;

/// Below this x, [`log_term`] takes its root s = x^(1/16) at x = 2⁻⁶⁴ (s = 1/16) and is linear
/// in x, λ(x) = x·λ(2⁻⁶⁴)/2⁻⁶⁴ to 1e-19: keeps s ≥ 1/16 so that in f32 a flushed subnormal x
/// (an absolute error < 2⁻¹²⁶) moves s by a relative 2⁻⁵⁸, not by its 16th root (emit's error
/// bound follows it). The albedo differs from 1 by ~1e-18 there.
pub const LOG_FLOOR: f64 = 5.421010862427522e-20;

/// λ(x) = n·x^((n−1)/n)·((1 + x)^(1/n) − x^(1/n)) = n·x·((1 + 1/x)^(1/n) − 1), n =
/// [`LOG_ROOT_ORDER`]: x·ln(1 + 1/x) with the logarithm in Box–Cox form, by square roots,
/// products and one division only (no logarithm, and no 0·∞ at x = 0: λ(0) = 0). Increasing
/// on [0, ∞): the secant slope ((1 + z)^(1/n) − 1)/z of a concave power decreases with
/// z = 1/x. With q = (1 + x)^(1/16), s = x^(1/16) and q¹⁶ − s¹⁶ = 1, it is
/// λ(x) = 16·x/(s·(q + s)(q² + s²)(q⁴ + s⁴)(q⁸ + s⁸)): products and sums of non-negative terms
/// only (no cancellation), so in f32 λ keeps a small relative error down to x = 0; s is taken
/// at max(x, [`LOG_FLOOR`]).
#[inline]
pub fn log_term(x: f64) -> f64 {
    let x = x.max(0.0);
    let s = nth_root(x.max(LOG_FLOOR), LOG_ROOT_ORDER);
    let q = nth_root(1.0 + x, LOG_ROOT_ORDER);
    let (s2, q2) = (s * s, q * q);
    let (s4, q4) = (s2 * s2, q2 * q2);
    let (s8, q8) = (s4 * s4, q4 * q4);
    LOG_ROOT_ORDER as f64 * x / (s * (q + s) * (q2 + s2) * (q4 + s4) * (q8 + s8))
}

/// v = (x + b·λ(x))/(1 + b·λ(1)) ([`log_term`]): 0 at x = 0, 1 at x = 1, increasing in x, and
/// for x ≤ 1 in b.
#[inline]
pub fn log_corrected(x: f64, b: f64) -> f64 {
    (x + b * log_term(x)) / (1.0 + b * log_term(1.0))
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// `:<x>` after a transform's name when its optional weight x (a grazing layer's β, a root's
/// linear b) is > 0; nothing for 0, the default, so that names without it stay as they are.
fn positive_suffix(x: f64) -> String {
    if x > 0.0 {
        format!(":{x}")
    } else {
        String::new()
    }
}

/// The boundary-layer coordinate with the scale s given: (x(1 + s) + τ)/(x + s + τ).
#[inline]
fn layer_scaled(x: f64, s: f64) -> f64 {
    (x * (1.0 + s) + LAYER_TAU) / (x + s + LAYER_TAU)
}

/// sin²φ with φ clamped to [0, π/2] (the transform [`InputTransform::SinSquared`]).
#[inline]
fn sin_squared(phi: f64) -> f64 {
    phi.clamp(0.0, std::f64::consts::FRAC_PI_2).sin().powi(2)
}

/// Coefficients c_j = (−1)^j/(2j + 1)! of sin u = u·Σ_j c_j u^(2j), j = 0 … 7 (the Taylor
/// series to u¹⁵; on |u| ≤ π/2 the remainder is below (π/2)¹⁷/17! = 6.0e-12): with
/// u = 2φ − π/2, sin²φ = (1 + sin u)/2, how emitted code forms [`InputTransform::SinSquared`].
pub fn sin_squared_series() -> [f64; 8] {
    let mut c = [0.0; 8];
    let mut f = 1.0;
    for (j, cj) in c.iter_mut().enumerate() {
        if j > 0 {
            f *= ((2 * j) * (2 * j + 1)) as f64;
        }
        *cj = if j % 2 == 0 { 1.0 / f } else { -1.0 / f };
    }
    c
}

/// α_o/α_t = √(max(1 − (1 − b²)·sin²φ, b²)), b = 1 − aniso ([`InputTransform::ProjectedRatio`]):
/// the projected roughness relative to the tangent's (Heitz 2014, eq. 80).
#[inline]
pub fn projected_ratio(aniso: f64, phi: f64) -> f64 {
    let b = 1.0 - aniso;
    (1.0 - (1.0 - b * b) * sin_squared(phi)).max(b * b).sqrt()
}

/// The projected roughness α_o of the azimuth φ on OpenPBR's anisotropic GGX:
/// α_t = r²·√(2/(1 + (1 − aniso)²)) (OpenPBR specification, "Microfacet model") and
/// α_o = α_t·√(1 − (1 − (1 − aniso)²)·sin²φ) (the projected roughness, Heitz 2014, eq. 80).
#[inline]
fn projected_alpha(r: f64, aniso: f64, phi: f64) -> f64 {
    let b = 1.0 - aniso;
    let alpha_t = r * r * (2.0 / (1.0 + b * b)).sqrt();
    alpha_t * (1.0 - (1.0 - b * b) * sin_squared(phi)).max(0.0).sqrt()
}

fn one() -> u32 {
    1
}

fn two() -> u32 {
    2
}

fn is_two(e: &u32) -> bool {
    *e == 2
}

/// `:<e>` after a root layer's name when e ≠ 2 (nothing otherwise, as before e existed).
fn power_suffix(e: u32) -> String {
    if e == 2 {
        String::new()
    } else {
        format!(":{e}")
    }
}

/// μ_c(F0) = 2q/(1 + q²), q = F0^¼ (two square roots, as emitted code takes it), F0 ∈ [0, 1]:
/// the cosine of the critical angle √(1 − 1/η²) with η = (1 + √F0)/(1 − √F0)
/// ([`InputTransform::CriticalAngle`]).
#[inline]
pub fn critical_cosine(f0: f64) -> f64 {
    let q = f0.max(0.0).sqrt().sqrt();
    2.0 * q / (1.0 + q * q)
}

/// x^(1/n) for n = 2, 4, 8 by repeated square roots (what emitted code computes); x ≥ 0.
#[inline]
fn nth_root(x: f64, n: u32) -> f64 {
    (0..n.trailing_zeros()).fold(x.max(0.0), |v, _| v.sqrt())
}

/// q(x) = x^(1/n) + b·x of [`InputTransform::RootNormalize`], b = `linear` ≥ 0, in the order
/// emitted code adds them.
#[inline]
fn root_linear(x: f64, n: u32, linear: f64) -> f64 {
    nth_root(x, n) + linear * x
}

/// The transformed coordinates t of the point x (original variables) into `t`.
#[inline]
pub fn transform_point(transforms: &[InputTransform], x: &[f64], t: &mut [f64]) {
    for (k, tr) in transforms.iter().enumerate() {
        t[k] = tr.apply(k, x);
    }
}

/// The original coordinates of the transformed point t (inverses taken in variable order,
/// so a boundary layer finds the variable it scales by already inverted).
pub fn inverse_point(transforms: &[InputTransform], t: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; t.len()];
    // a projected layer reads its azimuth, which may come after it: inverted last; a projected
    // ratio (an azimuth) reads its anisotropy: inverted after the plain variables
    let pass_of = |tr: &InputTransform| match tr {
        InputTransform::ProjectedLayer { .. } => 2,
        InputTransform::ProjectedRatio { .. } => 1,
        _ => 0,
    };
    for pass in 0..3 {
        for (k, tr) in transforms.iter().enumerate() {
            if pass_of(tr) == pass {
                x[k] = tr.inverse(k, t[k], &x);
            }
        }
    }
    x
}

/// The box of transformed coordinates that contains the image of `domain`, checking that every
/// transform is defined and monotone there.
pub fn transformed_box(
    names: &[String],
    domain: &[(f64, f64)],
    transforms: &[InputTransform],
) -> Result<Vec<(f64, f64)>> {
    if transforms.len() != domain.len() {
        return Err(FitError::ShapeMismatch {
            what: "input transforms",
            expected: domain.len(),
            got: transforms.len(),
            fix: "give one transform per variable (InputTransform::Identity for none)",
        });
    }
    (0..domain.len())
        .map(|k| transforms[k].image(k, names, domain))
        .collect()
}

/// Scattered data to fit: `coords` holds `names.len()` coordinates per point, row-major.
/// A grid is just points (see [`FitData::from_grid`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitData {
    pub names: Vec<String>,
    pub coords: Vec<f64>,
    pub values: Vec<f64>,
    /// Optional non-negative weights multiplying each residual (None = all 1).
    pub weights: Option<Vec<f64>>,
    /// The box [lo, hi] per variable the fit must be valid on (poles are excluded on all of it).
    pub domain: Vec<(f64, f64)>,
}

impl FitData {
    /// Builds and validates a data set.
    pub fn new(
        names: Vec<String>,
        coords: Vec<f64>,
        values: Vec<f64>,
        domain: Vec<(f64, f64)>,
    ) -> Result<FitData> {
        let data = FitData {
            names,
            coords,
            values,
            weights: None,
            domain,
        };
        data.validate()?;
        Ok(data)
    }

    /// Data on the tensor grid `axes[0] × axes[1] × …`, values row-major (last axis fastest);
    /// the domain is each axis' [min, max].
    pub fn from_grid(names: Vec<String>, axes: &[Vec<f64>], values: Vec<f64>) -> Result<FitData> {
        let d = axes.len();
        if d == 0 || d > MAX_DIM {
            return Err(FitError::BadDimension {
                got: d,
                max: MAX_DIM,
            });
        }
        let n: usize = axes.iter().map(Vec::len).product();
        if values.len() != n {
            return Err(FitError::ShapeMismatch {
                what: "grid values",
                expected: n,
                got: values.len(),
                fix: "supply one value per grid node, last axis fastest",
            });
        }
        let mut coords = Vec::with_capacity(n * d);
        let mut idx = vec![0usize; d];
        for _ in 0..n {
            for k in 0..d {
                coords.push(axes[k][idx[k]]);
            }
            for k in (0..d).rev() {
                idx[k] += 1;
                if idx[k] < axes[k].len() {
                    break;
                }
                idx[k] = 0;
            }
        }
        let domain = axes
            .iter()
            .map(|a| {
                a.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                        (lo.min(x), hi.max(x))
                    })
            })
            .collect();
        FitData::new(names, coords, values, domain)
    }

    /// Attaches weights (validated).
    pub fn with_weights(mut self, weights: Vec<f64>) -> Result<FitData> {
        self.weights = Some(weights);
        self.validate()?;
        Ok(self)
    }

    pub fn dim(&self) -> usize {
        self.names.len()
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Coordinates of point i.
    pub fn point(&self, i: usize) -> &[f64] {
        let d = self.dim();
        &self.coords[i * d..(i + 1) * d]
    }

    /// Weight of point i (1 without weights).
    pub fn weight(&self, i: usize) -> f64 {
        self.weights.as_ref().map_or(1.0, |w| w[i])
    }

    /// Number of points with non-zero weight.
    pub fn n_weighted(&self) -> usize {
        self.weights
            .as_ref()
            .map_or(self.len(), |w| w.iter().filter(|&&x| x > 0.0).count())
    }

    /// A deterministic pseudo-random subset of `min(m, len)` points in their original order,
    /// with the same domain (the same selection sampling as the rational fits' exploration set).
    pub fn subsample(&self, m: usize) -> Result<FitData> {
        let n = self.len();
        if n <= m {
            return Ok(self.clone());
        }
        let d = self.dim();
        let mut rng = SplitMix64(0x05EE_DF17_u64);
        let (mut coords, mut values) = (Vec::with_capacity(m * d), Vec::with_capacity(m));
        let mut weights = self.weights.as_ref().map(|_| Vec::with_capacity(m));
        for i in 0..n {
            if values.len() == m {
                break;
            }
            // Knuth TAOCP vol. 2, Algorithm 3.4.2 S: select with probability (m − chosen)/(n − i)
            if ((n - i) as f64) * rng.next_f64() < (m - values.len()) as f64 {
                coords.extend_from_slice(self.point(i));
                values.push(self.values[i]);
                if let Some(w) = weights.as_mut() {
                    w.push(self.weight(i));
                }
            }
        }
        let data = FitData {
            names: self.names.clone(),
            coords,
            values,
            weights,
            domain: self.domain.clone(),
        };
        data.validate()?;
        Ok(data)
    }

    /// Checks shapes, finiteness, weights and that every point lies in the domain.
    pub fn validate(&self) -> Result<()> {
        let d = self.dim();
        if d == 0 || d > MAX_DIM {
            return Err(FitError::BadDimension {
                got: d,
                max: MAX_DIM,
            });
        }
        let n = self.values.len();
        if self.coords.len() != n * d {
            return Err(FitError::ShapeMismatch {
                what: "coordinates",
                expected: n * d,
                got: self.coords.len(),
                fix: "give one coordinate per variable per value, row-major",
            });
        }
        if self.domain.len() != d {
            return Err(FitError::ShapeMismatch {
                what: "domain",
                expected: d,
                got: self.domain.len(),
                fix: "give one [lo, hi] interval per variable",
            });
        }
        if let Some(k) = (1..d).find(|&k| self.names[..k].contains(&self.names[k])) {
            return Err(FitError::DuplicateVariable {
                name: self.names[k].clone(),
            });
        }
        for (k, &(lo, hi)) in self.domain.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(FitError::InvalidDomain {
                    name: self.names[k].clone(),
                    lo,
                    hi,
                });
            }
        }
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            return Err(FitError::NonFinite {
                what: "value",
                index: i,
                value: self.values[i],
            });
        }
        if let Some(i) = self.values.iter().position(|v| v.abs() > MAX_VALUE) {
            return Err(FitError::ValueTooLarge {
                what: "value",
                index: i,
                value: self.values[i],
                max: MAX_VALUE,
            });
        }
        for (j, &x) in self.coords.iter().enumerate() {
            let (i, k) = (j / d, j % d);
            if !x.is_finite() {
                return Err(FitError::NonFinite {
                    what: "coordinate of point",
                    index: i,
                    value: x,
                });
            }
            let (lo, hi) = self.domain[k];
            if x < lo || x > hi {
                return Err(FitError::OutsideDomain {
                    index: i,
                    name: self.names[k].clone(),
                    value: x,
                    lo,
                    hi,
                });
            }
        }
        if let Some(w) = &self.weights {
            if w.len() != n {
                return Err(FitError::ShapeMismatch {
                    what: "weights",
                    expected: n,
                    got: w.len(),
                    fix: "give one weight per value",
                });
            }
            if let Some(i) = w.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(FitError::InvalidWeight {
                    index: i,
                    value: w[i],
                });
            }
        }
        Ok(())
    }
}

/// The affine map t ∈ [lo, hi] ↦ s = (t − c)/h ∈ [−1, 1] of one transformed variable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AxisScale {
    pub lo: f64,
    pub hi: f64,
    pub center: f64,
    pub half: f64,
}

impl AxisScale {
    pub fn new(lo: f64, hi: f64) -> AxisScale {
        AxisScale {
            lo,
            hi,
            center: 0.5 * (lo + hi),
            half: 0.5 * (hi - lo),
        }
    }
}

/// Data prepared for solving: transformed and scaled coordinates s ∈ [−1, 1]^d, values, weights.
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    pub d: usize,
    pub s: Vec<f64>,
    pub y: Vec<f64>,
    pub w: Vec<f64>,
    pub scales: Vec<AxisScale>,
}

impl Prepared {
    pub fn new(data: &FitData, transforms: &[InputTransform]) -> Result<Prepared> {
        data.validate()?;
        let d = data.dim();
        if transforms.len() != d {
            return Err(FitError::ShapeMismatch {
                what: "input transforms",
                expected: d,
                got: transforms.len(),
                fix: "give one transform per variable (InputTransform::Identity for none)",
            });
        }
        let scales: Vec<AxisScale> = transformed_box(&data.names, &data.domain, transforms)?
            .into_iter()
            .map(|(a, b)| AxisScale::new(a, b))
            .collect();
        let mut s = Vec::with_capacity(data.coords.len());
        for i in 0..data.len() {
            let x = data.point(i);
            for (k, sc) in scales.iter().enumerate() {
                // clamp: rounding in the transform may step a hair outside [−1, 1]
                s.push(((transforms[k].apply(k, x) - sc.center) / sc.half).clamp(-1.0, 1.0));
            }
        }
        let w = (0..data.len()).map(|i| data.weight(i)).collect();
        Ok(Prepared {
            d,
            s,
            y: data.values.clone(),
            w,
            scales,
        })
    }

    pub fn len(&self) -> usize {
        self.y.len()
    }

    pub fn point(&self, i: usize) -> &[f64] {
        &self.s[i * self.d..(i + 1) * self.d]
    }

    pub fn n_weighted(&self) -> usize {
        self.w.iter().filter(|&&x| x > 0.0).count()
    }

    /// A deterministic pseudo-random subset of `m` points (selection sampling, Knuth TAOCP
    /// vol. 2, Algorithm 3.4.2 S, driven by SplitMix64), in their original order; `None` if the
    /// data has no more than `m` points. Random rather than strided so grids do not alias.
    pub fn subsample(&self, m: usize) -> Option<Prepared> {
        let n = self.len();
        if n <= m {
            return None;
        }
        let mut rng = SplitMix64(0x05EE_DF17_u64);
        let mut out = Prepared {
            d: self.d,
            s: Vec::with_capacity(m * self.d),
            y: Vec::with_capacity(m),
            w: Vec::with_capacity(m),
            scales: self.scales.clone(),
        };
        let mut chosen = 0usize;
        for i in 0..n {
            let u = rng.next_f64();
            if ((n - i) as f64) * u < (m - chosen) as f64 {
                out.s.extend_from_slice(self.point(i));
                out.y.push(self.y[i]);
                out.w.push(self.w[i]);
                chosen += 1;
                if chosen == m {
                    break;
                }
            }
        }
        Some(out)
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny deterministic generator for subsampling.
pub(crate) struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_row_major_last_axis_fastest() {
        let d = FitData::from_grid(
            vec!["a".into(), "b".into()],
            &[vec![0.0, 1.0], vec![10.0, 20.0, 30.0]],
            vec![0.0; 6],
        )
        .unwrap();
        assert_eq!(d.point(0), &[0.0, 10.0]);
        assert_eq!(d.point(2), &[0.0, 30.0]);
        assert_eq!(d.point(3), &[1.0, 10.0]);
        assert_eq!(d.domain, vec![(0.0, 1.0), (10.0, 30.0)]);
    }

    #[test]
    fn validation_names_the_problem() {
        let e = FitData::new(
            vec!["x".into()],
            vec![0.0, f64::NAN],
            vec![1.0, 2.0],
            vec![(0.0, 1.0)],
        )
        .unwrap_err();
        assert!(matches!(e, FitError::NonFinite { index: 1, .. }), "{e}");
        let e = FitData::new(
            vec!["x".into()],
            vec![0.0, 2.0],
            vec![1.0, 2.0],
            vec![(0.0, 1.0)],
        )
        .unwrap_err();
        assert!(e.to_string().contains("widen the domain"), "{e}");
        let e = FitData::new(vec!["x".into()], vec![0.0], vec![1.0], vec![(1.0, 1.0)]).unwrap_err();
        assert!(matches!(e, FitError::InvalidDomain { .. }));
        let e = FitData::new(vec!["x".into()], vec![0.0], vec![1.0], vec![(0.0, 1.0)])
            .unwrap()
            .with_weights(vec![-1.0])
            .unwrap_err();
        assert!(matches!(e, FitError::InvalidWeight { .. }));
    }

    #[test]
    fn values_beyond_the_largest_magnitude_and_repeated_names_are_refused() {
        let grid = |names: [&str; 2], values: Vec<f64>| {
            FitData::from_grid(
                names.iter().map(|n| n.to_string()).collect(),
                &[vec![0.0, 1.0], vec![0.0, 1.0]],
                values,
            )
        };
        assert!(grid(["r", "mu"], vec![0.5, -MAX_VALUE, MAX_VALUE, 0.5]).is_ok());
        for v in [1e300, -1e308, 1.0001e100] {
            let e = grid(["r", "mu"], vec![0.5, 0.5, v, 0.5]).unwrap_err();
            assert!(matches!(e, FitError::ValueTooLarge { index: 2, .. }), "{e}");
            assert!(e.to_string().contains("rescale the values"), "{e}");
        }
        let e = grid(["r", "r"], vec![0.5; 4]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "variable 'r' is named twice; give every variable its own name"
        );
    }

    #[test]
    fn transforms_and_inverses() {
        let f = InputTransform::ClampNormalize {
            lo: 0.0125,
            hi: 0.25,
        };
        assert_eq!(f.apply(0, &[0.0125]), 0.0);
        assert_eq!(f.apply(0, &[0.25]), 1.0);
        assert_eq!(f.apply(0, &[0.5]), 1.0);
        assert!((f.inverse(0, f.apply(0, &[0.1]), &[0.0]) - 0.1).abs() < 1e-15);
        let x = vec!["x".to_string()];
        assert_eq!(
            InputTransform::OneMinus
                .image(0, &x, &[(0.0, 0.5)])
                .unwrap(),
            (0.5, 1.0)
        );
        assert!(InputTransform::Sqrt.image(0, &x, &[(-1.0, 1.0)]).is_err());
    }

    #[test]
    fn sin_squared_series_and_transform() {
        // the series the emitted code uses, (1 + u·Σ c_j u^(2j))/2, u = 2φ − π/2, is within
        // 1e-11 of sin²φ on [0, π/2] (remainder ≤ (π/2)¹⁷/17! = 6.0e-12)
        let c = sin_squared_series();
        assert_eq!(c[0], 1.0);
        assert_eq!(c[1], -1.0 / 6.0);
        assert_eq!(c[7], -1.0 / 1_307_674_368_000.0);
        let mut worst = 0.0f64;
        for i in 0..=1000 {
            let phi = std::f64::consts::FRAC_PI_2 * i as f64 / 1000.0;
            let u = 2.0 * phi - std::f64::consts::FRAC_PI_2;
            let h = c.iter().rev().fold(0.0, |h, &cj| h * u * u + cj);
            let series = 0.5 + 0.5 * u * h;
            let t = InputTransform::SinSquared.apply(0, &[phi]);
            assert_eq!(t, phi.sin().powi(2));
            worst = worst.max((series - t).abs());
        }
        assert!(worst < 1e-11, "{worst:e}");
        let names = vec!["phi".to_string()];
        let tr = InputTransform::SinSquared;
        assert_eq!(
            tr.image(0, &names, &[(0.0, std::f64::consts::FRAC_PI_2)])
                .unwrap(),
            (0.0, 1.0)
        );
        // sin² is not monotone past π/2: refused with the fix
        let e = tr.image(0, &names, &[(0.0, 3.0)]).unwrap_err().to_string();
        assert!(e.contains("[0, π/2]"), "{e}");
        let phi = 0.7;
        assert!((tr.inverse(0, tr.apply(0, &[phi]), &[0.0]) - phi).abs() < 1e-12);
        assert_eq!(
            InputTransform::parse_more("sin2", &names, 0),
            Some(Ok(InputTransform::SinSquared))
        );
    }

    #[test]
    fn projected_layer_transform() {
        let names: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let tr = InputTransform::parse_more("player:r:aniso:phi:2:2", &names, 2)
            .unwrap()
            .unwrap();
        assert_eq!(
            tr,
            InputTransform::ProjectedLayer {
                r: 0,
                aniso: 1,
                phi: 3,
                k: 2.0,
                root: 2,
                beta: 0.0
            }
        );
        assert_eq!(tr.label(&names), "player:r:aniso:phi:2:2");
        assert!(InputTransform::parse_more("player:r:aniso:mu:2", &names, 2)
            .unwrap()
            .is_err());
        // aniso = 0: the isotropic layer √L(μ; r) with k·α = k·r² (BoundaryLayer scales by k·y²)
        let iso = InputTransform::GrazingLayer {
            by: 0,
            k: 2.0,
            w: 0.0,
            root: 2,
            beta: 0.0,
        };
        for (r, mu, phi) in [(0.3, 0.1, 0.0), (0.7, 0.02, 1.2), (1.0, 0.5, 0.4)] {
            let x = [r, 0.0, mu, phi];
            assert!((tr.apply(2, &x) - iso.apply(2, &x)).abs() < 1e-15);
        }
        // α_o = α_t along the tangent, α_b = (1 − aniso)·α_t along the bitangent (OpenPBR axes)
        let (r, a) = (0.8, 0.9);
        let alpha_t = r * r * (2.0 / (1.0 + 0.1f64 * 0.1)).sqrt();
        assert!((projected_alpha(r, a, 0.0) - alpha_t).abs() < 1e-15);
        let along_b = projected_alpha(r, a, std::f64::consts::FRAC_PI_2);
        assert!((along_b - 0.1 * alpha_t).abs() < 1e-12, "{along_b}");
        // α_o² = α_t² cos²φ + α_b² sin²φ at an off-axis azimuth
        let phi: f64 = 0.61;
        let want = (alpha_t.powi(2) * phi.cos().powi(2)
            + (0.1 * alpha_t).powi(2) * phi.sin().powi(2))
        .sqrt();
        assert!((projected_alpha(r, a, phi) - want).abs() < 1e-14);
        // the image on the box contains every value on it, and the inverse finds μ again
        let dom = [
            (0.0, 1.0),
            (0.0, 0.95),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ];
        let (lo, hi) = tr.image(2, &names, &dom).unwrap();
        assert!(
            lo >= 0.0 && hi <= 1.0 && lo < 0.01 && hi == 1.0,
            "{lo} {hi}"
        );
        let mut rng = SplitMix64(7);
        for _ in 0..200 {
            let x: Vec<f64> = dom
                .iter()
                .map(|&(a, b)| a + (b - a) * rng.next_f64())
                .collect();
            let t = tr.apply(2, &x);
            assert!((lo..=hi).contains(&t), "{x:?} {t}");
            let back = inverse_point(
                &[
                    InputTransform::Identity,
                    InputTransform::Identity,
                    tr,
                    InputTransform::SinSquared,
                ],
                &[x[0], x[1], t, InputTransform::SinSquared.apply(3, &x)],
            );
            assert!((back[2] - x[2]).abs() < 1e-9 && (back[3] - x[3]).abs() < 1e-9);
        }
        // a domain the layer is not monotone on is refused with the fix
        let mut wide = dom;
        wide[3] = (0.0, 3.0);
        let e = tr.image(2, &names, &wide).unwrap_err().to_string();
        assert!(e.contains("phi in [0, π/2]"), "{e}");
    }

    #[test]
    fn projected_layer_log_term() {
        let names: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let tr = InputTransform::parse_more("player:r:aniso:phi:2:2:3", &names, 2)
            .unwrap()
            .unwrap();
        assert_eq!(tr.label(&names), "player:r:aniso:phi:2:2:3");
        let plain = InputTransform::parse_more("player:r:aniso:phi:2:2", &names, 2)
            .unwrap()
            .unwrap();
        assert!(
            InputTransform::parse_more("player:r:aniso:phi:2:2:-1", &names, 2)
                .unwrap()
                .is_err()
        );
        // aniso = 0: the isotropic grazing layer with the same β (b = β α², α = r²)
        let iso = InputTransform::GrazingLayer {
            by: 0,
            k: 2.0,
            w: 0.0,
            root: 2,
            beta: 3.0,
        };
        for (r, mu, phi) in [(0.3, 0.1, 0.0), (0.7, 0.002, 1.2), (1.0, 0.5, 0.4)] {
            let x = [r, 0.0, mu, phi];
            assert!((tr.apply(2, &x) - iso.apply(2, &x)).abs() < 1e-14);
        }
        // the weight follows α_o: along the smooth bitangent at strong anisotropy b = β α_b²
        // is small, and the log-corrected μ is v = (μ + b λ(μ))/(1 + b λ(1)) there
        let x = [1.0, 0.9, 1e-3, std::f64::consts::FRAC_PI_2];
        let ao = projected_alpha(1.0, 0.9, x[3]);
        let v = log_corrected(1e-3, 3.0 * ao * ao);
        let want = layer_scaled(v, 2.0 * ao).sqrt();
        assert!((tr.apply(2, &x) - want).abs() < 1e-15);
        // μ ln μ: the slope of t² near μ = 0 grows like ln(1/μ) relative to the plain layer
        let x1 = [1.0, 0.5, 1e-6, 0.3];
        let x2 = [1.0, 0.5, 1e-8, 0.3];
        let ratio = |x: &[f64]| tr.apply(2, x).powi(2) / plain.apply(2, x).powi(2);
        assert!(ratio(&x2) > ratio(&x1) && ratio(&x1) > 1.0);
        // β = 0 is the plain layer, and serialises without the field
        assert_eq!(
            serde_json::to_string(&plain).unwrap(),
            r#"{"kind":"projected_layer","r":0,"aniso":1,"phi":3,"k":2.0,"root":2}"#
        );
        // the image holds every value on the box, and the ends μ = 0, 1 map to the image's ends
        let dom = [
            (0.0, 1.0),
            (0.0, 0.95),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ];
        let (lo, hi) = tr.image(2, &names, &dom).unwrap();
        assert_eq!(hi, 1.0);
        let mut rng = SplitMix64(11);
        for _ in 0..400 {
            let mut x: Vec<f64> = dom
                .iter()
                .map(|&(a, b)| a + (b - a) * rng.next_f64())
                .collect();
            x[2] = x[2].powi(6); // into the layer
            let t = tr.apply(2, &x);
            assert!((lo..=hi).contains(&t), "{x:?} {t}");
            let back = inverse_point(
                &[
                    InputTransform::Identity,
                    InputTransform::Identity,
                    tr,
                    InputTransform::Identity,
                ],
                &[x[0], x[1], t, x[3]],
            );
            assert!((back[2] - x[2]).abs() < 1e-12, "{x:?} {back:?}");
        }
    }

    #[test]
    fn projected_ratio_transform() {
        let names: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let tr = InputTransform::parse_more("pratio:aniso", &names, 3)
            .unwrap()
            .unwrap();
        assert_eq!(tr, InputTransform::ProjectedRatio { aniso: 1 });
        assert_eq!(tr.label(&names), "pratio:aniso");
        assert!(InputTransform::parse_more("pratio:phi", &names, 3)
            .unwrap()
            .is_err());
        assert!(InputTransform::parse_more("pratio:nope", &names, 3)
            .unwrap()
            .is_err());
        let half_pi = std::f64::consts::FRAC_PI_2;
        // exactly α_o/α_t: 1 along the tangent, 1 − aniso along the bitangent, and
        // √(cos²φ + (1 − aniso)² sin²φ) between (Heitz 2014, eq. 80)
        for a in [0.0, 0.3, 0.9, 0.95, 0.99] {
            assert_eq!(tr.apply(3, &[0.5, a, 0.5, 0.0]), 1.0);
            let b = 1.0 - a;
            assert!((tr.apply(3, &[0.5, a, 0.5, half_pi]) - b).abs() < 1e-15);
            for phi in [0.2f64, 0.8, 1.37, 1.5] {
                let want = (phi.cos().powi(2) + b * b * phi.sin().powi(2)).sqrt();
                let t = tr.apply(3, &[0.5, a, 0.5, phi]);
                assert!((t - want).abs() < 1e-15, "{a} {phi}");
                let alpha_t = projected_alpha(0.5, a, 0.0);
                assert!((t * alpha_t - projected_alpha(0.5, a, phi)).abs() < 1e-15);
            }
        }
        // aniso = 0: no dependence on φ
        assert_eq!(tr.apply(3, &[0.5, 0.0, 0.5, 1.1]), 1.0);
        // the argument of the root stays ≥ (1 − aniso)² when sin²φ is rounded above 1 (as f32
        // code may round it): here with sin²φ = 1 + 2⁻²³ the plain formula gives a negative
        // argument at aniso → 1 but the transform gives 1 − aniso
        let (a, s) = (0.999f64, 1.0 + f64::from(f32::EPSILON));
        let b = 1.0 - a;
        assert!(1.0 - (1.0 - b * b) * s < b * b);
        assert_eq!((1.0 - (1.0 - b * b) * s).max(b * b).sqrt(), b);
        // decreasing in φ and in aniso; the image is [1 − max aniso, 1] on [0, π/2]
        let dom = [(0.0, 1.0), (0.0, 0.95), (0.0, 1.0), (0.0, half_pi)];
        let (lo, hi) = tr.image(3, &names, &dom).unwrap();
        assert!((lo - 0.05).abs() < 1e-15 && hi == 1.0, "{lo} {hi}");
        let mut rng = SplitMix64(5);
        for _ in 0..500 {
            let (a, p) = (0.95 * rng.next_f64(), half_pi * rng.next_f64());
            let t = tr.apply(3, &[0.5, a, 0.5, p]);
            assert!((lo..=hi).contains(&t));
            assert!(tr.apply(3, &[0.5, a, 0.5, p + 1e-3]) < t);
            assert!(tr.apply(3, &[0.5, a + 1e-3, 0.5, p]) < t);
            // the inverse finds φ again, with a projected layer of μ read after it
            let trs = [
                InputTransform::Identity,
                InputTransform::Identity,
                InputTransform::ProjectedLayer {
                    r: 0,
                    aniso: 1,
                    phi: 3,
                    k: 2.0,
                    root: 2,
                    beta: 0.0,
                },
                tr,
            ];
            let x = [0.6, a, 0.2, p];
            let mut t4 = [0.0; 4];
            transform_point(&trs, &x, &mut t4);
            let back = inverse_point(&trs, &t4);
            assert!(
                (back[3] - p).abs() < 1e-6 && (back[2] - 0.2).abs() < 1e-6,
                "{back:?}"
            );
        }
        // refused: an azimuth beyond π/2, aniso reaching 1, or no anisotropy variable
        let mut wide = dom;
        wide[3] = (0.0, 3.0);
        let e = tr.image(3, &names, &wide).unwrap_err().to_string();
        assert!(e.contains("[0, π/2]"), "{e}");
        let mut one = dom;
        one[1] = (0.0, 1.0);
        let e = tr.image(3, &names, &one).unwrap_err().to_string();
        assert!(e.contains("aniso < 1"), "{e}");
        let e = InputTransform::ProjectedRatio { aniso: 3 }
            .image(3, &names, &dom)
            .unwrap_err()
            .to_string();
        assert!(e.contains("another variable"), "{e}");
    }

    #[test]
    fn boundary_layer_transform() {
        let names = vec!["r".to_string(), "mu".to_string()];
        let bl = InputTransform::BoundaryLayer { by: 0, k: 1.0 };
        let t = |r: f64, mu: f64| bl.apply(1, &[r, mu]);
        // ends: μ = 1 ↦ 1 for every r, μ = 0 ↦ 0 for r > 0, r = 0 ↦ 1 (μ > 0 and the corner)
        for r in [1e-6, 0.1, 0.5, 1.0] {
            assert!(
                (t(r, 1.0) - 1.0).abs() < 1e-15 && t(r, 0.0) < 1e-18,
                "r = {r}"
            );
        }
        assert_eq!(t(0.0, 0.0), 1.0);
        assert_eq!(t(0.0, 1e-9), 1.0);
        // the similarity variable: for small r, t depends on μ/r² only (t ≈ c/(1 + c))
        for c in [0.1, 1.0, 10.0] {
            let (a, b) = (t(1e-3, c * 1e-6), t(1e-4, c * 1e-8));
            assert!(
                (a - c / (1.0 + c)).abs() < 1e-5 && (a - b).abs() < 1e-5,
                "c = {c}: {a} {b}"
            );
        }
        // monotone: increasing in μ, decreasing in r; the image of the unit square is [0, 1]
        assert!(t(0.3, 0.2) < t(0.3, 0.21) && t(0.3, 0.2) > t(0.31, 0.2));
        let (lo, hi) = bl.image(1, &names, &[(0.0, 1.0), (0.0, 1.0)]).unwrap();
        assert!(lo <= LAYER_TAU && hi == 1.0, "({lo}, {hi})");
        let (lo, hi) = bl.image(1, &names, &[(0.035, 1.0), (0.02, 1.0)]).unwrap();
        assert!((lo - t(1.0, 0.02)).abs() < 1e-16 && (hi - 1.0).abs() < 1e-15);
        // inverse
        for (r, mu) in [(0.2, 0.3), (1.0, 0.01), (0.05, 0.9)] {
            let x = inverse_point(&[InputTransform::Identity, bl], &[r, t(r, mu)]);
            assert!(
                (x[0] - r).abs() < 1e-15 && (x[1] - mu).abs() < 1e-12,
                "{x:?}"
            );
        }
        // refused: scaling by a later variable, μ outside [0, 1], negative r, k ≤ 0
        let later = InputTransform::BoundaryLayer { by: 1, k: 1.0 };
        assert!(later
            .image(0, &names, &[(0.0, 1.0), (0.0, 1.0)])
            .unwrap_err()
            .to_string()
            .contains("comes before"));
        assert!(bl.image(1, &names, &[(0.0, 1.0), (0.0, 2.0)]).is_err());
        assert!(bl.image(1, &names, &[(-1.0, 1.0), (0.0, 1.0)]).is_err());
        assert!(InputTransform::BoundaryLayer { by: 0, k: 0.0 }
            .image(1, &names, &[(0.0, 1.0), (0.0, 1.0)])
            .is_err());
    }

    /// q = x^(1/n) + b·x: onto [0, 1], clamped, the formula's value, inverted, refused with a
    /// negative or non-finite b, parsed from its fourth field, and b = 0 neither written nor
    /// changing a bit of the plain root.
    #[test]
    fn root_normalize_with_a_linear_term() {
        let f = InputTransform::RootNormalize {
            lo: 0.0125,
            hi: 0.25,
            root: 8,
            linear: 0.25,
        };
        assert_eq!(f.apply(0, &[0.0125]), 0.0);
        assert_eq!(f.apply(0, &[0.25]), 1.0);
        assert_eq!(f.apply(0, &[0.9]), 1.0, "clamped");
        let q = |x: f64| x.powf(0.125) + 0.25 * x;
        let want = (q(0.1) - q(0.0125)) / (q(0.25) - q(0.0125));
        assert!((f.apply(0, &[0.1]) - want).abs() < 1e-15);
        for x in [0.0125, 0.02, 0.1, 0.2499] {
            assert!(
                (f.inverse(0, f.apply(0, &[x]), &[0.0]) - x).abs() < 1e-14,
                "{x}"
            );
        }
        let names = ["f0", "r", "mu"].map(String::from).to_vec();
        assert_eq!(
            f.image(0, &names, &[(0.0125, 0.25), (0.0, 1.0), (0.0, 1.0)])
                .unwrap(),
            (0.0, 1.0)
        );
        for linear in [-0.1, f64::NAN, f64::INFINITY] {
            let bad = InputTransform::RootNormalize {
                lo: 0.0125,
                hi: 0.25,
                root: 8,
                linear,
            };
            assert!(bad.image(0, &names, &[(0.0125, 0.25)]).is_err(), "{bad:?}");
        }
        assert_eq!(
            InputTransform::parse_more("root:8:0.0125:0.25:0.25", &names, 0).unwrap(),
            Ok(f)
        );
        assert_eq!(f.name(), "root:8:0.0125:0.25:0.25");
        for bad in [
            "root:8:0.0125:0.25:-1",
            "root:8:0.0125:0.25:x",
            "root:8:0:1:1:1",
        ] {
            assert!(
                InputTransform::parse_more(bad, &names, 0).unwrap().is_err(),
                "{bad}"
            );
        }
        let json = serde_json::to_string(&f).unwrap();
        assert!(json.contains("\"linear\":0.25"), "{json}");
        assert_eq!(serde_json::from_str::<InputTransform>(&json).unwrap(), f);
        // b = 0: the plain root's text, JSON and bits
        let plain = InputTransform::RootNormalize {
            lo: 0.0125,
            hi: 0.25,
            root: 8,
            linear: 0.0,
        };
        let json = serde_json::to_string(&plain).unwrap();
        assert!(!json.contains("linear"), "{json}");
        assert_eq!(plain.name(), "root:8:0.0125:0.25");
        let r = |x: f64| x.sqrt().sqrt().sqrt();
        let bits = (r(0.1) - r(0.0125)) / (r(0.25) - r(0.0125));
        assert_eq!(plain.apply(0, &[0.1]).to_bits(), bits.to_bits());
    }

    #[test]
    fn root_normalize_transform() {
        let f = InputTransform::RootNormalize {
            lo: 0.0125,
            hi: 0.25,
            root: 4,
            linear: 0.0,
        };
        assert_eq!(f.apply(0, &[0.0125]), 0.0);
        assert_eq!(f.apply(0, &[0.25]), 1.0);
        assert_eq!(f.apply(0, &[0.9]), 1.0, "clamped");
        let want = (0.1f64.powf(0.25) - 0.0125f64.powf(0.25))
            / (0.25f64.powf(0.25) - 0.0125f64.powf(0.25));
        assert!((f.apply(0, &[0.1]) - want).abs() < 1e-15);
        assert!((f.inverse(0, f.apply(0, &[0.1]), &[0.0]) - 0.1).abs() < 1e-15);
        let x = vec!["f0".to_string()];
        assert_eq!(f.image(0, &x, &[(0.0125, 0.25)]).unwrap(), (0.0, 1.0));
        for bad in [
            InputTransform::RootNormalize {
                lo: 0.0,
                hi: 1.0,
                root: 3,
                linear: 0.0,
            },
            InputTransform::RootNormalize {
                lo: -0.1,
                hi: 1.0,
                root: 2,
                linear: 0.0,
            },
        ] {
            assert!(bad.image(0, &x, &[(0.0, 1.0)]).is_err(), "{bad:?}");
        }
        let names = ["f0", "r", "mu"].map(String::from).to_vec();
        assert_eq!(
            InputTransform::parse_more("root:4:0.0125:0.25", &names, 0).unwrap(),
            Ok(f)
        );
        assert!(InputTransform::parse_more("root:3:0:1", &names, 0)
            .unwrap()
            .is_err());
        assert!(InputTransform::parse_more("cube", &names, 0).is_none());
    }

    #[test]
    fn critical_angle_transform() {
        let f = InputTransform::CriticalAngle {
            lo: 0.0125,
            hi: 0.25,
        };
        // μ_c = √(1 − 1/η²), η = (1 + √F0)/(1 − √F0): F0 = 0.04 is η = 1.5, F0 = 0.25 is η = 3
        let eta = |f0: f64| (1.0 + f0.sqrt()) / (1.0 - f0.sqrt());
        for f0 in [0.0125, 0.04, 0.1, 0.25, 0.7] {
            let want = (1.0 - 1.0 / (eta(f0) * eta(f0))).sqrt();
            assert!((critical_cosine(f0) - want).abs() < 1e-15, "F0 {f0}");
        }
        assert!((critical_cosine(0.04) - 5.0f64.sqrt() / 3.0).abs() < 1e-15);
        assert!((critical_cosine(0.25) - 8.0f64.sqrt() / 3.0).abs() < 1e-15);
        assert_eq!(critical_cosine(0.0), 0.0);
        assert_eq!(critical_cosine(1.0), 1.0);
        // onto [0, 1] over [lo, hi], clamped outside, increasing, inverse to 1e-14
        assert_eq!(f.apply(0, &[0.0125]), 0.0);
        assert_eq!(f.apply(0, &[0.25]), 1.0);
        assert_eq!(f.apply(0, &[0.9]), 1.0, "clamped");
        assert_eq!(f.apply(0, &[0.001]), 0.0, "clamped");
        let mut last = -1.0;
        for i in 0..=100 {
            let f0 = 0.0125 + 0.2375 * i as f64 / 100.0;
            let t = f.apply(0, &[f0]);
            assert!(t > last, "increasing at {f0}");
            last = t;
            assert!(
                (f.inverse(0, t, &[0.0]) - f0).abs() < 1e-14,
                "inverse at {f0}"
            );
        }
        let x = vec!["f0".to_string()];
        assert_eq!(f.image(0, &x, &[(0.0125, 0.25)]).unwrap(), (0.0, 1.0));
        for (lo, hi) in [(-0.1, 0.25), (0.2, 0.1), (0.0, 1.5), (0.1, f64::NAN)] {
            let bad = InputTransform::CriticalAngle { lo, hi };
            assert!(bad.image(0, &x, &[(0.0125, 0.25)]).is_err(), "{bad:?}");
        }
        let names = ["f0", "r", "mu"].map(String::from).to_vec();
        assert_eq!(
            InputTransform::parse_more("critical:0.0125:0.25", &names, 0).unwrap(),
            Ok(f)
        );
        for bad in [
            "critical:0.3:0.2",
            "critical:0:2",
            "critical:0.1",
            "critical:a:b",
        ] {
            let e = InputTransform::parse_more(bad, &names, 0)
                .unwrap()
                .unwrap_err();
            assert!(e.contains("critical:lo:hi"), "{bad}: {e}");
        }
        assert_eq!(f.label(&names), "critical:0.0125:0.25");
    }

    #[test]
    fn root_layer_is_sqrt_mu_on_the_mirror_row_and_linear_inside_the_layer() {
        let names = ["f0", "r", "mu"].map(String::from).to_vec();
        let g = InputTransform::RootLayer {
            by: 1,
            k: 1.0,
            power: 2,
        };
        let t = |r: f64, mu: f64| g.apply(2, &[0.1, r, mu]);
        // r = 0: √μ to rounding (τ = 2⁻¹⁰⁰ is below √μ's last bit for μ ≥ 1e-12)
        for mu in [1e-12, 1e-4, 0.01, 0.3, 0.5, 1.0] {
            assert!(
                (t(0.0, mu) - mu.sqrt()).abs() <= 1e-15 * mu.sqrt(),
                "μ = {mu}"
            );
        }
        assert_eq!(t(0.0, 0.0), 0.0, "0/0 at the corner decided by τ");
        // the definition (√(μ + s) − √s)/(√(1 + s) − √s), s = k r², where it does not cancel
        for (r, mu) in [(0.3, 0.2), (1.0, 0.5), (0.1, 0.05), (0.7, 1.0)] {
            let s: f64 = r * r;
            let want = ((mu + s).sqrt() - s.sqrt()) / ((1.0 + s).sqrt() - s.sqrt());
            assert!((t(r, mu) - want).abs() < 1e-14, "r {r}, μ {mu}");
        }
        // onto [0, 1] at every r; increasing in μ, decreasing in r
        for r in [0.0, 0.01, 0.1, 0.5, 1.0] {
            assert_eq!(t(r, 0.0), 0.0);
            assert!((t(r, 1.0) - 1.0).abs() < 1e-15, "r {r}");
            let mut last = -1.0;
            for i in 0..=200 {
                let mu = (i as f64 / 200.0).powi(3);
                let v = t(r, mu);
                assert!(
                    v > last || (i == 0 && v == 0.0),
                    "increasing at r {r}, μ {mu}"
                );
                assert!(t(r + 0.01, mu) <= v + 1e-16, "decreasing in r at {r}, {mu}");
                last = v;
                assert!(
                    (g.inverse(2, v, &[0.1, r, 0.0]) - mu).abs() < 1e-12,
                    "inverse"
                );
            }
        }
        // inside the layer μ ≪ α = r²: linear in μ, slope (√(1 + s) + √s)/(2√s)
        for r in [0.01, 0.05] {
            let s: f64 = r * r;
            let slope = ((1.0 + s).sqrt() + s.sqrt()) / (2.0 * s.sqrt());
            let mu = 1e-3 * s;
            assert!((t(r, mu) / mu - slope).abs() < 1e-3 * slope, "r {r}");
        }
        // outside it, within O(√α) of √μ
        for (r, mu) in [(0.01, 0.2), (0.03, 0.5), (0.05, 0.9)] {
            assert!((t(r, mu) - mu.sqrt()).abs() < 2.0 * r, "r {r}, μ {mu}");
        }
        let dom = [(0.0125, 0.25), (0.0, 1.0), (0.0, 1.0)];
        assert_eq!(g.image(2, &names, &dom).unwrap(), (0.0, 1.0));
        let (lo, hi) = g
            .image(2, &names, &[(0.0125, 0.25), (0.5, 1.0), (0.25, 1.0)])
            .unwrap();
        assert!((lo - t(1.0, 0.25)).abs() < 1e-15 && (hi - 1.0).abs() < 1e-15);
        for bad in [
            InputTransform::RootLayer {
                by: 1,
                k: 0.0,
                power: 2,
            },
            InputTransform::RootLayer {
                by: 2,
                k: 1.0,
                power: 2,
            },
            InputTransform::RootLayer {
                by: 7,
                k: 1.0,
                power: 2,
            },
            InputTransform::RootLayer {
                by: 1,
                k: 1.0,
                power: 5,
            },
        ] {
            assert!(bad.image(2, &names, &dom).is_err(), "{bad:?}");
        }
        assert!(g
            .image(2, &names, &[(0.0125, 0.25), (0.0, 1.0), (-0.1, 1.0)])
            .is_err());
        assert_eq!(
            InputTransform::parse_more("slayer:r:1", &names, 2).unwrap(),
            Ok(g)
        );
        for bad in [
            "slayer:r:0",
            "slayer:mu:1",
            "slayer:q:1",
            "slayer:r",
            "slayer:r:x",
            "slayer:r:1:1",
            "slayer:r:1:5",
            "slayer:r:1:2.5",
            "slayer:r:1:3:0",
        ] {
            let e = InputTransform::parse_more(bad, &names, 2)
                .unwrap()
                .unwrap_err();
            assert!(e.contains("slayer:<variable>:<k>[:<e>]"), "{bad}: {e}");
        }
        assert_eq!(g.label(&names), "slayer:r:1");
        // e = 2 written out is the default; it is not written back, nor serialised
        assert_eq!(
            InputTransform::parse_more("slayer:r:1:2", &names, 2).unwrap(),
            Ok(g)
        );
        assert_eq!(
            serde_json::to_string(&g).unwrap(),
            r#"{"kind":"root_layer","by":1,"k":1.0}"#
        );
    }

    #[test]
    fn root_layer_of_a_higher_power_widens_the_layer_as_k_r_to_the_e() {
        let names = ["f0", "r", "mu"].map(String::from).to_vec();
        let g3 = InputTransform::parse_more("slayer:r:3:3", &names, 2)
            .unwrap()
            .unwrap();
        assert_eq!(
            g3,
            InputTransform::RootLayer {
                by: 1,
                k: 3.0,
                power: 3
            }
        );
        assert_eq!(g3.label(&names), "slayer:r:3:3");
        let json = serde_json::to_string(&g3).unwrap();
        assert_eq!(json, r#"{"kind":"root_layer","by":1,"k":3.0,"power":3}"#);
        assert_eq!(serde_json::from_str::<InputTransform>(&json).unwrap(), g3);
        // the power-2 layer of the width k r³ at each r: the same t to rounding
        for r in [0.0, 0.05, 0.3, 0.8, 1.0] {
            let g2 = InputTransform::RootLayer {
                by: 1,
                k: 3.0 * r,
                power: 2,
            };
            for mu in [0.0, 1e-6, 1e-3, 0.1, 0.5, 1.0] {
                let (a, b) = (g3.apply(2, &[0.1, r, mu]), g2.apply(2, &[0.1, r, mu]));
                assert!((a - b).abs() <= 4e-16, "r {r}, μ {mu}: {a} {b}");
                if r > 0.0 {
                    let back = g3.inverse(2, a, &[0.1, r, 0.0]);
                    assert!((back - mu).abs() < 1e-12, "inverse at r {r}, μ {mu}");
                }
            }
        }
        // onto [0, 1]; the image of a sub-box at its corners
        let dom = [(0.0125, 0.25), (0.0, 1.0), (0.0, 1.0)];
        assert_eq!(g3.image(2, &names, &dom).unwrap(), (0.0, 1.0));
        let (lo, hi) = g3
            .image(2, &names, &[(0.0125, 0.25), (0.5, 1.0), (0.25, 1.0)])
            .unwrap();
        let t = |r: f64, mu: f64| g3.apply(2, &[0.1, r, mu]);
        assert!((lo - t(1.0, 0.25)).abs() < 1e-15 && (hi - 1.0).abs() < 1e-15);
        // an odd power over a negative variable is refused
        assert!(g3
            .image(2, &names, &[(0.0125, 0.25), (-0.5, 1.0), (0.0, 1.0)])
            .is_err());
    }

    #[test]
    fn grazing_layer_keeps_the_smooth_row_and_resolves_the_layer() {
        let names = vec!["r".to_string(), "mu".to_string()];
        let g = InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 0.5,
            root: 1,
            beta: 0.0,
        };
        let t = |r: f64, mu: f64| g.apply(1, &[r, mu]);
        // the row r = 0 maps one to one onto [1 − w, 1]: t = 1 − w + w μ
        for mu in [0.0, 0.1, 0.5, 1.0] {
            assert!((t(0.0, mu) - (0.5 + 0.5 * mu)).abs() < 1e-15, "μ = {mu}");
        }
        // small r: the layer variable of μ/r² fills [0, 1 − w]
        for c in [0.1, 1.0, 10.0] {
            let (a, b) = (t(1e-3, c * 1e-6), t(1e-4, c * 1e-8));
            assert!((a - 0.5 * c / (1.0 + c)).abs() < 1e-5 && (a - b).abs() < 1e-5);
        }
        assert!(t(0.3, 0.2) < t(0.3, 0.21) && t(0.3, 0.2) > t(0.31, 0.2));
        let (lo, hi) = g.image(1, &names, &[(0.0, 1.0), (0.0, 1.0)]).unwrap();
        assert!(lo <= LAYER_TAU && (hi - 1.0).abs() < 1e-15, "({lo}, {hi})");
        // the square root of the plain layer variable: √μ-like near μ = 0 at large r
        let s = InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 0.0,
            root: 2,
            beta: 0.0,
        };
        let l = InputTransform::BoundaryLayer { by: 0, k: 1.0 };
        assert_eq!(s.apply(1, &[0.7, 0.3]), l.apply(1, &[0.7, 0.3]).sqrt());
        for (r, mu) in [(0.2, 0.3), (1.0, 0.01), (0.05, 0.9), (0.0, 0.4)] {
            // (w = 0 maps the row r = 0 to one point, like the plain layer: not invertible there)
            for tr in [g, s].into_iter().filter(|t| r > 0.0 || *t == g) {
                let x = inverse_point(&[InputTransform::Identity, tr], &[r, tr.apply(1, &[r, mu])]);
                assert!((x[1] - mu).abs() < 1e-12, "{tr:?}: {x:?}");
            }
        }
        assert!(InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 1.0,
            root: 1,
            beta: 0.0,
        }
        .image(1, &names, &[(0.0, 1.0), (0.0, 1.0)])
        .is_err());
        assert!(InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 0.5,
            root: 3,
            beta: 0.0,
        }
        .image(1, &names, &[(0.0, 1.0), (0.0, 1.0)])
        .is_err());
        assert_eq!(
            InputTransform::parse_more("glayer:r:1:0.5", &names, 1).unwrap(),
            Ok(g)
        );
        assert_eq!(
            InputTransform::parse_more("glayer:r:1:0:2", &names, 1).unwrap(),
            Ok(s)
        );
        assert!(InputTransform::parse_more("glayer:mu:1:0.5", &names, 1)
            .unwrap()
            .is_err());
    }

    #[test]
    fn log_corrected_layer_follows_mu_log_mu_and_keeps_the_layer() {
        let names = vec!["r".to_string(), "mu".to_string()];
        // λ(x) = 16·x·((1 + 1/x)^(1/16) − 1) (an independent computation by powf), which is
        // x ln(1 + 1/x) in Box–Cox form: ≥ it, within 40 % for 1/x ≤ 1e4
        assert_eq!(log_term(0.0), 0.0);
        for x in [1e-8f64, 1e-4, 1e-2, 0.3, 1.0] {
            let box_cox = 16.0 * x * ((1.0 + 1.0 / x).powf(1.0 / 16.0) - 1.0);
            assert!(
                (log_term(x) - box_cox).abs() < 1e-12 * box_cox,
                "x = {x}: {} vs {box_cox}",
                log_term(x)
            );
            let ratio = log_term(x) / (x * (1.0 + 1.0 / x).ln());
            assert!(x < 1e-4 || (1.0..1.4).contains(&ratio), "x = {x}: {ratio}");
        }
        // below the floor: linear in x
        let y = LOG_FLOOR / 8.0;
        assert!((log_term(y) - log_term(LOG_FLOOR) / 8.0).abs() < 1e-6 * log_term(y));
        // increasing, v(0) = 0, v(1) = 1, v = x without the correction
        let mut prev = -1.0;
        for i in 0..=1000 {
            let x = (i as f64 / 1000.0).powi(4);
            let v = log_corrected(x, 4.0);
            assert!(v > prev && (0.0..=1.0).contains(&v), "x = {x}");
            prev = v;
        }
        assert_eq!(log_corrected(1.0, 4.0), 1.0);
        assert_eq!(log_corrected(0.37, 0.0), 0.37);
        let g = |beta: f64| InputTransform::GrazingLayer {
            by: 0,
            k: 1.0,
            w: 0.0,
            root: 1,
            beta,
        };
        let (plain, logc) = (g(0.0), g(3.0));
        // α → 0: the plain layer variable of μ/α (the correction vanishes like α²)
        for c in [0.1, 1.0, 10.0] {
            let (a, b) = (
                logc.apply(1, &[1e-3, c * 1e-6]),
                plain.apply(1, &[1e-3, c * 1e-6]),
            );
            assert!((a - b).abs() < 1e-9, "c = {c}: {a} {b}");
        }
        // α = 1: v/μ grows like 1 + β λ(μ)/μ ≈ 1 + β ln(1/μ) as μ → 0
        let v = |mu: f64| log_corrected(mu, 3.0);
        assert!(v(1e-6) / 1e-6 > 3.0 * v(1e-2) / 1e-2);
        // image of the unit square, inverse, the serialised name and the file of β = 0
        let (lo, hi) = logc.image(1, &names, &[(0.0, 1.0), (0.0, 1.0)]).unwrap();
        assert!(lo <= LAYER_TAU && (hi - 1.0).abs() < 1e-15, "({lo}, {hi})");
        let (lo, hi) = logc.image(1, &names, &[(0.1, 0.9), (0.01, 0.5)]).unwrap();
        for (r, mu) in [(0.1, 0.01), (0.9, 0.01), (0.5, 0.2), (0.1, 0.5), (0.9, 0.5)] {
            let t = logc.apply(1, &[r, mu]);
            assert!(lo <= t && t <= hi, "({r}, {mu}): {t} not in [{lo}, {hi}]");
        }
        for (r, mu) in [(0.2, 0.3), (1.0, 0.001), (0.05, 0.9)] {
            let x = inverse_point(
                &[InputTransform::Identity, logc],
                &[r, logc.apply(1, &[r, mu])],
            );
            assert!((x[1] - mu).abs() < 1e-12, "{x:?}");
        }
        assert_eq!(
            InputTransform::parse_more("glayer:r:1:0:1:3", &names, 1).unwrap(),
            Ok(logc)
        );
        assert_eq!(logc.label(&names), "glayer:r:1:0:1:3");
        assert_eq!(plain.label(&names), "glayer:r:1:0:1");
        assert!(!serde_json::to_string(&plain).unwrap().contains("beta"));
        let json = serde_json::to_string(&logc).unwrap();
        assert_eq!(serde_json::from_str::<InputTransform>(&json).unwrap(), logc);
        for bad in [
            "glayer:r:1:0:1:-1",
            "glayer:r:1:0:1:x",
            "glayer:r:1:0:1:3:4",
        ] {
            assert!(
                InputTransform::parse_more(bad, &names, 1).unwrap().is_err(),
                "{bad}"
            );
        }
        assert!(g(f64::NAN)
            .image(1, &names, &[(0.0, 1.0), (0.0, 1.0)])
            .is_err());
    }

    #[test]
    fn subsample_is_deterministic_and_exact_size() {
        let n = 1000;
        let data = FitData::new(
            vec!["x".into()],
            (0..n).map(|i| i as f64).collect(),
            vec![0.0; n],
            vec![(0.0, 999.0)],
        )
        .unwrap();
        let p = Prepared::new(&data, &[InputTransform::Identity]).unwrap();
        let a = p.subsample(100).unwrap();
        let b = p.subsample(100).unwrap();
        assert_eq!(a.len(), 100);
        assert_eq!(a.s, b.s);
        assert!(p.subsample(1000).is_none());
    }
}
