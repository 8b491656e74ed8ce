//! Quadrature: nested Gauss–Legendre over panels split at the integrand's kinks, with a
//! per-cell error estimate from two rule orders and refinement when it misses the tolerance.
//!
//! A model describes its albedo integral as an [`Integrand2D`]: an outer variable `u` on a list
//! of panels, an inner variable `v` whose panels may depend on `u`, and a vector-valued integrand
//! that includes every Jacobian. Panels end where the integrand has a kink or a jump, so each
//! panel is smooth and Gauss–Legendre converges exponentially on it; the panel maps
//! ([`PanelMap`]) absorb the square-root behaviour that appears where a
//! kink curve is tangent to a line of constant `u`.

pub mod vector;

use crate::math::{exp_poly, UnitRule};

/// Number of channels an integrand carries (e.g. reflection and transmission).
pub const CHANNELS: usize = 2;

/// How a panel's rule is mapped onto it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PanelMap {
    /// Gauss–Legendre mapped affinely: for integrands analytic on a neighbourhood of the panel.
    Plain,
    /// Square-root behaviour at both ends: the map x = 3t² − 2t³ (a Sidi-type sigmoidal map,
    /// Sidi 1993), whose derivative vanishes at both ends.
    Smooth,
    /// Behaviour at the end `at` (the panel's a or b) handled by a substitution x = at ± y(t):
    /// * `sqrt` — square-root behaviour at that end (a kink curve tangent to the line, a critical
    ///   angle): y = L·t²(2 − t) makes √y analytic in t (see `sqrt_map`);
    /// * `delta` — a complex singularity at distance δ from that end (near-singular): the sinh
    ///   map y = δ·sinh(w) (Johnston & Elliott 2005, "A sinh transformation for evaluating nearly
    ///   singular boundary element integrals") moves it to distance π/2 in w whatever δ. Long
    ///   w-ranges (many decades between δ and L) are covered in pieces of at most
    ///   [`SINH_MAX_SPAN`], each with the full rule, which amounts to geometric grading.
    ///
    /// Both together compose: y = δ·sinh(W·t²(2 − t)) on the first piece. With `beyond` the
    /// singularity lies on the real axis behind `at` (y = −δ), which the map leaves at distance π
    /// from the w-axis rather than π/2 (sinh w = −1 at w = ±asinh 1 + iπ), so the pieces may be
    /// twice as long ([`SINH_MAX_SPAN_BEYOND`]).
    End {
        at: f64,
        toward: f64,
        sqrt: bool,
        delta: f64,
        beyond: bool,
    },
}

/// One panel [a, b] and its map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Panel {
    pub a: f64,
    pub b: f64,
    pub map: PanelMap,
}

/// A breakpoint and what the integrand does next to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Break {
    pub x: f64,
    /// Square-root behaviour on the side below x.
    pub sqrt_below: bool,
    /// Square-root behaviour on the side above x.
    pub sqrt_above: bool,
    /// Distance to the nearest complex singularity of the integrand on the side below x and on
    /// the side above it (∞ if none is known; the two differ where the integrand on one side
    /// is analytic and the other side's continuation is not).
    pub delta_below: f64,
    pub delta_above: f64,
    /// Whether that side's nearest singularity lies on the real axis on the *other* side of x,
    /// at distance δ behind the break (a branch point of the neighbouring region's continuation)
    /// rather than beside the panel.
    pub beyond_below: bool,
    pub beyond_above: bool,
}

impl Break {
    pub fn regular(x: f64) -> Break {
        Break {
            x,
            sqrt_below: false,
            sqrt_above: false,
            delta_below: f64::INFINITY,
            delta_above: f64::INFINITY,
            beyond_below: false,
            beyond_above: false,
        }
    }
    /// Square-root behaviour on both sides.
    pub fn sqrt(x: f64) -> Break {
        Break {
            sqrt_below: true,
            sqrt_above: true,
            ..Break::regular(x)
        }
    }
    /// Square-root behaviour on one side only (e.g. a critical angle, beyond which F = 1).
    pub fn one_sided_sqrt(x: f64, above: bool) -> Break {
        Break {
            sqrt_below: !above,
            sqrt_above: above,
            ..Break::regular(x)
        }
    }
    pub fn near_singular(x: f64, delta: f64) -> Break {
        Break::regular(x).with_delta(delta)
    }
    /// Also near-singular at distance `delta` on both sides (keeps the smaller of the two).
    pub fn with_delta(self, delta: f64) -> Break {
        self.with_delta_on(false, delta).with_delta_on(true, delta)
    }
    /// Also near-singular at distance `delta` on one side only.
    pub fn with_delta_on(self, above: bool, delta: f64) -> Break {
        self.with_singularity(above, delta, false)
    }
    /// Also near-singular on one side, from a singularity on the real axis at distance `delta`
    /// behind the break (see [`PanelMap::End`]).
    pub fn with_delta_beyond(self, above: bool, delta: f64) -> Break {
        self.with_singularity(above, delta, true)
    }
    /// A singularity at distance `delta` seen from the side `above`, kept if it is the nearest.
    fn with_singularity(mut self, above: bool, delta: f64, beyond: bool) -> Break {
        let (d, b) = if above {
            (&mut self.delta_above, &mut self.beyond_above)
        } else {
            (&mut self.delta_below, &mut self.beyond_below)
        };
        if delta < *d {
            *d = delta;
            *b = beyond;
        }
        self
    }
    /// The smaller of the two distances.
    pub fn delta(&self) -> f64 {
        self.delta_below.min(self.delta_above)
    }
    fn any_sqrt(&self) -> bool {
        self.sqrt_below || self.sqrt_above
    }
}

/// Breaks closer than this are one break (both variables are angles of order one; root finders
/// and bisections place breaks to ~1e-13).
pub const MERGE_TOL: f64 = 1e-11;

/// Smallest δ a near-singular end is mapped for: a feature narrower than this changes an
/// integral of order one by less than the tolerances furnace works to, and a smaller δ would only
/// add sinh pieces.
pub const MIN_DELTA: f64 = 1e-7;

/// A near-singular end is mapped only when δ is below this fraction of its (half) panel.
pub const NEAR_SINGULAR_RATIO: f64 = 0.5;

/// Longest w-range one rule covers under the sinh map (see [`PanelMap::End`]).
pub const SINH_MAX_SPAN: f64 = 3.0;

/// Longest w-range one rule covers under the sinh map when the singularity lies on the real axis
/// behind the mapped end (`beyond` in [`PanelMap::End`]): the same ratio of piece to strip.
pub const SINH_MAX_SPAN_BEYOND: f64 = 2.0 * SINH_MAX_SPAN;

/// The map an end needs on a panel (or half panel) of length `len` lying on its side
/// `toward`, if any.
fn end_map(b: &Break, toward: f64, len: f64) -> Option<PanelMap> {
    let (sqrt, delta, beyond) = if toward > b.x {
        (b.sqrt_above, b.delta_above, b.beyond_above)
    } else {
        (b.sqrt_below, b.delta_below, b.beyond_below)
    };
    let near = delta < NEAR_SINGULAR_RATIO * len;
    (sqrt || near).then_some(PanelMap::End {
        at: b.x,
        toward,
        sqrt,
        delta: if near { delta } else { f64::INFINITY },
        beyond: near && beyond,
    })
}

/// Sorts `breaks`, merges coincident ones in place (keeping the more singular behaviour) and appends the
/// panels between them. A panel with one special end is mapped towards it; a panel with two is
/// split at its midpoint so that each half is mapped towards its own end.
pub fn panels_from_breaks(breaks: &mut [Break], out: &mut Vec<Panel>) {
    panels_between(breaks, out, false)
}

/// [`panels_from_breaks`] for breaks that are all singular on the real axis or on lines
/// perpendicular to it through the breaks: a square-root break next to another break is then
/// near-singular at the other's branch point, behind it on the real axis (`beyond`).
pub fn panels_from_breaks_real(breaks: &mut [Break], out: &mut Vec<Panel>) {
    panels_between(breaks, out, true)
}

fn panels_between(breaks: &mut [Break], out: &mut Vec<Panel>, real: bool) {
    // (callers mostly pass them sorted: a check is cheaper than the sort's own)
    if !breaks.is_sorted_by(|p, q| p.x.total_cmp(&q.x).is_le()) {
        breaks.sort_by(|p, q| p.x.total_cmp(&q.x));
    }
    // merge in place
    let mut n = 0;
    for i in 0..breaks.len() {
        let b = breaks[i];
        if n > 0 && (b.x - breaks[n - 1].x).abs() <= MERGE_TOL {
            let last = &mut breaks[n - 1];
            last.sqrt_below |= b.sqrt_below;
            last.sqrt_above |= b.sqrt_above;
            *last = last
                .with_singularity(false, b.delta_below, b.beyond_below)
                .with_singularity(true, b.delta_above, b.beyond_above);
        } else {
            breaks[n] = b;
            n += 1;
        }
    }
    let merged = &mut breaks[..n];
    // Singularities of other breaks are near this one too: a square-root point is itself a
    // singularity, a near-singular break has one at complex distance δ from it; so break k is
    // near-singular at least at min_j hypot(x_j − x_k, δ_j) (0 for square roots; δ_j of the
    // side of j that faces k). On the stack for the usual handful of breaks (this runs once
    // per quadrature line).
    const STACK: usize = 12;
    let mut own_stack = [(0.0, 0.0, 0.0); STACK];
    let mut own_heap = Vec::new();
    let own: &mut [(f64, f64, f64)] = if n <= STACK {
        &mut own_stack[..n]
    } else {
        own_heap.resize(n, (0.0, 0.0, 0.0));
        &mut own_heap
    };
    for (o, b) in own.iter_mut().zip(merged.iter()) {
        *o = if b.any_sqrt() {
            (b.x, 0.0, 0.0)
        } else {
            (b.x, b.delta_below, b.delta_above)
        };
    }
    for (k, b) in merged.iter_mut().enumerate() {
        // the smallest squared distance, then one square root: the same bits as the smallest
        // of the distances (a correctly rounded square root is monotone), with one square root
        // per break instead of one per pair
        let mut near2 = f64::INFINITY;
        let mut real_at = f64::NAN;
        for (j, &(x, below, above)) in own.iter().enumerate() {
            let d = if x < b.x { above } else { below };
            if j != k && d.is_finite() {
                let d2 = (x - b.x) * (x - b.x) + d * d;
                if d2 < near2 {
                    near2 = d2;
                    real_at = if real && d == 0.0 { x } else { f64::NAN };
                }
            }
        }
        let near = near2.sqrt();
        *b = b
            .with_singularity(false, near, real_at > b.x)
            .with_singularity(true, near, real_at < b.x);
        b.delta_below = b.delta_below.max(MIN_DELTA);
        b.delta_above = b.delta_above.max(MIN_DELTA);
    }
    for w in merged.windows(2) {
        let (l, r) = (w[0], w[1]);
        if r.x <= l.x {
            continue;
        }
        let len = r.x - l.x;
        match (end_map(&l, r.x, len), end_map(&r, l.x, len)) {
            (
                Some(PanelMap::End {
                    sqrt: true,
                    delta: dl,
                    ..
                }),
                Some(PanelMap::End {
                    sqrt: true,
                    delta: dr,
                    ..
                }),
            ) if dl.is_infinite() && dr.is_infinite() => {
                // Square-root behaviour at both ends and nothing else: one panel, cubic map.
                out.push(Panel {
                    a: l.x,
                    b: r.x,
                    map: PanelMap::Smooth,
                });
            }
            (Some(ml), Some(mr)) => {
                let mid = 0.5 * (l.x + r.x);
                let ml = end_map(&l, mid, 0.5 * len).unwrap_or(ml);
                let mr = end_map(&r, mid, 0.5 * len).unwrap_or(mr);
                out.push(Panel {
                    a: l.x,
                    b: mid,
                    map: retarget(ml, mid),
                });
                out.push(Panel {
                    a: mid,
                    b: r.x,
                    map: retarget(mr, mid),
                });
            }
            (Some(m), None) | (None, Some(m)) => out.push(Panel {
                a: l.x,
                b: r.x,
                map: m,
            }),
            (None, None) => out.push(Panel {
                a: l.x,
                b: r.x,
                map: PanelMap::Plain,
            }),
        }
    }
}

fn retarget(map: PanelMap, toward: f64) -> PanelMap {
    match map {
        PanelMap::End {
            at,
            sqrt,
            delta,
            beyond,
            ..
        } => PanelMap::End {
            at,
            toward,
            sqrt,
            delta,
            beyond,
        },
        m => m,
    }
}

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

    /// How many channels [`Self::accumulate`] writes (default [`CHANNELS`]).
    fn channels(&self) -> usize {
        CHANNELS
    }
    /// Adds `w` times the integrand at (line, v) to `acc` (length [`Self::channels`]) and says
    /// whether the integrand is non-zero there. Integrands with many channels (a whole column of
    /// a table sharing one geometry) override it; the default calls [`Self::eval`].
    #[inline]
    fn accumulate(&self, line: &Self::Line, v: f64, w: f64, acc: &mut [f64]) -> bool {
        let y = self.eval(line, v);
        for k in 0..CHANNELS {
            acc[k] += w * y[k];
        }
        y.iter().any(|&c| c != 0.0)
    }

    /// Adds Σ_j ws[j]·f(line, vs[j]) to `acc`, node by node in order. Integrands whose
    /// evaluation is one long dependency chain (divisions, square roots, a polynomial sine)
    /// override it to evaluate several nodes side by side with the same arithmetic per node, so
    /// that the result is the same to the bit and only faster.
    fn accumulate_nodes(&self, line: &Self::Line, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        for (&v, &w) in vs.iter().zip(ws) {
            self.accumulate(line, v, w, acc);
        }
    }

    /// Adds the integral along `line` over its inner `panels` (every one active) at the inner
    /// rules `rule` to `acc`: by default each panel's nodes ([`DimRules::nodes_into`], into the
    /// buffers `vs` and `ws`) through [`Self::accumulate_nodes`], one panel after the other.
    /// Integrands whose panels are too short to fill the vector unit override it to evaluate
    /// the nodes of several panels side by side, each panel still summed on its own in node
    /// order, so that the result is the same to the bit.
    fn accumulate_line(
        &self,
        line: &Self::Line,
        panels: &[Panel],
        rule: &DimRules,
        vs: &mut Vec<f64>,
        ws: &mut Vec<f64>,
        acc: &mut [f64],
    ) {
        for seg in panels {
            vs.clear();
            ws.clear();
            rule.nodes_into(seg, vs, ws);
            self.accumulate_nodes(line, vs, ws, acc);
        }
    }

    /// Whether the outer variable converges so much faster than the inner one that the outer
    /// rule may use [`lean_order`] points instead of the full order (see [`Rules::outer_lean`]).
    fn lean_outer(&self) -> bool {
        false
    }

    /// Whether every inner panel carries a non-zero integrand (panels end at the support's
    /// boundary, as in a parametrisation whose lines stop at a horizon): then the activity
    /// test of [`integrate_2d_into`], one evaluation per panel and line, is skipped.
    fn panels_all_active(&self) -> bool {
        false
    }

    /// Whether the integrand is non-zero at each point `vs[j]` of `line` (into `out[j]`); by
    /// default [`Self::accumulate`] with weight 0 into `scratch` (length [`Self::channels`]).
    fn nonzero_at(&self, line: &Self::Line, vs: &[f64], out: &mut [bool], scratch: &mut [f64]) {
        for (o, &v) in out.iter_mut().zip(vs) {
            *o = self.accumulate(line, v, 0.0, scratch);
        }
    }

    /// Outer panels with their maps; by default every break of [`Self::outer_breaks`] is
    /// treated as a square-root point (safe whatever the behaviour there).
    fn outer_panels(&self, out: &mut Vec<Panel>) {
        let mut b = Vec::with_capacity(8);
        self.outer_breaks(&mut b);
        smooth_panels(&b, out);
    }
    /// The line at `u` and its inner panels; by default every break of [`Self::line`] is
    /// treated as a square-root point.
    fn line_panels(&self, u: f64, out: &mut Vec<Panel>) -> Self::Line {
        let mut b = Vec::with_capacity(8);
        let line = self.line(u, &mut b);
        smooth_panels(&b, out);
        line
    }
}

fn smooth_panels(breaks: &[f64], out: &mut Vec<Panel>) {
    for w in breaks.windows(2) {
        if w[1] > w[0] {
            let (l, r) = (Break::sqrt(w[0]), Break::sqrt(w[1]));
            panels_from_breaks(&mut [l, r], out);
        }
    }
}

/// One dimension's rules at one order.
#[derive(Clone, Debug)]
pub struct DimRules {
    pub plain: UnitRule,
    pub smooth: UnitRule,
}

impl DimRules {
    fn new(order: usize) -> DimRules {
        DimRules {
            plain: UnitRule::gauss_legendre(order),
            smooth: UnitRule::gauss_legendre_smoothed(order),
        }
    }

    /// Appends the nodes of `panel` to `xs` and their weights (the map's Jacobian included) to
    /// `ws`. Each map is a loop without calls or branches over the rule's nodes, so that it
    /// vectorises.
    #[inline]
    pub fn nodes_into(&self, panel: &Panel, xs: &mut Vec<f64>, ws: &mut Vec<f64>) {
        let map = self.map(panel);
        let start = xs.len();
        let n = map.len();
        xs.resize(start + n, 0.0);
        ws.resize(start + n, 0.0);
        map.fill_dispatch(&mut xs[start..], &mut ws[start..]);
    }

    /// How the rule is placed on `panel` ([`NodeMap::fill`] writes the nodes): the one
    /// logarithm a sinh-mapped end takes is here, the per-node arithmetic there.
    #[inline]
    pub fn map<'a>(&'a self, panel: &Panel) -> NodeMap<'a> {
        let (a, b) = (panel.a, panel.b);
        match panel.map {
            PanelMap::Plain => NodeMap::Affine {
                rule: &self.plain,
                a,
                b,
            },
            PanelMap::Smooth => NodeMap::Affine {
                rule: &self.smooth,
                a,
                b,
            },
            PanelMap::End {
                at,
                toward,
                sqrt,
                delta,
                beyond,
            } => {
                let rule = &self.plain;
                let len = (toward - at).abs();
                let sign = if toward > at { 1.0 } else { -1.0 };
                let (lo, hi) = (a.min(b), a.max(b));
                if delta.is_finite() {
                    // y = δ·sinh(w), w ∈ [0, W], in pieces; the first piece quadratic in t if sqrt.
                    let span = crate::math::asinh_pos(len / delta);
                    let max_span = if beyond {
                        SINH_MAX_SPAN_BEYOND
                    } else {
                        SINH_MAX_SPAN
                    };
                    let pieces = (span / max_span).ceil().max(1.0) as usize;
                    let dw = span / pieces as f64;
                    NodeMap::Sinh {
                        rule,
                        map: SinhPieces {
                            at,
                            sign,
                            delta,
                            lo,
                            hi,
                            dw,
                            pieces,
                            sqrt,
                        },
                    }
                } else {
                    NodeMap::Sqrt {
                        rule,
                        at,
                        sign,
                        len,
                    }
                }
            }
        }
    }
}

/// The rule of one panel as placed by its [`PanelMap`] ([`DimRules::map`]).
pub enum NodeMap<'a> {
    /// x = a + (b − a)·t.
    Affine { rule: &'a UnitRule, a: f64, b: f64 },
    /// y = L·t²(2 − t) from `at` (see [`sqrt_map`]).
    Sqrt {
        rule: &'a UnitRule,
        at: f64,
        sign: f64,
        len: f64,
    },
    /// The sinh map in pieces.
    Sinh { rule: &'a UnitRule, map: SinhPieces },
}

impl NodeMap<'_> {
    /// How many nodes the panel has.
    #[inline(always)]
    pub fn len(&self) -> usize {
        match self {
            NodeMap::Affine { rule, .. } | NodeMap::Sqrt { rule, .. } => rule.nodes.len(),
            NodeMap::Sinh { rule, map } => rule.nodes.len() * map.pieces,
        }
    }

    /// Whether the panel has no nodes (a rule of order 0).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Writes the nodes into `xs` and their weights (the map's Jacobian included) into `ws`,
    /// both of length [`Self::len`]: loops without calls or branches, inlined into the caller
    /// (a [`vector::Kernel`] compiles them for its vector unit; the operations, and so the bits,
    /// are the same on every unit).
    #[inline(always)]
    pub fn fill(&self, xs: &mut [f64], ws: &mut [f64]) {
        match self {
            NodeMap::Affine { rule, a, b } => {
                let (a, b) = (*a, *b);
                for ((x, w), (&t, &wt)) in xs
                    .iter_mut()
                    .zip(ws.iter_mut())
                    .zip(rule.nodes.iter().zip(&rule.weights))
                {
                    *x = a + (b - a) * t;
                    *w = wt * (b - a);
                }
            }
            NodeMap::Sqrt {
                rule,
                at,
                sign,
                len,
            } => {
                let (at, sign, len) = (*at, *sign, *len);
                for ((x, w), (&t, &wt)) in xs
                    .iter_mut()
                    .zip(ws.iter_mut())
                    .zip(rule.nodes.iter().zip(&rule.weights))
                {
                    let (q, dq) = sqrt_map(t);
                    *x = at + sign * len * q;
                    *w = wt * len * dq;
                }
            }
            NodeMap::Sinh { rule, map } => map.fill(&rule.nodes, &rule.weights, xs, ws),
        }
    }

    /// [`Self::fill`], the sinh map on the widest vector unit ([`vector::run`]).
    #[inline]
    fn fill_dispatch(&self, xs: &mut [f64], ws: &mut [f64]) {
        match self {
            NodeMap::Sinh { rule, map } => map.fill_dispatch(&rule.nodes, &rule.weights, xs, ws),
            _ => self.fill(xs, ws),
        }
    }
}

/// The pieces of a sinh-mapped end (see [`PanelMap::End`]): node x = at + sign·δ·sinh(w),
/// w = dw·(k + q(t)) on piece k, q(t) = t except on the first piece of a square-root end.
pub struct SinhPieces {
    at: f64,
    sign: f64,
    delta: f64,
    lo: f64,
    hi: f64,
    dw: f64,
    pieces: usize,
    sqrt: bool,
}

impl SinhPieces {
    /// Writes the `pieces·n` nodes and weights: e^w = e^{k·dw}·e^{dw·q}, the first factor
    /// carried from piece to piece, the second a polynomial exponential per node ([`exp_poly`]),
    /// e^−w by one division.
    #[inline(always)]
    fn fill(&self, nodes: &[f64], weights: &[f64], xs: &mut [f64], ws: &mut [f64]) {
        let n = nodes.len();
        let (dw, delta) = (self.dw, self.delta);
        let step = exp_poly(dw);
        let mut piece_exp = 1.0;
        for k in 0..self.pieces {
            let (xk, wk) = (&mut xs[k * n..(k + 1) * n], &mut ws[k * n..(k + 1) * n]);
            let first_sqrt = self.sqrt && k == 0;
            for (((x, w), &t), &wt) in xk.iter_mut().zip(wk.iter_mut()).zip(nodes).zip(weights) {
                let (q, dq) = if first_sqrt { sqrt_map(t) } else { (t, 1.0) };
                let e = piece_exp * exp_poly(dw * q);
                let inv = 1.0 / e;
                let (sinh, cosh) = (0.5 * (e - inv), 0.5 * (e + inv));
                *x = (self.at + self.sign * delta * sinh)
                    .max(self.lo)
                    .min(self.hi);
                *w = wt * dw * dq * delta * cosh;
            }
            piece_exp *= step;
        }
    }

    /// [`Self::fill`] on the widest vector unit ([`vector::run`]): the same bits on every machine.
    fn fill_dispatch(&self, nodes: &[f64], weights: &[f64], xs: &mut [f64], ws: &mut [f64]) {
        struct Fill<'a> {
            map: &'a SinhPieces,
            nodes: &'a [f64],
            weights: &'a [f64],
            xs: &'a mut [f64],
            ws: &'a mut [f64],
        }
        impl vector::Kernel for Fill<'_> {
            type Output = ();
            #[inline(always)]
            fn run(&mut self) {
                self.map.fill(self.nodes, self.weights, self.xs, self.ws)
            }
        }
        vector::run(Fill {
            map: self,
            nodes,
            weights,
            xs,
            ws,
        })
    }
}

/// q(t) and q'(t) of the square-root substitution y = L·q(t), q = t²(2 − t): quadratic at the
/// break (so √y is analytic in t), with slope 1 rather than 2 at the far end, so that the far
/// half of the panel keeps the node density of a plain rule instead of half of it. Against
/// q = t² this takes 4 % (conductor 64²), 9 % (leaving dielectric 16³) and 11 % (entering
/// dielectric 16³) fewer instructions at the same tolerance, because fewer cells miss the
/// estimate at the companion order (callgrind, `furnace tabulate`, errors against an order-24 table).
#[inline]
fn sqrt_map(t: f64) -> (f64, f64) {
    (t * t * (2.0 - t), t * (4.0 - 3.0 * t))
}

/// The rules used for one evaluation.
#[derive(Clone, Debug)]
pub struct Rules {
    /// The larger of the two orders (the one an estimate reports).
    pub order: usize,
    pub outer: DimRules,
    pub inner: DimRules,
    /// The outer rule at [`lean_order`] of the outer order, for integrands whose outer variable
    /// converges much faster than the inner one ([`Integrand2D::lean_outer`]).
    pub outer_lean: DimRules,
}

impl Rules {
    pub fn new(order: usize) -> Rules {
        Rules::with_orders(order, order)
    }

    /// Different orders in the two dimensions (for convergence studies).
    pub fn with_orders(outer: usize, inner: usize) -> Rules {
        let (outer, inner) = (outer.max(1), inner.max(1));
        Rules {
            order: outer.max(inner),
            outer: DimRules::new(outer),
            inner: DimRules::new(inner),
            outer_lean: DimRules::new(lean_order(outer)),
        }
    }
}

/// The outer order a lean-outer integrand uses at `order`: 5·order/6 rounded to the nearest
/// integer (12 → 10, 9 → 8, 15 → 13, 19 → 16), so that the estimate still compares two orders
/// in both dimensions.
pub fn lean_order(order: usize) -> usize {
    ((5 * order + 3) / 6).max(1)
}

/// Nested product rule over all panels.
pub fn integrate_2d<I: Integrand2D>(f: &I, rules: &Rules) -> [f64; CHANNELS] {
    let mut total = [0.0; CHANNELS];
    integrate_2d_into(f, rules, &mut total);
    total
}

/// Nested product rule over all panels, into `total` (length `f.channels()`, zeroed here).
pub fn integrate_2d_into<I: Integrand2D>(f: &I, rules: &Rules, total: &mut [f64]) {
    // the buffers of the thread's previous call (a call nested in an integrand takes new ones)
    BUFFERS.with(|b| match b.try_borrow_mut() {
        Ok(mut b) => integrate_with(f, rules, total, &mut b),
        Err(_) => integrate_with(f, rules, total, &mut Buffers::default()),
    })
}

/// The working storage of [`integrate_2d_into`], reused by a thread's calls: every entry a call
/// reads is one it wrote, so results do not depend on what a previous call left.
#[derive(Default)]
struct Buffers {
    scratch: Vec<f64>,
    line_sum: Vec<f64>,
    outer: Vec<Panel>,
    inner: Vec<Panel>,
    vs: Vec<f64>,
    ws: Vec<f64>,
    us: Vec<f64>,
    wus: Vec<f64>,
    mids: Vec<f64>,
    active: Vec<bool>,
}

thread_local! {
    static BUFFERS: std::cell::RefCell<Buffers> = std::cell::RefCell::new(Buffers::default());
}

fn integrate_with<I: Integrand2D>(f: &I, rules: &Rules, total: &mut [f64], buf: &mut Buffers) {
    let Buffers {
        scratch,
        line_sum,
        outer,
        inner,
        vs,
        ws,
        us,
        wus,
        mids,
        active,
    } = buf;
    let n = f.channels();
    total.iter_mut().for_each(|t| *t = 0.0);
    scratch.clear();
    scratch.resize(n, 0.0);
    line_sum.clear();
    line_sum.resize(n, 0.0);
    outer.clear();
    f.outer_panels(outer);
    // A panel between kinks on which the integrand vanishes at the midpoint vanishes throughout
    // (kinks are its only way to switch on); likewise an outer panel whose middle line vanishes
    // at every inner midpoint (e.g. beyond the latitude where the reflection horizon closes).
    let all_active = f.panels_all_active();
    let mut activity =
        |line: &I::Line, inner: &[Panel], mids: &mut Vec<f64>, active: &mut Vec<bool>| {
            if all_active {
                active.clear();
                active.resize(inner.len(), true);
                return;
            }
            mids.clear();
            mids.extend(inner.iter().map(|seg| 0.5 * (seg.a + seg.b)));
            active.clear();
            active.resize(mids.len(), false);
            f.nonzero_at(line, mids, active, scratch);
        };
    for panel in outer.iter() {
        if !all_active {
            inner.clear();
            let mid_line = f.line_panels(0.5 * (panel.a + panel.b), inner);
            activity(&mid_line, inner, mids, active);
            if !active.iter().any(|&a| a) {
                continue;
            }
        }
        let outer_rules = if f.lean_outer() {
            &rules.outer_lean
        } else {
            &rules.outer
        };
        // the outer rule's nodes and weights on this panel
        us.clear();
        wus.clear();
        outer_rules.nodes_into(panel, us, wus);
        for (&u, &wu) in us.iter().zip(wus.iter()) {
            inner.clear();
            let line = f.line_panels(u, inner);
            line_sum.iter_mut().for_each(|t| *t = 0.0);
            if all_active {
                f.accumulate_line(&line, inner, &rules.inner, vs, ws, line_sum);
            } else {
                activity(&line, inner, mids, active);
                for (seg, _) in inner.iter().zip(active.iter()).filter(|(_, a)| **a) {
                    vs.clear();
                    ws.clear();
                    rules.inner.nodes_into(seg, vs, ws);
                    f.accumulate_nodes(&line, vs, ws, line_sum);
                }
            }
            for k in 0..n {
                total[k] += wu * line_sum[k];
            }
        }
    }
}

/// Quadrature settings of a table or an evaluation: the base order per panel and dimension,
/// the lower order whose difference from it is the error estimate, the per-cell tolerance on that
/// estimate, and the highest order refinement may reach.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct QuadratureSettings {
    /// Gauss–Legendre points per panel and dimension.
    pub order: usize,
    /// The lower order of the error estimate |Q(order) − Q(companion)|. Since the rules converge
    /// geometrically, the estimate is of the error of Q(companion): conservative for Q(order).
    pub companion: usize,
    /// A cell whose estimate exceeds this is recomputed at a higher order ([`next_order`]),
    /// estimated against the previous one.
    pub tolerance: f64,
    /// Refinement stops here; a cell still above tolerance is reported, never hidden.
    pub max_order: usize,
}

impl Default for QuadratureSettings {
    fn default() -> Self {
        QuadratureSettings::with_order(DEFAULT_ORDER)
    }
}

/// Default base order. With the panel maps above the bare order-12 rule is within 2.4e-8
/// (conductor) and 9.5e-10 (entering dielectric) of the reference albedos, and
/// |Q(12) − Q(9)| ≤ 1e-7 holds for 77 % of the cells of a 1024² conductor table and 95 % of a
/// 128³ entering dielectric one (90 % leaving), the rest being refined (`furnace bench tabulate`, `furnace tabulate`;
/// see docs/quadrature.md).
pub const DEFAULT_ORDER: usize = 12;

impl QuadratureSettings {
    /// `order` with companion ⌈3·order/4⌉, tolerance 1e-7 and refinement up to 8·order.
    pub fn with_order(order: usize) -> QuadratureSettings {
        QuadratureSettings {
            order,
            companion: (3 * order).div_ceil(4).max(1),
            tolerance: 1e-7,
            max_order: (8 * order).min(MAX_ORDER),
        }
    }

    /// Every order [`estimate`] may use: companion, order, 2·order, … up to max_order.
    pub fn orders(&self) -> Vec<usize> {
        let mut v = vec![self.companion, self.order];
        let mut o = self.order;
        while next_order(o) <= self.max_order {
            o = next_order(o);
            v.push(o);
        }
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Refuses settings no rule can honour.
    pub fn validate(&self) -> Result<(), String> {
        if self.order < 2 || self.order > MAX_ORDER {
            return Err(format!(
                "quadrature order {} is outside [2, {MAX_ORDER}]",
                self.order
            ));
        }
        if self.companion < 1 || self.companion >= self.order {
            return Err(format!(
                "companion order {} must be at least 1 and below the order {}",
                self.companion, self.order
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(format!(
                "tolerance {} must be a positive finite number, e.g. 1e-7",
                self.tolerance
            ));
        }
        if self.max_order < self.order || self.max_order > MAX_ORDER {
            return Err(format!(
                "max order {} must lie in [order = {}, {MAX_ORDER}]",
                self.max_order, self.order
            ));
        }
        Ok(())
    }
}

/// The order refinement tries after `order`: ×1.25 (12 → 15 → 19 → …). The previous order is the
/// new estimate's companion, so after the first step the estimate measures the error of the
/// base order itself, which the panel structure makes small: on a 256² conductor table 37 % of
/// the cells miss the tolerance on |Q(12) − Q(9)|, and refining them ×1.25 instead of ×1.5
/// (Q(15) instead of Q(18)) takes 7 % fewer instructions for the whole table (callgrind).
pub fn next_order(order: usize) -> usize {
    (5 * order).div_ceil(4)
}

/// The largest order accepted anywhere (rules are built once per order; beyond this the panel
/// structure, not the order, is what is wrong).
pub const MAX_ORDER: usize = 1024;

/// A value with its error estimate.
#[derive(Clone, Copy, Debug)]
pub struct Estimate<const N: usize> {
    pub value: [f64; N],
    /// max over channels of |Q(order) − Q(lower order)|: conservative, it estimates the error
    /// of the lower-order result while `value` is the higher-order one.
    pub error: f64,
    /// The order that met the tolerance (or the highest tried if none did).
    pub order: usize,
    /// False when even `max_order` left the estimate above the tolerance.
    pub converged: bool,
}

/// Error estimates of a batch of points from their values at the companion (`low`) and base
/// (`high`) orders: a point whose |high − low| (max over channels) exceeds the tolerance is
/// recomputed at the next order ([`next_order`]) and estimated against its previous value,
/// until it meets the tolerance or `max_order` is reached. `eval(open, rules, out)` integrates
/// the points `open` (indices into the batch, ascending) with `rules` into `out` (one entry
/// per open point), so that points sharing work (a column of a table) are refined together.
/// This is the one refinement loop: single points and table columns both go through it.
pub fn refine<const N: usize>(
    settings: &QuadratureSettings,
    cache: &RuleCache,
    low: &[[f64; N]],
    high: &[[f64; N]],
    mut eval: impl FnMut(&[usize], &Rules, &mut [[f64; N]]),
) -> Vec<Estimate<N>> {
    let difference = |a: &[f64; N], b: &[f64; N]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    let mut out: Vec<Estimate<N>> = low
        .iter()
        .zip(high)
        .map(|(l, h)| {
            let error = difference(h, l);
            Estimate {
                value: *h,
                error,
                order: settings.order,
                converged: error <= settings.tolerance,
            }
        })
        .collect();
    let mut order = settings.order;
    let (mut open, mut next) = (Vec::new(), Vec::new());
    loop {
        open.clear();
        open.extend((0..out.len()).filter(|&k| !out[k].converged));
        if open.is_empty() || next_order(order) > settings.max_order {
            return out;
        }
        order = next_order(order);
        next.clear();
        next.resize(open.len(), [0.0; N]);
        eval(&open, cache.get(order), &mut next);
        for (&k, v) in open.iter().zip(&next) {
            let error = difference(v, &out[k].value);
            out[k] = Estimate {
                value: *v,
                error,
                order,
                converged: error <= settings.tolerance,
            };
        }
    }
}

/// [`refine`] for one value: `f` at the companion and base orders, then at higher orders while
/// the estimate exceeds the tolerance.
pub fn estimate<const N: usize>(
    settings: &QuadratureSettings,
    cache: &RuleCache,
    mut f: impl FnMut(&Rules) -> [f64; N],
) -> Estimate<N> {
    let low = f(cache.get(settings.companion));
    let high = f(cache.get(settings.order));
    refine(settings, cache, &[low], &[high], |_, rules, out| {
        out[0] = f(rules)
    })
    .remove(0)
}

/// Rules for every order a tabulation may need, built once.
#[derive(Debug)]
pub struct RuleCache {
    rules: Vec<Rules>,
}

impl RuleCache {
    pub fn new(settings: &QuadratureSettings) -> RuleCache {
        RuleCache {
            rules: settings.orders().into_iter().map(Rules::new).collect(),
        }
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

    #[test]
    fn the_tolerance_must_be_positive_and_finite() {
        let mut q = QuadratureSettings::default();
        assert!(q.validate().is_ok());
        for t in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            q.tolerance = t;
            let e = q.validate().unwrap_err();
            assert!(e.contains("must be a positive finite number"), "{e}");
        }
    }

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

    /// An integrand whose value is itself a 2-D integral: the inner call cannot take the
    /// thread's buffers the outer one holds and takes its own; the result is the product of the
    /// two integrals, the same bits call after call, and a call after a larger one (more nodes)
    /// reads nothing the larger one left.
    struct Nested;
    impl Integrand2D for Nested {
        type Line = f64;
        fn outer_breaks(&self, out: &mut Vec<f64>) {
            out.extend([0.0, 1.0]);
        }
        fn line(&self, u: f64, b: &mut Vec<f64>) -> f64 {
            b.extend([0.0, 1.0]);
            u
        }
        fn eval(&self, u: &f64, v: f64) -> [f64; CHANNELS] {
            let inner = integrate_2d(&Kinked, &Rules::new(6));
            [u * v * inner[0], inner[1]]
        }
    }

    #[test]
    fn nested_and_repeated_calls_give_the_bits_of_separate_ones() {
        let rules = Rules::new(5);
        let alone = integrate_2d(&Kinked, &Rules::new(6));
        let nested = integrate_2d(&Nested, &rules);
        // ∫∫ u v dv du = 1/4 times the inner integral
        assert!((nested[0] - 0.25 * alone[0]).abs() < 1e-14, "{nested:?}");
        assert!((nested[1] - alone[1]).abs() < 1e-14, "{nested:?}");
        assert_eq!(integrate_2d(&Nested, &rules), nested);
        assert_eq!(integrate_2d(&Kinked, &Rules::new(6)), alone);
        let big = integrate_2d(&Kinked, &Rules::new(40));
        assert_eq!(integrate_2d(&Kinked, &Rules::new(6)), alone);
        assert!((big[0] - 1.0 / 3.0).abs() < 1e-14);
    }

    /// The AVX2/AVX-512 builds of the sinh map give the bits of the baseline build.
    #[test]
    fn sinh_map_is_the_same_on_every_vector_unit() {
        let rule = UnitRule::gauss_legendre(19);
        for (sqrt, pieces) in [(false, 1), (true, 1), (true, 3), (false, 4)] {
            let map = SinhPieces {
                at: 0.3,
                sign: 1.0,
                delta: 1e-3,
                lo: 0.3,
                hi: 1.2,
                dw: 2.1,
                pieces,
                sqrt,
            };
            let n = rule.nodes.len() * pieces;
            let (mut x0, mut w0, mut x1, mut w1) =
                (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            map.fill(&rule.nodes, &rule.weights, &mut x0, &mut w0);
            map.fill_dispatch(&rule.nodes, &rule.weights, &mut x1, &mut w1);
            assert!(x0.iter().zip(&x1).all(|(a, b)| a.to_bits() == b.to_bits()));
            assert!(w0.iter().zip(&w1).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }

    /// ∫_0^1 ln(x + δ) dx with the branch point on the real axis behind the end: the sinh map
    /// with `beyond` takes fewer pieces and is as accurate as without.
    #[test]
    fn a_singularity_behind_the_end_takes_longer_sinh_pieces() {
        let delta: f64 = 1e-6;
        let exact = (1.0 + delta) * (1.0 + delta).ln() - delta * delta.ln() - 1.0;
        let rules = DimRules::new(12);
        let mut nodes = [0; 2];
        for (k, beyond) in [false, true].into_iter().enumerate() {
            let panel = Panel {
                a: 0.0,
                b: 1.0,
                map: PanelMap::End {
                    at: 0.0,
                    toward: 1.0,
                    sqrt: false,
                    delta,
                    beyond,
                },
            };
            let (mut xs, mut ws) = (Vec::new(), Vec::new());
            rules.nodes_into(&panel, &mut xs, &mut ws);
            let q: f64 = xs.iter().zip(&ws).map(|(x, w)| w * (x + delta).ln()).sum();
            assert!((q - exact).abs() < 1e-13, "beyond {beyond}: {q} vs {exact}");
            nodes[k] = xs.len();
        }
        // asinh(1e6) = 14.5: 5 pieces of ≤ 3, 3 of ≤ 6
        assert_eq!(nodes, [60, 36]);
    }

    /// A square-root break next to another is near-singular at the other's branch point, on the
    /// real axis behind it: flagged `beyond` by `panels_from_breaks_real` only, the sides facing
    /// away from the neighbour only, and the distances are those of `panels_from_breaks`.
    #[test]
    fn square_root_neighbours_are_singular_behind_the_break() {
        let breaks = [
            Break::regular(0.0),
            Break::sqrt(0.5),
            Break::sqrt(0.5 + 1e-4),
            Break::regular(1.0),
        ];
        let (mut plain, mut real) = (Vec::new(), Vec::new());
        panels_from_breaks(&mut breaks.clone(), &mut plain);
        panels_from_breaks_real(&mut breaks.clone(), &mut real);
        assert_eq!(plain.len(), real.len());
        let beyond = |p: &Panel| match p.map {
            PanelMap::End { beyond, delta, .. } => (beyond, delta),
            _ => (false, f64::INFINITY),
        };
        for (p, q) in plain.iter().zip(&real) {
            assert_eq!((p.a, p.b), (q.a, q.b));
            assert!(!beyond(p).0);
            assert_eq!(beyond(p).1.to_bits(), beyond(q).1.to_bits());
        }
        // [0, 0.5] is mapped towards 0.5 (sqrt) and [0.5 + 1e-4, 1] towards 0.5 + 1e-4: each
        // near-singular at the other square root, behind it
        let mapped: Vec<_> = real.iter().filter(|p| beyond(p).1.is_finite()).collect();
        assert!(!mapped.is_empty());
        assert!(mapped.iter().all(|p| beyond(p).0), "{real:?}");
    }

    #[test]
    fn estimate_refines_until_tolerance() {
        let settings = QuadratureSettings {
            order: 4,
            companion: 2,
            tolerance: 1e-12,
            max_order: 64,
        };
        let cache = RuleCache::new(&settings);
        // ∫0^1 exp(x) dx with a 1-D "integrand" disguised as a 1-point inner rule
        let e = estimate(&settings, &cache, |r: &Rules| {
            [r.outer
                .plain
                .nodes
                .iter()
                .zip(&r.outer.plain.weights)
                .map(|(x, w)| w * x.exp())
                .sum::<f64>()]
        });
        assert!(e.converged);
        assert!((e.value[0] - (std::f64::consts::E - 1.0)).abs() < 1e-13);
        assert!(e.order > 4);
    }
}
