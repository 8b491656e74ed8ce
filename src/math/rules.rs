//! Gauss–Legendre rules, optionally composed with a polynomial endpoint transform.
//!
//! The transform x = 3t² − 2t³ (a Sidi-type sigmoidal map, Sidi 1993) has a vanishing first
//! derivative at both ends of a panel. It turns the square-root endpoint behaviour that appears
//! wherever an integration limit is a kink curve or a sphere's rim into a smooth integrand, at
//! the price of slightly slower convergence for integrands that were smooth already.

use std::f64::consts::PI;

/// A quadrature rule on the unit interval [0, 1].
#[derive(Clone, Debug)]
pub struct UnitRule {
    pub nodes: Vec<f64>,
    pub weights: Vec<f64>,
}

impl UnitRule {
    /// n-point Gauss–Legendre on [0, 1] (nodes by Newton iteration on P_n, Golub–Welsch-free).
    pub fn gauss_legendre(n: usize) -> UnitRule {
        assert!(n >= 1, "a Gauss–Legendre rule needs at least one node");
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            // Tricomi's initial guess, then Newton on P_n(x).
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, d) = legendre_with_derivative(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre_with_derivative(n, x);
            dp = if d != 0.0 { d } else { dp };
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            // map [-1, 1] -> [0, 1]
            nodes[i] = 0.5 * (1.0 - x);
            nodes[n - 1 - i] = 0.5 * (1.0 + x);
            weights[i] = 0.5 * w;
            weights[n - 1 - i] = 0.5 * w;
        }
        if n % 2 == 1 {
            nodes[n / 2] = 0.5;
        }
        UnitRule { nodes, weights }
    }

    /// Gauss–Legendre composed with the endpoint transform x = 3t² − 2t³ (see module docs).
    pub fn gauss_legendre_smoothed(n: usize) -> UnitRule {
        let gl = UnitRule::gauss_legendre(n);
        let nodes = gl.nodes.iter().map(|&t| t * t * (3.0 - 2.0 * t)).collect();
        let weights = gl
            .nodes
            .iter()
            .zip(&gl.weights)
            .map(|(&t, &w)| w * 6.0 * t * (1.0 - t))
            .collect();
        UnitRule { nodes, weights }
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

/// P_n(x) and P_n'(x) by the three-term recurrence.
fn legendre_with_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_degree_2n_minus_1() {
        for n in [1, 2, 3, 8, 17, 64] {
            let r = UnitRule::gauss_legendre(n);
            assert!((r.weights.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            let deg = 2 * n - 1;
            let q: f64 = r
                .nodes
                .iter()
                .zip(&r.weights)
                .map(|(x, w)| w * x.powi(deg as i32))
                .sum();
            assert!((q - 1.0 / (deg as f64 + 1.0)).abs() < 1e-13, "n={n}: {q}");
        }
    }

    #[test]
    fn smoothed_rule_integrates_sqrt_endpoint_singularity() {
        // ∫0^1 sqrt(x(1-x)) dx = π/8; plain GL converges as n^-1.5, the smoothed one fast.
        let exact = PI / 8.0;
        let f = |x: f64| (x * (1.0 - x)).sqrt();
        let q = |r: &UnitRule| -> f64 {
            r.nodes
                .iter()
                .zip(&r.weights)
                .map(|(&x, &w)| w * f(x))
                .sum()
        };
        let plain = (q(&UnitRule::gauss_legendre(16)) - exact).abs();
        let smooth = (q(&UnitRule::gauss_legendre_smoothed(16)) - exact).abs();
        assert!(smooth < 1e-9, "{smooth}");
        assert!(smooth < plain / 100.0);
    }
}
