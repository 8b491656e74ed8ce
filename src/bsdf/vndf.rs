//! The visible-normal integrand of the GGX glossy model, and a second, independent
//! parametrisation of the conductor and the dielectrics, which the slope-space integrands'
//! tests compare against.
//!
//! # The integral
//! The albedo is integrated over *visible* microfacet normals (Heitz 2018, "Sampling the GGX
//! distribution of visible normals"): with h distributed by D_ωo(h) = G1(ωo) max(0, ωo·h) D(h) / μo
//! (Heitz 2014, eq. 14), each lobe contributes
//!
//! * reflection: E_R = ∫ D_ωo(h) F(ωo·h) G2(ωo, ωi)/G1(ωo) [μi > 0] dh, ωi = reflect(ωo, h);
//! * transmission: E_T = ∫ D_ωo(h) (1 − F) G2(ωo, ωt)/G1(ωo) [μt < 0] dh, ωt = refract(ωo, h, η)
//!   (energy form: no 1/η² factor, so E_R + E_T → 1 as α → 0).
//!
//! The weights are bounded by 1 and the near-delta lobe of α → 0 becomes a constant integrand, so
//! nothing degenerates at low roughness. In the stretched (α = 1) configuration the visible
//! normals of the hemisphere have density (N·V)/(π s), s = (1 + V_z)/2, on the lune
//! {N_z > 0, N·V > 0}. We parametrise N by a latitude β about the plane of incidence and a
//! longitude φ measured from the rim in that plane:
//! N = (cos β cos φ, sin β, cos β sin φ) in the basis (e2, e1, e3·…) — see [`VndfIntegrand`] — so
//! N·V = cos β sin(φ + θv), N_z = cos β sin φ, dω = cos β dβ dφ, with β ∈ [−π/2, π/2] (symmetric:
//! we integrate [0, π/2] twice) and φ ∈ [0, π − θv].
//!
//! # Kinks
//! Every kink of the integrand is a level set of a quadratic form in N: the reflection horizon
//! μi = 0 ⇔ 2(ωo·m) m_z − μo|m|² = 0 and the critical angle (ωo·h)² = 1 − η² ⇔ (ωo·m)² − (1−η²)|m|² = 0,
//! with m = (αN_x, αN_y, N_z) the unnormalised half vector. On a line of constant β such a form is
//! P + R cos(2φ − γ) + A_yy tan²β, so its zeros are closed-form; the β at which zeros appear,
//! merge or cross the ends of the φ range are closed-form as well and become outer panel ends.
//! The transmitted direction crossing the horizon when leaving the denser medium squares into
//! a quadratic form as well (see [`VndfIntegrand::transmit_roots`]); only where the three kink
//! curves meet are the outer panel ends found by scanning β and bisecting.

use super::kinks::{sort_dedup, QuadForm};
use super::microfacet::{Lobes, ALPHA_MIN};
use crate::math::{fresnel_dielectric, fresnel_from_cosines, safe_sqrt, sin_cos_0_pi, SmithForm};
use crate::quadrature::{panels_from_breaks, Break, Integrand2D, Panel, CHANNELS};
use std::f64::consts::{FRAC_PI_2, PI};

/// The visible-normal integrand of one cell (see the module docs).
pub struct VndfIntegrand {
    alpha: f64,
    mu_o: f64,
    sin_o: f64,
    /// Stretched view direction V = normalize(α sinθo, 0, μo) at angle θv from the normal.
    sin_v: f64,
    cos_v: f64,
    phi_max: f64,
    /// 2/(π s): the β-symmetry doubling over the visible projected area π s.
    norm: f64,
    smith: SmithForm,
    lobes: Lobes,
    /// Reflection horizon μi = 0 (valid where positive).
    horizon: QuadForm,
    /// Critical angle of total internal reflection (valid where positive), when η < 1.
    tir: Option<QuadForm>,
    /// Whether the transmitted direction can cross the horizon (η < 1), a kink to split at.
    transmit_horizon: bool,
    /// The transmission horizon μt = 0 squared into a quadratic form (leaving the denser
    /// medium only): see [`VndfIntegrand::transmit_roots`].
    transmit: Option<QuadForm>,
    /// Which channels this integrand carries; the other one is left at zero and its kinks are
    /// not panel ends. Leaving the denser medium, reflection and transmission are integrated
    /// separately: reflection needs only closed-form kinks, transmission lives on the small
    /// non-TIR cap with the numerically located horizon.
    part: Part,
    /// Column mode: relative IORs of many cells that share this geometry (entering dielectric
    /// or glossy only, whose kinks do not depend on η); channels are 2 per IOR.
    column: Vec<f64>,
    /// Outer panels, computed once per cell (they do not depend on the rule order).
    outer_cache: std::cell::OnceCell<Vec<Panel>>,
    /// Buffers reused by every line of the cell (a line's breaks and roots), so that the
    /// per-line geometry allocates nothing.
    scratch: std::cell::RefCell<Scratch>,
    /// Precomputed masking terms of ωo: a(μo) and μo + a(μo) (see [`SmithForm::g2_over_g1`]).
    a_o: f64,
    mu_o_plus_a_o: f64,
}

/// Reused buffers of [`VndfIntegrand`] (see its `scratch`).
#[derive(Default)]
struct Scratch {
    breaks: Vec<Break>,
    roots: Vec<f64>,
    near: Vec<(f64, f64)>,
    xs: Vec<f64>,
    tmp: Vec<f64>,
    tagged: Vec<(f64, u8)>,
}

/// The channels a [`VndfIntegrand`] carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    Both,
    ReflectionOnly,
    TransmissionOnly,
}

/// Nodes evaluated side by side in [`Integrand2D::accumulate_nodes`].
const LANES: usize = 8;

/// Per-line data of [`VndfIntegrand`].
pub struct Line {
    sb: f64,
    cb: f64,
    weight: f64,
}

impl VndfIntegrand {
    /// The integrand of one cell; α below [`ALPHA_MIN`] is integrated at ALPHA_MIN.
    pub fn new(alpha: f64, mu_o: f64, smith: SmithForm, lobes: Lobes) -> VndfIntegrand {
        let alpha = alpha.max(ALPHA_MIN);
        let sin_o = safe_sqrt(1.0 - mu_o * mu_o);
        let theta_v = (alpha * sin_o).atan2(mu_o);
        let (sin_v, cos_v) = theta_v.sin_cos();
        let s = 0.5 * (1.0 + cos_v);
        // 2(ωo·m) m_z − μo|m|², m = (αN_x, αN_y, N_z)
        let horizon = QuadForm::new(
            -mu_o * alpha * alpha,
            sin_o * alpha,
            mu_o,
            -mu_o * alpha * alpha,
        );
        let eta = match lobes {
            Lobes::Dielectric { eta } => Some(eta),
            _ => None,
        };
        let tir = eta.filter(|&e| e < 1.0).map(|e| {
            // (ωo·m)² − k|m|², k = 1 − η²
            let k = 1.0 - e * e;
            QuadForm::new(
                alpha * alpha * (sin_o * sin_o - k),
                sin_o * alpha * mu_o,
                mu_o * mu_o - k,
                -k * alpha * alpha,
            )
        });
        let a_o = crate::math::smith_a(mu_o, alpha);
        VndfIntegrand {
            part: Part::Both,
            column: Vec::new(),
            outer_cache: std::cell::OnceCell::new(),
            scratch: std::cell::RefCell::new(Scratch::default()),
            a_o,
            mu_o_plus_a_o: mu_o + a_o,
            alpha,
            mu_o,
            sin_o,
            sin_v,
            cos_v,
            phi_max: PI - theta_v,
            norm: 2.0 / (PI * s),
            smith,
            lobes,
            horizon,
            tir,
            transmit_horizon: tir.is_some(),
            transmit: eta.filter(|&e| e < 1.0).map(|e| {
                // (η² − 1) m_z² + 2μo (ωo·m) m_z − μo² |m|², m = (αN_x, αN_y, N_z)
                let m2 = mu_o * mu_o;
                QuadForm::new(
                    -m2 * alpha * alpha,
                    mu_o * sin_o * alpha,
                    e * e - 1.0 + m2,
                    -m2 * alpha * alpha,
                )
            }),
        }
    }

    /// Only one channel of a dielectric integrand (see [`Part`]).
    pub fn part(
        alpha: f64,
        mu_o: f64,
        smith: SmithForm,
        lobes: Lobes,
        part: Part,
    ) -> VndfIntegrand {
        let mut f = VndfIntegrand::new(alpha, mu_o, smith, lobes);
        f.part = part;
        if part == Part::ReflectionOnly {
            f.transmit_horizon = false;
        }
        f
    }

    /// The same geometry for a column of cells differing only in their relative IOR (entering
    /// dielectric or glossy, whose kinks do not depend on it): channels 2k, 2k+1 belong to
    /// `etas[k]`.
    pub fn column(
        alpha: f64,
        mu_o: f64,
        smith: SmithForm,
        lobes: Lobes,
        etas: &[f64],
    ) -> VndfIntegrand {
        debug_assert!(
            etas.iter().all(|&e| e >= 1.0),
            "column mode needs η ≥ 1 (no critical angle)"
        );
        let mut f = VndfIntegrand::new(alpha, mu_o, smith, lobes);
        f.column = etas.to_vec();
        f
    }

    /// G2(ωo, ωi)/G1(ωo) for μi > 0, with ωo's terms precomputed (see [`SmithForm::g2_over_g1`]).
    #[inline]
    fn masking(&self, mu_i: f64) -> f64 {
        match self.smith {
            SmithForm::Separable => crate::math::smith_g1(mu_i, self.alpha),
            SmithForm::HeightCorrelated => {
                let a_i = crate::math::smith_a(mu_i, self.alpha);
                let den = self.a_o * mu_i + a_i * self.mu_o;
                if den > 0.0 {
                    self.mu_o_plus_a_o * mu_i / den
                } else {
                    1.0
                }
            }
        }
    }

    /// Unit half vector h for the stretched normal at (β, φ).
    #[inline]
    fn half_vector(&self, line: &Line, sp: f64, cp: f64) -> Option<[f64; 3]> {
        let m = [
            self.alpha * line.cb * cp,
            self.alpha * line.sb,
            line.cb * sp,
        ];
        let len2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
        if len2 <= 0.0 {
            return None;
        }
        let inv = 1.0 / len2.sqrt();
        Some([m[0] * inv, m[1] * inv, m[2] * inv])
    }

    /// z of the reflected direction at (line, φ).
    fn reflected_z(&self, line: &Line, phi: f64) -> f64 {
        let (sp, cp) = sin_cos_0_pi(phi);
        match self.half_vector(line, sp, cp) {
            Some(h) => 2.0 * (self.sin_o * h[0] + self.mu_o * h[2]) * h[2] - self.mu_o,
            None => -self.mu_o,
        }
    }

    /// Distance in φ from a horizon zero at `phi` to the nearest singularity of the masking
    /// weight. As a function of μ = |ωi·n| the weight G2/G1 has branch points at μ = ±iα/√(1−α²)
    /// (from Λ) and, height-correlated, a pole at μ ≈ −α·μo/ao (from 1/(ao·μi + ai·μo)); divided
    /// by |dμ/dφ| (central difference) that scale becomes a distance in φ.
    fn near_singular_delta(&self, phi: f64, mu: impl Fn(f64) -> f64) -> f64 {
        const H: f64 = 1e-7; // finite-difference step in φ (μ is smooth there)
        let slope = ((mu(phi + H) - mu(phi - H)) / (2.0 * H)).abs();
        let scale = match self.smith {
            SmithForm::Separable => self.alpha,
            SmithForm::HeightCorrelated => {
                let a_o = crate::math::smith_a(self.mu_o, self.alpha);
                if a_o > 0.0 {
                    self.alpha * (self.mu_o / a_o).min(1.0)
                } else {
                    self.alpha
                }
            }
        };
        if slope > 0.0 && scale > 0.0 {
            scale / slope
        } else {
            f64::INFINITY
        }
    }

    /// Whether ωo is totally internally reflected at the normal of (line, φ).
    fn is_tir(&self, line: &Line, phi: f64, eta: f64) -> bool {
        let (sp, cp) = sin_cos_0_pi(phi);
        match self.half_vector(line, sp, cp) {
            Some(h) => {
                let c = self.sin_o * h[0] + self.mu_o * h[2];
                (1.0 - c * c) / (eta * eta) >= 1.0
            }
            None => true,
        }
    }

    /// z of the transmitted direction (positive: above the horizon, invalid), continued through
    /// the critical angle with cos θt clamped to 0 so that it is continuous on a non-TIR panel
    /// including its ends.
    fn transmitted_z(&self, line: &Line, phi: f64, eta: f64) -> f64 {
        let (sp, cp) = sin_cos_0_pi(phi);
        let Some(h) = self.half_vector(line, sp, cp) else {
            return 0.0;
        };
        let c = self.sin_o * h[0] + self.mu_o * h[2];
        let cos_t = safe_sqrt(1.0 - (1.0 - c * c) / (eta * eta));
        -self.mu_o / eta + (c / eta - cos_t) * h[2]
    }

    /// Zeros of the transmitted z on the non-TIR panels of a line (breakpoints so far), in
    /// closed form. With c = ωo·h and η cos θt = √(η² − 1 + c²), μt = 0 reads
    /// c·h_z − μo = h_z·√(η² − 1 + c²) (Walter et al. 2007, eq. 40, z component); squared, it is
    /// (η² − 1) h_z² + 2c·μo·h_z − μo² = 0, a quadratic form in the unnormalised normal m, whose
    /// zeros on a line are closed-form like the horizon's. Solving it for c shows every zero has
    /// c² ≥ 1 − η² (no TIR), with c·h_z − μo = ((1 − η²) h_z² − μo²)/(2μo): the zeros of the
    /// unsquared equation are those with (1 − η²) h_z² ≥ μo², the others belong to the spurious
    /// sign (and the two branches meet on the critical-angle curve).
    fn transmit_roots(
        &self,
        line: &Line,
        eta: f64,
        breaks: &[f64],
        out: &mut Vec<f64>,
        tmp: &mut Vec<f64>,
    ) {
        let Some(q) = &self.transmit else {
            return;
        };
        let mut roots = [0.0; 8];
        tmp.clear();
        q.roots(line.sb, line.cb, self.phi_max, tmp);
        let n = tmp.len().min(roots.len());
        roots[..n].copy_from_slice(&tmp[..n]);
        for &phi in &roots[..n] {
            let (sp, cp) = sin_cos_0_pi(phi);
            let Some(h) = self.half_vector(line, sp, cp) else {
                continue;
            };
            if (1.0 - eta * eta) * h[2] * h[2] < self.mu_o * self.mu_o {
                continue; // the spurious branch
            }
            // strictly inside a panel that transmits
            let k = breaks.partition_point(|&b| b < phi);
            if k == 0 || k == breaks.len() || breaks[k] == phi {
                continue;
            }
            let (a, b) = (breaks[k - 1], breaks[k]);
            if !self.is_tir(line, 0.5 * (a + b), eta) {
                out.push(phi);
            }
        }
    }

    /// The sequence of kinds of kink along the line at latitude β (0: reflection horizon,
    /// 1: critical angle, 2: transmission horizon), in increasing φ.
    fn kink_signature(&self, beta: f64, eta: f64, sig: &mut Vec<u8>) {
        let (sb, cb) = beta.sin_cos();
        let line = Line {
            sb,
            cb,
            weight: 0.0,
        };
        let mut scratch = self.scratch.borrow_mut();
        let Scratch {
            tagged,
            tmp,
            xs: breaks,
            roots,
            ..
        } = &mut *scratch;
        tagged.clear();
        tmp.clear();
        if self.part != Part::TransmissionOnly {
            self.horizon.roots(sb, cb, self.phi_max, tmp);
            tagged.extend(tmp.drain(..).map(|p| (p, 0)));
        }
        if let Some(t) = &self.tir {
            t.roots(sb, cb, self.phi_max, tmp);
            tagged.extend(tmp.drain(..).map(|p| (p, 1)));
        }
        if self.transmit_horizon {
            breaks.clear();
            breaks.extend(tagged.iter().map(|t| t.0));
            breaks.push(0.0);
            breaks.push(self.phi_max);
            sort_dedup(breaks);
            self.transmit_roots(&line, eta, breaks, tmp, roots);
            tagged.extend(tmp.drain(..).map(|p| (p, 2)));
        }
        tagged.sort_by(|a, b| a.0.total_cmp(&b.0));
        sig.clear();
        sig.extend(tagged.iter().map(|t| t.1));
    }

    /// Latitudes at which the kinks of a line change topology — zeros appear or merge, cross
    /// the ends of the φ range or cross each other (where the critical-angle curve meets a
    /// horizon): found by scanning β for a change in [`Self::kink_signature`] and bisecting
    /// each change to [`BETA_TOL`]. Needed only when leaving the denser medium, where the
    /// transmission horizon is not a quadratic form and kink curves intersect.
    fn scanned_outer_breaks(&self, eta: f64, out: &mut Vec<f64>) {
        let mut samples: Vec<f64> = (0..=BETA_SCAN)
            .map(|j| FRAC_PI_2 * j as f64 / BETA_SCAN as f64)
            .collect();
        samples.extend(out.iter().copied());
        sort_dedup(&mut samples);
        let mut sigs = vec![Vec::new(); samples.len()];
        for (b, sig) in samples.iter().zip(sigs.iter_mut()) {
            self.kink_signature(*b, eta, sig);
        }
        let mut mid_sig = Vec::with_capacity(8);
        for k in 1..samples.len() {
            if sigs[k] == sigs[k - 1] {
                continue;
            }
            let (mut lo, mut hi) = (samples[k - 1], samples[k]);
            while hi - lo > BETA_TOL {
                let mid = 0.5 * (lo + hi);
                self.kink_signature(mid, eta, &mut mid_sig);
                if mid_sig == sigs[k - 1] {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.push(0.5 * (lo + hi));
        }
    }
}

/// |μi| below which an end of the φ range counts as a horizon zero.
const END_ZERO: f64 = 1e-12;

/// How far from the φ range a complex or outside zero of a kink form still counts as a
/// near-singularity (beyond it Gauss–Legendre converges fast enough at order 12–16 anyway).
const NEAR_REACH: f64 = 0.3;

/// Latitude samples used to find where the kinks of a line change topology.
const BETA_SCAN: usize = 32;
/// Bisection tolerance on such a latitude: far below what the rules resolve.
const BETA_TOL: f64 = 1e-11;

impl Integrand2D for VndfIntegrand {
    type Line = Line;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        let mut panels = Vec::new();
        self.outer_panels(&mut panels);
        out.extend(panels.iter().map(|p| p.a));
        out.extend(panels.last().map(|p| p.b));
    }

    fn line(&self, beta: f64, breaks: &mut Vec<f64>) -> Line {
        let mut panels = Vec::new();
        let line = self.line_panels(beta, &mut panels);
        breaks.extend(panels.iter().map(|p| p.a));
        breaks.extend(panels.last().map(|p| p.b));
        line
    }

    fn outer_panels(&self, out: &mut Vec<Panel>) {
        out.extend_from_slice(self.outer_cache.get_or_init(|| {
            let mut panels = Vec::with_capacity(8);
            self.compute_outer_panels(&mut panels);
            panels
        }));
    }

    fn line_panels(&self, beta: f64, out: &mut Vec<Panel>) -> Line {
        self.compute_line_panels(beta, out)
    }

    #[inline]
    fn eval(&self, line: &Line, phi: f64) -> [f64; CHANNELS] {
        let (sp, cp) = sin_cos_0_pi(phi);
        self.eval_sin_cos(line, sp, cp)
    }

    fn channels(&self) -> usize {
        if self.column.is_empty() {
            CHANNELS
        } else {
            2 * self.column.len()
        }
    }

    fn accumulate_nodes(&self, line: &Line, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        if !self.column.is_empty() {
            for (&v, &w) in vs.iter().zip(ws) {
                self.accumulate(line, v, w, acc);
            }
            return;
        }
        // LANES nodes at a time, stage by stage, so that the independent dependency chains of
        // different nodes (the polynomial sine, square roots, divisions) overlap. Every node
        // gets exactly the arithmetic of [`Integrand2D::eval`], and the sums run in node order:
        // the result is the same to the bit.
        for (vc, wc) in vs.chunks(LANES).zip(ws.chunks(LANES)) {
            let y = self.eval_lanes(line, vc);
            for (yj, &w) in y.iter().zip(wc) {
                acc[0] += w * yj[0];
                acc[1] += w * yj[1];
            }
        }
    }

    fn nonzero_at(&self, line: &Line, vs: &[f64], out: &mut [bool], scratch: &mut [f64]) {
        if !self.column.is_empty() {
            for (o, &v) in out.iter_mut().zip(vs) {
                *o = self.accumulate(line, v, 0.0, scratch);
            }
            return;
        }
        for (vc, oc) in vs.chunks(LANES).zip(out.chunks_mut(LANES)) {
            let y = self.eval_lanes(line, vc);
            for (o, yj) in oc.iter_mut().zip(&y) {
                *o = yj[0] != 0.0 || yj[1] != 0.0;
            }
        }
    }

    #[inline]
    fn accumulate(&self, line: &Line, phi: f64, w: f64, acc: &mut [f64]) -> bool {
        if self.column.is_empty() {
            let y = self.eval(line, phi);
            acc[0] += w * y[0];
            acc[1] += w * y[1];
            return y[0] != 0.0 || y[1] != 0.0;
        }
        // Column mode: the geometry once, then the IOR-dependent factors per cell.
        let (sp, cp) = sin_cos_0_pi(phi);
        let Some(h) = self.half_vector(line, sp, cp) else {
            return false;
        };
        let visible = w * line.weight * (sp * self.cos_v + cp * self.sin_v);
        let c = self.sin_o * h[0] + self.mu_o * h[2];
        let mu_i = 2.0 * c * h[2] - self.mu_o;
        let w_r = if mu_i > 0.0 { self.masking(mu_i) } else { 0.0 };
        self.accumulate_column(c, h[2], visible, w_r, acc)
    }
}

impl VndfIntegrand {
    /// The integrand at up to [`LANES`] points of `line`, stage by stage (all sines, then all
    /// evaluations) so that the nodes' dependency chains overlap; unused lanes hold φ = π/2.
    #[inline(always)]
    fn eval_lanes(&self, line: &Line, vc: &[f64]) -> [[f64; CHANNELS]; LANES] {
        let mut phi = [FRAC_PI_2; LANES];
        phi[..vc.len()].copy_from_slice(vc);
        let (mut sp, mut cp) = ([0.0; LANES], [0.0; LANES]);
        for j in 0..LANES {
            (sp[j], cp[j]) = sin_cos_0_pi(phi[j]);
        }
        let mut y = [[0.0; CHANNELS]; LANES];
        for j in 0..LANES {
            y[j] = self.eval_sin_cos(line, sp[j], cp[j]);
        }
        y
    }

    /// Column mode: adds the IOR-dependent factors of every cell of the column at one normal
    /// (ωo·h = c, height h_z, weight `visible`, reflection masking w_r). The loops over the
    /// column have no branches (selects only) so that they vectorise; each cell gets exactly the
    /// arithmetic of [`fresnel_dielectric`] and [`Self::transmission`].
    #[inline]
    fn accumulate_column(&self, c: f64, h_z: f64, visible: f64, w_r: f64, acc: &mut [f64]) -> bool {
        let n = self.column.len();
        let (acc_pairs, _) = acc.as_chunks_mut::<2>();
        let acc_pairs = &mut acc_pairs[..n];
        match self.lobes {
            Lobes::Glossy { .. } => {
                if w_r == 0.0 {
                    return false;
                }
                let cos_i = c.clamp(0.0, 1.0);
                for (a, &eta) in acc_pairs.iter_mut().zip(&self.column) {
                    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
                    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
                    let f = fresnel_from_cosines(cos_i, cos_t, eta);
                    let f = if !eta.is_finite() || sin2_t >= 1.0 {
                        1.0
                    } else {
                        f
                    };
                    let f = if eta == 1.0 { 0.0 } else { f };
                    a[0] += visible * f * w_r;
                    a[1] += visible * w_r;
                }
                true
            }
            _ => {
                let m = |mu: f64| self.masking(mu);
                for (a, &eta) in acc_pairs.iter_mut().zip(&self.column) {
                    let sin2_t = (1.0 - c * c) / (eta * eta);
                    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
                    let f = fresnel_from_cosines(c, cos_t, eta);
                    let mu_t = -self.mu_o / eta + (c / eta - cos_t) * h_z;
                    let w_t = if mu_t < 0.0 { m(-mu_t) } else { 0.0 };
                    let tir = sin2_t >= 1.0;
                    let (f, w_t) = if tir { (1.0, 0.0) } else { (f, w_t) };
                    a[0] += visible * f * w_r;
                    a[1] += visible * (1.0 - f) * w_t;
                }
                true
            }
        }
    }

    /// The integrand at the normal with (sin φ, cos φ) on `line`.
    #[inline(always)]
    fn eval_sin_cos(&self, line: &Line, sp: f64, cp: f64) -> [f64; CHANNELS] {
        let Some(h) = self.half_vector(line, sp, cp) else {
            return [0.0; CHANNELS];
        };
        // N·V = cos β sin(φ + θv): the clamped-cosine density of visible normals
        let visible = line.weight * (sp * self.cos_v + cp * self.sin_v);
        let c = self.sin_o * h[0] + self.mu_o * h[2]; // ωo·h > 0 for visible normals
        if self.part == Part::TransmissionOnly {
            if let Lobes::Dielectric { eta } = self.lobes {
                let (f, w_t) = self.transmission(c, h[2], eta);
                return [0.0, visible * (1.0 - f) * w_t];
            }
        }
        let mu_i = 2.0 * c * h[2] - self.mu_o; // z of reflect(ωo, h)
        let w_r = if mu_i > 0.0 { self.masking(mu_i) } else { 0.0 }; // horizon
        if self.part == Part::ReflectionOnly {
            if let Lobes::Dielectric { eta } = self.lobes {
                return [visible * fresnel_dielectric(c, eta) * w_r, 0.0];
            }
        }
        match self.lobes {
            Lobes::Conductor => [visible * w_r, 0.0],
            Lobes::Glossy { eta } => {
                let f = fresnel_dielectric(c, eta);
                [visible * f * w_r, visible * w_r]
            }
            Lobes::Dielectric { eta } => {
                let (f, w_t) = self.transmission(c, h[2], eta);
                match self.part {
                    Part::Both => [visible * f * w_r, visible * (1.0 - f) * w_t],
                    Part::ReflectionOnly => [visible * f * w_r, 0.0],
                    Part::TransmissionOnly => [0.0, visible * (1.0 - f) * w_t],
                }
            }
        }
    }

    fn compute_outer_panels(&self, out: &mut Vec<Panel>) {
        // Where kink curves are tangent to a line or cross the ends of the φ range, the inner
        // integral has square-root behaviour in β.
        let mut xs = vec![0.0, FRAC_PI_2];
        if self.part != Part::TransmissionOnly {
            self.horizon.outer_breaks(self.phi_max, &mut xs);
        }
        if let Some(t) = &self.tir {
            t.outer_breaks(self.phi_max, &mut xs);
        }
        sort_dedup(&mut xs);
        if let (Some(tir), Lobes::Dielectric { eta }) = (&self.tir, self.lobes) {
            if self.part == Part::ReflectionOnly {
                // the horizon and the critical-angle curve cross in closed form
                self.horizon.crossings(tir, self.phi_max, &mut xs);
            } else {
                // three kink curves meet: scan for topology changes
                self.scanned_outer_breaks(eta, &mut xs);
            }
            sort_dedup(&mut xs);
        }
        // β = π/2 is a rim too (N_z = cos β sin φ): the stretching map is singular at distance
        // ~α from it, so every break carries that distance.
        let rim = |x: f64| (FRAC_PI_2 - x).hypot(self.alpha);
        let mut breaks: Vec<Break> = xs
            .iter()
            .map(|&x| {
                if x == 0.0 {
                    Break::regular(x)
                } else if x == FRAC_PI_2 {
                    Break::near_singular(x, self.alpha)
                } else {
                    Break::sqrt(x).with_delta(rim(x))
                }
            })
            .collect();
        panels_from_breaks(&mut breaks, out);
    }

    fn compute_line_panels(&self, beta: f64, out: &mut Vec<Panel>) -> Line {
        let (sb, cb) = beta.sin_cos();
        let line = Line {
            sb,
            cb,
            weight: self.norm * cb * cb,
        };
        // Every break also sits near the singularities of the stretching map itself: h ∝
        // (α cos β cos φ, α sin β, cos β sin φ) degenerates at φ ≈ ±iα and φ ≈ π ± iα.
        let a2 = self.alpha * self.alpha;
        let rim = |x: f64| (x * x + a2).sqrt().min(((PI - x) * (PI - x) + a2).sqrt());
        let mut scratch = self.scratch.borrow_mut();
        let Scratch {
            breaks,
            roots,
            near,
            xs,
            tmp,
            ..
        } = &mut *scratch;
        breaks.clear();
        // The ends of the range are horizon zeros themselves at grazing incidence (μo = 0: the
        // rim reflects into the horizon), where the masking weight is near-singular too.
        for end in [0.0, self.phi_max] {
            let mut b = Break::near_singular(end, rim(end));
            if self.reflected_z(&line, end).abs() <= END_ZERO {
                b = b.with_delta(self.near_singular_delta(end, |p| self.reflected_z(&line, p)));
            }
            breaks.push(b);
        }
        roots.clear();
        if self.part != Part::TransmissionOnly {
            self.horizon.roots(sb, cb, self.phi_max, roots);
            for &phi in roots.iter() {
                let delta = self.near_singular_delta(phi, |p| self.reflected_z(&line, p));
                breaks.push(Break::near_singular(phi, delta.min(rim(phi))));
            }
        }
        if let Some(t) = &self.tir {
            roots.clear();
            t.roots(sb, cb, self.phi_max, roots);
            // F has its square root on the transmitting side only (beyond the critical angle
            // F = 1 and nothing is transmitted).
            let eta = match self.lobes {
                Lobes::Dielectric { eta } => eta,
                _ => 1.0,
            };
            breaks.extend(roots.iter().map(|&x| {
                let step = 1e-9 * (1.0 + x);
                let above = !self.is_tir(&line, x + step, eta);
                Break::one_sided_sqrt(x, above).with_delta(rim(x))
            }));
        }
        // Kink curves that pass close by without crossing the line (or cross just outside the
        // range) leave near-singularities: a break at the nearest point, mapped towards it.
        near.clear();
        if self.part != Part::TransmissionOnly {
            self.horizon
                .near_singularities(sb, cb, self.phi_max, NEAR_REACH, near);
        }
        if let Some(t) = &self.tir {
            t.near_singularities(sb, cb, self.phi_max, NEAR_REACH, near);
        }
        breaks.extend(
            near.iter()
                .map(|&(x, d)| Break::near_singular(x, d.max(crate::quadrature::MIN_DELTA))),
        );
        if let (true, Lobes::Dielectric { eta }) = (self.transmit_horizon, self.lobes) {
            xs.clear();
            xs.extend(breaks.iter().map(|b| b.x));
            sort_dedup(xs);
            roots.clear();
            self.transmit_roots(&line, eta, xs, roots, tmp);
            for &phi in roots.iter() {
                let delta = self.near_singular_delta(phi, |p| -self.transmitted_z(&line, p, eta));
                breaks.push(Break::near_singular(phi, delta.min(rim(phi))));
            }
        }
        panels_from_breaks(breaks, out);
        line
    }
}

impl VndfIntegrand {
    /// Fresnel reflectance and the transmitted masking weight at a normal with ωo·h = c and
    /// height h_z, for relative IOR `eta` (F = 1 and no transmission under TIR).
    #[inline]
    fn transmission(&self, c: f64, h_z: f64, eta: f64) -> (f64, f64) {
        let sin2_t = (1.0 - c * c) / (eta * eta);
        if sin2_t >= 1.0 {
            return (1.0, 0.0); // tir
        }
        let cos_t = (1.0 - sin2_t).sqrt();
        let f = fresnel_from_cosines(c, cos_t, eta);
        let mu_t = -self.mu_o / eta + (c / eta - cos_t) * h_z; // z of refract(ωo, h, η)
        let w_t = if mu_t < 0.0 { self.masking(-mu_t) } else { 0.0 };
        (f, w_t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_crossings_match_the_scan() {
        // Leaving glass at grazing-ish incidence: horizon and critical angle cross.
        let lobes = Lobes::Dielectric { eta: 1.0 / 1.5 };
        let f = VndfIntegrand::part(
            0.36,
            0.4,
            SmithForm::HeightCorrelated,
            lobes,
            Part::ReflectionOnly,
        );
        let tir = f.tir.unwrap();
        let mut closed = Vec::new();
        f.horizon.crossings(&tir, f.phi_max, &mut closed);
        let mut all = vec![0.0, FRAC_PI_2];
        f.horizon.outer_breaks(f.phi_max, &mut all);
        tir.outer_breaks(f.phi_max, &mut all);
        let mut scanned = all.clone();
        f.scanned_outer_breaks(1.0 / 1.5, &mut scanned);
        // every crossing found in closed form is a topology change the scan also finds
        for c in &closed {
            assert!(
                scanned.iter().any(|s| (s - c).abs() < 1e-9),
                "crossing {c} not in scan {scanned:?}"
            );
        }
    }

    #[test]
    fn quadratic_forms_match_direct_evaluation() {
        // The horizon form's sign must agree with the sign of μi computed from h.
        let f = VndfIntegrand::new(0.5, 0.3, SmithForm::HeightCorrelated, Lobes::Conductor);
        for &beta in &[0.1, 0.7, 1.3] {
            let (sb, cb) = f64::sin_cos(beta);
            let line = Line {
                sb,
                cb,
                weight: 1.0,
            };
            for j in 1..50 {
                let phi = f.phi_max * j as f64 / 50.0;
                let (sp, cp) = sin_cos_0_pi(phi);
                let h = f.half_vector(&line, sp, cp).unwrap();
                let c = f.sin_o * h[0] + f.mu_o * h[2];
                let mu_i = 2.0 * c * h[2] - f.mu_o;
                let q = f.horizon.value(sb, cb, phi);
                if mu_i.abs() > 1e-9 {
                    assert_eq!(q > 0.0, mu_i > 0.0, "β={beta} φ={phi}");
                }
            }
        }
    }
}
