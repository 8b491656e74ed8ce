//! Kink geometry of the visible-normal parametrisation ([`super::vndf`]): the reflection
//! horizon, the critical angle and the squared transmission horizon are each the zero set of a
//! quadratic form in the stretched normal N, whose zeros on a line of constant latitude, and the
//! latitudes where they appear, merge, cross the ends of the range or cross each other, are all
//! closed-form.

use std::f64::consts::PI;

/// The quadratic form Q(N) = A_xx N_x² + 2A_xz N_x N_z + A_zz N_z² + A_yy N_y² restricted to the
/// unit sphere: on the line of latitude β, Q = cos²β (P + R cos(2φ − γ)) + A_yy sin²β.
#[derive(Clone, Copy, Debug)]
pub(crate) struct QuadForm {
    p: f64,
    r: f64,
    gamma: f64,
    a_yy: f64,
}

impl QuadForm {
    pub(crate) fn new(a_xx: f64, a_xz: f64, a_zz: f64, a_yy: f64) -> QuadForm {
        let half = 0.5 * (a_xx - a_zz);
        QuadForm {
            p: 0.5 * (a_xx + a_zz),
            r: half.hypot(a_xz),
            gamma: a_xz.atan2(half),
            a_yy,
        }
    }

    /// Value on the line (sβ, cβ) at φ (for the sign only).
    #[cfg(test)]
    pub(crate) fn value(&self, sb: f64, cb: f64, phi: f64) -> f64 {
        cb * cb * (self.p + self.r * (2.0 * phi - self.gamma).cos()) + self.a_yy * sb * sb
    }

    /// Zeros in φ ∈ (0, phi_max) on the line (sβ, cβ), appended to `out`.
    pub(crate) fn roots(&self, sb: f64, cb: f64, phi_max: f64, out: &mut Vec<f64>) {
        let den = self.r * cb * cb;
        if den <= 0.0 {
            return;
        }
        let c = -(self.p * cb * cb + self.a_yy * sb * sb) / den;
        if !(c > -1.0 && c < 1.0) {
            return;
        }
        let a = c.acos();
        for k in -1..=1 {
            for s in [-1.0, 1.0] {
                let phi = 0.5 * (self.gamma + s * a) + k as f64 * PI;
                if phi > 0.0 && phi < phi_max {
                    out.push(phi);
                }
            }
        }
    }

    /// The singularities of a kink function built on this form that lie *near* the range
    /// without being zeros inside it: complex zeros (the curve almost touches the line) give
    /// an interior point `re` at distance `im`; real zeros just outside the range give the end
    /// they are close to, at distance `d`. Appends `(point, distance)` pairs with distance below
    /// `reach`.
    pub(crate) fn near_singularities(
        &self,
        sb: f64,
        cb: f64,
        phi_max: f64,
        reach: f64,
        out: &mut Vec<(f64, f64)>,
    ) {
        let den = self.r * cb * cb;
        if den <= 0.0 {
            return;
        }
        let c = -(self.p * cb * cb + self.a_yy * sb * sb) / den;
        if !c.is_finite() {
            return;
        }
        if c > -1.0 && c < 1.0 {
            let a = c.acos();
            for k in -2..=2 {
                for s in [-1.0, 1.0] {
                    let phi = 0.5 * (self.gamma + s * a) + k as f64 * PI;
                    if phi <= 0.0 && -phi < reach {
                        out.push((0.0, -phi));
                    } else if phi >= phi_max && phi - phi_max < reach {
                        out.push((phi_max, phi - phi_max));
                    }
                }
            }
        } else {
            // cos(2φ − γ) = c with |c| ≥ 1: 2φ − γ = {0, π} ± i·acosh|c|
            let im = 0.5 * c.abs().acosh();
            if im >= reach {
                return;
            }
            let shift = if c >= 1.0 { 0.0 } else { PI };
            for k in -2..=2 {
                let re = 0.5 * (self.gamma + shift) + k as f64 * PI;
                if re > 0.0 && re < phi_max {
                    out.push((re, im));
                } else if re <= 0.0 && (-re).hypot(im) < reach {
                    out.push((0.0, (-re).hypot(im)));
                } else if re >= phi_max && (re - phi_max).hypot(im) < reach {
                    out.push((phi_max, (re - phi_max).hypot(im)));
                }
            }
        }
    }

    /// Latitudes β ∈ (0, π/2) at which the zero curves of two forms cross inside the φ range.
    /// Eliminating tan²β between the two line equations leaves a cos X + b sin X + c = 0 in
    /// X = 2φ, so the crossings are closed-form too.
    pub(crate) fn crossings(&self, other: &QuadForm, phi_max: f64, out: &mut Vec<f64>) {
        let (q1, q2) = (self, other);
        let mut push = |phi: f64, q: &QuadForm| {
            if phi > 0.0 && phi < phi_max && q.a_yy != 0.0 {
                let t2 = -(q.p + q.r * (2.0 * phi - q.gamma).cos()) / q.a_yy;
                if t2 > 0.0 && t2.is_finite() {
                    out.push(t2.sqrt().atan());
                }
            }
        };
        if q1.a_yy == 0.0 || q2.a_yy == 0.0 {
            // one curve is a fixed set of lines φ = const (independent of β)
            let (fixed, moving) = if q1.a_yy == 0.0 { (q1, q2) } else { (q2, q1) };
            if fixed.r > 0.0 {
                let c = -fixed.p / fixed.r;
                if c > -1.0 && c < 1.0 {
                    let a = c.acos();
                    for k in -1..=2 {
                        for sgn in [-1.0, 1.0] {
                            push(0.5 * (fixed.gamma + sgn * a) + k as f64 * PI, moving);
                        }
                    }
                }
            }
            return;
        }
        let a = q2.a_yy * q1.r * q1.gamma.cos() - q1.a_yy * q2.r * q2.gamma.cos();
        let b = q2.a_yy * q1.r * q1.gamma.sin() - q1.a_yy * q2.r * q2.gamma.sin();
        let c = q2.a_yy * q1.p - q1.a_yy * q2.p;
        let rho = a.hypot(b);
        if rho == 0.0 {
            return;
        }
        let cc = -c / rho;
        if !(cc > -1.0 && cc < 1.0) {
            return;
        }
        let theta = b.atan2(a);
        let d = cc.acos();
        for k in -1..=2 {
            for sgn in [-1.0, 1.0] {
                push(0.5 * (theta + sgn * d) + k as f64 * PI, q1);
            }
        }
    }

    /// Latitudes β ∈ (0, π/2) at which the zero set on a line changes shape: zeros merge
    /// (cos(2φ − γ) = ±1 inside the range) or cross an end of the φ range.
    pub(crate) fn outer_breaks(&self, phi_max: f64, out: &mut Vec<f64>) {
        if self.a_yy == 0.0 {
            return;
        }
        let mut push_tan2 = |t2: f64| {
            if t2 > 0.0 && t2.is_finite() {
                out.push(t2.sqrt().atan());
            }
        };
        // Merges: P + A_yy tan²β = ∓R, at φ = (γ + {0, π})/2 + kπ.
        for (sign, shift) in [(1.0, 0.0), (-1.0, PI)] {
            let inside = (-1..=1).any(|k| {
                let phi = 0.5 * (self.gamma + shift) + k as f64 * PI;
                phi > 0.0 && phi < phi_max
            });
            if inside {
                push_tan2(-(self.p + sign * self.r) / self.a_yy);
            }
        }
        // Crossing an end of the range.
        for phi in [0.0, phi_max] {
            let q = self.p + self.r * (2.0 * phi - self.gamma).cos();
            push_tan2(-q / self.a_yy);
        }
    }
}

/// Sorts `v` and drops entries within 1e-15 of the previous one (coincident breaks).
pub(crate) fn sort_dedup(v: &mut Vec<f64>) {
    v.sort_by(|a, b| a.total_cmp(b));
    v.dedup_by(|a, b| (*a - *b).abs() <= 1e-15);
}
