//! The GGX dielectric albedo in slope space, polar about the distribution's peak, as for the
//! conductor ([`super::slope`]): on every radial line each kink of the integrand — the
//! reflection horizon, the critical angle, the transmission horizon, the visibility limit — is a
//! closed-form root of a quadratic in ρ, and a panel end; the latitudes where their order
//! changes are closed-form too. No line needs a scan, a bisection or an activity test.
//!
//! # The integrals
//! With the slopes (x, y) = ρ(cos ψ, sin ψ) of the microfacet normal, h ∝ (−x, −y, 1),
//! ωo = (sin θo, 0, μo) and relative IOR η (seen from ωo), write sc = sin θo·cos ψ,
//! d² = 1 + ρ² and g = μo − sc·ρ = (ωo·h)·d. Both lobes are integrals of the conductor's form
//! (D(h)(ωo·h) dω_h = P22·g dx dy, Heitz 2014 eq. 86; energy form: no 1/η² on transmission):
//!
//! E_R = ∫ P22 g F G2(ωo, ωi)/μo [μi > 0] dx dy,   E_T = ∫ P22 g (1 − F) G2(ωo, ωt)/μo [μt < 0] dx dy.
//!
//! * μi = n_R/d² with n_R = μo(1 − ρ²) − 2sc·ρ: reflection ends at ρmax(ψ) (the disc of
//!   [`super::slope`]).
//! * η cos θt = √Q/d with Q = g² + (η² − 1)d² (Walter 2007, eq. 40): the critical angle (η < 1)
//!   is Q = 0, a quadratic in ρ; F = 1 where Q < 0. The Fresnel terms need only g and √Q:
//!   r_s = (g − √Q)/(g + √Q), r_p = (η²g − √Q)/(η²g + √Q) (Walter 2007, eq. 22).
//! * η μt d² = A − √Q with A = −ρ(sc + μo ρ). Squared, μt = 0 is C = μo²ρ² + 2μo·sc·ρ + sin²θo − η²
//!   = 0, the circle of radius η/μo about ωo's image (−tan θo, 0) (A² − Q = d²C); its root is
//!   the transmission horizon where A > 0 (the real branch), i.e. only leaving the denser medium
//!   with μo below the critical cosine, where the peak itself is totally reflected. Entering
//!   (η ≥ 1) μt < 0 everywhere, and transmission ends where ωo·h = 0 (ρ = μo/sc).
//!
//! So on a line the cap of non-TIR normals is [q₁, q₂] (q₁ = 0 when μo exceeds the critical
//! cosine, q₂ = ∞ past the asymptote sc² = 1 − η²), transmission [ρt, q₂] within it, reflection
//! [0, ρmax]; the transmission circle is concentric with the horizon and smaller, so ρt < ρmax.
//! Latitudes where the structure changes: the rays tangent to the cap and the circle (the two
//! touch there, cos ψ = −√(1 − η² − μo²)/sin θo, one-sided square-root behaviour), the crossing of
//! the cap with the reflection horizon (in polar coordinates about ωo's image, scaled by μo,
//! the horizon is the unit circle and the crossing is at sin θo·cos φ = 2η² − 1), and the
//! asymptote (q₂ → ∞, cos ψ = −√(1 − η²)/sin θo). The branch points of √(sc² + μo²) (ρmax) and
//! of √(sc² + μo² − 1 + η²) (the cap, the circle) lie at π/2 ± i·asinh(·/sin θo): a near-singular
//! break at π/2.
//!
//! # Panels and evaluation
//! The radial variables are the conductor's (ρ = α sinh s about the peak, u = 1/ρ beyond
//! [`RHO_TAIL`]). Near-singular ends: the masking weights' branch points (|μ| ~ α) next to the
//! two horizons, at distance α/|dμ/dρ| (|dμi/dρ| = k at ρmax, |dμt/dρ| = μo/(η ρt) at ρt); the
//! Fresnel factor's square root at the cap boundary gets the square-root map on the cap side.
//! Each panel carries a fixed set of lobes ([`Lobe`]) and is summed by a branch-free block of
//! [`LANES`] nodes on the widest vector unit ([`vector::run`]); everything is rational in ρ but
//! for three square roots, and each channel takes one division (the masking weights' and the
//! Fresnel terms' denominators multiplied together).

use super::microfacet::{ALPHA_MIN, GRAZING_RATIO};
use super::slope::{peak_panels, Horizon, RHO_TAIL};
use crate::math::{asinh_pos, exp_poly, sin_cos_0_pi, smith_a, SmithForm};
use crate::quadrature::vector::{self, LANES};
use crate::quadrature::{panels_from_breaks, Break, Integrand2D, Panel, CHANNELS, MIN_DELTA};
use std::f64::consts::{FRAC_PI_2, PI};

/// What a panel of a radial line carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Lobe {
    /// Reflection with F = 1 (total internal reflection): the conductor's integrand.
    Mirror,
    /// Reflection with Fresnel, no transmission.
    Fresnel,
    /// Reflection with Fresnel and transmission.
    Both,
    /// Transmission only (beyond the reflection horizon).
    Transmit,
}

/// Most segments (runs of one [`Lobe`]) on a line: 0, q₁, ρt, q₂, ρmax.
const MAX_SEGMENTS: usize = 6;

/// A radial position known as both ρ and u = 1/ρ (either may be 0 or ∞).
#[derive(Clone, Copy, Debug)]
struct Radius {
    rho: f64,
    u: f64,
}

impl Radius {
    fn rho(rho: f64) -> Radius {
        Radius { rho, u: 1.0 / rho }
    }
    fn u(u: f64) -> Radius {
        Radius { rho: 1.0 / u, u }
    }
}

/// A kink on a radial line: where, which sides have square-root behaviour, and the distance to
/// its nearest complex singularity in ρ and in u.
#[derive(Clone, Copy, Debug)]
struct Kink {
    at: Radius,
    sqrt_below: bool,
    sqrt_above: bool,
    delta_rho: f64,
    delta_u: f64,
}

impl Kink {
    fn regular(at: Radius) -> Kink {
        Kink {
            at,
            sqrt_below: false,
            sqrt_above: false,
            delta_rho: f64::INFINITY,
            delta_u: f64::INFINITY,
        }
    }
}

/// The slope-space dielectric integrand of one cell: channels [E_R, E_T].
pub struct SlopeDielectric {
    alpha: f64,
    mu_o: f64,
    sin_o: f64,
    eta: f64,
    eta2: f64,
    /// 1 − η² (positive leaving the denser medium) and √ of it (0 entering).
    cc2: f64,
    cc: f64,
    /// sin²θo − η² = 1 − η² − μo² (the constant of C), computed as a product.
    c0: f64,
    /// Masking weight G2/μo = c_smith·2n/(n·p + q·a(n)) for a numerator n of μ (both Smith
    /// forms: height-correlated (p, q, c) = (a(μo), μo, 1), separable (1, 1, 2/(μo + a(μo)))).
    p: f64,
    q: f64,
    c_smith: f64,
    smith: SmithForm,
    /// Scale in μ of the masking weights' singularities next to the horizons.
    mask_scale: f64,
}

/// Per-line data of [`SlopeDielectric`].
pub struct DielectricLine {
    sc: f64,
    h: Horizon,
    /// The s part is [0, s_end]; the u part v = s_end + (u_tail − u) beyond it.
    s_end: f64,
    u_tail: f64,
    /// Segments in v: the i-th ends at `seg_end[i]` and carries `seg_lobe[i]`.
    seg_end: [f64; MAX_SEGMENTS],
    seg_lobe: [Lobe; MAX_SEGMENTS],
    segments: usize,
}

impl SlopeDielectric {
    /// A dielectric interface of roughness α > 0 and relative IOR η > 0 seen from μo ∈ [0, 1].
    /// α below [`ALPHA_MIN`] is integrated at ALPHA_MIN, μo below [`GRAZING_RATIO`]·α at μo = 0.
    pub fn new(alpha: f64, mu_o: f64, eta: f64, smith: SmithForm) -> SlopeDielectric {
        let alpha = alpha.max(ALPHA_MIN);
        let mu_o = if mu_o < GRAZING_RATIO * alpha {
            0.0
        } else {
            mu_o
        };
        let a_o = smith_a(mu_o, alpha);
        let (p, q, c_smith) = match smith {
            SmithForm::HeightCorrelated => (a_o, mu_o, 1.0),
            SmithForm::Separable => (1.0, 1.0, 2.0 / (mu_o + a_o)),
        };
        let cc2 = ((1.0 - eta) * (1.0 + eta)).max(0.0);
        let cc = cc2.sqrt();
        SlopeDielectric {
            alpha,
            mu_o,
            sin_o: (1.0 - mu_o * mu_o).max(0.0).sqrt(),
            eta,
            eta2: eta * eta,
            cc2,
            cc,
            c0: (1.0 - eta) * (1.0 + eta) - mu_o * mu_o,
            p,
            q,
            c_smith,
            smith,
            mask_scale: alpha,
        }
    }

    /// Leaving the denser medium: a critical angle exists.
    fn leaving(&self) -> bool {
        self.eta < 1.0
    }

    /// The integrand at [`LANES`] nodes of one panel: `PART` 0 is the s part with ρmax finite
    /// (μi in factored form), 1 the s part with ρmax = ∞, 2 the u part; `LOBE` the [`Lobe`]
    /// as its index. No branches (selects only), so that the block vectorises.
    #[inline(always)]
    fn block<const PART: u8, const LOBE: u8>(
        &self,
        line: &DielectricLine,
        v: &[f64; LANES],
    ) -> [[f64; CHANNELS]; LANES] {
        let (alpha, mu_o, eta2) = (self.alpha, self.mu_o, self.eta2);
        let alpha2 = alpha * alpha;
        let one_m_a2 = 1.0 - alpha2;
        let sc = line.sc;
        let h = &line.h;
        let reflect = LOBE != 3;
        let fresnel = LOBE != 0;
        let transmit = LOBE >= 2;
        // ×2 for ψ ∈ [π, 2π] and 1/π from P22 (the masking weights' 2 is below)
        let scale = self.c_smith * (2.0 / PI);
        let mut y = [[0.0; CHANNELS]; LANES];
        for (yj, &vj) in y.iter_mut().zip(v) {
            // the common factor (measure, projected area) and the line's polynomials, either
            // in ρ (s part) or multiplied by u² (u part; every weight is homogeneous in them)
            // u: the factor that puts √Q on A's scale in the transmitted z (1 in the s part)
            let (jac, d2, g, n, a, c, u_t) = if PART == 2 {
                let u = line.u_tail - (vj - line.s_end);
                let au2 = 1.0 + alpha2 * u * u;
                let g = mu_o * u - sc;
                let n = (u - h.u_max) * (h.k_prime + mu_o * u);
                let a = -(sc * u + mu_o);
                let c = mu_o * mu_o + u * (2.0 * mu_o * sc + self.c0 * u);
                (alpha2 / (au2 * au2), 1.0 + u * u, g, n, a, c, u)
            } else {
                let e = exp_poly(vj);
                let inv = 1.0 / e;
                let (sinh, cosh) = (0.5 * (e - inv), 0.5 * (e + inv));
                let rho = alpha * sinh;
                let n = if PART == 0 {
                    (h.rho_max - rho) * (mu_o * rho + h.k)
                } else {
                    mu_o * (1.0 - rho * rho) - 2.0 * sc * rho
                };
                let a = -rho * (sc + mu_o * rho);
                let c = self.c0 + rho * (2.0 * mu_o * sc + mu_o * mu_o * rho);
                (
                    sinh / (cosh * cosh * cosh),
                    1.0 + rho * rho,
                    mu_o - sc * rho,
                    n,
                    a,
                    c,
                    1.0,
                )
            };
            let base = scale * jac * g;
            // Fresnel from g and √Q: F = num_r/den_f, 1 − F = num_t/den_f
            let sq = (g * g + (eta2 - 1.0) * d2).max(0.0).sqrt();
            let (a1, a2) = (g + sq, eta2 * g + sq);
            let (b1, b2) = (g - sq, eta2 * g - sq);
            let (a1s, a2s) = (a1 * a1, a2 * a2);
            let (num_r, num_t, den_f) = if fresnel {
                (
                    b1 * b1 * a2s + b2 * b2 * a1s,
                    4.0 * g * sq * (a2s + eta2 * a1s),
                    2.0 * a1s * a2s,
                )
            } else {
                (1.0, 0.0, 1.0)
            };
            if reflect {
                let a_d = (n * n * one_m_a2 + alpha2 * d2 * d2).max(0.0).sqrt();
                let den = n * self.p + self.q * a_d;
                let r = base * 2.0 * n * num_r / (den * den_f);
                yj[0] = if n > 0.0 { r } else { 0.0 };
            }
            if transmit {
                // −η μt d² = m/dm: √Q − A where A ≤ 0, else −d²C/(A + √Q) (no cancellation);
                // in the u part A, C and d² carry u², √Q only u
                let sq_t = u_t * sq;
                let direct = a <= 0.0;
                let m = if direct { sq_t - a } else { -d2 * c };
                let dm = if direct { 1.0 } else { a + sq_t };
                let e = self.eta * d2 * dm;
                let a_t = (m * m * one_m_a2 + alpha2 * e * e).max(0.0).sqrt();
                let den = m * self.p + self.q * a_t;
                let t = base * 2.0 * m * num_t / (den * den_f);
                yj[1] = if m > 0.0 { t } else { 0.0 };
            }
        }
        y
    }

    /// Σ ws·f(vs) per channel over one panel ([`Self::block`] on the widest vector unit).
    fn sum<const PART: u8, const LOBE: u8>(
        &self,
        line: &DielectricLine,
        vs: &[f64],
        ws: &[f64],
    ) -> [f64; CHANNELS] {
        vector::run(vector::WeightedSum {
            block: DielectricBlock::<PART, LOBE> { f: self, line },
            vs,
            ws,
        })
    }

    /// The segment a panel with nodes `vs` lies in, and whether it is in the u part.
    fn segment(line: &DielectricLine, vs: &[f64]) -> (Lobe, u8) {
        let mid = 0.5 * (vs[0] + vs[vs.len() - 1]);
        let i = line.seg_end[..line.segments]
            .iter()
            .position(|&e| mid < e)
            .unwrap_or(line.segments.saturating_sub(1));
        let part = if mid > line.s_end {
            2
        } else if line.h.rho_max.is_finite() {
            0
        } else {
            1
        };
        (line.seg_lobe[i], part)
    }

    fn sum_panel(&self, line: &DielectricLine, vs: &[f64], ws: &[f64]) -> [f64; CHANNELS] {
        let (lobe, part) = Self::segment(line, vs);
        macro_rules! by_lobe {
            ($part:literal) => {
                match lobe {
                    Lobe::Mirror => self.sum::<$part, 0>(line, vs, ws),
                    Lobe::Fresnel => self.sum::<$part, 1>(line, vs, ws),
                    Lobe::Both => self.sum::<$part, 2>(line, vs, ws),
                    Lobe::Transmit => self.sum::<$part, 3>(line, vs, ws),
                }
            };
        }
        match part {
            0 => by_lobe!(0),
            1 => by_lobe!(1),
            _ => by_lobe!(2),
        }
    }

    /// The kinks of the line at sc = sin θo·cos ψ and the lobes between them, in increasing ρ:
    /// `kinks[0]` is ρ = 0, `lobes[i]` the segment above `kinks[i]`; the line ends at the last
    /// kink. Returns the number of kinks (0: nothing on this line).
    fn kinks(
        &self,
        sc: f64,
        h: &Horizon,
        kinks: &mut [Kink; MAX_SEGMENTS + 1],
        lobes: &mut [Lobe; MAX_SEGMENTS],
    ) -> usize {
        let mu_o = self.mu_o;
        let reflects = h.rho_max > 0.0; // NaN (μo = 0 looking forward) is false
                                        // reflection horizon: |dμi/dρ| = k there, |dμi/du| = k'
        let horizon = {
            let mut delta_u = if h.k_prime > 0.0 {
                self.mask_scale / h.k_prime
            } else {
                f64::INFINITY
            };
            if self.smith == SmithForm::HeightCorrelated && mu_o > 0.0 {
                // the pole at u = 0 (μi → −μo as ρ → ∞), umax beyond the horizon end
                delta_u = delta_u.min(h.u_max);
            }
            Kink {
                delta_rho: if h.k > 0.0 {
                    self.mask_scale / h.k
                } else {
                    f64::INFINITY
                },
                delta_u,
                ..Kink::regular(Radius {
                    rho: h.rho_max,
                    u: h.u_max,
                })
            }
        };
        // The cap [q1, q2] of normals that refract, and transmission [t0, q2] within it.
        let inf = Radius {
            rho: f64::INFINITY,
            u: 0.0,
        };
        let zero = Radius {
            rho: 0.0,
            u: f64::INFINITY,
        };
        let mut start = Kink::regular(zero);
        let (q1, q2, t0): (Option<Kink>, Option<Kink>, Option<Kink>);
        if !self.leaving() {
            // no critical angle; transmission up to ωo·h = 0 at ρ = μo/sc (looking away from ωo)
            q1 = None;
            t0 = None;
            q2 = Some(if sc > 0.0 {
                Kink::regular(Radius::u(sc / mu_o))
            } else {
                Kink::regular(inf)
            });
        } else {
            let (cc, cc2) = (self.cc, self.cc2);
            let w2 = sc * sc + mu_o * mu_o - cc2;
            let c0 = -self.c0; // μo² − (1 − η²): Q at ρ = 0
            if c0 >= 0.0 {
                // the peak refracts: the cap is [0, q], q the smallest positive root of Q
                let w = w2.max(0.0).sqrt();
                let q = if sc >= 0.0 {
                    Radius::u((mu_o * sc + cc * w) / c0)
                } else if sc * sc < cc2 {
                    Radius::u((cc2 - sc * sc) / (cc * w - mu_o * sc))
                } else {
                    inf
                };
                q1 = None;
                q2 = Some(Kink {
                    sqrt_below: true,
                    ..Kink::regular(q)
                });
                t0 = None;
                // the other root of Q, on the opposite line, near the peak when μo is near
                // the critical cosine
                if cc * w - mu_o * sc > 0.0 {
                    let back = c0 / (cc * w - mu_o * sc);
                    start.delta_rho = back;
                }
            } else if sc < 0.0 && w2 >= 0.0 {
                // the peak is totally reflected; the line crosses the cap
                let w = w2.sqrt();
                let den = mu_o * -sc + cc * w;
                let entry = Radius::rho(-c0 / den);
                let exit = if sc * sc < cc2 {
                    Radius::u((cc2 - sc * sc) / den)
                } else {
                    inf
                };
                // the real root of C (A > 0): ρt = −c0/(μo(|sc| + w)), |dμt/dρ| = μo/(η ρt)
                let t = Radius::u(mu_o * (w - sc) / -c0);
                q1 = Some(Kink {
                    sqrt_above: true,
                    ..Kink::regular(entry)
                });
                q2 = Some(Kink {
                    sqrt_below: true,
                    ..Kink::regular(exit)
                });
                t0 = (t.rho < exit.rho).then(|| {
                    let delta_u = self.mask_scale * self.eta * t.u / mu_o;
                    Kink {
                        delta_rho: delta_u * t.rho * t.rho,
                        delta_u,
                        ..Kink::regular(t)
                    }
                });
            } else {
                q1 = None;
                q2 = None;
                t0 = None;
            }
        }
        // Assemble: candidate kinks, sorted, each segment's lobes from where it lies.
        let mut cand = [Kink::regular(zero); 5];
        let mut n = 0;
        for k in [reflects.then_some(horizon), q1, q2, t0]
            .into_iter()
            .flatten()
        {
            if k.at.rho > 0.0 {
                cand[n] = k;
                n += 1;
            }
        }
        cand[..n].sort_by(|a, b| a.at.rho.total_cmp(&b.at.rho));
        let rho_max = if reflects { h.rho_max } else { 0.0 };
        let (cap_lo, cap_hi) = match (self.leaving(), q2) {
            (false, _) => (0.0, f64::INFINITY),
            (true, Some(q2)) => (q1.map_or(0.0, |k| k.at.rho), q2.at.rho),
            (true, None) => (f64::INFINITY, f64::INFINITY),
        };
        let (t_lo, t_hi) = match (self.leaving(), q2, t0) {
            (false, Some(q2), _) => (0.0, q2.at.rho),
            (true, Some(q2), None) if q1.is_none() => (0.0, q2.at.rho),
            (true, Some(q2), Some(t)) => (t.at.rho, q2.at.rho),
            _ => (f64::INFINITY, f64::INFINITY),
        };
        kinks[0] = start;
        let mut m = 1;
        let mut lo = 0.0;
        for k in &cand[..n] {
            let hi = k.at.rho;
            if hi <= lo {
                // coincident with the previous kink: keep the more singular behaviour
                let last = &mut kinks[m - 1];
                last.sqrt_below |= k.sqrt_below;
                last.sqrt_above |= k.sqrt_above;
                last.delta_rho = last.delta_rho.min(k.delta_rho);
                last.delta_u = last.delta_u.min(k.delta_u);
                continue;
            }
            let r = hi <= rho_max;
            let f = lo >= cap_lo && hi <= cap_hi;
            let t = lo >= t_lo && hi <= t_hi;
            let lobe = match (r, f, t) {
                (true, false, _) => Lobe::Mirror,
                (true, true, false) => Lobe::Fresnel,
                (true, true, true) => Lobe::Both,
                (false, _, true) => Lobe::Transmit,
                (false, _, false) => break, // past both lobes: the line ends
            };
            lobes[m - 1] = lobe;
            kinks[m] = *k;
            m += 1;
            lo = hi;
        }
        if m == 1 {
            0
        } else {
            m
        }
    }

    fn compute_line(&self, psi: f64, out: &mut Vec<Panel>) -> DielectricLine {
        let alpha = self.alpha;
        let sc = self.sin_o * sin_cos_0_pi(psi).1;
        let h = Horizon::new(sc, self.mu_o);
        let mut line = DielectricLine {
            sc,
            h,
            s_end: 0.0,
            u_tail: 1.0 / RHO_TAIL,
            seg_end: [0.0; MAX_SEGMENTS],
            seg_lobe: [Lobe::Mirror; MAX_SEGMENTS],
            segments: 0,
        };
        let mut kinks = [Kink::regular(Radius { rho: 0.0, u: 0.0 }); MAX_SEGMENTS + 1];
        let mut lobes = [Lobe::Mirror; MAX_SEGMENTS];
        let n = self.kinks(sc, &h, &mut kinks, &mut lobes);
        if n == 0 {
            return line;
        }
        let end = kinks[n - 1].at;
        // The u variable takes over beyond RHO_TAIL when the line ends well beyond it, at a
        // kink if one lies within a factor 2 of RHO_TAIL (no sliver panels either side).
        let tail = end.rho > 2.0 * RHO_TAIL;
        let rho_sw = if tail {
            (1..n - 1)
                .map(|i| kinks[i].at.rho)
                .filter(|&r| (0.5 * RHO_TAIL..=2.0 * RHO_TAIL).contains(&r))
                .min_by(|&a, &b| {
                    let d = |r: f64| (r / RHO_TAIL).ln().abs();
                    d(a).total_cmp(&d(b))
                })
                .unwrap_or(RHO_TAIL)
        } else {
            end.rho
        };
        // the kink the s part ends at, if one lies there
        let at_switch = kinks[1..n].iter().find(|k| k.at.rho == rho_sw).copied();
        line.u_tail = 1.0 / rho_sw;
        line.s_end = asinh_pos(rho_sw / alpha);
        let s_end = line.s_end;
        let s_of = |rho: f64| asinh_pos(rho / alpha);
        let ds = |k: &Kink| k.delta_rho / (alpha * alpha + k.at.rho * k.at.rho).sqrt();
        // s part: the kinks below the switch, then s_end
        let mut sb: [Break; MAX_SEGMENTS + 2] = [Break::regular(0.0); MAX_SEGMENTS + 2];
        let mut ns = 0;
        for k in kinks[1..n].iter().filter(|k| k.at.rho < rho_sw) {
            sb[ns] = Break {
                x: s_of(k.at.rho),
                sqrt_below: k.sqrt_below,
                sqrt_above: k.sqrt_above,
                delta: ds(k).max(MIN_DELTA),
            };
            ns += 1;
        }
        let mut end_break = match &at_switch {
            Some(k) => Break {
                x: s_end,
                sqrt_below: k.sqrt_below,
                sqrt_above: k.sqrt_above,
                delta: ds(k),
            },
            None => Break::regular(s_end),
        };
        // singularities beyond the switch, seen from s_end: along the axis and off it
        for k in kinks[1..n].iter().filter(|k| k.at.rho > rho_sw) {
            if k.at.rho.is_finite() {
                let (x, y) = (k.at.rho / alpha, rho_sw / alpha);
                let beyond = ((x + (x * x + 1.0).sqrt()) / (y + (y * y + 1.0).sqrt())).ln();
                let d = if k.sqrt_below || k.sqrt_above {
                    0.0
                } else {
                    ds(k)
                };
                end_break.delta = end_break.delta.min(beyond.hypot(d));
            }
        }
        end_break.delta = end_break.delta.max(MIN_DELTA);
        sb[ns] = end_break;
        ns += 1;
        // the first segment from the peak, then the rest
        let first = sb[0];
        let first_delta = if ns > 1 {
            // a neighbour's singularities are near too
            let mut d = first.delta;
            for b in &sb[1..ns] {
                let own = if b.sqrt_below || b.sqrt_above {
                    0.0
                } else {
                    b.delta
                };
                d = d.min((b.x - first.x).hypot(own));
            }
            d.max(MIN_DELTA)
        } else {
            first.delta
        };
        // a singularity on the opposite line near the peak, at distance asinh(δ/α) in s
        let start_delta = asinh_pos(kinks[0].delta_rho / alpha).max(MIN_DELTA);
        peak_panels(first.x, first_delta, first.sqrt_below, start_delta, out);
        if ns > 1 {
            panels_from_breaks(&mut sb[..ns], out);
        }
        // u part: from the switch to the end, v = s_end + (u_sw − u)
        if tail {
            let mut ub: [Break; MAX_SEGMENTS + 2] = [Break::regular(0.0); MAX_SEGMENTS + 2];
            let mut nu = 0;
            ub[nu] = match &at_switch {
                Some(k) => Break {
                    x: s_end,
                    sqrt_below: k.sqrt_below,
                    sqrt_above: k.sqrt_above,
                    delta: k.delta_u.max(MIN_DELTA),
                },
                None => Break::regular(s_end),
            };
            nu += 1;
            for k in &kinks[1..n] {
                if k.at.rho > rho_sw {
                    ub[nu] = Break {
                        x: s_end + (line.u_tail - k.at.u),
                        sqrt_below: k.sqrt_below,
                        sqrt_above: k.sqrt_above,
                        delta: k.delta_u.max(MIN_DELTA),
                    };
                    nu += 1;
                }
            }
            panels_from_breaks(&mut ub[..nu], out);
        }
        // segment ends in v
        for i in 1..n {
            let k = &kinks[i];
            line.seg_end[i - 1] = if k.at.rho <= rho_sw {
                s_of(k.at.rho).min(s_end)
            } else {
                s_end + (line.u_tail - k.at.u)
            };
            line.seg_lobe[i - 1] = lobes[i - 1];
        }
        line.segments = n - 1;
        line
    }
}

/// One line's [`SlopeDielectric::block`] as a [`vector::Block`].
struct DielectricBlock<'a, const PART: u8, const LOBE: u8> {
    f: &'a SlopeDielectric,
    line: &'a DielectricLine,
}

impl<const PART: u8, const LOBE: u8> vector::Block<CHANNELS> for DielectricBlock<'_, PART, LOBE> {
    #[inline(always)]
    fn block(&self, v: &[f64; LANES]) -> [[f64; CHANNELS]; LANES] {
        self.f.block::<PART, LOBE>(self.line, v)
    }
}

impl Integrand2D for SlopeDielectric {
    type Line = DielectricLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        let mut panels = Vec::new();
        self.outer_panels(&mut panels);
        out.extend(panels.iter().map(|p| p.a));
        out.extend(panels.last().map(|p| p.b));
    }

    fn line(&self, psi: f64, breaks: &mut Vec<f64>) -> DielectricLine {
        let mut panels = Vec::new();
        let line = self.line_panels(psi, &mut panels);
        breaks.extend(panels.iter().map(|p| p.a));
        breaks.extend(panels.last().map(|p| p.b));
        line
    }

    /// ψ ∈ [0, π] (the integrand is even in ψ): see the module docs for the breaks.
    fn outer_panels(&self, out: &mut Vec<Panel>) {
        let (s, mu_o) = (self.sin_o, self.mu_o);
        let branch = |x: f64| {
            if s > 0.0 {
                asinh_pos(x / s)
            } else {
                f64::INFINITY
            }
        };
        let mut delta = branch(mu_o);
        let mut breaks = [Break::regular(0.0); 6];
        let mut n = 0;
        let mut push = |b: Break, n: &mut usize| {
            breaks[*n] = b;
            *n += 1;
        };
        push(Break::regular(0.0), &mut n);
        push(Break::regular(PI), &mut n);
        if self.leaving() && s > 0.0 {
            let cc = self.cc;
            let c0 = -self.c0; // μo² − (1 − η²)
            if c0 >= 0.0 {
                delta = delta.min(branch(c0.sqrt()));
            } else {
                // tangent to the cap and the circle: cos ψ = −√(1 − η² − μo²)/sin θo, where
                // w² = sc² + μo² − 1 + η² vanishes. The transmitted μt is of order w·cc/η
                // there, so the masking weight's scale α is reached at w ≈ αη/cc: a
                // singularity at that w² on the side without a cap.
                let c = (-c0).sqrt() / s;
                if c < 1.0 {
                    let dw2 = 2.0 * s * s * c * (1.0 - c * c).sqrt(); // |d(w²)/dψ|
                    let wc = self.mask_scale * self.eta / cc;
                    push(
                        Break::one_sided_sqrt(PI - c.acos(), true).with_delta(wc * wc / dw2),
                        &mut n,
                    );
                }
            }
            // the cap's asymptote: cos ψ = −√(1 − η²)/sin θo
            if cc < s {
                push(Break::one_sided_sqrt(PI - (cc / s).acos(), true), &mut n);
            }
            // the cap crossing the reflection horizon: sin θo cos φ = 2η² − 1 about ωo's image
            if mu_o > 0.0 {
                let cos_phi = (2.0 * self.eta2 - 1.0) / s;
                if cos_phi.abs() < 1.0 {
                    let sin_phi = (1.0 - cos_phi * cos_phi).sqrt();
                    let psi = sin_phi.atan2(cos_phi - s);
                    if psi > 0.0 && psi < PI {
                        push(Break::sqrt(psi), &mut n);
                    }
                }
            }
        }
        push(
            Break::near_singular(FRAC_PI_2, delta.max(MIN_DELTA)),
            &mut n,
        );
        panels_from_breaks(&mut breaks[..n], out);
    }

    fn line_panels(&self, psi: f64, out: &mut Vec<Panel>) -> DielectricLine {
        self.compute_line(psi, out)
    }

    fn panels_all_active(&self) -> bool {
        true
    }

    fn accumulate_nodes(&self, line: &DielectricLine, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        if vs.is_empty() {
            return;
        }
        let y = self.sum_panel(line, vs, ws);
        acc[0] += y[0];
        acc[1] += y[1];
    }

    /// One node through lane 0 of the block of its panel (tables go through
    /// `accumulate_nodes`; this serves the trait's defaults and the tests).
    fn eval(&self, line: &DielectricLine, v: f64) -> [f64; CHANNELS] {
        if line.segments == 0 {
            return [0.0; CHANNELS];
        }
        let y = self.sum_panel(line, &[v], &[1.0]);
        [y[0], y[1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::Lobes;
    use crate::bsdf::vndf::{Part, VndfIntegrand};
    use crate::quadrature::{integrate_2d, Rules};

    const SMITH: [SmithForm; 2] = [SmithForm::HeightCorrelated, SmithForm::Separable];

    fn vndf(alpha: f64, mu: f64, eta: f64, smith: SmithForm) -> [f64; 2] {
        let lobes = Lobes::Dielectric { eta };
        let rules = Rules::new(48);
        if eta < 1.0 {
            let r = integrate_2d(
                &VndfIntegrand::part(alpha, mu, smith, lobes, Part::ReflectionOnly),
                &rules,
            );
            let t = integrate_2d(
                &VndfIntegrand::part(alpha, mu, smith, lobes, Part::TransmissionOnly),
                &rules,
            );
            [r[0], t[1]]
        } else {
            integrate_2d(&VndfIntegrand::new(alpha, mu, smith, lobes), &rules)
        }
    }

    /// Two parametrisations that share no coordinate, panel or map.
    #[test]
    fn agrees_with_the_visible_normal_parametrisation() {
        let rules = Rules::new(32);
        let mut worst = 0.0f64;
        for smith in SMITH {
            for eta in [1.0 / 1.5, 1.0 / 2.5, 0.9, 1.5] {
                for (r, mu) in [
                    (0.05, 0.9),
                    (0.1, 0.0),
                    (0.3, 0.01),
                    (0.5, 0.5),
                    (0.7, 0.05),
                    (0.9, 0.3),
                    (1.0, 1.0),
                    (0.4, 0.74),
                    (0.6, 0.2),
                ] {
                    let alpha = r * r;
                    let a = integrate_2d(&SlopeDielectric::new(alpha, mu, eta, smith), &rules);
                    let b = vndf(alpha, mu, eta, smith);
                    let d = (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
                    worst = worst.max(d);
                    assert!(
                        d < 1e-9,
                        "{smith:?} η={eta} r={r} mu={mu}: slope {a:?} vs vndf {b:?}"
                    );
                }
            }
        }
        eprintln!("worst {worst:e}");
    }
}
