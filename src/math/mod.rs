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
