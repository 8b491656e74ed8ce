//! The anisotropic GGX white-conductor albedo in stretched slope space: the isotropic slope
//! integrand of [`super::slope`] with the slope density made isotropic by stretching.
//!
//! # The integral
//! In the tangent frame (t, b, n) the GGX slope density with roughnesses α_x (along t) and α_y
//! (along b) is P22(x, y) = 1/(π α_x α_y (1 + x²/α_x² + y²/α_y²)²) (Heitz 2014, eq. 86 with
//! the slopes scaled by α_x and α_y). With ωo = (sin θo cos φ, sin θo sin φ, μo) the white
//! conductor's albedo is, as in the isotropic case,
//!
//! E = ∫ P22 G2(ωo, ωi) (μo − ωo,xy·(x, y))/μo dx dy
//!
//! over the slopes whose mirror direction lies above the horizon — the same disc
//! |(x, y) + tan θo (cos φ, sin φ)|² < 1 + tan²θo, since reflection does not know α. Stretched
//! polar coordinates (x, y) = ρ'(α_x cos χ, α_y sin χ) make the density isotropic,
//! P22 dx dy = ρ' dρ' dχ / (π(1 + ρ'²)²), and keep every ray from the peak a ray: the horizon
//! is still the end of every radial line. On the line χ the slope radius is ρ = α_χ ρ' with
//! α_χ = √(α_x² cos²χ + α_y² sin²χ), and everything along the line — the horizon ρmax, the
//! radial variables s = asinh(ρ/α_χ) and u = 1/ρ, their maps and Jacobians — is the isotropic
//! line of [`super::slope`] with α replaced by α_χ and sin θo cos ψ by the projection of ωo on
//! the line's direction. Only the masking differs: Smith's a(ω) = √(μ² + α_x² ω_x² + α_y² ω_y²)
//! ([`crate::math::smith_a_aniso`]: the projected roughness of ω's azimuth) needs ωi's tangential components,
//! d·ωi,xy = −2(μo − sc·ρ)ρ·e − d·ωo,xy with d = 1 + ρ² and e the line's unit direction.
//!
//! # The outer variable
//! χ ∈ [0, 2π] (no mirror symmetry unless φ ∈ {0, π/2}). ρmax(χ) = μo/(g + √(g² + μo²A)) with
//! g = sin θo(α_x cos χ cos φ + α_y sin χ sin φ) and A = α_χ², so its only singularities are the
//! branch points g² + μo²A = 0: a quadratic form in (cos χ, sin χ) whose discriminant is
//! −(α_x α_y μo)², so that tan χ = (−Q ± i α_x α_y μo)/R in closed form (see
//! [`AnisoSlopeIntegrand::branch_points`]). Their real parts are near-singular outer breaks at
//! the distance of their imaginary parts — at strong anisotropy this distance is about
//! μo·α_y/α_x, the width in χ of the long thin ellipse the horizon disc becomes once stretched.
//! For α_x = α_y they are the isotropic integrand's π/2 ± i·asinh(μo/sin θo), about ωo's azimuth.

use super::microfacet::{ALPHA_MIN, GRAZING_RATIO};
use super::slope::SlopeLine;
use crate::math::{exp_poly, SmithForm};
use crate::quadrature::vector::{self, LANES};
use crate::quadrature::{panels_from_breaks, Break, Integrand2D, Panel, CHANNELS};
use std::f64::consts::{FRAC_PI_2, PI};

/// The stretched-slope integrand of one anisotropic conductor cell.
pub struct AnisoSlopeIntegrand {
    alpha_x: f64,
    alpha_y: f64,
    mu_o: f64,
    /// ωo's tangential components sin θo (cos φ, sin φ).
    wo_x: f64,
    wo_y: f64,
    smith: SmithForm,
    /// a(ωo) and, separable, G1(ωo)/μo = 2/(μo + a(ωo)).
    a_o: f64,
    g1_o_over_mu_o: f64,
    /// Start of the outer range [chi0, chi0 + 2π], midway between branch points.
    chi0: f64,
    /// The outer panels ([`Self::find_outer_panels`]), found once for every order the cell's
    /// estimate integrates at.
    outer: Vec<Panel>,
}

/// Per-line data of [`AnisoSlopeIntegrand`].
pub struct AnisoLine {
    /// Unit direction of the line in the slope plane and its slope scale α_χ.
    ex: f64,
    ey: f64,
    alpha_l: f64,
    /// The isotropic line at α = α_χ, with the projection of ωo,xy on the line's direction.
    radial: SlopeLine,
}

impl AnisoSlopeIntegrand {
    /// The white conductor with roughness α_x along the tangent and α_y along the bitangent, seen
    /// from μo ∈ [0, 1] at azimuth φ from the tangent. α below [`ALPHA_MIN`] is integrated at
    /// ALPHA_MIN, μo below [`GRAZING_RATIO`]·min(α_x, α_y) at μo = 0.
    pub fn conductor(
        alpha_x: f64,
        alpha_y: f64,
        mu_o: f64,
        phi: f64,
        smith: SmithForm,
    ) -> AnisoSlopeIntegrand {
        let (alpha_x, alpha_y) = (alpha_x.max(ALPHA_MIN), alpha_y.max(ALPHA_MIN));
        let mu_o = if mu_o < GRAZING_RATIO * alpha_x.min(alpha_y) {
            0.0
        } else {
            mu_o
        };
        let sin_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        let (wo_x, wo_y) = (sin_o * cp, sin_o * sp);
        let a_o = (mu_o * mu_o + alpha_x * alpha_x * wo_x * wo_x + alpha_y * alpha_y * wo_y * wo_y)
            .sqrt();
        let mut f = AnisoSlopeIntegrand {
            alpha_x,
            alpha_y,
            mu_o,
            wo_x,
            wo_y,
            smith,
            a_o,
            g1_o_over_mu_o: 2.0 / (mu_o + a_o),
            chi0: 0.0,
            outer: Vec::new(),
        };
        f.chi0 = f.branch_points().map_or(0.0, |(re, _)| re + FRAC_PI_2);
        let mut outer = Vec::with_capacity(8);
        f.find_outer_panels(&mut outer);
        f.outer = outer;
        f
    }

    /// χ ∈ [χ0, χ0 + 2π] with the branch points of ρmax at χ0 + π/2 and χ0 + 3π/2, each a
    /// near-singular break at the distance of its imaginary part, and the masking breaks.
    fn find_outer_panels(&self, out: &mut Vec<Panel>) {
        let c0 = self.chi0;
        let delta = self
            .branch_points()
            .map_or(f64::INFINITY, |(_, im)| im)
            .max(crate::quadrature::MIN_DELTA);
        let mut breaks = vec![
            Break::regular(c0),
            Break::near_singular(c0 + FRAC_PI_2, delta),
            Break::near_singular(c0 + 1.5 * PI, delta),
            Break::regular(c0 + 2.0 * PI),
        ];
        self.masking_breaks(&mut breaks);
        panels_from_breaks(&mut breaks, out);
    }

    /// The branch points of ρmax(χ), where g² + μo²A = 0: as a quadratic form in
    /// (cos χ, sin χ), P cos² + 2Q cos sin + R sin² with P = α_x²(ωo,x² + μo²),
    /// Q = α_x α_y ωo,x ωo,y, R = α_y²(ωo,y² + μo²) and PR − Q² = (α_x α_y μo)², so
    /// tan χ = (−Q ± i α_x α_y μo)/R. Returns (Re χ, |Im χ|) of the pair with Re χ ∈ (−π/2, π/2]
    /// (the other pair is π further), or `None` when they lie at infinity (α_x = α_y, μo = 1).
    fn branch_points(&self) -> Option<(f64, f64)> {
        let (ax, ay, m) = (self.alpha_x, self.alpha_y, self.mu_o);
        let q = ax * ay * self.wo_x * self.wo_y;
        let r = ay * ay * (self.wo_y * self.wo_y + m * m);
        let p = ax * ax * (self.wo_x * self.wo_x + m * m);
        if r <= 0.0 {
            // μo = 0 with ωo along the tangent: tan χ = ±∞ (χ = π/2), on the real axis
            return (p > 0.0).then_some((FRAC_PI_2, 0.0));
        }
        let (u, v) = (-q / r, ax * ay * m / r);
        // atan(u + iv) = ½ atan2(2u, 1 − u² − v²) + (i/4) ln((u² + (v + 1)²)/(u² + (v − 1)²))
        let re = 0.5 * (2.0 * u).atan2(1.0 - u * u - v * v);
        let den = u * u + (v - 1.0) * (v - 1.0);
        if den <= 0.0 {
            return None;
        }
        let im = 0.25 * ((u * u + (v + 1.0) * (v + 1.0)) / den).ln();
        Some((re, im.abs()))
    }

    /// d·ωi,xy at the horizon end of the line in direction (ex, ey) (scaled by any positive
    /// factor), or `None` where the line has no horizon (μo = 0 looking forward).
    fn horizon_direction(&self, ex: f64, ey: f64) -> Option<(f64, f64)> {
        let sc = ex * self.wo_x + ey * self.wo_y;
        let u_max = SlopeLine::new(sc, self.mu_o).u_max;
        if !u_max.is_finite() {
            return None;
        }
        let pu = self.mu_o * u_max - sc;
        let d = 1.0 + u_max * u_max;
        Some((
            -2.0 * pu * ex - d * self.wo_x,
            -2.0 * pu * ey - d * self.wo_y,
        ))
    }

    /// The line direction at stretched angle χ: (e_x, e_y, α_χ).
    #[inline]
    fn direction(&self, chi: f64) -> (f64, f64, f64) {
        let (s, c) = chi.sin_cos();
        let (px, py) = (self.alpha_x * c, self.alpha_y * s);
        let alpha_l = px.hypot(py);
        (px / alpha_l, py / alpha_l, alpha_l)
    }

    /// Near-singular outer breaks of the masking weight: next to the horizon, a(ωi) varies on the
    /// scale of ωi's projected roughness α_i = √(α_x² cos²ϑ + α_y² sin²ϑ) (ϑ the azimuth of the
    /// horizontal ωi there), whose zeros (ϑ = ±π/2 ± i·atanh(α_y/α_x) for α_x > α_y) come close
    /// to the real axis at strong anisotropy. Where ωi at the horizon is perpendicular to the
    /// rougher axis (ωi,x = 0 for α_x > α_y, found by a scan and bisection in χ), the line
    /// integral is near-singular at the distance atanh(min α/max α)/|dϑ/dχ|.
    fn masking_breaks(&self, out: &mut Vec<Break>) {
        if self.alpha_y == self.alpha_x {
            return; // isotropic: α_i is constant
        }
        // ωi's component along the rougher axis vanishes where α_i comes closest to zero
        let along_x = self.alpha_x > self.alpha_y;
        let ratio = self.alpha_y.min(self.alpha_x) / self.alpha_y.max(self.alpha_x);
        let width = ratio.atanh();
        let azimuth = |chi: f64| -> Option<(f64, f64)> {
            let (ex, ey, _) = self.direction(chi);
            self.horizon_direction(ex, ey)
                .map(|(x, y)| if along_x { (x, y) } else { (y, x) })
        };
        const SCAN: usize = 64;
        let c0 = self.chi0;
        let step = 2.0 * PI / SCAN as f64;
        let mut prev: Option<(f64, f64)> = None;
        for k in 0..=SCAN {
            let chi = c0 + step * k as f64;
            // only the sign of ωi's component along the rougher axis is compared
            let here = azimuth(chi).map(|(x, _)| (chi, x));
            if let (Some((c_lo, f_lo)), Some((c_hi, f_hi))) = (prev, here) {
                if (f_lo > 0.0) != (f_hi > 0.0) {
                    let (mut lo, mut hi) = (c_lo, c_hi);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        match azimuth(mid) {
                            Some((x, _)) if (x > 0.0) == (f_lo > 0.0) => lo = mid,
                            Some(_) => hi = mid,
                            None => break,
                        }
                    }
                    let root = 0.5 * (lo + hi);
                    const H: f64 = 1e-6;
                    let theta = |chi: f64| azimuth(chi).map(|(x, y)| y.atan2(x));
                    if let (Some(a), Some(b)) = (theta(root - H), theta(root + H)) {
                        let mut dt = b - a;
                        if dt > PI {
                            dt -= 2.0 * PI;
                        } else if dt < -PI {
                            dt += 2.0 * PI;
                        }
                        let rate = (dt / (2.0 * H)).abs();
                        if rate > 0.0 && root > c0 && root < c0 + 2.0 * PI {
                            out.push(Break::near_singular(
                                root,
                                (width / rate).max(crate::quadrature::MIN_DELTA),
                            ));
                        }
                    }
                }
            }
            prev = here;
        }
    }

    /// Σ_j ws[j]·f(vs[j]) in node order, by blocks of [`LANES`] nodes ([`Self::block`]), on
    /// the widest vector unit ([`vector::run`]): the same bits on every machine.
    #[inline(always)]
    fn sum<const TAIL: bool, const FACTORED: bool, const HC: bool>(
        &self,
        line: &AnisoLine,
        vs: &[f64],
        ws: &[f64],
    ) -> f64 {
        vector::run(vector::WeightedSum {
            block: AnisoBlock::<TAIL, FACTORED, HC> { f: self, line },
            vs,
            ws,
        })[0]
    }

    /// The integrand at [`LANES`] nodes of the s part (or the u part, `TAIL`) without branches:
    /// the isotropic block of [`super::slope`] at α = α_χ, with the anisotropic masking.
    #[inline(always)]
    fn block<const TAIL: bool, const FACTORED: bool, const HC: bool>(
        &self,
        line: &AnisoLine,
        v: &[f64; LANES],
    ) -> [[f64; 1]; LANES] {
        let mu_o = self.mu_o;
        let (ax2, ay2) = (self.alpha_x * self.alpha_x, self.alpha_y * self.alpha_y);
        let (ex, ey, wx, wy) = (line.ex, line.ey, self.wo_x, self.wo_y);
        let scale = if HC {
            1.0 / PI
        } else {
            self.g1_o_over_mu_o / PI
        };
        let mut y = [[0.0; 1]; LANES];
        if TAIL {
            // u = 1/ρ, every length multiplied by u²: μi = n/d with n = (u − umax)(k' + μo·u),
            // d = 1 + u²; d·ωi,xy = −2(μo·u − sc)·e − d·ωo,xy; the Jacobian α_χ²u/(1 + α_χ²u²)²
            // times the projected factor (μo − sc/u).
            let al2 = line.alpha_l * line.alpha_l;
            for (yj, &vj) in y.iter_mut().zip(v) {
                let u = line.radial.u_tail - (vj - line.radial.s_end);
                let n = (u - line.radial.u_max) * (line.radial.k_prime + mu_o * u);
                let d = 1.0 + u * u;
                let pu = mu_o * u - line.radial.sc;
                let (dwx, dwy) = (-2.0 * pu * ex - d * wx, -2.0 * pu * ey - d * wy);
                let a_d = (n * n + ax2 * dwx * dwx + ay2 * dwy * dwy).sqrt();
                let den = if HC {
                    n * self.a_o + mu_o * a_d
                } else {
                    n + a_d
                };
                let au2 = 1.0 + al2 * u * u;
                let g = scale * 2.0 * n * al2 * pu / (au2 * au2 * den);
                yj[0] = if n > 0.0 { g } else { 0.0 };
            }
            return y;
        }
        for (yj, &vj) in y.iter_mut().zip(v) {
            let e = exp_poly(vj);
            let inv = 1.0 / e;
            let (sinh, cosh) = (0.5 * (e - inv), 0.5 * (e + inv));
            let rho = line.alpha_l * sinh;
            let n = if FACTORED {
                (line.radial.rho_max - rho) * (mu_o * rho + line.radial.k)
            } else {
                mu_o * (1.0 - rho * rho) - 2.0 * line.radial.sc * rho
            };
            let d = 1.0 + rho * rho;
            let proj = mu_o - line.radial.sc * rho;
            let t = -2.0 * proj * rho;
            let (dwx, dwy) = (t * ex - d * wx, t * ey - d * wy);
            let a_d = (n * n + ax2 * dwx * dwx + ay2 * dwy * dwy).sqrt();
            let den = if HC {
                n * self.a_o + mu_o * a_d
            } else {
                n + a_d
            };
            let g = scale * 2.0 * n * sinh * proj / (cosh * cosh * cosh * den);
            yj[0] = if n > 0.0 { g } else { 0.0 };
        }
        y
    }

    #[inline(always)]
    fn sum_any(&self, line: &AnisoLine, vs: &[f64], ws: &[f64]) -> f64 {
        let tail = vs.first().is_some_and(|&v| v > line.radial.s_end);
        match (tail, line.radial.rho_max.is_finite(), self.smith) {
            (false, true, SmithForm::HeightCorrelated) => {
                self.sum::<false, true, true>(line, vs, ws)
            }
            (false, true, SmithForm::Separable) => self.sum::<false, true, false>(line, vs, ws),
            (false, false, SmithForm::HeightCorrelated) => {
                self.sum::<false, false, true>(line, vs, ws)
            }
            (false, false, SmithForm::Separable) => self.sum::<false, false, false>(line, vs, ws),
            (true, _, SmithForm::HeightCorrelated) => self.sum::<true, true, true>(line, vs, ws),
            (true, _, SmithForm::Separable) => self.sum::<true, true, false>(line, vs, ws),
        }
    }
}

/// One line's [`AnisoSlopeIntegrand::block`] as a [`vector::Block`].
struct AnisoBlock<'a, const TAIL: bool, const FACTORED: bool, const HC: bool> {
    f: &'a AnisoSlopeIntegrand,
    line: &'a AnisoLine,
}

impl<const TAIL: bool, const FACTORED: bool, const HC: bool> vector::Block<1>
    for AnisoBlock<'_, TAIL, FACTORED, HC>
{
    #[inline(always)]
    fn block(&self, v: &[f64; LANES]) -> [[f64; 1]; LANES] {
        self.f.block::<TAIL, FACTORED, HC>(self.line, v)
    }
}

impl Integrand2D for AnisoSlopeIntegrand {
    type Line = AnisoLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        let mut panels = Vec::new();
        self.outer_panels(&mut panels);
        out.extend(panels.iter().map(|p| p.a));
        out.extend(panels.last().map(|p| p.b));
    }

    fn line(&self, chi: f64, breaks: &mut Vec<f64>) -> AnisoLine {
        let mut panels = Vec::new();
        let line = self.line_panels(chi, &mut panels);
        breaks.extend(panels.iter().map(|p| p.a));
        breaks.extend(panels.last().map(|p| p.b));
        line
    }

    /// The panels [`AnisoSlopeIntegrand::conductor`] found ([`AnisoSlopeIntegrand::find_outer_panels`]).
    fn outer_panels(&self, out: &mut Vec<Panel>) {
        out.extend_from_slice(&self.outer);
    }

    fn line_panels(&self, chi: f64, out: &mut Vec<Panel>) -> AnisoLine {
        let (ex, ey, alpha_l) = self.direction(chi);
        let mut radial = SlopeLine::new(ex * self.wo_x + ey * self.wo_y, self.mu_o);
        if radial.reflects() {
            // The masking weight's scale next to the horizon: the projected roughness of ωi
            // there (horizontal), from d·ωi,xy at u = umax (finite also for ρmax = ∞).
            let mask_scale = match self.horizon_direction(ex, ey) {
                Some((dwx, dwy)) if dwx * dwx + dwy * dwy > 0.0 => {
                    let n2 = dwx * dwx + dwy * dwy;
                    let (qx, qy) = (self.alpha_x * dwx, self.alpha_y * dwy);
                    ((qx * qx + qy * qy) / n2).sqrt()
                }
                _ => self.alpha_y,
            };
            radial.panels(alpha_l, self.mu_o, mask_scale, self.smith, out);
        }
        AnisoLine {
            ex,
            ey,
            alpha_l,
            radial,
        }
    }

    fn panels_all_active(&self) -> bool {
        true
    }

    fn accumulate_nodes(&self, line: &AnisoLine, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        acc[0] += self.sum_any(line, vs, ws);
    }

    fn eval(&self, line: &AnisoLine, v: f64) -> [f64; CHANNELS] {
        [self.sum_any(line, &[v], &[1.0]), 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::slope::SlopeIntegrand;
    use crate::quadrature::{integrate_2d, Rules};

    #[test]
    fn isotropic_limit() {
        let rules = Rules::new(24);
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            for (r, mu) in [(0.3, 0.5), (1.0, 1.0), (0.7, 0.05), (0.1, 0.0), (0.9, 0.3)] {
                let alpha: f64 = r * r;
                let iso = integrate_2d(&SlopeIntegrand::conductor(alpha, mu, smith), &rules)[0];
                for phi in [0.0, 0.4, 1.3] {
                    let a = integrate_2d(
                        &AnisoSlopeIntegrand::conductor(alpha, alpha, mu, phi, smith),
                        &rules,
                    )[0];
                    assert!(
                        (a - iso).abs() < 1e-10,
                        "{smith:?} r={r} mu={mu} phi={phi}: {a} vs {iso}"
                    );
                }
            }
        }
    }
}
