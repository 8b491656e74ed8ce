//! The GGX white-conductor albedo in slope space, polar about the distribution's peak: the
//! integrand's only kink — the reflection horizon — is a coordinate line here, so no line needs
//! a root or a split inside it.
//!
//! # The integral
//! With microfacet slopes (x, y), h = (−x, −y, 1)/√(1 + x² + y²), the GGX slope density
//! P22 = 1/(πα²(1 + (x² + y²)/α²)²) (Heitz 2014, eq. 58 with eq. 86), D(h) dω_h = P22 √(1+x²+y²) dx dy
//! and ωo = (sin θo, 0, μo), the albedo of the white (F = 1) conductor is
//!
//! E = ∫ D(h) G2(ωo, ωi) (ωo·h)/μo dω_h = ∫ P22 G2 (μo − sin θo·x)/μo dx dy,
//!
//! over the slopes whose reflection ωi = 2(ωo·h)h − ωo lies above the horizon. Since
//! μi = 2(μo − sin θo·x)/(1 + x² + y²) − μo, that set is the disc (x + T)² + y² < 1 + T² with
//! T = tan θo (radius 1/μo); it contains every slope visible from ωo. In polar coordinates
//! (ρ, ψ) about the origin (the peak of P22) the disc is 0 ≤ ρ < ρmax(ψ), the positive root of
//! ρ² + 2Tρ cos ψ − 1 = 0, so the horizon is the end of every radial line and the integrand vanishes
//! there linearly (G2 ∝ μi as μi → 0). Two radial variables absorb P22:
//!
//! * near the peak, ρ = α sinh s: P22 ρ dρ = tanh s sech² s ds / π, whose poles lie at
//!   s = ±iπ/2: a plain rule up to s = [`S_PLAIN`], a sinh map towards s = 0 beyond;
//! * beyond ρ = [`RHO_TAIL`] (when the horizon lies beyond twice that), u = 1/ρ:
//!   P22 ρ dρ = α² u du / (π(1 + α²u²)²), analytic down to u = 0 (ρ = ∞, reached at μo = 0),
//!   so one panel covers the whole tail however large ρmax.
//!
//! The horizon end is near-singular — the masking weight varies on the scale μi ~ α there — and
//! is sinh-mapped (Johnston & Elliott 2005) with the distance that scale makes along the line;
//! when the map would thin the rule out too much at the other end, only the half next to the
//! horizon is mapped ([`SPLIT_LW`]). In ψ ∈ [0, π] (the integrand is even) ρmax(ψ) has branch
//! points at ψ = π/2 ± i·asinh(μo/sin θo): two panels, sinh-mapped towards π/2 at grazing μo.
//!
//! Against the visible-normal parametrisation of [`super::ggx`] this needs no root finding, no
//! scan and no activity test; about a twentieth of a table's cells refine instead of a fifth
//! (`examples/count.rs` compares evaluations cell by cell), and its evaluation vectorises (see
//! [`SlopeIntegrand::accumulate_nodes`]).
//!
//! With G2/μo written without the 1/μo (height-correlated: 2μi/(μi·a(μo) + μo·a(μi)), separable:
//! G1(μi)·2/(μo + a(μo)), a(μ) = √(μ² + α²(1 − μ²))), nothing degenerates at μo = 0.

use super::microfacet::{ALPHA_MIN, GRAZING_RATIO};
use crate::math::{asinh_pos, exp_poly, sin_cos_0_pi, smith_a, SmithForm};
use crate::quadrature::vector::{self, LANES};
use crate::quadrature::{
    panels_from_breaks, Break, DimRules, Integrand2D, Panel, PanelMap, CHANNELS,
};
use std::f64::consts::{FRAC_PI_2, PI};

/// Longest s range (from the peak at s = 0) covered by a plain rule: beyond it the poles of
/// sech² s at distance π/2 call for the sinh map towards s = 0.
const S_PLAIN: f64 = 2.0;

/// A horizon end mapped by y = δ·sinh(w) over a range of length L, w ∈ [0, W], W = asinh(L/δ),
/// stretches the far end by about L, so the poles at distance π/2 from s = 0 come to w-distance
/// ≈ π/(2L) of a w range of length W. Gauss–Legendre keeps converging like ρ⁻²ⁿ with ρ ≥ 2.8
/// while L·W ≤ 2.6; beyond it only the half next to the horizon is mapped.
const SPLIT_LW: f64 = 2.6;

/// Radius in slope space beyond which the tail variable u = 1/ρ takes over from s.
pub(crate) const RHO_TAIL: f64 = 2.0;

/// The slope-space integrand of one conductor cell.
pub struct SlopeIntegrand {
    alpha: f64,
    mu_o: f64,
    sin_o: f64,
    smith: SmithForm,
    /// a(μo) and, separable, G1(μo)/μo = 2/(μo + a(μo)).
    a_o: f64,
    g1_o_over_mu_o: f64,
    /// Scale in μi of the masking weight's singularities next to the horizon.
    mask_scale: f64,
    /// One line's integrand values ([`Integrand2D::accumulate_line`]), reused.
    line_buf: std::cell::RefCell<Vec<f64>>,
}

/// Per-line data of [`SlopeIntegrand`]: the direction ψ and where the line ends.
pub struct SlopeLine {
    /// sin θo · cos ψ (e·ωo,xy of the line's direction e).
    pub(crate) sc: f64,
    /// ρmax and 1/ρmax (either may be infinite at μo = 0), and k = μo/ρmax, k' = μo·ρmax.
    pub(crate) rho_max: f64,
    pub(crate) u_max: f64,
    pub(crate) k: f64,
    pub(crate) k_prime: f64,
    /// The inner variable v is s on [0, s_end] and s_end + (u_tail − u) beyond it.
    pub(crate) s_end: f64,
    pub(crate) u_tail: f64,
}

impl SlopeIntegrand {
    /// The white conductor of roughness α > 0 seen from μo ∈ [0, 1]. α below [`ALPHA_MIN`] is
    /// integrated at ALPHA_MIN, μo below [`GRAZING_RATIO`]·α at μo = 0 (see there).
    pub fn conductor(alpha: f64, mu_o: f64, smith: SmithForm) -> SlopeIntegrand {
        let alpha = alpha.max(ALPHA_MIN);
        let mu_o = if mu_o < GRAZING_RATIO * alpha {
            0.0
        } else {
            mu_o
        };
        let a_o = smith_a(mu_o, alpha);
        // a(μi) has its branch points at μi = ±iα/√(1 − α²): α is their (conservative) scale.
        // The height-correlated weight's one pole, μi = −μo (where μi·a(μo) + μo·a(μi) = 0),
        // lies where ωo·h = 0, which cancels it, or at ρ = ∞ (u = 0), which does not: see
        // `line_panels`.
        let mask_scale = alpha;
        SlopeIntegrand {
            alpha,
            mu_o,
            sin_o: (1.0 - mu_o * mu_o).max(0.0).sqrt(),
            smith,
            a_o,
            g1_o_over_mu_o: 2.0 / (mu_o + a_o),
            mask_scale,
            line_buf: std::cell::RefCell::new(Vec::new()),
        }
    }

    /// Σ_j ws[j]·f(vs[j]) for the conductor, in node order, by blocks of [`LANES`] nodes
    /// ([`Self::block`]), compiled for the current target.
    #[cfg(test)]
    fn sum<const TAIL: bool, const FACTORED: bool, const HC: bool>(
        &self,
        line: &SlopeLine,
        vs: &[f64],
        ws: &[f64],
    ) -> f64 {
        use vector::Kernel;
        vector::WeightedSum {
            block: ConductorBlock::<TAIL, FACTORED, HC> { f: self, line },
            vs,
            ws,
        }
        .run()[0]
    }

    /// Σ_j ws[j]·f(vs[j]) on the widest vector unit ([`vector::run`]): the same bits on every
    /// machine.
    fn sum_dispatch<const TAIL: bool, const FACTORED: bool, const HC: bool>(
        &self,
        line: &SlopeLine,
        vs: &[f64],
        ws: &[f64],
    ) -> f64 {
        vector::run(vector::WeightedSum {
            block: ConductorBlock::<TAIL, FACTORED, HC> { f: self, line },
            vs,
            ws,
        })[0]
    }

    /// The integrand at [`LANES`] nodes of the s part (or the u part, `TAIL`): the arithmetic of
    /// [`Integrand2D::eval`] without branches (selects only) and with the 1 + ρ² of μi cancelled
    /// from the masking weight (one division per node), so that the block vectorises.
    /// `FACTORED`: ρmax is finite (μi in factored form); `HC`: height-correlated masking.
    #[inline(always)]
    fn block<const TAIL: bool, const FACTORED: bool, const HC: bool>(
        &self,
        line: &SlopeLine,
        v: &[f64; LANES],
    ) -> [[f64; 1]; LANES] {
        let (alpha, mu_o) = (self.alpha, self.mu_o);
        let alpha2 = alpha * alpha;
        let scale = if HC {
            2.0 / PI
        } else {
            self.g1_o_over_mu_o * (2.0 / PI)
        };
        let mut y = [[0.0; 1]; LANES];
        if TAIL {
            // u = 1/ρ: μi = n/d with n = (u − umax)(k' + μo·u), d = 1 + u²; the Jacobian
            // α²u/(1 + α²u²)² times the projected factor (μo − sc/u) is α²(μo·u − sc)/(1 + α²u²)².
            for (yj, &vj) in y.iter_mut().zip(v) {
                let u = line.u_tail - (vj - line.s_end);
                let n = (u - line.u_max) * (line.k_prime + mu_o * u);
                let d = 1.0 + u * u;
                let a_d = (n * n * (1.0 - alpha2) + alpha2 * d * d).max(0.0).sqrt();
                let den = if HC {
                    n * self.a_o + mu_o * a_d
                } else {
                    n + a_d
                };
                let au2 = 1.0 + alpha2 * u * u;
                let g = scale * 2.0 * n * alpha2 * (mu_o * u - line.sc) / (au2 * au2 * den);
                yj[0] = if n > 0.0 { g } else { 0.0 };
            }
            return y;
        }
        for (yj, &vj) in y.iter_mut().zip(v) {
            // e^s by the polynomial, e^−s by one (vectorised) division
            let e = exp_poly(vj);
            let inv = 1.0 / e;
            let (sinh, cosh) = (0.5 * (e - inv), 0.5 * (e + inv));
            let rho = alpha * sinh;
            // μi = n/d with d = 1 + ρ² > 0; a(μi) = √(n²(1 − α²) + α²d²)/d, and d cancels from
            // μi/(μi·a(μo) + μo·a(μi)) and μi/(μi + a(μi)): one division per node.
            let n = if FACTORED {
                (line.rho_max - rho) * (mu_o * rho + line.k)
            } else {
                mu_o * (1.0 - rho * rho) - 2.0 * line.sc * rho
            };
            let d = 1.0 + rho * rho;
            let a_d = (n * n * (1.0 - alpha2) + alpha2 * d * d).max(0.0).sqrt();
            let den = if HC {
                n * self.a_o + mu_o * a_d
            } else {
                n + a_d
            };
            let proj = mu_o - line.sc * rho;
            let g = scale * 2.0 * n * sinh * proj / (cosh * cosh * cosh * den);
            yj[0] = if n > 0.0 { g } else { 0.0 };
        }
        y
    }
}

/// The integrand at the nodes `vs` of one line part into `out`, [`LANES`] nodes at a time
/// across panel ends ([`SlopeIntegrand::block`]): a [`vector::Kernel`].
struct ConductorRun<'a, const TAIL: bool, const FACTORED: bool, const HC: bool> {
    f: &'a SlopeIntegrand,
    line: &'a SlopeLine,
    vs: &'a [f64],
    out: &'a mut [f64],
}

impl<const TAIL: bool, const FACTORED: bool, const HC: bool> vector::Kernel
    for ConductorRun<'_, TAIL, FACTORED, HC>
{
    type Output = ();
    #[inline(always)]
    fn run(&mut self) {
        for (vc, oc) in self.vs.chunks(LANES).zip(self.out.chunks_mut(LANES)) {
            let mut v = [vc[0]; LANES];
            v[..vc.len()].copy_from_slice(vc);
            let y = self.f.block::<TAIL, FACTORED, HC>(self.line, &v);
            for (o, yj) in oc.iter_mut().zip(&y) {
                *o = yj[0];
            }
        }
    }
}

/// Where a radial line ψ of the slope plane leaves the reflection disc (the horizon μi = 0):
/// ρmax = μo/k = k'/μo with k = sc + √(sc² + μo²), k' = −sc + √(sc² + μo²), k·k' = μo²
/// (sc = sin θo·cos ψ), each computed without cancellation; ρmax = ∞ (umax = 0) at μo = 0
/// looking away from ωo, and NaN or 0 looking towards it (nothing reflects).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Horizon {
    pub k: f64,
    pub k_prime: f64,
    pub rho_max: f64,
    pub u_max: f64,
}

impl Horizon {
    #[inline]
    pub(crate) fn new(sc: f64, mu_o: f64) -> Horizon {
        let root = (sc * sc + mu_o * mu_o).sqrt(); // both in [−1, 1]: no scaling needed
        let (k, k_prime) = if sc >= 0.0 {
            let k = sc + root;
            (k, mu_o * mu_o / k)
        } else {
            let kp = root - sc;
            (mu_o * mu_o / kp, kp)
        };
        let (rho_max, u_max) = if sc >= 0.0 {
            (mu_o / k, k / mu_o)
        } else {
            (k_prime / mu_o, mu_o / k_prime)
        };
        Horizon {
            k,
            k_prime,
            rho_max,
            u_max,
        }
    }
}

/// Panels of the peak part [0, s1] of a radial line in s = asinh(ρ/α), whose end s1 is
/// near-singular at distance `end_delta` (and has square-root behaviour below it if `sqrt`) and
/// whose start s = 0 at distance `start_delta` (the poles of sech² s, π/2, or nearer ones).
/// A piece longer than [`S_PLAIN`] (or twice its start's distance) is graded towards s = 0. A
/// near-singular end's sinh map crowds the rule towards s1 and thins it out towards s = 0,
/// whose singularities would then come too close: on long lines ([`SPLIT_LW`]) only the half
/// next to the end is mapped; a square-root end longer than 2·S_PLAIN likewise.
pub(crate) fn peak_panels(
    s1: f64,
    end_delta: f64,
    sqrt: bool,
    start_delta: f64,
    out: &mut Vec<Panel>,
) {
    let start_delta = start_delta.min(FRAC_PI_2);
    let peak_part = |len: f64, out: &mut Vec<Panel>| {
        let map = if len > S_PLAIN || start_delta < crate::quadrature::NEAR_SINGULAR_RATIO * len {
            PanelMap::End {
                at: 0.0,
                toward: len,
                sqrt: false,
                delta: start_delta,
                beyond: false,
            }
        } else {
            PanelMap::Plain
        };
        out.push(Panel {
            a: 0.0,
            b: len,
            map,
        });
    };
    let near = end_delta < crate::quadrature::NEAR_SINGULAR_RATIO * s1;
    if near || sqrt {
        // L·asinh(L/δ) > SPLIT_LW ⇔ L/δ > sinh(SPLIT_LW/L), without a logarithm
        let x = (SPLIT_LW / s1).min(700.0);
        let split = if near {
            s1 / end_delta > 0.5 * (exp_poly(x) - exp_poly(-x))
        } else {
            s1 > 2.0 * S_PLAIN
        } || start_delta < FRAC_PI_2;
        let mid = if split { 0.5 * s1 } else { 0.0 };
        if mid > 0.0 {
            peak_part(mid, out);
        }
        out.push(Panel {
            a: mid,
            b: s1,
            map: PanelMap::End {
                at: s1,
                toward: mid,
                sqrt,
                delta: if near { end_delta } else { f64::INFINITY },
                beyond: false,
            },
        });
    } else {
        peak_part(s1, out);
    }
}

impl SlopeLine {
    /// The radial line whose direction e has e·ωo,xy = `sc` (sin θo·cos ψ for the isotropic
    /// integrand), seen from μo, up to where it leaves the reflection disc ([`Horizon`]); its
    /// panels are laid by [`SlopeLine::panels`].
    pub(crate) fn new(sc: f64, mu_o: f64) -> SlopeLine {
        let Horizon {
            k,
            k_prime,
            rho_max,
            u_max,
        } = Horizon::new(sc, mu_o);
        SlopeLine {
            sc,
            rho_max,
            u_max,
            k,
            k_prime,
            s_end: 0.0,
            u_tail: 1.0 / RHO_TAIL,
        }
    }

    /// Whether any of the line lies above the horizon (not so at μo = 0 looking towards ωo).
    pub(crate) fn reflects(&self) -> bool {
        !(self.rho_max.is_nan() || self.rho_max <= 0.0)
    }

    /// Lays the panels of the inner variable v — s = asinh(ρ/α), then s_end + (u_tail − u) with
    /// u = 1/ρ past [`RHO_TAIL`] — for slope scale `alpha` along the line, the masking weight's
    /// singularities lying at |μi| ~ `mask_scale` next to the horizon; sets `s_end` and `u_tail`.
    /// Nothing when the line does not reflect ([`SlopeLine::reflects`]).
    pub(crate) fn panels(
        &mut self,
        alpha: f64,
        mu_o: f64,
        mask_scale: f64,
        smith: SmithForm,
        out: &mut Vec<Panel>,
    ) {
        if !self.reflects() {
            return; // μo = 0 looking forward: nothing reflects above the horizon
        }
        let line = self;
        let (rho_max, u_max, k, k_prime) = (line.rho_max, line.u_max, line.k, line.k_prime);
        let rt = RHO_TAIL;
        // The tail variable takes over only when the horizon lies well beyond ρ = RHO_TAIL, so
        // that no tail panel is a sliver.
        let tail = rho_max > 2.0 * rt;
        let rho_s = if tail { rt } else { rho_max };
        line.u_tail = 1.0 / rt;
        line.s_end = asinh_pos(rho_s / alpha);
        // s = 0 sits at distance π/2 from the poles of sech² s. The horizon sits next to the
        // masking weight's singularities (|μi| ~ mask_scale), where |dμi/dρ| = k, so that
        // |dμi/ds| = k·√(α² + ρmax²) and |dμi/du| = k·ρmax² = k'; seen from the end of the s
        // part, they lie at s(ρmax) − s_end along the axis and that distance off it.
        let s_end = line.s_end;
        let slope_s = k * (alpha * alpha + rho_max * rho_max).sqrt();
        let horizon_delta = if slope_s > 0.0 {
            mask_scale / slope_s
        } else {
            f64::INFINITY
        };
        // asinh(ρmax/α) − asinh(ρs/α) as one logarithm: ln((x + √(x²+1))/(y + √(y²+1)))
        let beyond = if tail {
            let (x, y) = (rho_max / alpha, rho_s / alpha);
            ((x + (x * x + 1.0).sqrt()) / (y + (y * y + 1.0).sqrt())).ln()
        } else {
            0.0
        };
        let end_delta = (beyond * beyond + horizon_delta * horizon_delta)
            .sqrt()
            .max(crate::quadrature::MIN_DELTA);
        peak_panels(s_end, end_delta, false, f64::INFINITY, out);
        if tail {
            // the u part is panelled on its own: a distance in u is none in s
            let v_end = s_end + (line.u_tail - u_max);
            let mut delta = if k_prime > 0.0 {
                mask_scale / k_prime
            } else {
                f64::INFINITY
            };
            if smith == SmithForm::HeightCorrelated && mu_o > 0.0 {
                // the pole at u = 0 (μi → −μo as ρ → ∞), at distance umax beyond the horizon end
                delta = delta.min(u_max);
            }
            let mut breaks = [
                Break::regular(s_end),
                Break::near_singular(v_end, delta.max(crate::quadrature::MIN_DELTA)),
            ];
            panels_from_breaks(&mut breaks, out);
        }
    }
}

/// One line's [`SlopeIntegrand::block`] as a [`vector::Block`].
struct ConductorBlock<'a, const TAIL: bool, const FACTORED: bool, const HC: bool> {
    f: &'a SlopeIntegrand,
    line: &'a SlopeLine,
}

impl<const TAIL: bool, const FACTORED: bool, const HC: bool> vector::Block<1>
    for ConductorBlock<'_, TAIL, FACTORED, HC>
{
    #[inline(always)]
    fn block(&self, v: &[f64; LANES]) -> [[f64; 1]; LANES] {
        self.f.block::<TAIL, FACTORED, HC>(self.line, v)
    }
}

impl Integrand2D for SlopeIntegrand {
    type Line = SlopeLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        out.extend([0.0, FRAC_PI_2, PI]);
    }

    fn line(&self, psi: f64, breaks: &mut Vec<f64>) -> SlopeLine {
        let mut panels = Vec::new();
        let line = self.line_panels(psi, &mut panels);
        breaks.extend(panels.iter().map(|p| p.a));
        breaks.extend(panels.last().map(|p| p.b));
        line
    }

    /// ψ ∈ [0, π] (the integrand is even in ψ), split at π/2: ρmax(ψ) contains
    /// √(sin²θo cos²ψ + μo²), whose branch points ψ = π/2 ± i·asinh(μo/sin θo) approach the real
    /// axis at grazing incidence.
    fn outer_panels(&self, out: &mut Vec<Panel>) {
        let delta = if self.sin_o > 0.0 {
            asinh_pos(self.mu_o / self.sin_o)
        } else {
            f64::INFINITY
        };
        let mut breaks = [
            Break::regular(0.0),
            Break::near_singular(FRAC_PI_2, delta.max(crate::quadrature::MIN_DELTA)),
            Break::regular(PI),
        ];
        panels_from_breaks(&mut breaks, out);
    }

    fn line_panels(&self, psi: f64, out: &mut Vec<Panel>) -> SlopeLine {
        let sc = self.sin_o * sin_cos_0_pi(psi).1;
        let mut line = SlopeLine::new(sc, self.mu_o);
        line.panels(self.alpha, self.mu_o, self.mask_scale, self.smith, out);
        line
    }

    /// ψ's integrand is analytic with its one near-singularity mapped: at order 9 (the other
    /// variable at 40) its rule alone is off by at most 1.0e-8 over a 20² grid of (r, μ), the
    /// inner one by up to 6.6e-7 (`examples/lean_outer.rs`), so it takes
    /// [`crate::quadrature::lean_order`] points.
    fn lean_outer(&self) -> bool {
        true
    }

    /// Every panel of a line lies inside the horizon disc, where the integrand is positive.
    fn panels_all_active(&self) -> bool {
        true
    }

    /// The nodes of all the line's panels in one buffer, each line part (s, u) evaluated by one
    /// block loop across panel ends ([`ConductorRun`]), each panel summed from zero in node
    /// order and added in turn: the bits of [`Self::accumulate_nodes`] panel by panel, with
    /// fewer blocks left part empty.
    fn accumulate_line(
        &self,
        line: &SlopeLine,
        panels: &[Panel],
        rule: &DimRules,
        vs: &mut Vec<f64>,
        ws: &mut Vec<f64>,
        acc: &mut [f64],
    ) {
        const MAX_PANELS: usize = 32;
        if panels.len() > MAX_PANELS {
            for seg in panels {
                vs.clear();
                ws.clear();
                rule.nodes_into(seg, vs, ws);
                self.accumulate_nodes(line, vs, ws, acc);
            }
            return;
        }
        vs.clear();
        ws.clear();
        let mut ends = [0usize; MAX_PANELS];
        let mut tail = [false; MAX_PANELS];
        for (i, seg) in panels.iter().enumerate() {
            let start = vs.len();
            rule.nodes_into(seg, vs, ws);
            ends[i] = vs.len();
            // a panel lies wholly in the s part or wholly in the u part
            tail[i] = vs[start..].first().is_some_and(|&v| v > line.s_end);
        }
        let n = panels.len();
        let mut y = self.line_buf.borrow_mut();
        y.resize(vs.len(), 0.0);
        let mut i = 0;
        while i < n {
            let mut j = i + 1;
            while j < n && tail[j] == tail[i] {
                j += 1;
            }
            let (first, last) = (if i == 0 { 0 } else { ends[i - 1] }, ends[j - 1]);
            let (v, out) = (&vs[first..last], &mut y[first..last]);
            macro_rules! run {
                ($tail:literal, $factored:literal, $hc:literal) => {
                    vector::run(ConductorRun::<$tail, $factored, $hc> {
                        f: self,
                        line,
                        vs: v,
                        out,
                    })
                };
            }
            match (tail[i], line.rho_max.is_finite(), self.smith) {
                (false, true, SmithForm::HeightCorrelated) => run!(false, true, true),
                (false, true, SmithForm::Separable) => run!(false, true, false),
                (false, false, SmithForm::HeightCorrelated) => run!(false, false, true),
                (false, false, SmithForm::Separable) => run!(false, false, false),
                (true, _, SmithForm::HeightCorrelated) => run!(true, true, true),
                (true, _, SmithForm::Separable) => run!(true, true, false),
            }
            i = j;
        }
        let mut from = 0;
        for &end in &ends[..n] {
            let mut sum = 0.0;
            for (&w, &yj) in ws[from..end].iter().zip(&y[from..end]) {
                sum += w * yj;
            }
            acc[0] += sum;
            from = end;
        }
    }

    /// The hot loop of a table: blocks of [`LANES`] nodes without branches or calls
    /// ([`SlopeIntegrand::block`]), compiled for the widest vector unit the CPU has, summed per
    /// panel in node order.
    fn accumulate_nodes(&self, line: &SlopeLine, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        // A panel lies wholly in the s part or wholly in the u part.
        let tail = vs.first().is_some_and(|&v| v > line.s_end);
        acc[0] += match (tail, line.rho_max.is_finite(), self.smith) {
            (false, true, SmithForm::HeightCorrelated) => {
                self.sum_dispatch::<false, true, true>(line, vs, ws)
            }
            (false, true, SmithForm::Separable) => {
                self.sum_dispatch::<false, true, false>(line, vs, ws)
            }
            (false, false, SmithForm::HeightCorrelated) => {
                self.sum_dispatch::<false, false, true>(line, vs, ws)
            }
            (false, false, SmithForm::Separable) => {
                self.sum_dispatch::<false, false, false>(line, vs, ws)
            }
            (true, _, SmithForm::HeightCorrelated) => {
                self.sum_dispatch::<true, true, true>(line, vs, ws)
            }
            (true, _, SmithForm::Separable) => self.sum_dispatch::<true, true, false>(line, vs, ws),
        };
    }

    /// One node through lane 0 of [`SlopeIntegrand::block`] (tables go through
    /// `accumulate_nodes`; this serves the trait's defaults and the tests).
    fn eval(&self, line: &SlopeLine, v: f64) -> [f64; CHANNELS] {
        let v = [v; LANES];
        let tail = v[0] > line.s_end;
        let y = match (tail, line.rho_max.is_finite(), self.smith) {
            (false, true, SmithForm::HeightCorrelated) => self.block::<false, true, true>(line, &v),
            (false, true, SmithForm::Separable) => self.block::<false, true, false>(line, &v),
            (false, false, SmithForm::HeightCorrelated) => {
                self.block::<false, false, true>(line, &v)
            }
            (false, false, SmithForm::Separable) => self.block::<false, false, false>(line, &v),
            (true, _, SmithForm::HeightCorrelated) => self.block::<true, true, true>(line, &v),
            (true, _, SmithForm::Separable) => self.block::<true, true, false>(line, &v),
        };
        [y[0][0], 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::Lobes;
    use crate::bsdf::vndf::VndfIntegrand;
    use crate::math::{dot, reflect};
    use crate::quadrature::{integrate_2d, Rules};

    const SMITH: [SmithForm; 2] = [SmithForm::HeightCorrelated, SmithForm::Separable];
    /// (r, μo): peaked and rough lobes, grazing, normal and exactly-grazing incidence.
    const CELLS: [(f64, f64); 9] = [
        (0.02, 0.5),
        (0.05, 0.9),
        (0.1, 0.0),
        (0.3, 0.01),
        (0.5, 0.5),
        (0.7, 0.05),
        (0.9, 0.3),
        (1.0, 1.0),
        (1.0, 0.0),
    ];

    /// Two parametrisations that share no coordinate, panel or map: slopes polar about the peak
    /// here, visible normals by latitude and longitude in `ggx`.
    #[test]
    fn agrees_with_the_visible_normal_parametrisation() {
        let rules = Rules::new(32);
        for smith in SMITH {
            for (r, mu) in CELLS {
                let alpha = r * r;
                let a = integrate_2d(&SlopeIntegrand::conductor(alpha, mu, smith), &rules)[0];
                let b = integrate_2d(
                    &VndfIntegrand::new(alpha, mu, smith, Lobes::Conductor),
                    &rules,
                )[0];
                assert!(
                    (a - b).abs() < 2e-10,
                    "{smith:?} r={r} mu={mu}: slope {a} vs vndf {b}"
                );
            }
        }
    }

    /// Smith: ∫ D(h) max(0, ωo·h) dω_h = (1 + Λ(μo))·μo → α/2 as μo → 0, and G2/μo → 2/α there,
    /// so the height-correlated albedo at grazing incidence is exactly 1 (every visible facet
    /// reflects above the horizon).
    #[test]
    fn height_correlated_albedo_at_grazing_incidence_is_one() {
        for r in [0.1, 0.4, 0.8, 1.0] {
            let e = integrate_2d(
                &SlopeIntegrand::conductor(r * r, 0.0, SmithForm::HeightCorrelated),
                &Rules::new(24),
            )[0];
            assert!((e - 1.0).abs() < 1e-9, "r={r}: E(μ=0) = {e}");
        }
    }

    /// The integrand straight from its definition — h from the slopes, ωi = reflect(ωo, h),
    /// P22, G2 from `math` — times the radial Jacobian, against the vector blocks of
    /// `accumulate_nodes`, summed over every kind of panel (s part plain and mapped, horizon
    /// map, tail). μo > 0: at μo = 0, G2/μo is a limit (covered by the tests above).
    #[test]
    fn matches_the_integrand_from_its_definition() {
        let rules = Rules::new(12);
        for smith in SMITH {
            for (r, mu) in CELLS.into_iter().filter(|&(_, mu)| mu > 0.0) {
                let alpha = r * r;
                let f = SlopeIntegrand::conductor(alpha, mu, smith);
                let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
                for psi in [0.1, 1.0, 1.6, 2.5, 3.1] {
                    let mut panels = Vec::new();
                    let line = f.line_panels(psi, &mut panels);
                    let direct = |v: f64| {
                        let (rho, drho_dv) = if v <= line.s_end {
                            (alpha * v.sinh(), alpha * v.cosh())
                        } else {
                            let u = line.u_tail - (v - line.s_end);
                            (1.0 / u, 1.0 / (u * u))
                        };
                        let (x, y) = (rho * psi.cos(), rho * psi.sin());
                        let len = (1.0 + x * x + y * y).sqrt();
                        let h = [-x / len, -y / len, 1.0 / len];
                        let wi = reflect(wo, h);
                        if wi[2] <= 0.0 {
                            return 0.0;
                        }
                        let p22 = 1.0
                            / (PI * alpha * alpha * (1.0 + rho * rho / (alpha * alpha)).powi(2));
                        // (ωo·h)/h_z is the projected-area factor μo − sin θo·x; both ψ signs: ×2
                        2.0 * rho * p22 * drho_dv * smith.g2(mu, wi[2], alpha) * dot(wo, h) * len
                            / mu
                    };
                    for p in &panels {
                        let (mut vs, mut ws) = (Vec::new(), Vec::new());
                        rules.inner.nodes_into(p, &mut vs, &mut ws);
                        let want: f64 = vs.iter().zip(&ws).map(|(&v, &w)| w * direct(v)).sum();
                        let mut acc = [0.0; CHANNELS];
                        f.accumulate_nodes(&line, &vs, &ws, &mut acc);
                        assert!(
                            (acc[0] - want).abs() <= 1e-12 * want.abs().max(1e-300),
                            "{smith:?} r={r} mu={mu} psi={psi} panel {p:?}: {} vs {want}",
                            acc[0]
                        );
                    }
                }
            }
        }
    }

    /// A line evaluated across panel ends gives the bits of its panels summed one at a time.
    #[test]
    fn a_line_gives_the_bits_of_its_panels() {
        let rules = Rules::new(15);
        let (mut vs, mut ws) = (Vec::new(), Vec::new());
        for smith in SMITH {
            for (r, mu) in CELLS {
                let f = SlopeIntegrand::conductor(r * r, mu, smith);
                for psi in [0.1, 1.0, 1.6, 2.5, 3.1] {
                    let mut panels = Vec::new();
                    let line = f.line_panels(psi, &mut panels);
                    let mut whole = [0.0; CHANNELS];
                    f.accumulate_line(&line, &panels, &rules.inner, &mut vs, &mut ws, &mut whole);
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
                        "{smith:?} r={r} mu={mu} psi={psi}"
                    );
                }
            }
        }
    }

    /// The AVX2/AVX-512 builds of the block sum give the bits of the baseline build, so tables do
    /// not depend on the CPU (trivially true on a CPU without them).
    #[test]
    fn wide_vector_units_give_the_same_bits() {
        let rules = Rules::new(15);
        for (r, mu) in CELLS {
            let f = SlopeIntegrand::conductor(r * r, mu, SmithForm::HeightCorrelated);
            let g = SlopeIntegrand::conductor(r * r, mu, SmithForm::Separable);
            for psi in [0.3, 2.8] {
                let mut panels = Vec::new();
                let line = f.line_panels(psi, &mut panels);
                for p in &panels {
                    let (mut vs, mut ws) = (Vec::new(), Vec::new());
                    rules.inner.nodes_into(p, &mut vs, &mut ws);
                    let tail = vs[0] > line.s_end;
                    let pairs = match (tail, line.rho_max.is_finite()) {
                        (true, _) => [
                            (
                                f.sum::<true, true, true>(&line, &vs, &ws),
                                f.sum_dispatch::<true, true, true>(&line, &vs, &ws),
                            ),
                            (
                                g.sum::<true, true, false>(&line, &vs, &ws),
                                g.sum_dispatch::<true, true, false>(&line, &vs, &ws),
                            ),
                        ],
                        (false, true) => [
                            (
                                f.sum::<false, true, true>(&line, &vs, &ws),
                                f.sum_dispatch::<false, true, true>(&line, &vs, &ws),
                            ),
                            (
                                g.sum::<false, true, false>(&line, &vs, &ws),
                                g.sum_dispatch::<false, true, false>(&line, &vs, &ws),
                            ),
                        ],
                        (false, false) => [
                            (
                                f.sum::<false, false, true>(&line, &vs, &ws),
                                f.sum_dispatch::<false, false, true>(&line, &vs, &ws),
                            ),
                            (
                                g.sum::<false, false, false>(&line, &vs, &ws),
                                g.sum_dispatch::<false, false, false>(&line, &vs, &ws),
                            ),
                        ],
                    };
                    for (base, wide) in pairs {
                        assert_eq!(base.to_bits(), wide.to_bits(), "r={r} mu={mu} psi={psi}");
                    }
                }
            }
        }
    }
}
