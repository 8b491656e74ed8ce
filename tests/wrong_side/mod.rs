//! The energy a rough dielectric interface, seen from inside, refracts to the wrong side of the
//! macro-surface, integrated independently of furnace's quadrature: over Heitz's (2018)
//! visible-normal sampling map, with panels found by scanning and bisection.

use furnace::math::{fresnel_dielectric, smith_lambda};

/// Gauss–Legendre nodes and weights on [0, 1] (Newton on the Legendre recurrence).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (0.5 * (1.0 - x), 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// One leaving-glass cell seen through Heitz's (2018) visible-normal sampling map: a point
/// (ρ, φ) of the unit disk maps to a microfacet normal h, and the map pushes the uniform
/// measure of the disk forward to D_ωo(h) dh.
pub struct Cell {
    alpha: f64,
    wo: [f64; 3],
    eta: f64,
    vh: [f64; 3],
    t2v: [f64; 3],
    s: f64,
    lambda_o: f64,
}

impl Cell {
    pub fn new(alpha: f64, mu_o: f64, eta: f64) -> Cell {
        let wo = [(1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o];
        let l = (alpha * alpha * wo[0] * wo[0] + mu_o * mu_o).sqrt();
        let vh = [alpha * wo[0] / l, 0.0, mu_o / l];
        // T1 = (0, 1, 0), T2 = Vh × T1
        let t2v = [-vh[2], 0.0, vh[0]];
        Cell {
            alpha,
            wo,
            eta,
            vh,
            t2v,
            s: 0.5 * (1.0 + vh[2]),
            lambda_o: smith_lambda(mu_o, alpha),
        }
    }

    /// h at disk point (ρ cos φ, ρ sin φ) (Heitz 2018, §4.2–4.3 and §3.4).
    fn half_vector(&self, rho: f64, phi: f64) -> [f64; 3] {
        let t1 = rho * phi.cos();
        let t2 = (1.0 - self.s) * (1.0 - t1 * t1).max(0.0).sqrt() + self.s * rho * phi.sin();
        let nz = (1.0 - t1 * t1 - t2 * t2).max(0.0).sqrt();
        let n = [
            t2 * self.t2v[0] + nz * self.vh[0],
            t1,
            t2 * self.t2v[2] + nz * self.vh[2],
        ];
        let m = [self.alpha * n[0], self.alpha * n[1], n[2].max(0.0)];
        let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        [m[0] / l, m[1] / l, m[2] / l]
    }

    /// (cos²θt, μt with cos θt clamped at 0): both continuous, their zeros are the kinks.
    fn kinks(&self, h: [f64; 3]) -> (f64, f64) {
        let c = self.wo[0] * h[0] + self.wo[2] * h[2];
        let q = 1.0 - (1.0 - c * c) / (self.eta * self.eta);
        let mu_t = -self.wo[2] / self.eta + (c / self.eta - q.max(0.0).sqrt()) * h[2];
        (q, mu_t)
    }

    /// (1 − F)·G2/G1 where the refracted direction lies on the wrong side (μt > 0), else 0.
    fn weight(&self, rho: f64, phi: f64) -> f64 {
        let h = self.half_vector(rho, phi);
        let (q, mu_t) = self.kinks(h);
        if q <= 0.0 || mu_t <= 0.0 {
            return 0.0;
        }
        let c = self.wo[0] * h[0] + self.wo[2] * h[2];
        let f = fresnel_dielectric(c, self.eta);
        let lt = smith_lambda(mu_t, self.alpha);
        (1.0 - f) * (1.0 + self.lambda_o) / (1.0 + self.lambda_o + lt)
    }

    /// ∫ weight dφ over φ ∈ [−π/2, π/2] (the map is even in t1): panels between the zeros of
    /// cos²θt and μt, found by a scan and bisection, each integrated with a square-root map
    /// at both ends (1 − F and μt go like √ of the distance to a zero of cos²θt).
    pub fn line(&self, rho: f64, rule: &[(f64, f64)]) -> f64 {
        use std::f64::consts::FRAC_PI_2;
        const SCAN: usize = 96;
        let at = |phi: f64| self.kinks(self.half_vector(rho, phi));
        let mut ends = vec![-FRAC_PI_2];
        let phis: Vec<f64> = (0..=SCAN)
            .map(|k| -FRAC_PI_2 + std::f64::consts::PI * k as f64 / SCAN as f64)
            .collect();
        let vals: Vec<(f64, f64)> = phis.iter().map(|&p| at(p)).collect();
        for k in 0..SCAN {
            for which in 0..2 {
                let g = |v: (f64, f64)| if which == 0 { v.0 } else { v.1 };
                if (g(vals[k]) > 0.0) != (g(vals[k + 1]) > 0.0) {
                    let (mut lo, mut hi) = (phis[k], phis[k + 1]);
                    let lo_pos = g(vals[k]) > 0.0;
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if (g(at(mid)) > 0.0) == lo_pos {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    ends.push(0.5 * (lo + hi));
                }
            }
        }
        ends.push(FRAC_PI_2);
        ends.sort_by(f64::total_cmp);
        let mut sum = 0.0;
        for w in ends.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b - a < 1e-15 || self.weight(rho, 0.5 * (a + b)) == 0.0 {
                continue;
            }
            // φ = a + (b − a)(3t² − 2t³): both ends square-root points
            for &(t, wt) in rule {
                let phi = a + (b - a) * t * t * (3.0 - 2.0 * t);
                sum += wt * (b - a) * 6.0 * t * (1.0 - t) * self.weight(rho, phi);
            }
        }
        2.0 * sum
    }

    /// W = ∫ D_ωo(h)(1 − F)G2/G1 [μt > 0] dh = ∫ weight ρ dρ dφ / π over the unit disk.
    /// The wrong side is reached only on bands of ρ (thin slivers of the disk along the
    /// critical-angle curve), so the lines are first probed on a grid of ρ (uniform, then graded
    /// towards the rim, where steep microfacets crowd at low roughness); each band of probed
    /// lines that reach it, widened by a probe on each side, is integrated with adaptive
    /// Gauss–Kronrod (7–15, the worst interval bisected until the error estimate meets `tol`).
    pub fn wrong_side(&self, tol: f64) -> f64 {
        const UNIFORM: usize = 256;
        const RIM: i32 = 50;
        let rule = gauss_legendre(16);
        let f = |rho: f64| self.line(rho, &rule) * rho / std::f64::consts::PI;
        let mut probes: Vec<f64> = (0..=UNIFORM).map(|k| k as f64 / UNIFORM as f64).collect();
        probes.extend((9..=RIM).map(|k| 1.0 - 2f64.powi(-k)));
        probes.push(1.0);
        probes.sort_by(f64::total_cmp);
        probes.dedup();
        let reached: Vec<bool> = probes.iter().map(|&r| f(r) > 0.0).collect();
        let mut total = 0.0;
        let mut k = 0;
        while k < probes.len() {
            if !reached[k] {
                k += 1;
                continue;
            }
            let first = k;
            while k + 1 < probes.len() && reached[k + 1] {
                k += 1;
            }
            let (a, b) = (
                probes[first.saturating_sub(1)],
                probes[(k + 1).min(probes.len() - 1)],
            );
            total += adaptive(&f, a, b, tol);
            k += 1;
        }
        total
    }
}

/// ∫ f over [a, b] by Gauss–Kronrod 7–15 on 16 intervals, bisecting the worst until the sum of
/// the error estimates is at most `tol`.
fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    const START: usize = 16;
    let step = (b - a) / START as f64;
    let mut parts: Vec<_> = (0..START)
        .map(|k| gk15(f, a + k as f64 * step, a + (k + 1) as f64 * step))
        .collect();
    for _ in 0..400 {
        let total_err: f64 = parts.iter().map(|p| p.3).sum();
        if total_err <= tol {
            break;
        }
        let k = (0..parts.len())
            .max_by(|&i, &j| parts[i].3.total_cmp(&parts[j].3))
            .expect("parts");
        let (a, b, _, _) = parts.swap_remove(k);
        let m = 0.5 * (a + b);
        parts.push(gk15(f, a, m));
        parts.push(gk15(f, m, b));
    }
    parts.iter().map(|p| p.2).sum()
}

/// (a, b, Kronrod value, |Kronrod − Gauss|) on [a, b].
// the 15-point Gauss–Kronrod nodes and weights as tabulated (QUADPACK's qk15), digits kept
#[allow(clippy::excessive_precision)]
fn gk15(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64, f64) {
    const XK: [f64; 8] = [
        0.991455371120812639,
        0.949107912342758525,
        0.864864423359769073,
        0.741531185599394440,
        0.586087235467691130,
        0.405845151377397167,
        0.207784955007898468,
        0.0,
    ];
    const WK: [f64; 8] = [
        0.022935322010529225,
        0.063092092629978553,
        0.104790010322250184,
        0.140653259715525919,
        0.169004726639267903,
        0.190350578064785410,
        0.204432940075298892,
        0.209482141084727828,
    ];
    const WG: [f64; 4] = [
        0.129484966168869693,
        0.279705391489276668,
        0.381830050505118945,
        0.417959183673469388,
    ];
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let fc = f(c);
    let (mut k, mut g) = (WK[7] * fc, WG[3] * fc);
    for j in 0..7 {
        let (f1, f2) = (f(c - h * XK[j]), f(c + h * XK[j]));
        k += WK[j] * (f1 + f2);
        if j % 2 == 1 {
            g += WG[j / 2] * (f1 + f2);
        }
    }
    (a, b, k * h, ((k - g) * h).abs())
}
