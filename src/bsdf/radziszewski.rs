//! The glossy BRDF of Radziszewski & Alda, "Family of Energy Conserving Glossy Reflection Models"
//! (cited below as "R&A"): a phenomenological lobe around the mirror direction that is energy
//! preserving by construction, so its albedo is 1 for every glossiness and direction — an
//! end-to-end check of the quadrature.
//!
//! # The model
//! With x = cos²θi and y = cos²θr, where ωr = (θr, φr) = (θo, φo + π) is the mirror direction
//! of ωo,
//!
//! f(ωi, ωo) = 2 · f_θ(x, y) · f_φ(k, φi − φr)            (R&A, eq. 19, ×2 — see below)
//!
//! * f_θ(x, y) = m tanh²n_θ e^{−m(x+y)} / (tanh²n_θ − (1 − e^{−mx})(1 − e^{−my}))², m = 2 ln cosh n_θ
//!   (R&A, eq. 17), normalised so that ∫₀¹ f_θ(x, y) dx = 1 for every y (eq. 11);
//! * f_φ(k, Δφ) = C_k / (k(1 − cos Δφ) + 1)⁶, C_k = (2k + 1)^5.5 / (2π P₅(k)) (R&A, eq. 18),
//!   normalised so that ∫ f_φ dΔφ = 1 over [−π, π] for every k;
//! * the user-facing glossiness n sets n_θ = n and n_φ = 0.75 n √(n sinθi sinθr) (R&A, §5), and
//!   the longitudinal exponent is k = n_φ sinθi sinθr (R&A, §4.3 and eq. 19), so the lobe becomes
//!   constant in φ where ωi or ωr is normal.
//!
//! **Normalisation (the factor 2).** R&A eq. 8 substitutes x = cos²θi: cosθi sinθi dθi = dx/2,
//! so the reflectivity of eq. 19 as printed is R = ½ ∫₀¹ f_θ dx · ∫ f_φ dφ = ½ — both factors are
//! normalised to 1 (eqs. 11 and 18), the Jacobian ½ of eq. 8 is not. We therefore multiply eq. 19
//! by 2 ([`NORMALISATION`]); then E = 1 exactly, and the n → 0 limit is 2 · 1 · 1/(2π) = 1/π,
//! Lambert, as R&A's "Limit #1 – diffuse" requires.
//!
//! **P₅'s argument.** Eq. 19 prints P₅(n_φ) in the denominator but (2 n_φ sinθi sinθr + 1)^5.5 in
//! the numerator. Eq. 18's normalisation holds only if both use the same exponent, so we use
//! P₅(k), k = n_φ sinθi sinθr, in both. With P₅(n_φ) (and the factor 2) we measured
//! E = 0.42 at n = 1, μo = 0.5 and E = 8.4e-4 at n = 10, μo = 0.9: that reading cannot be meant.
//!
//! **Floating point.** Eq. 17 as printed cancels catastrophically. Its denominator
//! D = tanh²n − (1 − e^{−mx})(1 − e^{−my}) is a difference of two numbers near 1 whenever x and
//! y are both large (near-normal ωi and ωr), while its exact value there is as small as
//! e^{−m}(1 − e^{−m}) ≈ 4e^{−2n} (at x = y = 1). The relative error of D is therefore about
//! ε e^{2n}/4 (ε = 2⁻⁵³), doubled by the square in f_θ. Measured in double precision against the
//! form below, on a 51 × 51 grid of (x, y) (test `printed_latitudinal_formula_fails_near_normal_incidence`),
//! the worst relative error of the printed form, always at x = y = 1, is 6.5e-13 at n = 5,
//! 4.2e-8 at n = 10, 8.5e-4 at n = 15 and 9.1e-2 at n = 18; from n = 19 it returns ∞ (D = 0) at
//! x = y = 1, at n = 20 already from x = y = 0.98 and at n = 25 from x = y = 0.78. (tanh n itself
//! rounds to 1 from n ≈ 19.06.) So the paper's warning "n ≳ 25" is optimistic in double
//! precision: errors above 1e-8 appear near normal incidence from n ≈ 10. We evaluate eq. 17
//! instead, for x ≥ y (it is symmetric, eq. 10), as
//!
//! f_θ = m T e^{−m(x−y)} / q²,  q = D e^{my} = (1 − e^{−mx}) + e^{−m(x−y)} (1 − e^{−m(1−x)}),
//!
//! with T = tanh²n, 1 − e^{−a} = −expm1(−a) and ln cosh n evaluated without overflow: every
//! term is non-negative, nothing cancels, nothing overflows, and the only underflow,
//! e^{−m(x−y)} → 0, is the true value of a vanishing tail. It agrees with eq. 17 evaluated in
//! 2000-digit arithmetic to < 1e-12 relative for 0.001 ≤ n ≤ 1000 (test
//! `latitudinal_matches_high_precision_reference`), and n → 0 is the Lambert limit f_θ → 1. The
//! valid range [0, [`N_MAX`]] is where the quadrature below was verified, not a limit of the
//! formula.
//!
//! # The integral
//! E(μo) = ∫ f μi dμi dφ = ∫₀¹ (dx/2) ∫_{−π}^{π} f dΔφ. Both factors of f are sharp lobes at high n
//! (width ~1/n in x around x = y, ~1/√k in Δφ around 0), so both variables are mapped onto the lobe:
//!
//! * outer: x = y + sinh(w)/λ, λ = max(n, 1): the sech²-like lobe in x becomes a
//!   doubly-exponentially decaying function of w. Panels end at the peak x = y and at
//!   n|x − y| = 1, 5, 20 ([`LOBE_BREAKS`]), so the panels that carry the lobe have the same
//!   length in w for every n;
//! * inner: Δφ ∈ [0, π] (the BRDF is even in Δφ), Δφ = 2 atan(tan ψ / √(2k + 1)), ψ ∈ [0, π/2]
//!   split at π/4, which turns eq. 18's (k(1 − cos Δφ) + 1)^{−6} dΔφ into
//!   2 (sin²ψ + (2k+1) cos²ψ)⁵ / (2k+1)^5.5 dψ, a trigonometric polynomial of ψ, for every k.
//!
//! The BRDF itself is evaluated at the mapped (x, Δφ) and multiplied by both Jacobians; nothing
//! analytic about its integral is used.

use super::{AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use crate::quadrature::{integrate_2d, Integrand2D, Rules, CHANNELS};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, LN_2, PI};

/// Eq. 19 is multiplied by this: R&A eq. 8's Jacobian cosθ sinθ dθ = dx/2 is not absorbed by the
/// normalisations of eqs. 11 and 18 (see the module docs).
pub const NORMALISATION: f64 = 2.0;
/// n_φ = 0.75 n √(n sinθi sinθr): the 0.75 (R&A, §5).
const LONGITUDINAL_GLOSS_RATIO: f64 = 0.75;
/// Below this n, f_θ = 1 + O(n²) equals 1 in double precision (n² < 2⁻⁵³), and eq. 17 would be
/// 0/0 at n = 0: we return the limit.
const LAMBERT_LIMIT_N: f64 = 1e-8;
/// ln cosh n switches from log1p(2 sinh²(n/2)) (accurate for small n) to n − ln 2 + log1p(e^{−2n})
/// (no overflow for large n); both are accurate to a few ulps at n = 1.
const LN_COSH_SWITCH: f64 = 1.0;
/// The sinh map of x uses the lobe width 1/λ, λ = max(n, this): below n = 1 the lobe is wider than
/// [0, 1] and the map is kept close to the identity.
const MIN_LOBE_SCALE: f64 = 1.0;
/// Outer panels end where the lobe has fallen off: at n_θ|x − y| = 1, 5 and 20 (in units of the
/// lobe width 1/λ), where the sech² profile is 0.42, 1.8e-4 and 1.7e-17 of its peak. Panels of
/// bounded length in w make the convergence independent of n (without them the order-16 error
/// grows from 4e-7 at n = 20 to 5e-4 at n = 1000).
const LOBE_BREAKS: [f64; 3] = [1.0, 5.0, 20.0];
/// Largest glossiness accepted. The evaluation is stable beyond it, but x = cos²θ carries an
/// absolute rounding error of ~ε, which f_θ amplifies by ~m ≈ 2n: at n = 10⁶ that is ~1e-10
/// relative, and the albedo integral was verified to stay within 1e-9 of 1 up to here (test
/// `albedo_is_one_up_to_n_max`).
pub const N_MAX: f64 = 1e6;

/// The glossy model `radziszewski-glossy`: E(n, μ) = 1.
#[derive(Clone, Copy, Debug, Default)]
pub struct RadziszewskiModel;

impl RadziszewskiModel {
    /// E(n, μo) by quadrature of the BRDF with `rules`.
    pub fn albedo(&self, n: f64, mu_o: f64, rules: &Rules) -> f64 {
        integrate_2d(&GlossyIntegrand::new(n, mu_o), rules)[0]
    }
}

impl Model for RadziszewskiModel {
    fn id(&self) -> ModelId {
        ModelId::new(Family::RADZISZEWSKI_GLOSSY)
    }

    fn summary(&self) -> String {
        "Radziszewski & Alda energy-conserving glossy lobe about the mirror direction (eq. 19 ×2, n_θ = n, n_φ = 0.75 n √(n sinθi sinθr)); E = 1"
            .to_string()
    }

    fn axes(&self) -> Vec<AxisSpec> {
        vec![
            AxisSpec::new(
                "n",
                (1.0, 20.0),
                (0.0, N_MAX),
                "glossiness n: n_θ = n, n_φ = 0.75 n √(n sinθi sinθr) (R&A §5); n = 0 is Lambert",
            ),
            AxisSpec::new(
                "mu",
                (0.0, 1.0),
                (0.0, 1.0),
                "cosine of the outgoing direction, μo = n·ωo",
            ),
        ]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec!["E"]
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        [self.albedo(x[0], x[1], rules), 0.0, 0.0]
    }
}

/// ln cosh n without overflow or cancellation (see [`LN_COSH_SWITCH`]).
fn ln_cosh(n: f64) -> f64 {
    let n = n.abs();
    if n < LN_COSH_SWITCH {
        let h = (0.5 * n).sinh();
        (2.0 * h * h).ln_1p() // cosh n − 1 = 2 sinh²(n/2)
    } else {
        n - LN_2 + (-2.0 * n).exp().ln_1p() // cosh n = eⁿ (1 + e^{−2n}) / 2
    }
}

/// Latitudinal factor f_θ(x, y), x = cos²θi, y = cos²θr, at n_θ = `n` (R&A, eq. 17), in the
/// cancellation-free form of the module docs. Symmetric; ∫₀¹ f_θ(x, y) dx = 1.
pub fn latitudinal(n: f64, x: f64, y: f64) -> f64 {
    if n < LAMBERT_LIMIT_N {
        return 1.0; // f_θ = 1 + O(n²): the matte limit (R&A, §3 "Limit #1")
    }
    let (x, y) = if x >= y { (x, y) } else { (y, x) }; // R&A, eq. 10
    let m = 2.0 * ln_cosh(n); // R&A, eq. 17 (m = 2 ln cosh n)
    let t = n.tanh().powi(2); // tanh² n
    let decay = (-m * (x - y)).exp(); // e^{−m(x−y)} ≤ 1
    let q = -(-m * x).exp_m1() - decay * (-m * (1.0 - x)).exp_m1(); // R&A eq. 17 denominator ÷ e^{−my}
    m * t * decay / (q * q) // R&A, eq. 17 with numerator and denominator divided by e^{−2my}
}

/// P₅(k) = 7.875k⁵ + 21.875k⁴ + 25k³ + 15k² + 5k + 1 (R&A, eq. 18), by Horner.
pub fn p5(k: f64) -> f64 {
    ((((7.875 * k + 21.875) * k + 25.0) * k + 15.0) * k + 5.0) * k + 1.0 // R&A, eq. 18
}

/// Longitudinal factor f_φ(k, Δφ) = C_k / (k(1 − cos Δφ) + 1)⁶ (R&A, eq. 18);
/// ∫_{−π}^{π} f_φ dΔφ = 1 for every k ≥ 0.
pub fn longitudinal(k: f64, dphi: f64) -> f64 {
    let c = (2.0 * k + 1.0).powf(5.5) / (2.0 * PI * p5(k)); // R&A, eq. 18 (C_n)
    let h = (0.5 * dphi).sin();
    let one_minus_cos = 2.0 * h * h; // 1 − cos Δφ without cancellation near the peak
    c / (k * one_minus_cos + 1.0).powi(6) // R&A, eq. 18
}

/// The longitudinal exponent k = n_φ sinθi sinθr with n_φ = 0.75 n √(n sinθi sinθr)
/// (R&A, §5 and eq. 19).
pub fn longitudinal_exponent(n: f64, sin_i: f64, sin_r: f64) -> f64 {
    let s = sin_i * sin_r;
    let n_phi = LONGITUDINAL_GLOSS_RATIO * n * (n * s).sqrt(); // R&A, §5
    n_phi * s // R&A, eq. 19 (n_φ sinθi sinθr)
}

/// The BRDF at glossiness `n` for incident cosine `mu_i`, mirror-direction cosine `mu_r` (= μo)
/// and azimuth difference `dphi` = φi − φr (R&A, eq. 19, ×[`NORMALISATION`]).
pub fn brdf(n: f64, mu_i: f64, mu_r: f64, dphi: f64) -> f64 {
    let sin_i = ((1.0 - mu_i) * (1.0 + mu_i)).max(0.0).sqrt();
    let sin_r = ((1.0 - mu_r) * (1.0 + mu_r)).max(0.0).sqrt();
    let k = longitudinal_exponent(n, sin_i, sin_r);
    let (x, y) = (mu_i * mu_i, mu_r * mu_r);
    NORMALISATION * latitudinal(n, x, y) * longitudinal(k, dphi) // R&A, eq. 19 (×2)
}

/// The albedo integrand of one (n, μo) cell over (w, ψ) (see the module docs).
pub struct GlossyIntegrand {
    n: f64,
    mu_o: f64,
    /// y = cos²θr = μo².
    y: f64,
    sin_r: f64,
    /// λ of the sinh map x = y + sinh(w)/λ.
    lambda: f64,
}

/// Per-line data of [`GlossyIntegrand`]: one value of x = cos²θi.
pub struct GlossyLine {
    mu_i: f64,
    /// dx/dw of the sinh map.
    dx_dw: f64,
    /// √(2k + 1): the scale of the ψ map at this line's longitudinal exponent k.
    scale: f64,
}

impl GlossyIntegrand {
    pub fn new(n: f64, mu_o: f64) -> GlossyIntegrand {
        let sin_r = ((1.0 - mu_o) * (1.0 + mu_o)).max(0.0).sqrt();
        GlossyIntegrand {
            n,
            mu_o,
            y: mu_o * mu_o,
            sin_r,
            lambda: n.max(MIN_LOBE_SCALE),
        }
    }
}

impl Integrand2D for GlossyIntegrand {
    type Line = GlossyLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        // x ∈ [0, 1] ⇔ w ∈ [−asinh(λy), asinh(λ(1 − y))]; split at the peak x = y and where
        // the lobe has fallen off on either side
        let (lo, hi) = (
            -(self.lambda * self.y).asinh(),
            (self.lambda * (1.0 - self.y)).asinh(),
        );
        out.extend([lo, 0.0, hi]);
        for d in LOBE_BREAKS {
            let w = d.asinh();
            out.extend([-w, w].into_iter().filter(|&v| v > lo && v < hi));
        }
        out.sort_by(|a, b| a.total_cmp(b));
    }

    fn line(&self, w: f64, inner_breaks: &mut Vec<f64>) -> GlossyLine {
        let x = (self.y + w.sinh() / self.lambda).clamp(0.0, 1.0);
        let sin_i = (1.0 - x).sqrt();
        let k = longitudinal_exponent(self.n, sin_i, self.sin_r);
        // the ψ integrand is a trigonometric polynomial of degree 10; one split at π/4 takes the
        // order-16 error on it from 3e-9 to 2e-13
        inner_breaks.extend([0.0, FRAC_PI_4, FRAC_PI_2]);
        let dx_dw = w.cosh() / self.lambda; // d/dw of x = y + sinh(w)/λ
        GlossyLine {
            mu_i: x.sqrt(),
            dx_dw,
            scale: (2.0 * k + 1.0).sqrt(),
        }
    }

    #[inline]
    fn eval(&self, line: &GlossyLine, psi: f64) -> [f64; CHANNELS] {
        let (sp, cp) = psi.sin_cos();
        let dphi = 2.0 * sp.atan2(line.scale * cp); // Δφ = 2 atan(tan ψ / √(2k+1)) ∈ [0, π]
        let dphi_dpsi = 2.0 * line.scale / (line.scale * line.scale * cp * cp + sp * sp); // d/dψ of the line above
        let f = brdf(self.n, line.mu_i, self.mu_o, dphi);
        // μi dμi = dx/2 (R&A, eq. 8); ×2: f is even in Δφ, so [−π, π] folds onto [0, π]
        [0.5 * 2.0 * f * line.dx_dw * dphi_dpsi, 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::UnitRule;

    const N_GRID: [f64; 9] = [0.0, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0];
    const MU_GRID: [f64; 10] = [0.0, 1e-6, 0.05, 0.2, 0.5, 0.7, 0.9, 0.999, 1.0 - 1e-9, 1.0];

    /// Eq. 17 exactly as printed (with m = 2 ln cosh n), to document where it fails.
    fn latitudinal_as_printed(n: f64, x: f64, y: f64) -> f64 {
        let m = 2.0 * n.cosh().ln();
        let t2 = n.tanh().powi(2);
        let d = t2 - (1.0 - (-m * x).exp()) * (1.0 - (-m * y).exp());
        m * t2 * (-m * (x + y)).exp() / (d * d)
    }

    fn max_albedo_error(n_grid: &[f64], order: usize) -> f64 {
        let rules = Rules::new(order);
        let mut worst: f64 = 0.0;
        for &n in n_grid {
            for mu in MU_GRID {
                let e = RadziszewskiModel.albedo(n, mu, &rules);
                assert!(e.is_finite(), "n={n} mu={mu}: {e}");
                worst = worst.max((e - 1.0).abs());
            }
        }
        worst
    }

    #[test]
    fn albedo_is_one_for_n_up_to_20() {
        for order in [16, 32] {
            let err = max_albedo_error(&N_GRID, order);
            eprintln!("radziszewski n ≤ 20, order {order}: max |E − 1| = {err:.3e}");
            assert!(err <= 1e-6, "order {order}: {err:e}");
        }
    }

    #[test]
    fn albedo_is_one_up_to_n_max() {
        for order in [16, 32] {
            let err = max_albedo_error(&[50.0, 200.0, 1e3, 1e4, 1e5, N_MAX], order);
            eprintln!("radziszewski 50 ≤ n ≤ {N_MAX:e}, order {order}: max |E − 1| = {err:.3e}");
            assert!(err <= 1e-9, "order {order}: {err:e}");
        }
    }

    /// The printed eq. 19 reflects half the light: ∫ f_θ dx = 1 and ∫ f_φ dφ = 1, but
    /// cosθ sinθ dθ = dx/2.
    #[test]
    fn printed_normalisation_reflects_one_half() {
        let rules = Rules::new(32);
        for n in [0.0, 3.0, 20.0] {
            for mu in [0.0, 0.4, 1.0] {
                let printed = RadziszewskiModel.albedo(n, mu, &rules) / NORMALISATION;
                assert!((printed - 0.5).abs() < 1e-9, "n={n} mu={mu}: {printed}");
            }
        }
        // n → 0: Lambert, f = 1/π
        assert!((brdf(0.0, 0.3, 0.8, 1.0) - 1.0 / PI).abs() < 1e-15);
        // (the longitudinal exponent k ∝ n^1.5 is 3e-10 here, so f_φ deviates by ~1e-9 relative)
        assert!((brdf(1e-6, 0.3, 0.8, 1.0) - 1.0 / PI).abs() < 1e-9);
    }

    /// C_k normalises eq. 18: P₅ is (2k+1)^2.5 times the Legendre polynomial P_5 at
    /// (k+1)/√(2k+1) (from ∫ dφ/(a − b cos φ)⁶ = 2π P_5(a/√(a²−b²))/(a²−b²)³), and a direct
    /// 1-D quadrature of f_φ over [−π, π] gives 1.
    #[test]
    fn longitudinal_factor_is_normalised() {
        let legendre5 = |z: f64| (63.0 * z.powi(5) - 70.0 * z.powi(3) + 15.0 * z) / 8.0;
        let rule = UnitRule::gauss_legendre(200);
        for k in [0.0, 0.3, 1.0, 7.0, 67.0] {
            let z = (k + 1.0) / (2.0 * k + 1.0f64).sqrt();
            let via_legendre = legendre5(z) * (2.0 * k + 1.0f64).powf(2.5);
            assert!((p5(k) - via_legendre).abs() <= 1e-12 * p5(k), "k={k}");
            // split at the peak Δφ = 0; 200 points resolve the width ~1/√k
            let total: f64 = rule
                .nodes
                .iter()
                .zip(&rule.weights)
                .map(|(&t, &w)| w * PI * 2.0 * longitudinal(k, PI * t))
                .sum();
            assert!((total - 1.0).abs() < 1e-10, "k={k}: {total}");
        }
    }

    #[test]
    fn latitudinal_factor_is_symmetric_and_matches_printed_form_where_that_is_accurate() {
        for n in [0.01, 0.5, 2.0, 5.0] {
            for &(x, y) in &[
                (0.1, 0.7),
                (0.5, 0.5),
                (0.99, 0.2),
                (0.0, 0.0),
                (1.0, 1.0),
                (0.0, 1.0),
            ] {
                let a = latitudinal(n, x, y);
                assert_eq!(a, latitudinal(n, y, x));
                let p = latitudinal_as_printed(n, x, y);
                // the printed form's own error at n ≤ 5 is ≲ ε e^{2n} ≈ 2e-12
                assert!(((a - p) / a).abs() < 1e-10, "n={n} x={x} y={y}: {a} vs {p}");
            }
        }
    }

    /// Eq. 17 evaluated as printed in 2000-digit arithmetic (mpmath 1.3, rounded to f64; inputs the exact
    /// binary values of the f64 literals below): the stable form matches to within its
    /// conditioning (~m ε ≈ 4e-13 relative at n = 1000).
    #[test]
    fn latitudinal_matches_high_precision_reference() {
        const REFERENCE: [(f64, f64, f64, f64); 12] = [
            (20.0, 1.0, 1.0, 38.61370563888011),
            (20.0, 0.5, 0.5, 9.653426489308806),
            (20.0, 0.25, 0.75, 1.5917755719451874e-7),
            (100.0, 1.0, 1.0, 198.6137056388801),
            (100.0, 0.3, 0.31, 21.074071085954493),
            (1000.0, 0.9, 0.9, 499.65342640972005),
            (1000.0, 0.0, 0.0, 1998.6137056388802),
            (1000.0, 0.5, 0.502, 35.39540226858334),
            (0.001, 0.2, 0.9, 0.9999997600000415),
            (25.0, 0.78, 0.78, 12.15370178186844),
            (3.0, 0.0, 1.0, 0.04602189543756067),
            (0.7, 0.1, 0.4, 1.032796975859045),
        ];
        for (n, x, y, want) in REFERENCE {
            let got = latitudinal(n, x, y);
            assert!(
                ((got - want) / want).abs() < 1e-12,
                "n={n} x={x} y={y}: {got} vs {want}"
            );
        }
    }

    /// Where the printed eq. 17 loses precision: near x = y = 1 (ωi, ωr near the normal).
    #[test]
    fn printed_latitudinal_formula_fails_near_normal_incidence() {
        for n in [5.0, 10.0, 15.0, 18.0, 19.0, 20.0, 25.0] {
            let mut worst: f64 = 0.0;
            let mut at = (0.0, 0.0);
            for i in 0..=50 {
                for j in 0..=50 {
                    let (x, y) = (i as f64 / 50.0, j as f64 / 50.0);
                    let exact = latitudinal(n, x, y);
                    let rel = ((latitudinal_as_printed(n, x, y) - exact) / exact).abs();
                    if rel > worst {
                        worst = rel;
                        at = (x, y);
                    }
                }
            }
            eprintln!(
                "printed eq. 17 at n = {n}: max relative error {worst:.3e} at (x, y) = {at:?}"
            );
        }
        assert!(latitudinal_as_printed(20.0, 1.0, 1.0).is_infinite());
        assert!(latitudinal(20.0, 1.0, 1.0).is_finite());
    }
}
