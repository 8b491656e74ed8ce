//! Quadrature: nested Gauss–Legendre over panels split at the integrand's kinks, with a
//! per-cell error estimate from two rule orders and refinement when it misses the tolerance.
//!
//! A model describes its albedo integral as an [`Integrand2D`]: an outer variable `u` on a list
//! of panels, an inner variable `v` whose panels may depend on `u`, and a vector-valued integrand
//! that includes every Jacobian. Panels end where the integrand has a kink or a jump, so each
//! panel is smooth and Gauss–Legendre converges exponentially on it; the smoothed rule
//! ([`UnitRule::gauss_legendre_smoothed`]) absorbs the square-root behaviour that appears where a
//! kink curve is tangent to a line of constant `u`.

use crate::math::UnitRule;

/// Number of channels an integrand carries (e.g. reflection and transmission).
pub const CHANNELS: usize = 2;

/// A 2-D integrand with known breakpoints: ∫ du ∫ dv f(u, v).
pub trait Integrand2D {
    /// Data precomputed once per outer coordinate (trigonometry, frames).
    type Line;
    /// Sorted breakpoints of the outer variable, both ends included.
    fn outer_breaks(&self, out: &mut Vec<f64>);
    /// The line at outer coordinate `u`, and its sorted inner breakpoints (both ends included).
    fn line(&self, u: f64, inner_breaks: &mut Vec<f64>) -> Self::Line;
    /// The integrand at (u, v) on `line`, every Jacobian included.
    fn eval(&self, line: &Self::Line, v: f64) -> [f64; CHANNELS];
}

/// The rules used for one evaluation: the same order in both dimensions.
#[derive(Clone, Debug)]
pub struct Rules {
    pub order: usize,
    pub rule: UnitRule,
}

impl Rules {
    pub fn new(order: usize) -> Rules {
        Rules { order, rule: UnitRule::gauss_legendre_smoothed(order.max(1)) }
    }
}

/// Nested product rule over all panels.
pub fn integrate_2d<I: Integrand2D>(f: &I, rules: &Rules) -> [f64; CHANNELS] {
    let rule = &rules.rule;
    let mut outer = Vec::with_capacity(8);
    f.outer_breaks(&mut outer);
    let mut inner = Vec::with_capacity(8);
    let mut total = [0.0; CHANNELS];
    for panel in outer.windows(2) {
        let (a, b) = (panel[0], panel[1]);
        if b <= a {
            continue;
        }
        let mut panel_sum = [0.0; CHANNELS];
        for (&t, &wt) in rule.nodes.iter().zip(&rule.weights) {
            let u = a + (b - a) * t;
            inner.clear();
            let line = f.line(u, &mut inner);
            let mut line_sum = [0.0; CHANNELS];
            for seg in inner.windows(2) {
                let (c, d) = (seg[0], seg[1]);
                if d <= c {
                    continue;
                }
                let mut seg_sum = [0.0; CHANNELS];
                for (&s, &ws) in rule.nodes.iter().zip(&rule.weights) {
                    let y = f.eval(&line, c + (d - c) * s);
                    for k in 0..CHANNELS {
                        seg_sum[k] += ws * y[k];
                    }
                }
                for k in 0..CHANNELS {
                    line_sum[k] += (d - c) * seg_sum[k];
                }
            }
            for k in 0..CHANNELS {
                panel_sum[k] += wt * line_sum[k];
            }
        }
        for k in 0..CHANNELS {
            total[k] += (b - a) * panel_sum[k];
        }
    }
    total
}

/// Quadrature settings of a table or an evaluation: the base order per panel and dimension,
/// the per-cell tolerance on the error estimate, and the highest order refinement may reach.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct QuadratureSettings {
    /// Gauss–Legendre points per panel and dimension.
    pub order: usize,
    /// A cell whose error estimate exceeds this is recomputed at twice the order.
    pub tolerance: f64,
    /// Refinement stops here; a cell still above tolerance is reported, never hidden.
    pub max_order: usize,
}

impl Default for QuadratureSettings {
    fn default() -> Self {
        QuadratureSettings { order: 16, tolerance: 1e-8, max_order: 128 }
    }
}

/// A value with its error estimate.
#[derive(Clone, Copy, Debug)]
pub struct Estimate<const N: usize> {
    pub value: [f64; N],
    /// max over channels of |Q(order) − Q(order/2)|: conservative, it estimates the error of
    /// the lower-order result while `value` is the higher-order one.
    pub error: f64,
    /// The order that met the tolerance (or `max_order` if none did).
    pub order: usize,
    /// False when even `max_order` left the estimate above the tolerance.
    pub converged: bool,
}

/// Evaluates `f(order)` at increasing orders until |f(n) − f(n/2)| ≤ tolerance.
/// `rules_for` caches rules per order so that tabulation does not rebuild them per cell.
pub fn estimate<const N: usize>(
    settings: &QuadratureSettings,
    cache: &RuleCache,
    mut f: impl FnMut(&Rules) -> [f64; N],
) -> Estimate<N> {
    let mut order = settings.order.max(2);
    let mut low = f(cache.get(order / 2));
    loop {
        let high = f(cache.get(order));
        let error = high
            .iter()
            .zip(&low)
            .map(|(h, l)| (h - l).abs())
            .fold(0.0, f64::max);
        let converged = error <= settings.tolerance;
        if converged || order * 2 > settings.max_order.max(order) {
            return Estimate { value: high, error, order, converged };
        }
        low = high;
        order *= 2;
    }
}

/// Rules for every order a tabulation may need, built once.
#[derive(Debug)]
pub struct RuleCache {
    rules: Vec<Rules>,
}

impl RuleCache {
    /// Rules for `base/2, base, 2·base, …` up to `max_order`.
    pub fn new(settings: &QuadratureSettings) -> RuleCache {
        let mut rules = Vec::new();
        let mut order = (settings.order.max(2)) / 2;
        while order <= settings.max_order.max(settings.order) {
            rules.push(Rules::new(order));
            order *= 2;
        }
        RuleCache { rules }
    }

    pub fn get(&self, order: usize) -> &Rules {
        self.rules
            .iter()
            .find(|r| r.order == order)
            .expect("RuleCache::get: order outside the cached range (a bug in the caller)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_0^1 ∫_0^1 |x − y| dy dx = 1/3, with the kink at y = x given as a breakpoint.
    struct Kinked;
    impl Integrand2D for Kinked {
        type Line = f64;
        fn outer_breaks(&self, out: &mut Vec<f64>) {
            out.extend([0.0, 1.0]);
        }
        fn line(&self, u: f64, b: &mut Vec<f64>) -> f64 {
            b.extend([0.0, u, 1.0]);
            u
        }
        fn eval(&self, u: &f64, v: f64) -> [f64; CHANNELS] {
            [(u - v).abs(), 1.0]
        }
    }

    #[test]
    fn breakpoints_make_kinked_integrands_exact() {
        let q = integrate_2d(&Kinked, &Rules::new(8));
        assert!((q[0] - 1.0 / 3.0).abs() < 1e-14, "{}", q[0]);
        assert!((q[1] - 1.0).abs() < 1e-14);
    }

    #[test]
    fn estimate_refines_until_tolerance() {
        let settings = QuadratureSettings { order: 4, tolerance: 1e-12, max_order: 64 };
        let cache = RuleCache::new(&settings);
        // ∫0^1 exp(x) dx with a 1-D "integrand" disguised as a 1-point inner rule
        let e = estimate(&settings, &cache, |r: &Rules| {
            [r.rule.nodes.iter().zip(&r.rule.weights).map(|(x, w)| w * x.exp()).sum::<f64>()]
        });
        assert!(e.converged);
        assert!((e.value[0] - (std::f64::consts::E - 1.0)).abs() < 1e-13);
        assert!(e.order > 4);
    }
}
