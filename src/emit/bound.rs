//! A rigorous bound on |f32 code − exact fit| over a whole domain, not just at sampled points.
//!
//! Each register of a [`Compiled`] function is evaluated over a box of inputs as a [`Ball`]: an
//! interval holding the exact value v, and constants (ρ, a) with |computed − v| ≤ ρ·|v| + a for
//! every input in the box and every rounding model furnace emits for: each operation rounded
//! once (u = 2⁻²⁴), multiply–adds fused (one rounding fewer, so covered), and the division and
//! square-root errors GPUs are allowed (5u and 9u, [`super::ir`]); every operation may also
//! flush a subnormal to zero (absolute error < 2⁻¹²⁶). The rules are Higham 2002, "Accuracy and
//! Stability of Numerical Algorithms", §2.2 (the standard model fl(x op y) = (x op y)(1 + δ),
//! |δ| ≤ u) carried through each operation exactly, products and quotients of error terms
//! included — no first-order truncation. Sums of same-sign terms keep the relative form, so an
//! error stays relative through the input transforms however small the values.
//!
//! An albedo function is bounded in two stages ([`albedo_bound`]): its input transforms over
//! the whole domain (their results, the transformed variables t, have known exact ranges), then
//! its polynomial part over boxes of t, split at the worst box until the bound is within
//! [`TIGHTNESS`] of the largest point bound met or [`MAX_BOXES`] boxes are used. The second
//! stage works in t because the grazing-layer transform maps every neighbourhood of the corner
//! r = μ = 0 onto all of [0, 1]: no box in (r, μ) is small there.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::ir::{Compiled, Node, Program};
use crate::fit::FitResult;

const U: f64 = 1.0 / (1u64 << 24) as f64;
/// GPU division: 2.5 ulp ≤ 5u (see [`super::ir::GPU_DIV_ULPS`]).
const DIV_REL: f64 = 5.0 * U;
/// GPU square root: ≈ 4.5 ulp ≤ 9u (see [`super::ir::GPU_SQRT_ULPS`]).
const SQRT_REL: f64 = 9.0 * U;
/// A subnormal result or operand flushed to zero changes it by less than the smallest normal
/// f32, 2⁻¹²⁶.
const FLUSH: f64 = 1.1754943508222875e-38;
/// Splitting stops when the worst box's bound is within this fraction of the largest bound at
/// a single point met so far.
pub const TIGHTNESS: f64 = 0.25;
/// Most boxes the second stage evaluates.
pub const MAX_BOXES: usize = 40_000;

/// The exact value lies in [lo, hi]; the computed one is within rel·|v| + abs of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    pub lo: f64,
    pub hi: f64,
    pub rel: f64,
    pub abs: f64,
}

impl Ball {
    fn exact(lo: f64, hi: f64) -> Ball {
        Ball {
            lo,
            hi,
            rel: 0.0,
            abs: 0.0,
        }
    }
    fn mag(&self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
    /// The absolute bound on |computed − exact| over the box.
    pub fn error(&self) -> f64 {
        let e = self.rel * self.mag() + self.abs;
        if e.is_nan() {
            f64::INFINITY
        } else {
            e
        }
    }
    /// Rounding of a result with relative error `d`, plus flushing.
    fn rounded(mut self, d: f64) -> Ball {
        self.rel += d * (1.0 + self.rel);
        self.abs = self.abs * (1.0 + d) + FLUSH;
        self
    }
    fn unbounded(lo: f64, hi: f64) -> Ball {
        Ball {
            lo,
            hi,
            rel: 0.0,
            abs: f64::INFINITY,
        }
    }
}

fn min_max(xs: [f64; 4]) -> (f64, f64) {
    let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo, hi)
}

/// Evaluates `c` over the box of `inputs` into `out` (one [`Ball`] per register); `hints[i]`,
/// if set, is a range known to hold register i's exact value (intersected with its interval).
pub fn eval_box(c: &Compiled, inputs: &[Ball], hints: &[Option<(f64, f64)>], out: &mut Vec<Ball>) {
    out.clear();
    for (i, node) in c.nodes().iter().enumerate() {
        let r = |k: usize| out[k];
        let mut b = match *node {
            Node::Lit(l) => Ball {
                lo: l.exact,
                hi: l.exact,
                rel: 0.0,
                abs: (l.value as f64 - l.exact).abs(),
            },
            Node::Param(k) => inputs[k],
            Node::Add(x, y) | Node::Sub(x, y) => {
                let (a, mut b) = (r(x), r(y));
                if matches!(node, Node::Sub(..)) {
                    b = Ball {
                        lo: -b.hi,
                        hi: -b.lo,
                        ..b
                    };
                }
                let (lo, hi) = (a.lo + b.lo, a.hi + b.hi);
                // |â + b̂ − (a + b)| ≤ ρa|a| + ρb|b| + αa + αb; for same-sign terms
                // |a| + |b| = |a + b|, so the relative form survives
                let same_sign = (a.lo >= 0.0 && b.lo >= 0.0) || (a.hi <= 0.0 && b.hi <= 0.0);
                let sum = if same_sign {
                    Ball {
                        lo,
                        hi,
                        rel: a.rel.max(b.rel),
                        abs: a.abs + b.abs,
                    }
                } else {
                    Ball {
                        lo,
                        hi,
                        rel: 0.0,
                        abs: a.error() + b.error(),
                    }
                };
                sum.rounded(U)
            }
            Node::Mul(x, y) => {
                let (a, b) = (r(x), r(y));
                let (lo, hi) = min_max([a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi]);
                // â b̂ − ab with â = a(1+α) + α′: ab(α + β + αβ) + a(1+α)β′ + b(1+β)α′ + α′β′
                Ball {
                    lo,
                    hi,
                    rel: a.rel + b.rel + a.rel * b.rel,
                    abs: a.mag() * b.abs * (1.0 + a.rel)
                        + b.mag() * a.abs * (1.0 + b.rel)
                        + a.abs * b.abs,
                }
                .rounded(U)
            }
            Node::Div(x, y) => {
                let (a, b) = (r(x), r(y));
                if b.lo <= 0.0 && b.hi >= 0.0 {
                    Ball::unbounded(f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    let bmin = b.lo.abs().min(b.hi.abs());
                    // |b̂| ≥ |b|(1 − ρb) − αb; |â/b̂ − a/b| ≤ |v|(ρa + ρb)|b|/|b̂| + (αa + |v| αb)/|b̂|
                    let floor = bmin * (1.0 - b.rel) - b.abs;
                    let g = 1.0 - b.rel - b.abs / bmin;
                    let (lo, hi) = min_max([a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi]);
                    if !(floor > 0.0 && g > 0.0) {
                        Ball::unbounded(lo, hi)
                    } else {
                        Ball {
                            lo,
                            hi,
                            rel: (a.rel + b.rel) / g + b.abs / floor,
                            abs: a.abs / floor,
                        }
                        .rounded(DIV_REL)
                    }
                }
            }
            Node::Min(x, y) | Node::Max(x, y) => {
                // t ↦ t ± ρ|t| is increasing for ρ < 1, so min/max keep max(ρ) and max(α)
                let (a, b) = (r(x), r(y));
                let (lo, hi) = if matches!(node, Node::Min(..)) {
                    (a.lo.min(b.lo), a.hi.min(b.hi))
                } else {
                    (a.lo.max(b.lo), a.hi.max(b.hi))
                };
                let rel = a.rel.max(b.rel);
                if rel < 1.0 {
                    Ball {
                        lo,
                        hi,
                        rel,
                        abs: a.abs.max(b.abs),
                    }
                } else {
                    Ball {
                        lo,
                        hi,
                        rel: 0.0,
                        abs: a.error().max(b.error()),
                    }
                }
            }
            Node::Sqrt(x) => {
                let a = r(x);
                if a.lo < 0.0 {
                    Ball::unbounded(0.0, a.hi.max(0.0).sqrt())
                } else {
                    // √(a(1+α) + α′) − √a: ≤ ρ√a from the relative part; from the absolute one
                    // ≤ α′/(√y + √(y + α′)) ≤ α′/√y with y = a(1+α) ≥ lo(1 − ρ), and ≤ √α′ always
                    let y = a.lo * (1.0 - a.rel);
                    let abs = if y > 0.0 {
                        a.abs.sqrt().min(a.abs / y.sqrt())
                    } else {
                        a.abs.sqrt()
                    };
                    Ball {
                        lo: a.lo.sqrt(),
                        hi: a.hi.sqrt(),
                        rel: a.rel,
                        abs,
                    }
                    .rounded(SQRT_REL)
                }
            }
            Node::SelectGe(x, y, t, e) => {
                let (a, b, t, e) = (r(x), r(y), r(t), r(e));
                if a.lo - a.error() >= b.hi + b.error() {
                    t
                } else if a.hi + a.error() < b.lo - b.error() {
                    e
                } else {
                    // the branch taken may differ from the exact one: no bound from this box
                    Ball::unbounded(t.lo.min(e.lo), t.hi.max(e.hi))
                }
            }
        };
        if let Some((lo, hi)) = hints.get(i).copied().flatten() {
            b.lo = b.lo.max(lo);
            b.hi = b.hi.min(hi);
        }
        out.push(b);
    }
}

/// The bound of the first result over a box.
fn result_error(
    c: &Compiled,
    inputs: &[Ball],
    hints: &[Option<(f64, f64)>],
    regs: &mut Vec<Ball>,
) -> f64 {
    eval_box(c, inputs, hints, regs);
    regs[c.results()[0]].error()
}

/// A box of the branch and bound, ordered by its bound.
struct Cell {
    bound: f64,
    lo: Vec<f64>,
    hi: Vec<f64>,
}
impl PartialEq for Cell {
    fn eq(&self, o: &Self) -> bool {
        self.bound.total_cmp(&o.bound) == Ordering::Equal
    }
}
impl Eq for Cell {}
impl PartialOrd for Cell {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cell {
    fn cmp(&self, o: &Self) -> Ordering {
        self.bound.total_cmp(&o.bound)
    }
}

/// The outcome of bounding a function over a box.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Bound {
    /// |computed − exact| ≤ this for every input in the box (∞ if it could not be bounded).
    pub max_error: f64,
    /// The largest bound at a single point met (a lower estimate of the best possible bound).
    pub point_estimate: f64,
    /// Boxes evaluated.
    pub boxes: usize,
}

/// Bounds the first result of `c` over the box `domain` whose inputs carry the errors
/// `input_error` (absolute), splitting the worst box in half along its widest side (relative to
/// the domain) until the bound is within [`TIGHTNESS`] of the largest point bound met.
pub fn bound_over(
    c: &Compiled,
    domain: &[(f64, f64)],
    input_error: &[f64],
    max_boxes: usize,
) -> Bound {
    let d = domain.len();
    let mut regs = Vec::new();
    let balls = |lo: &[f64], hi: &[f64]| -> Vec<Ball> {
        (0..d)
            .map(|k| Ball {
                abs: input_error[k],
                ..Ball::exact(lo[k], hi[k])
            })
            .collect()
    };
    let width: Vec<f64> = domain
        .iter()
        .map(|&(lo, hi)| (hi - lo).max(f64::MIN_POSITIVE))
        .collect();
    let lo0: Vec<f64> = domain.iter().map(|r| r.0).collect();
    let hi0: Vec<f64> = domain.iter().map(|r| r.1).collect();
    let mut heap = BinaryHeap::new();
    let first = result_error(c, &balls(&lo0, &hi0), &[], &mut regs);
    heap.push(Cell {
        bound: first,
        lo: lo0,
        hi: hi0,
    });
    let mut boxes = 1;
    let mut point = 0.0f64;
    while let Some(worst) = heap.pop() {
        let centre: Vec<f64> = worst
            .lo
            .iter()
            .zip(&worst.hi)
            .map(|(a, b)| 0.5 * (a + b))
            .collect();
        point = point.max(result_error(c, &balls(&centre, &centre), &[], &mut regs));
        let done = worst.bound <= (1.0 + TIGHTNESS) * point || boxes + 2 > max_boxes;
        let splittable = (0..d).any(|k| worst.hi[k] > worst.lo[k]);
        if done || !splittable {
            let max_error = worst.bound;
            return Bound {
                max_error,
                point_estimate: point,
                boxes,
            };
        }
        let k = (0..d)
            .max_by(|&a, &b| {
                ((worst.hi[a] - worst.lo[a]) / width[a])
                    .total_cmp(&((worst.hi[b] - worst.lo[b]) / width[b]))
            })
            .expect("at least one variable");
        let mid = 0.5 * (worst.lo[k] + worst.hi[k]);
        for half in 0..2 {
            let (mut lo, mut hi) = (worst.lo.clone(), worst.hi.clone());
            if half == 0 {
                hi[k] = mid;
            } else {
                lo[k] = mid;
            }
            let bound = result_error(c, &balls(&lo, &hi), &[], &mut regs);
            boxes += 1;
            heap.push(Cell { bound, lo, hi });
        }
    }
    Bound {
        max_error: f64::INFINITY,
        point_estimate: point,
        boxes,
    }
}

/// The rigorous bound of an albedo function of `fit` over every f32 input (inputs outside the
/// domain are clamped into it): stage 1 bounds its transformed variables `core_inputs` (the
/// `let`s the polynomial part starts from) over the whole domain, stage 2 the polynomial part
/// over boxes of those variables. If the function has no such split, the whole function is
/// bounded over boxes of its inputs.
pub fn albedo_bound(
    program: &Program,
    name: &str,
    fit: &FitResult,
    core_inputs: &[String],
) -> Bound {
    let a = &fit.approximant;
    let dom32 = super::generate::domain_f32(fit);
    // the code clamps to the domain rounded inwards to f32, the exact fit to the domain itself
    let clamp_gap: Vec<f64> = a
        .domain
        .iter()
        .zip(&dom32)
        .map(|(&(lo, hi), &(l, h))| (l as f64 - lo).abs().max((hi - h as f64).abs()) + FLUSH)
        .collect();
    let Ok(whole) = Compiled::new(program, name) else {
        return unbounded();
    };
    // the exact fit sees the input clamped to its domain; the code's clamped input is within
    // `clamp_gap` of that
    let x_box = a.domain.clone();
    let ranges = match a.transformed_domain() {
        Ok(r) => r,
        Err(_) => return bound_over(&whole, &x_box, &clamp_gap, MAX_BOXES),
    };
    let core = Compiled::after_lets(program, name, core_inputs);
    let regs: Option<Vec<usize>> = core_inputs.iter().map(|n| whole.register(n)).collect();
    let (Ok(core), Some(regs)) = (core, regs) else {
        return bound_over(&whole, &x_box, &clamp_gap, MAX_BOXES);
    };
    // stage 1: each transformed variable's exact range is known; its error over the whole domain
    let mut hints = vec![None; whole.len()];
    for (k, &r) in regs.iter().enumerate() {
        hints[r] = Some(ranges[k]);
    }
    let inputs: Vec<Ball> = x_box
        .iter()
        .zip(&clamp_gap)
        .map(|(&(lo, hi), &gap)| Ball {
            abs: gap,
            ..Ball::exact(lo, hi)
        })
        .collect();
    let mut out = Vec::new();
    eval_box(&whole, &inputs, &hints, &mut out);
    let delta: Vec<f64> = regs.iter().map(|&r| out[r].error()).collect();
    // stage 2: the polynomial part over boxes of the transformed variables
    bound_over(&core, &ranges, &delta, MAX_BOXES)
}

fn unbounded() -> Bound {
    Bound {
        max_error: f64::INFINITY,
        point_estimate: f64::INFINITY,
        boxes: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::super::ir::build::*;
    use super::super::ir::{Arith, Function, Stmt};
    use super::*;

    fn program(body: Vec<Stmt>, result: crate::emit::ir::Expr) -> Program {
        Program {
            functions: vec![Function {
                name: "f".into(),
                doc: vec![],
                params: vec!["x".into(), "y".into()],
                body,
                result,
            }],
        }
    }

    /// The bound holds at many points, in every rounding model, for cancellation, a division,
    /// a square root and a clamp; and it is not vacuous.
    #[test]
    fn the_bound_covers_every_rounding_model() {
        let p = program(
            vec![
                Stmt {
                    name: "s".into(),
                    value: sqrt(add(mul(var("x"), var("x")), lit(0.1))),
                    comment: None,
                },
                Stmt {
                    name: "q".into(),
                    value: add(mul(sub(var("y"), lit(0.3)), lit(2.0)), lit(1.5)),
                    comment: None,
                },
            ],
            clamp(
                div(sub(var("s"), mul(lit(0.7), var("x"))), var("q")),
                lit(-5.0),
                lit(5.0),
            ),
        );
        let c = Compiled::new(&p, "f").unwrap();
        let domain = [(0.0, 1.0), (0.0, 1.0)];
        let b = bound_over(&c, &domain, &[0.0, 0.0], 4000);
        assert!(b.max_error.is_finite() && b.max_error < 1e-5, "{b:?}");
        let mut regs = Vec::new();
        let mut worst = 0.0f64;
        let mut state = 7u64;
        for i in 0..20_000u64 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = (state >> 40) as f32 / (1u64 << 24) as f32;
            let y = (state >> 16 & 0xFF_FFFF) as f32 / (1u64 << 24) as f32;
            let (xd, yd) = (x as f64, y as f64);
            let exact =
                (((xd * xd + 0.1).sqrt() - 0.7 * xd) / ((yd - 0.3) * 2.0 + 1.5)).clamp(-5.0, 5.0);
            for arith in [Arith::Ieee, Arith::Fused, Arith::Gpu { seed: i }] {
                let got = c.eval_f32(&[x, y], arith, &mut regs) as f64;
                // 0.1, 0.3, 0.7 are not f32: the bound covers their representation error too
                assert!(
                    (got - exact).abs() <= b.max_error,
                    "{arith:?} at ({x}, {y}): {got} vs {exact}, bound {}",
                    b.max_error
                );
                worst = worst.max((got - exact).abs());
            }
        }
        assert!(
            worst > b.max_error / 50.0,
            "vacuous bound {} for a worst error {worst}",
            b.max_error
        );
    }

    #[test]
    fn a_denominator_through_zero_is_unbounded() {
        let p = program(vec![], div(lit(1.0), sub(var("x"), lit(0.5))));
        let c = Compiled::new(&p, "f").unwrap();
        let b = bound_over(&c, &[(0.0, 1.0), (0.0, 1.0)], &[0.0, 0.0], 500);
        assert!(b.max_error.is_infinite(), "{b:?}");
    }

    #[test]
    fn relative_errors_survive_tiny_positive_values() {
        // (x(1 + y²) + τ)/(x + y² + τ) ∈ [0, 1] with τ = 2⁻¹⁰⁰: relative error stays ~8u
        let tau = 2f64.powi(-100);
        let p = program(
            vec![],
            div(
                add(
                    mul(var("x"), add(lit(1.0), mul(var("y"), var("y")))),
                    lit(tau),
                ),
                add(add(var("x"), mul(var("y"), var("y"))), lit(tau)),
            ),
        );
        let c = Compiled::new(&p, "f").unwrap();
        let mut out = Vec::new();
        let hints: Vec<Option<(f64, f64)>> = (0..c.len())
            .map(|i| (i == c.results()[0]).then_some((0.0, 1.0)))
            .collect();
        eval_box(
            &c,
            &[Ball::exact(0.0, 1.0), Ball::exact(0.0, 1.0)],
            &hints,
            &mut out,
        );
        let e = out[c.results()[0]].error();
        assert!(e < 20.0 * U, "{e:e}");
    }
}
