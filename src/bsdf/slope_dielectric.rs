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
use crate::quadrature::{
    panels_from_breaks, panels_from_breaks_real, Break, DimRules, Integrand2D, Panel, CHANNELS,
    MIN_DELTA,
};
use std::f64::consts::{FRAC_PI_2, PI};

/// √(x² + y²) for the distances of panel ends to singularities, without libm's `hypot` (whose
/// guard against overflow costs more than the rest of a line's set-up arithmetic; an overflow
/// here means a distance too large to matter, ∞).
#[inline]
fn hyp(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

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
    /// The reflection deficit (1 − F)·R of the critical-angle cap ([`SlopeDielectric::deficit`]).
    Deficit,
    /// The reflection deficit and transmission.
    DeficitBoth,
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
    /// The side whose integrand has those singularities (`None`: both; `Some(true)`: above,
    /// e.g. the transmitted masking weight's, which the reflection below does not carry).
    side: Option<bool>,
}

impl Kink {
    /// The kink as a panel break at `x` in a line variable, near-singular at `delta` there.
    fn at_x(&self, x: f64, delta: f64) -> Break {
        Break {
            x,
            sqrt_below: self.sqrt_below,
            sqrt_above: self.sqrt_above,
            delta_below: if self.side == Some(true) {
                f64::INFINITY
            } else {
                delta
            },
            delta_above: if self.side == Some(false) {
                f64::INFINITY
            } else {
                delta
            },
            beyond_below: false,
            beyond_above: false,
        }
    }

    fn regular(at: Radius) -> Kink {
        Kink {
            at,
            sqrt_below: false,
            sqrt_above: false,
            delta_rho: f64::INFINITY,
            delta_u: f64::INFINITY,
            side: None,
        }
    }
}

/// The η-independent part of the integrand at one node ([`SlopeDielectric::node`]).
#[derive(Clone, Copy, Default)]
struct Node {
    /// Measure × projected area × the Smith form's constant.
    base: f64,
    d2: f64,
    g: f64,
    /// Numerator of μi and the reflection masking weight's denominator.
    n: f64,
    den_r: f64,
    /// A, and C without its constant term (c_rest; the constant 1 − η² − μo² enters × c_w).
    a: f64,
    c_rest: f64,
    c_w: f64,
    u_t: f64,
}

/// The relative IORs of a column ([`SlopeDielectric::column`]), field by field (the loops over
/// them vectorise).
#[derive(Clone, Debug, Default)]
struct Column {
    eta: Vec<f64>,
    eta2: Vec<f64>,
    /// 1 − η² − μo² (as a product).
    c0: Vec<f64>,
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
    /// Column mode: the IORs of cells sharing this geometry (entering only, η ≥ 1, whose kinks
    /// do not depend on η); channels 2k, 2k + 1 belong to `column[k]`. Empty: one cell, η.
    column: Column,
    /// Column mode: one panel's sums, reused.
    scratch: std::cell::RefCell<Vec<f64>>,
    /// Deficit mode ([`SlopeDielectric::deficit`]): only the critical-angle cap, channels
    /// [∫(1 − F)·R, E_T].
    deficit: bool,
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
            column: Column::default(),
            scratch: std::cell::RefCell::new(Vec::new()),
            deficit: false,
        }
    }

    /// Leaving the denser medium (η < 1), the integrals over the cap of normals below the
    /// critical angle only: channels [∫(1 − F)·R, E_T], so that E_R is the white conductor's
    /// albedo minus the first (outside the cap F = 1). Where ωo is totally reflected at the
    /// peak (μo below the critical cosine) the cap lies off the peak and covers only the
    /// latitudes past its tangent, so this is far less work than both lobes everywhere, and the
    /// conductor's albedo serves a whole column of IORs.
    pub fn deficit(alpha: f64, mu_o: f64, eta: f64, smith: SmithForm) -> SlopeDielectric {
        debug_assert!(eta < 1.0, "the deficit form is for η < 1");
        SlopeDielectric {
            deficit: true,
            ..SlopeDielectric::new(alpha, mu_o, eta, smith)
        }
    }

    /// The same geometry for a column of cells differing only in their relative IOR, all
    /// entering the denser medium (η ≥ 1: no critical angle, so the kinks do not depend on η);
    /// channels 2k, 2k + 1 belong to `etas[k]`. The panels are those of the smallest η.
    pub fn column(alpha: f64, mu_o: f64, etas: &[f64], smith: SmithForm) -> SlopeDielectric {
        debug_assert!(etas.iter().all(|&e| e >= 1.0), "column mode needs η ≥ 1");
        let eta = etas.iter().copied().fold(f64::INFINITY, f64::min);
        let mut f = SlopeDielectric::new(alpha, mu_o, eta, smith);
        let mu_o = f.mu_o;
        f.column = Column {
            eta: etas.to_vec(),
            eta2: etas.iter().map(|&e| e * e).collect(),
            c0: etas
                .iter()
                .map(|&e| (1.0 - e) * (1.0 + e) - mu_o * mu_o)
                .collect(),
        };
        f
    }

    /// Leaving the denser medium: a critical angle exists.
    fn leaving(&self) -> bool {
        self.eta < 1.0
    }

    /// The η-independent part of the integrand at node `v` of a line: `PART` 0 is the s part
    /// with ρmax finite (μi in factored form), 1 the s part with ρmax = ∞, 2 the u part.
    #[inline(always)]
    fn node<const PART: u8>(&self, line: &DielectricLine, v: f64) -> Node {
        let (alpha, mu_o, sc) = (self.alpha, self.mu_o, line.sc);
        let alpha2 = alpha * alpha;
        let h = &line.h;
        // ×2 for ψ ∈ [π, 2π] and 1/π from P22 (the masking weights' 2 is in `lobes`)
        let scale = self.c_smith * (2.0 / PI);
        // the measure and projected area, and the line's polynomials, either in ρ (s part) or
        // multiplied by u² (u part; every weight is homogeneous in them); `u_t` puts √Q on the
        // scale of A in the transmitted z (u in the u part, 1 in the s part)
        let (jac, d2, g, n, a, c_rest, c_w, u_t) = if PART == 2 {
            let u = line.u_tail - (v - line.s_end);
            let au2 = 1.0 + alpha2 * u * u;
            let g = mu_o * u - sc;
            let n = (u - h.u_max) * (h.k_prime + mu_o * u);
            let a = -(sc * u + mu_o);
            let c_rest = mu_o * (mu_o + 2.0 * sc * u);
            (alpha2 / (au2 * au2), 1.0 + u * u, g, n, a, c_rest, u * u, u)
        } else {
            let e = exp_poly(v);
            let inv = 1.0 / e;
            let (sinh, cosh) = (0.5 * (e - inv), 0.5 * (e + inv));
            let rho = alpha * sinh;
            let n = if PART == 0 {
                (h.rho_max - rho) * (mu_o * rho + h.k)
            } else {
                mu_o * (1.0 - rho * rho) - 2.0 * sc * rho
            };
            let a = -rho * (sc + mu_o * rho);
            let c_rest = rho * (2.0 * mu_o * sc + mu_o * mu_o * rho);
            (
                sinh / (cosh * cosh * cosh),
                1.0 + rho * rho,
                mu_o - sc * rho,
                n,
                a,
                c_rest,
                1.0,
                1.0,
            )
        };
        let a_d = (n * n * (1.0 - alpha2) + alpha2 * d2 * d2).max(0.0).sqrt();
        Node {
            base: scale * jac * g,
            d2,
            g,
            n,
            den_r: n * self.p + self.q * a_d,
            a,
            c_rest,
            c_w,
            u_t,
        }
    }

    /// Reflection and transmission at a node for relative IOR η (`c0` = 1 − η² − μo²); `LOBE`
    /// is the [`Lobe`] as its index. No branches (selects only), so that it vectorises.
    #[inline(always)]
    fn lobes<const LOBE: u8>(&self, nd: &Node, eta: f64, eta2: f64, c0: f64) -> [f64; CHANNELS] {
        let alpha2 = self.alpha * self.alpha;
        let reflect = LOBE != 3;
        let fresnel = LOBE != 0;
        let transmit = matches!(LOBE, 2 | 3 | 5);
        let deficit = LOBE >= 4;
        let (g, d2) = (nd.g, nd.d2);
        let mut y = [0.0; CHANNELS];
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
            let num = if deficit { num_t } else { num_r };
            let r = nd.base * 2.0 * nd.n * num / (nd.den_r * den_f);
            y[0] = if nd.n > 0.0 { r } else { 0.0 };
        }
        if transmit {
            // −η μt d² = m/dm: √Q − A where A ≤ 0, else −d²C/(A + √Q) (no cancellation);
            // in the u part A, C and d² carry u², √Q only u
            let sq_t = nd.u_t * sq;
            let c = c0 * nd.c_w + nd.c_rest;
            let direct = nd.a <= 0.0;
            let m = if direct { sq_t - nd.a } else { -d2 * c };
            let dm = if direct { 1.0 } else { nd.a + sq_t };
            let e = eta * d2 * dm;
            let a_t = (m * m * (1.0 - alpha2) + alpha2 * e * e).max(0.0).sqrt();
            let den = m * self.p + self.q * a_t;
            let t = nd.base * 2.0 * m * num_t / (den * den_f);
            y[1] = if m > 0.0 { t } else { 0.0 };
        }
        y
    }

    /// The integrand at `W` nodes of one panel ([`Self::node`], [`Self::lobes`]; W =
    /// [`LANES`] but in [`CapLine`]'s narrow loop).
    #[inline(always)]
    fn block<const PART: u8, const LOBE: u8, const W: usize>(
        &self,
        line: &DielectricLine,
        v: &[f64; W],
    ) -> [[f64; CHANNELS]; W] {
        let (mut r, mut t) = ([0.0; W], [0.0; W]);
        for j in 0..W {
            let nd = self.node::<PART>(line, v[j]);
            [r[j], t[j]] = self.lobes::<LOBE>(&nd, self.eta, self.eta2, self.c0);
        }
        let mut out = [[0.0; CHANNELS]; W];
        for j in 0..W {
            out[j] = [r[j], t[j]];
        }
        out
    }

    /// The cap's integrand ([`Lobe::DeficitBoth`]) at `W` nodes of one line part, lane j
    /// keeping its reflection deficit where `r_on[j]` and its transmission where `t_on[j]`, so
    /// that one block serves nodes of [`Lobe::Deficit`], [`Lobe::DeficitBoth`] and
    /// [`Lobe::Transmit`] panels with the bits of [`Self::block`] for each.
    #[inline(always)]
    fn block_masked<const PART: u8, const W: usize>(
        &self,
        line: &DielectricLine,
        v: &[f64; W],
        r_on: &[bool; W],
        t_on: &[bool; W],
    ) -> ([f64; W], [f64; W]) {
        let (mut r, mut t) = ([0.0; W], [0.0; W]);
        for j in 0..W {
            let nd = self.node::<PART>(line, v[j]);
            let [yr, yt] = self.lobes::<5>(&nd, self.eta, self.eta2, self.c0);
            r[j] = if r_on[j] { yr } else { 0.0 };
            t[j] = if t_on[j] { yt } else { 0.0 };
        }
        (r, t)
    }

    /// Deficit mode: the integrand at the nodes `vs[first..last]` of one line part (`PART`) into
    /// `r_out` and `t_out`, `W` ≤ [`LANES`] nodes at a time across panel ends: by
    /// [`Self::block`] of `LOBE`, or, `LOBE` = [`MASKED`], by [`Self::block_masked`] with the
    /// lobes `on` of each node's panel. The last block reads and writes up to `W` − 1 entries
    /// past `last` (the buffers are that much longer; what it writes there is overwritten or
    /// unused).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn deficit_run<const PART: u8, const LOBE: u8, const W: usize>(
        &self,
        line: &DielectricLine,
        vs: &[f64],
        on: (&[bool], &[bool]),
        r_out: &mut [f64],
        t_out: &mut [f64],
        first: usize,
        last: usize,
    ) {
        let mut at = first;
        while at < last {
            let v: &[f64; W] = vs[at..at + W].try_into().unwrap();
            let (r, t) = if LOBE == MASKED {
                let ron: &[bool; W] = on.0[at..at + W].try_into().unwrap();
                let ton: &[bool; W] = on.1[at..at + W].try_into().unwrap();
                self.block_masked::<PART, W>(line, v, ron, ton)
            } else {
                let y = self.block::<PART, LOBE, W>(line, v);
                let (mut r, mut t) = ([0.0; W], [0.0; W]);
                for j in 0..W {
                    [r[j], t[j]] = y[j];
                }
                (r, t)
            };
            r_out[at..at + W].copy_from_slice(&r);
            t_out[at..at + W].copy_from_slice(&t);
            at += W;
        }
    }

    /// Column mode: Σ ws·f(vs) per IOR of the column into `out_r` and `out_t`, each IOR's
    /// sums in node order as [`Self::sum`] forms them; the loop over the IORs vectorises.
    #[inline(always)]
    fn column_sum<const PART: u8, const LOBE: u8>(
        &self,
        line: &DielectricLine,
        vs: &[f64],
        ws: &[f64],
        out_r: &mut [f64],
        out_t: &mut [f64],
    ) {
        out_r.iter_mut().for_each(|o| *o = 0.0);
        out_t.iter_mut().for_each(|o| *o = 0.0);
        let c = &self.column;
        for (&v, &w) in vs.iter().zip(ws) {
            let nd = self.node::<PART>(line, v);
            for ((((r, t), &eta), &eta2), &c0) in out_r
                .iter_mut()
                .zip(out_t.iter_mut())
                .zip(&c.eta)
                .zip(&c.eta2)
                .zip(&c.c0)
            {
                let y = self.lobes::<LOBE>(&nd, eta, eta2, c0);
                *r += w * y[0];
                *t += w * y[1];
            }
        }
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
                    Lobe::Deficit => self.sum::<$part, 4>(line, vs, ws),
                    Lobe::DeficitBoth => self.sum::<$part, 5>(line, vs, ws),
                }
            };
        }
        match part {
            0 => by_lobe!(0),
            1 => by_lobe!(1),
            _ => by_lobe!(2),
        }
    }

    /// Column mode: one panel's sums for every IOR into `out` ([`Self::column_sum`] on the
    /// widest vector unit).
    fn column_panel(&self, line: &DielectricLine, vs: &[f64], ws: &[f64], out: &mut [f64]) {
        struct ColumnSum<'a, const PART: u8, const LOBE: u8> {
            f: &'a SlopeDielectric,
            line: &'a DielectricLine,
            vs: &'a [f64],
            ws: &'a [f64],
            out: &'a mut [f64],
        }
        impl<const PART: u8, const LOBE: u8> vector::Kernel for ColumnSum<'_, PART, LOBE> {
            type Output = ();
            #[inline(always)]
            fn run(&mut self) {
                let (r, t) = self.out.split_at_mut(self.out.len() / 2);
                self.f
                    .column_sum::<PART, LOBE>(self.line, self.vs, self.ws, r, t)
            }
        }
        let (lobe, part) = Self::segment(line, vs);
        macro_rules! run {
            ($part:literal, $lobe:expr) => {
                vector::run(ColumnSum::<$part, $lobe> {
                    f: self,
                    line,
                    vs,
                    ws,
                    out,
                })
            };
        }
        macro_rules! by_lobe {
            ($part:literal) => {
                match lobe {
                    Lobe::Mirror => run!($part, 0),
                    Lobe::Fresnel => run!($part, 1),
                    Lobe::Both => run!($part, 2),
                    Lobe::Transmit => run!($part, 3),
                    Lobe::Deficit => run!($part, 4),
                    Lobe::DeficitBoth => run!($part, 5),
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
                // the reflection below it; transmission beyond it does not see them
                side: Some(false),
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
                        side: Some(true),
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
        // insertion sort: stable like `sort_by`, without its call for a handful of kinks
        for i in 1..n {
            let mut j = i;
            while j > 0 && cand[j - 1].at.rho.total_cmp(&cand[j].at.rho).is_gt() {
                cand.swap(j - 1, j);
                j -= 1;
            }
        }
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
        let mut ended = n;
        for (i, k) in cand[..n].iter().enumerate() {
            let hi = k.at.rho;
            if hi <= lo {
                // coincident with the previous kink: keep the more singular behaviour
                let last = &mut kinks[m - 1];
                last.sqrt_below |= k.sqrt_below;
                last.sqrt_above |= k.sqrt_above;
                last.delta_rho = last.delta_rho.min(k.delta_rho);
                last.delta_u = last.delta_u.min(k.delta_u);
                if last.side != k.side {
                    last.side = None;
                }
                continue;
            }
            let r = hi <= rho_max;
            let f = lo >= cap_lo && hi <= cap_hi;
            let t = lo >= t_lo && hi <= t_hi;
            let lobe = match (self.deficit, r, f, t) {
                (false, true, false, _) => Some(Lobe::Mirror),
                (false, true, true, false) => Some(Lobe::Fresnel),
                (false, true, true, true) => Some(Lobe::Both),
                (true, true, true, false) => Some(Lobe::Deficit),
                (true, true, true, true) => Some(Lobe::DeficitBoth),
                (_, false, _, true) => Some(Lobe::Transmit),
                _ => None,
            };
            match lobe {
                Some(lobe) => {
                    lobes[m - 1] = lobe;
                    kinks[m] = *k;
                    m += 1;
                }
                // before the cap (deficit mode): the line starts at its end
                None if m == 1 => kinks[0] = *k,
                None => {
                    ended = i; // past both lobes: the line ends
                    break;
                }
            }
            lo = hi;
        }
        // Kinks past the end still have their singularities near it.
        if m > 1 && ended < n {
            let last = &mut kinks[m - 1];
            if last.side == Some(true) {
                last.side = None; // the line ends here: its last segment lies below
            }
            for k in &cand[ended..n] {
                let sqrt = k.sqrt_below || k.sqrt_above;
                let (dr, du) = if sqrt {
                    (0.0, 0.0)
                } else {
                    (k.delta_rho, k.delta_u)
                };
                if k.at.rho.is_finite() {
                    last.delta_rho = last.delta_rho.min(hyp(k.at.rho - last.at.rho, dr));
                }
                if last.at.u.is_finite() {
                    last.delta_u = last.delta_u.min(hyp(last.at.u - k.at.u, du));
                }
            }
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
        let (start, end) = (kinks[0], kinks[n - 1].at);
        // The u variable takes over beyond RHO_TAIL when the line ends well beyond it, at a
        // kink if one lies within a factor 2 of RHO_TAIL (no sliver panels either side), or
        // from the start when the line starts beyond RHO_TAIL/2 (a cap far off the peak).
        let tail = end.rho > 2.0 * RHO_TAIL;
        let rho_sw = if !tail {
            end.rho
        } else if start.at.rho >= 0.5 * RHO_TAIL {
            start.at.rho
        } else {
            (1..n - 1)
                .map(|i| kinks[i].at.rho)
                .filter(|&r| (0.5 * RHO_TAIL..=2.0 * RHO_TAIL).contains(&r))
                .min_by(|&a, &b| {
                    let d = |r: f64| (r / RHO_TAIL).ln().abs();
                    d(a).total_cmp(&d(b))
                })
                .unwrap_or(RHO_TAIL)
        };
        // the kink the s part ends at, if one lies there
        let at_switch = kinks[..n].iter().find(|k| k.at.rho == rho_sw).copied();
        line.u_tail = 1.0 / rho_sw;
        line.s_end = asinh_pos(rho_sw / alpha);
        let s_end = line.s_end;
        let s_of = |rho: f64| asinh_pos(rho / alpha);
        let ds = |k: &Kink| k.delta_rho / (alpha * alpha + k.at.rho * k.at.rho).sqrt();
        // s of the kinks below the switch (NaN: not computed)
        let mut s_at = [f64::NAN; MAX_SEGMENTS + 1];
        if rho_sw > start.at.rho {
            // s part: the start (unless it is the peak), the kinks below the switch, s_end
            let mut sb: [Break; MAX_SEGMENTS + 2] = [Break::regular(0.0); MAX_SEGMENTS + 2];
            let mut ns = 0;
            let from_peak = start.at.rho == 0.0;
            let first = if from_peak { 1 } else { 0 };
            for (i, k) in kinks.iter().enumerate().take(n).skip(first) {
                if k.at.rho < rho_sw {
                    s_at[i] = s_of(k.at.rho);
                    sb[ns] = k.at_x(s_at[i], ds(k).max(MIN_DELTA));
                    ns += 1;
                }
            }
            if !from_peak {
                // a line starting off the peak still sees the poles of sech² s at ±iπ/2
                let d = hyp(sb[0].x, FRAC_PI_2);
                sb[0] = sb[0].with_delta(d);
            }
            let mut end_delta = at_switch.as_ref().map_or(f64::INFINITY, ds);
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
                    end_delta = end_delta.min(hyp(beyond, d));
                }
            }
            let end_delta = end_delta.max(MIN_DELTA);
            sb[ns] = match &at_switch {
                Some(k) => k.at_x(s_end, end_delta),
                None => Break::near_singular(s_end, end_delta),
            };
            ns += 1;
            if from_peak {
                // the first segment from the peak, then the rest
                let first = sb[0];
                let first_delta = if ns > 1 {
                    // a neighbour's singularities are near too
                    // (the smallest squared distance, then one square root: the bits of the
                    // smallest distance, a correctly rounded square root being monotone)
                    let mut d2 = f64::INFINITY;
                    for b in &sb[1..ns] {
                        let own = if b.sqrt_below || b.sqrt_above {
                            0.0
                        } else {
                            b.delta()
                        };
                        let dx = b.x - first.x;
                        d2 = d2.min(dx * dx + own * own);
                    }
                    first.delta().min(d2.sqrt()).max(MIN_DELTA)
                } else {
                    first.delta()
                };
                // a singularity on the opposite line near the peak, at distance asinh(δ/α)
                let start_delta = asinh_pos(start.delta_rho / alpha).max(MIN_DELTA);
                peak_panels(first.x, first_delta, first.sqrt_below, start_delta, out);
            }
            if ns > 1 {
                panels_from_breaks(&mut sb[..ns], out);
            }
        }
        // u part: from the switch to the end, v = s_end + (u_sw − u)
        if tail {
            let mut ub: [Break; MAX_SEGMENTS + 2] = [Break::regular(0.0); MAX_SEGMENTS + 2];
            let mut nu = 0;
            ub[nu] = match &at_switch {
                Some(k) => k.at_x(s_end, k.delta_u.max(MIN_DELTA)),
                None => Break::regular(s_end),
            };
            nu += 1;
            for k in &kinks[1..n] {
                if k.at.rho > rho_sw {
                    ub[nu] = k.at_x(s_end + (line.u_tail - k.at.u), k.delta_u.max(MIN_DELTA));
                    nu += 1;
                }
            }
            panels_from_breaks(&mut ub[..nu], out);
        }
        // segment ends in v
        for i in 1..n {
            let k = &kinks[i];
            line.seg_end[i - 1] = if k.at.rho <= rho_sw {
                // s_of(ρsw) is s_end itself
                let s = if k.at.rho == rho_sw {
                    s_end
                } else if s_at[i].is_nan() {
                    s_of(k.at.rho)
                } else {
                    s_at[i]
                };
                s.min(s_end)
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
        self.f.block::<PART, LOBE, LANES>(self.line, v)
    }
}

/// Nodes [`LineBuf`] makes room for at once: a line of 8 panels of 24 nodes and their spare.
const LINE_ROOM: usize = 8 * 24 + LANES;

/// Most panels a cap line takes through [`CapLine`] (more go panel by panel).
const MAX_PANELS: usize = 32;

/// Deficit mode: one line of the cap as a [`vector::Kernel`] — its panels' nodes
/// ([`crate::quadrature::NodeMap::fill`]), their values ([`SlopeDielectric::deficit_run`])
/// and each panel's sums in node order, added to `acc`. Returns false, having added nothing,
/// if a panel carries a lobe the cap does not have (the caller then goes panel by panel).
struct CapLine<'a> {
    f: &'a SlopeDielectric,
    line: &'a DielectricLine,
    panels: &'a [Panel],
    rule: &'a DimRules,
    buf: &'a mut LineBuf,
    acc: &'a mut [f64],
}

impl vector::Kernel for CapLine<'_> {
    type Output = bool;
    #[inline(always)]
    fn run(&mut self) -> bool {
        self.eval_line::<LANES>()
    }
    /// Blocks of 4 on AVX2 and SSE2: 8 lanes of the cap's integrand hold more values than
    /// their 16 registers, and spill.
    #[inline(always)]
    fn run_narrow(&mut self) -> bool {
        self.eval_line::<4>()
    }
}

impl CapLine<'_> {
    /// The line by blocks of `W` ≤ [`LANES`] nodes.
    #[inline(always)]
    fn eval_line<const W: usize>(&mut self) -> bool {
        let (f, line, panels) = (self.f, self.line, self.panels);
        let n = panels.len();
        let LineBuf {
            vs,
            ws,
            r,
            t,
            r_on,
            t_on,
        } = &mut *self.buf;
        let mut ends = [0usize; MAX_PANELS];
        let (mut pr, mut pt) = ([false; MAX_PANELS], [false; MAX_PANELS]);
        let mut part = [0u8; MAX_PANELS];
        let mut len = 0;
        for (i, seg) in panels.iter().enumerate() {
            let map = self.rule.map(seg);
            let m = map.len();
            // LANES spare entries: the last block of a run reads past its end
            if vs.len() < len + m + LANES {
                // room for a typical line at once (a cell's lines reuse it)
                let room = (len + m + LANES).max(LINE_ROOM);
                vs.resize(room, 0.0);
                ws.resize(room, 0.0);
            }
            map.fill(&mut vs[len..len + m], &mut ws[len..len + m]);
            let (lobe, p) = SlopeDielectric::segment(line, &vs[len..len + m]);
            (pr[i], pt[i]) = match lobe {
                Lobe::Deficit => (true, false),
                Lobe::DeficitBoth => (true, true),
                Lobe::Transmit => (false, true),
                _ => return false,
            };
            part[i] = p;
            len += m;
            ends[i] = len;
        }
        if r.len() < vs.len() {
            r.resize(vs.len(), 0.0);
            t.resize(vs.len(), 0.0);
            r_on.resize(vs.len(), false);
            t_on.resize(vs.len(), false);
        }
        let mut i = 0;
        while i < n {
            // a run of panels in one line part, of one lobe or several
            let mut j = i + 1;
            let mut one_lobe = true;
            while j < n && part[j] == part[i] {
                one_lobe &= pr[j] == pr[i] && pt[j] == pt[i];
                j += 1;
            }
            let first = if i == 0 { 0 } else { ends[i - 1] };
            let last = ends[j - 1];
            if !one_lobe {
                let mut from = first;
                for k in i..j {
                    r_on[from..ends[k]].fill(pr[k]);
                    t_on[from..ends[k]].fill(pt[k]);
                    from = ends[k];
                }
            }
            let lobe = match (one_lobe, pr[i], pt[i]) {
                (false, _, _) => MASKED,
                (true, true, false) => 4,
                (true, true, true) => 5,
                _ => 3,
            };
            let on = (&r_on[..], &t_on[..]);
            macro_rules! run {
                ($part:literal, $lobe:expr) => {
                    f.deficit_run::<$part, { $lobe }, W>(line, vs, on, r, t, first, last)
                };
            }
            macro_rules! by_lobe {
                ($part:literal) => {
                    match lobe {
                        3 => run!($part, 3),
                        4 => run!($part, 4),
                        5 => run!($part, 5),
                        _ => run!($part, MASKED),
                    }
                };
            }
            match part[i] {
                0 => by_lobe!(0),
                1 => by_lobe!(1),
                _ => by_lobe!(2),
            }
            i = j;
        }
        // each panel summed from zero in node order, then added: the bits of `sum_panel`
        let mut from = 0;
        for &end in &ends[..n] {
            let (mut sr, mut st) = (0.0, 0.0);
            for ((&w, &yr), &yt) in ws[from..end].iter().zip(&r[from..end]).zip(&t[from..end]) {
                sr += w * yr;
                st += w * yt;
            }
            self.acc[0] += sr;
            self.acc[1] += st;
            from = end;
        }
        true
    }
}

/// The lobe index of [`SlopeDielectric::deficit_run`] whose nodes carry their own lobes.
const MASKED: u8 = 6;

/// Deficit mode: one line's nodes, weights, integrand values and the lobes of its nodes,
/// reused by every line and cell on a thread ([`LINE_BUF`]).
#[derive(Default)]
struct LineBuf {
    vs: Vec<f64>,
    ws: Vec<f64>,
    r: Vec<f64>,
    t: Vec<f64>,
    r_on: Vec<bool>,
    t_on: Vec<bool>,
}

thread_local! {
    /// The cap's line buffers, one set per thread: a table's cells then allocate none (every
    /// entry a line reads is one it wrote, but for the spare lanes of its last block, whose
    /// values are discarded).
    static LINE_BUF: std::cell::RefCell<LineBuf> = std::cell::RefCell::new(LineBuf::default());
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
        // the range: [0, π], or in deficit mode with the peak totally reflected the latitudes
        // past the tangent to the cap
        let mut lo = 0.0;
        if self.leaving() && s > 0.0 {
            let cc = self.cc;
            let c0 = -self.c0; // μo² − (1 − η²)
            if c0 >= 0.0 {
                delta = delta.min(branch(c0.sqrt()));
            } else {
                // tangent to the cap and the circle: cos ψ = −√(1 − η² − μo²)/sin θo, where
                // w² = sc² + μo² − 1 + η² vanishes. The transmitted μt is of order w·cc/η
                // there, so the masking weight's scale α is reached at w ≈ αη/cc: a
                // singularity of the cap side's integrand at that w² (μt = ±iα/√(1 − α²), the
                // masking weight's branch points, makes w² real and negative): on the real axis
                // behind the tangent, so its sinh pieces may be twice as long.
                let c = (-c0).sqrt() / s;
                if c < 1.0 {
                    let dw2 = 2.0 * s * s * c * (1.0 - c * c).sqrt(); // |d(w²)/dψ|
                    let wc = self.mask_scale * self.eta / cc;
                    let psi_t = PI - c.acos();
                    push(
                        Break::one_sided_sqrt(psi_t, true).with_delta_beyond(true, wc * wc / dw2),
                        &mut n,
                    );
                    if self.deficit {
                        lo = psi_t;
                    }
                } else if self.deficit {
                    return; // no line meets the cap
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
                    if psi > lo && psi < PI {
                        push(Break::sqrt(psi), &mut n);
                    }
                }
            }
        }
        push(Break::regular(PI), &mut n);
        if lo == 0.0 {
            push(Break::regular(0.0), &mut n);
            push(
                Break::near_singular(FRAC_PI_2, delta.max(MIN_DELTA)),
                &mut n,
            );
        }
        // every break here is a square root on the real axis or near-singular on a line
        // perpendicular to it (π/2's branch points)
        panels_from_breaks_real(&mut breaks[..n], out);
    }

    fn line_panels(&self, psi: f64, out: &mut Vec<Panel>) -> DielectricLine {
        self.compute_line(psi, out)
    }

    fn panels_all_active(&self) -> bool {
        true
    }

    /// Deficit mode: the whole line in one kernel on the widest vector unit ([`CapLine`]): the
    /// nodes of all its panels mapped into one buffer, each line part (s, u) evaluated by one
    /// branch-free loop across panel ends, each panel summed from zero in node order — the
    /// bits of one panel at a time; the other modes panel by panel.
    fn accumulate_line(
        &self,
        line: &DielectricLine,
        panels: &[Panel],
        rule: &DimRules,
        vs: &mut Vec<f64>,
        ws: &mut Vec<f64>,
        acc: &mut [f64],
    ) {
        let by_panel = |vs: &mut Vec<f64>, ws: &mut Vec<f64>, acc: &mut [f64]| {
            for seg in panels {
                vs.clear();
                ws.clear();
                rule.nodes_into(seg, vs, ws);
                self.accumulate_nodes(line, vs, ws, acc);
            }
        };
        if !self.deficit || !self.column.eta.is_empty() || panels.len() > MAX_PANELS {
            return by_panel(vs, ws, acc);
        }
        let done = LINE_BUF.with(|buf| {
            vector::run(CapLine {
                f: self,
                line,
                panels,
                rule,
                buf: &mut buf.borrow_mut(),
                acc: &mut *acc,
            })
        });
        if !done {
            by_panel(vs, ws, acc);
        }
    }

    fn channels(&self) -> usize {
        if self.column.eta.is_empty() {
            CHANNELS
        } else {
            2 * self.column.eta.len()
        }
    }

    fn accumulate_nodes(&self, line: &DielectricLine, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        if vs.is_empty() {
            return;
        }
        if !self.column.eta.is_empty() {
            // one panel's sums: all IORs' reflection, then all their transmission
            let mut panel = self.scratch.borrow_mut();
            panel.resize(acc.len(), 0.0);
            self.column_panel(line, vs, ws, &mut panel);
            let (r, t) = panel.split_at(acc.len() / 2);
            for (a, (r, t)) in acc.chunks_exact_mut(2).zip(r.iter().zip(t)) {
                a[0] += r;
                a[1] += t;
            }
            return;
        }
        let y = self.sum_panel(line, vs, ws);
        acc[0] += y[0];
        acc[1] += y[1];
    }

    /// One node through lane 0 of the block of its panel (tables go through
    /// `accumulate_nodes`; this serves the trait's defaults and the tests; in column mode, the
    /// smallest IOR's).
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
    use crate::bsdf::slope::SlopeIntegrand;
    use crate::bsdf::vndf::{Part, VndfIntegrand};
    use crate::quadrature::{integrate_2d, integrate_2d_into, Rules};

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

    /// Cells from grazing to normal incidence, near-smooth to rough.
    const CELLS: [(f64, f64); 7] = [
        (0.05, 0.9),
        (0.1, 0.0),
        (0.3, 0.01),
        (0.5, 0.5),
        (0.7, 0.05),
        (0.6, 0.2),
        (1.0, 1.0),
    ];

    /// Leaving the denser medium, E_R as the white conductor's albedo less the cap's reflection
    /// deficit and E_T from the cap alone agree with both lobes integrated over whole lines.
    #[test]
    fn the_deficit_form_agrees_with_both_lobes() {
        let rules = Rules::new(32);
        for smith in SMITH {
            for eta in [1.0 / 1.25, 1.0 / 1.5, 1.0 / 3.0, 0.95] {
                for (r, mu) in CELLS {
                    let alpha = r * r;
                    let whole = integrate_2d(&SlopeDielectric::new(alpha, mu, eta, smith), &rules);
                    let e = integrate_2d(&SlopeIntegrand::conductor(alpha, mu, smith), &rules)[0];
                    let cap =
                        integrate_2d(&SlopeDielectric::deficit(alpha, mu, eta, smith), &rules);
                    let (er, et) = (e - cap[0], cap[1]);
                    let d = (er - whole[0]).abs().max((et - whole[1]).abs());
                    assert!(
                        d < 1e-10,
                        "{smith:?} η={eta} r={r} mu={mu}: [{er}, {et}] vs {whole:?}"
                    );
                }
            }
        }
    }

    /// The cap's lines evaluated across panel ends give the bits of their panels summed one at
    /// a time, over lines with every lobe and both line parts.
    #[test]
    fn a_cap_line_gives_the_bits_of_its_panels() {
        let rules = Rules::new(15);
        let (mut vs, mut ws) = (Vec::new(), Vec::new());
        let mut mixed = 0;
        for smith in SMITH {
            for eta in [1.0 / 1.25, 1.0 / 1.5, 1.0 / 3.0, 0.95] {
                for (r, mu) in CELLS {
                    let f = SlopeDielectric::deficit(r * r, mu, eta, smith);
                    for psi in [0.5, 1.6, 2.2, 2.6, 2.9, 3.1] {
                        let mut panels = Vec::new();
                        let line = f.line_panels(psi, &mut panels);
                        let mut whole = [0.0; CHANNELS];
                        f.accumulate_line(
                            &line,
                            &panels,
                            &rules.inner,
                            &mut vs,
                            &mut ws,
                            &mut whole,
                        );
                        let mut one_by_one = [0.0; CHANNELS];
                        for p in &panels {
                            vs.clear();
                            ws.clear();
                            rules.inner.nodes_into(p, &mut vs, &mut ws);
                            f.accumulate_nodes(&line, &vs, &ws, &mut one_by_one);
                        }
                        assert_eq!(
                            whole.map(f64::to_bits),
                            one_by_one.map(f64::to_bits),
                            "{smith:?} η={eta} r={r} mu={mu} psi={psi}"
                        );
                        mixed += usize::from(
                            line.seg_lobe[..line.segments]
                                .windows(2)
                                .any(|w| w[0] != w[1]),
                        );
                    }
                }
            }
        }
        assert!(mixed > 0, "no line with more than one lobe");
    }

    /// A column of IORs entering the denser medium gives each IOR's single-cell integrals, to
    /// the bit (the kinks do not depend on η there, and the arithmetic per node is the same).
    #[test]
    fn a_column_gives_each_cells_bits() {
        let rules = Rules::new(15);
        let etas = [1.25, 1.6, 2.2, 3.0];
        for smith in SMITH {
            for (r, mu) in CELLS {
                let alpha = r * r;
                let column = SlopeDielectric::column(alpha, mu, &etas, smith);
                let mut c = vec![0.0; 2 * etas.len()];
                integrate_2d_into(&column, &rules, &mut c);
                for (k, &eta) in etas.iter().enumerate() {
                    let one = integrate_2d(&SlopeDielectric::new(alpha, mu, eta, smith), &rules);
                    assert_eq!(
                        [c[2 * k].to_bits(), c[2 * k + 1].to_bits()],
                        [one[0].to_bits(), one[1].to_bits()],
                        "{smith:?} η={eta} r={r} mu={mu}"
                    );
                }
            }
        }
    }

    /// The AVX2/AVX-512 builds of every node loop (single cells both ways, the cap's deficit,
    /// a column) give the bits of the baseline build, so tables do not depend on the CPU
    /// (trivially true on a CPU without them).
    #[test]
    fn wide_vector_units_give_the_same_bits() {
        let rules = Rules::new(15);
        let etas = [1.25, 2.0, 3.0];
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for smith in SMITH {
            for (r, mu) in CELLS {
                let alpha = r * r;
                for eta in [1.0 / 1.5, 0.95, 1.5] {
                    let mut cells = vec![SlopeDielectric::new(alpha, mu, eta, smith)];
                    if eta < 1.0 {
                        cells.push(SlopeDielectric::deficit(alpha, mu, eta, smith));
                    }
                    for f in &cells {
                        let wide = integrate_2d(f, &rules);
                        let base = vector::on_baseline(|| integrate_2d(f, &rules));
                        assert_eq!(bits(&wide), bits(&base), "{smith:?} η={eta} r={r} mu={mu}");
                    }
                }
                let column = SlopeDielectric::column(alpha, mu, &etas, smith);
                let (mut wide, mut base) = (vec![0.0; 6], vec![0.0; 6]);
                integrate_2d_into(&column, &rules, &mut wide);
                vector::on_baseline(|| integrate_2d_into(&column, &rules, &mut base));
                assert_eq!(bits(&wide), bits(&base), "{smith:?} column r={r} mu={mu}");
            }
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
