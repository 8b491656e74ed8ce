//! Pure math: GGX microfacet functions, dielectric Fresnel, Gauss–Legendre rules and
//! compensated summation. Nothing here knows about models, tables or files.

pub mod ggx;
pub mod rules;

pub use ggx::*;
pub use rules::*;

/// `sqrt(max(x, 0))`: guards the square roots of quantities that are non-negative in exact
/// arithmetic but may round to a tiny negative value (e.g. `1 - cos²`).
#[inline]
pub fn safe_sqrt(x: f64) -> f64 {
    x.max(0.0).sqrt()
}

/// e^x for |x| ≤ 700 (quadrature maps and nodes; no overflow or subnormal handling): Cody–Waite reduction x = k·ln 2 + r with
/// |r| ≤ ln 2 / 2, the degree-13 Taylor polynomial of e^r (truncation error below 5e-18
/// relative, evaluated by Estrin's scheme) and 2^k put into the exponent bits. Branch-free and call-free, unlike libm's exp,
/// so that a loop over nodes vectorises. Within 2 ulp of `f64::exp` (unit test).
#[inline(always)]
pub fn exp_poly(x: f64) -> f64 {
    const SHIFTER: f64 = 6755399441055744.0; // 1.5·2^52: adding it rounds to an integer
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let kd = x * std::f64::consts::LOG2_E + SHIFTER;
    let k = kd - SHIFTER;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // Estrin's scheme (pairs, then powers r², r⁴, r⁸): a dependency chain of depth 5 instead of
    // Horner's 13 multiply–adds
    const C: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362880.0,
        1.0 / 3628800.0,
        1.0 / 39916800.0,
        1.0 / 479001600.0,
        1.0 / 6227020800.0,
    ];
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let q0 = (C[0] + C[1] * r) + (C[2] + C[3] * r) * r2;
    let q1 = (C[4] + C[5] * r) + (C[6] + C[7] * r) * r2;
    let q2 = (C[8] + C[9] * r) + (C[10] + C[11] * r) * r2;
    let q3 = C[12] + C[13] * r;
    let p = (q0 + q1 * r4) + (q2 + q3 * r4) * r8;
    let bits = kd
        .to_bits()
        .wrapping_sub(SHIFTER.to_bits())
        .wrapping_add(1023)
        << 52;
    p * f64::from_bits(bits)
}

/// asinh(x) for x ≥ 0: ln(x + √(1 + x²)), rearranged as ln_1p(x + x²/(1 + √(1 + x²))) below
/// x = 0.5 (accurate for small x), and ln(2x) beyond 1e8 where the two agree to
/// within x⁻²/4 (and x² would overflow later). `f64::asinh` spends as long again on a `hypot`
/// that guards against overflow, which these ranges do not need; map spans and line ends
/// evaluate it several times per quadrature line.
#[inline]
pub fn asinh_pos(x: f64) -> f64 {
    if x > 1e8 {
        (2.0 * x).ln()
    } else if x > 0.5 {
        // x + √(1 + x²) > 1.6: no cancellation, and `ln` is cheaper than `ln_1p`
        (x + (1.0 + x * x).sqrt()).ln()
    } else {
        (x + x * x / (1.0 + (1.0 + x * x).sqrt())).ln_1p()
    }
}

/// (sin x, cos x) for x ∈ [0, π] — the range of every angle the quadrature integrates over —
/// by Taylor polynomials about π/2 in Horner form: with y = x − π/2 ∈ [−π/2, π/2],
/// sin x = cos y and cos x = −sin y. Terms up to y²² / y²¹ leave a truncation error below
/// (π/2)²³/23! ≈ 1.2e-18, so the result is within a few ulps of libm's `sin_cos` (checked in the
/// tests) at a quarter of its cost; the hot loop of the quadrature calls this once per node.
#[inline]
pub fn sin_cos_0_pi(x: f64) -> (f64, f64) {
    debug_assert!(
        (-1e-9..=std::f64::consts::PI + 1e-9).contains(&x),
        "sin_cos_0_pi({x})"
    );
    let y = x - std::f64::consts::FRAC_PI_2;
    let y2 = y * y;
    // cos y = Σ (−1)^k y^{2k}/(2k)!, k ≤ 11
    let mut c = -1.0 / 1_124_000_727_777_607_680_000.0; // −1/22!
    for k in (0..11).rev() {
        c = c * y2 + COS_TAYLOR[k];
    }
    // sin y = y Σ (−1)^k y^{2k}/(2k+1)!, k ≤ 10
    let mut s = SIN_TAYLOR[10];
    for k in (0..10).rev() {
        s = s * y2 + SIN_TAYLOR[k];
    }
    (c, -(s * y))
}

/// (−1)^k/(2k)! for k = 0..=10.
const COS_TAYLOR: [f64; 11] = [
    1.0,
    -1.0 / 2.0,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40_320.0,
    -1.0 / 3_628_800.0,
    1.0 / 479_001_600.0,
    -1.0 / 87_178_291_200.0,
    1.0 / 20_922_789_888_000.0,
    -1.0 / 6_402_373_705_728_000.0,
    1.0 / 2_432_902_008_176_640_000.0,
];

/// (−1)^k/(2k+1)! for k = 0..=10.
const SIN_TAYLOR: [f64; 11] = [
    1.0,
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5_040.0,
    1.0 / 362_880.0,
    -1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    -1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    -1.0 / 121_645_100_408_832_000.0,
    1.0 / 51_090_942_171_709_440_000.0,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two positive finite numbers.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn exp_poly_is_within_two_ulp_of_libm() {
        let mut worst = 0;
        for k in -140_000..=140_000 {
            let x = k as f64 * 0.005; // [−700, 700]
            worst = worst.max(ulps(exp_poly(x), x.exp()));
        }
        assert!(worst <= 2, "exp_poly is {worst} ulp from exp");
        assert_eq!(exp_poly(0.0), 1.0);
    }

    #[test]
    fn asinh_pos_is_within_four_ulp_of_std() {
        let mut worst = 0;
        for k in 0..=40_000 {
            let x = 10f64.powf(-12.0 + 24.0 * k as f64 / 40_000.0); // 1e-12 … 1e12
            worst = worst.max(ulps(asinh_pos(x), x.asinh()));
        }
        assert!(worst <= 4, "asinh_pos is {worst} ulp from asinh");
        assert_eq!(asinh_pos(0.0), 0.0);
    }

    #[test]
    fn fast_sin_cos_matches_libm_on_0_pi() {
        let mut worst = 0.0f64;
        for k in 0..=200_000 {
            let x = std::f64::consts::PI * k as f64 / 200_000.0;
            let (s, c) = sin_cos_0_pi(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst < 1e-15, "{worst:e}");
    }
}

/// Neumaier's compensated summation (an improved Kahan sum), as pbrt-v4 uses for long sums.
#[derive(Clone, Copy, Debug, Default)]
pub struct CompensatedSum {
    sum: f64,
    c: f64,
}

impl CompensatedSum {
    #[inline]
    pub fn add(&mut self, x: f64) {
        let t = self.sum + x;
        if self.sum.abs() >= x.abs() {
            self.c += (self.sum - t) + x;
        } else {
            self.c += (x - t) + self.sum;
        }
        self.sum = t;
    }
    #[inline]
    pub fn value(&self) -> f64 {
        self.sum + self.c
    }
}
