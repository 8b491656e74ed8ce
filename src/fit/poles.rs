//! Pole certificate: a proof that the denominator Q has no zero on the whole domain box — not a
//! check at sample points.
//!
//! Q (monomial form in the transformed variables) is mapped to the unit box and converted to the
//! tensor-product Bernstein basis. Bernstein coefficients enclose the range of Q on the box
//! (the convex-hull property; Farouki & Rajan 1987, "On the numerical condition of polynomials in
//! Bernstein form"); if they all have one sign beyond a rigorous rounding-error bound, Q ≠ 0 on
//! the box. Otherwise the box is halved by de Casteljau subdivision (Garloff 1986, "Convergent
//! bounds for the range of multivariate polynomials") until every sub-box is decided, a point
//! of opposite sign proves a zero (then the zero is located by bisection), or the boxes become
//! too small / too many (Undecided — never reported as good).

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::basis::{binomial, gamma, monomial_to_unit_box, Polynomial};

/// Outcome of the pole check of a denominator on the domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum PoleVerdict {
    /// Proved: |Q| ≥ `min_lower_bound` > 0 on the whole domain box (and Q has one sign).
    Certified { min_lower_bound: f64, boxes: usize },
    /// Q changes sign in the domain: there is a pole near `at` (original variables).
    PoleFound { at: Vec<f64> },
    /// Neither proved nor refuted (Q touches zero to working precision, or the box budget ran
    /// out); treat as not pole-free.
    Undecided { reason: String, boxes: usize },
    /// A polynomial: no denominator.
    NoDenominator,
}

impl PoleVerdict {
    /// True if the approximant is proved finite on its domain.
    pub fn is_certified(&self) -> bool {
        matches!(
            self,
            PoleVerdict::Certified { .. } | PoleVerdict::NoDenominator
        )
    }
}

/// Limits of the subdivision.
#[derive(Clone, Debug, PartialEq)]
pub struct CertifyOptions {
    /// Most sub-boxes examined before giving up (Undecided).
    pub max_boxes: usize,
    /// Sub-boxes narrower than this (in unit-box coordinates) are not split further.
    pub min_box_width: f64,
    /// Extra splits of the weakest certified boxes to tighten `min_lower_bound`.
    pub refine_splits: usize,
}

impl Default for CertifyOptions {
    fn default() -> Self {
        CertifyOptions {
            max_boxes: 200_000,
            min_box_width: 1e-7,
            refine_splits: 64,
        }
    }
}

/// Result in transformed coordinates (the caller maps `at` back to the original variables).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawVerdict {
    Certified { min_lower_bound: f64, boxes: usize },
    PoleFound { at: Vec<f64> },
    Undecided { reason: String, boxes: usize },
}

struct Tensor {
    /// Degree per axis.
    deg: Vec<usize>,
    /// Stride per axis (last axis fastest).
    stride: Vec<usize>,
}

impl Tensor {
    fn new(deg: Vec<usize>) -> Tensor {
        let d = deg.len();
        let mut stride = vec![1; d];
        for k in (0..d.saturating_sub(1)).rev() {
            stride[k] = stride[k + 1] * (deg[k + 1] + 1);
        }
        Tensor { deg, stride }
    }
    fn len(&self) -> usize {
        self.deg.iter().map(|n| n + 1).product()
    }
    /// Start indices of all fibres along axis k.
    fn fibre_starts(&self, k: usize) -> Vec<usize> {
        (0..self.len())
            .filter(|&i| (i / self.stride[k]).is_multiple_of(self.deg[k] + 1))
            .collect()
    }
}

#[derive(Clone)]
struct SubBox {
    lo: Vec<f64>,
    hi: Vec<f64>,
    coeffs: Vec<f64>,
    /// Bound on the rounding error of every coefficient.
    err: f64,
}

impl SubBox {
    fn range(&self) -> (f64, f64) {
        self.coeffs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &c| {
                (a.min(c), b.max(c))
            })
    }
    fn width(&self) -> f64 {
        self.lo
            .iter()
            .zip(&self.hi)
            .map(|(a, b)| b - a)
            .fold(0.0, f64::max)
    }
    fn center(&self) -> Vec<f64> {
        self.lo
            .iter()
            .zip(&self.hi)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }
}

/// Halves `b` along axis k by de Casteljau at 1/2.
fn split(t: &Tensor, b: &SubBox, k: usize) -> (SubBox, SubBox) {
    let n = t.deg[k];
    let st = t.stride[k];
    let mut left = b.coeffs.clone();
    let mut right = b.coeffs.clone();
    let mut w = vec![0.0; n + 1];
    for s in t.fibre_starts(k) {
        for (i, wi) in w.iter_mut().enumerate() {
            *wi = b.coeffs[s + i * st];
        }
        left[s] = w[0];
        right[s + n * st] = w[n];
        for r in 1..=n {
            for i in 0..=n - r {
                w[i] = 0.5 * (w[i] + w[i + 1]);
            }
            left[s + r * st] = w[0];
            right[s + (n - r) * st] = w[n - r];
        }
    }
    let maxabs = b.coeffs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    // each averaging level adds at most u·max|b| (the halving is exact); ×2 safety
    let err = b.err + n as f64 * f64::EPSILON * maxabs;
    let mid = 0.5 * (b.lo[k] + b.hi[k]);
    let mut l = SubBox {
        lo: b.lo.clone(),
        hi: b.hi.clone(),
        coeffs: left,
        err,
    };
    let mut r = SubBox {
        lo: b.lo.clone(),
        hi: b.hi.clone(),
        coeffs: right,
        err,
    };
    l.hi[k] = mid;
    r.lo[k] = mid;
    (l, r)
}

/// Certifies that `q` (monomial in t) has no zero on the box `bounds` (in t).
pub(crate) fn certify_polynomial(
    q: &Polynomial,
    bounds: &[(f64, f64)],
    opts: &CertifyOptions,
) -> RawVerdict {
    let d = bounds.len();
    let deg: Vec<usize> = (0..d)
        .map(|k| q.exponents.iter().map(|e| e[k] as usize).max().unwrap_or(0))
        .collect();
    let t = Tensor::new(deg.clone());
    let (u, u_abs) = monomial_to_unit_box(q, bounds);
    let mut coeffs = vec![0.0; t.len()];
    let mut abs = vec![0.0; t.len()];
    for ((e, &c), &a) in q.exponents.iter().zip(&u).zip(&u_abs) {
        let idx: usize = e.iter().zip(&t.stride).map(|(&x, &s)| x as usize * s).sum();
        coeffs[idx] = c;
        abs[idx] = a;
    }
    // monomial → Bernstein along each axis: b_i = Σ_{j≤i} C(i,j)/C(n,j) a_j (Farouki & Rajan 1988)
    for k in 0..d {
        let n = deg[k];
        let st = t.stride[k];
        for s in t.fibre_starts(k) {
            for buf in [&mut coeffs, &mut abs] {
                let a: Vec<f64> = (0..=n).map(|j| buf[s + j * st]).collect();
                for i in 0..=n {
                    let mut acc = 0.0;
                    for (j, &aj) in a.iter().enumerate().take(i + 1) {
                        acc += binomial(i as u32, j as u32) / binomial(n as u32, j as u32) * aj;
                    }
                    buf[s + i * st] = acc;
                }
            }
        }
    }
    let nmax = deg.iter().copied().max().unwrap_or(0);
    let ops = d * (nmax + 1) + d + 1 + 2 * nmax + d * (nmax + 3) + q.coefficients.len();
    let err0 = gamma(ops) * abs.iter().fold(0.0f64, |m, &a| m.max(a));

    let to_t = |uu: &[f64]| -> Vec<f64> {
        uu.iter()
            .zip(bounds)
            .map(|(&x, &(lo, hi))| lo + (hi - lo) * x)
            .collect()
    };
    // a point where Q is reliably positive / negative, in unit-box coordinates
    let mut witness: [Option<Vec<f64>>; 2] = [None, None];
    let note = |w: &mut [Option<Vec<f64>>; 2], p: Vec<f64>, positive: bool| {
        let slot = &mut w[usize::from(!positive)];
        if slot.is_none() {
            *slot = Some(p);
        }
    };
    let locate = |pos: &[f64], neg: &[f64]| -> Vec<f64> {
        // bisection on the segment: Q(pos) > 0 > Q(neg), so a zero lies between
        let (mut a, mut b) = (pos.to_vec(), neg.to_vec());
        for _ in 0..60 {
            let m: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
            if q.eval(&to_t(&m)) > 0.0 {
                a = m;
            } else {
                b = m;
            }
        }
        to_t(&a)
    };

    let root = SubBox {
        lo: vec![0.0; d],
        hi: vec![1.0; d],
        coeffs,
        err: err0,
    };
    let mut queue = VecDeque::from([root]);
    let mut certified: Vec<(SubBox, bool)> = Vec::new();
    let mut boxes = 0usize;
    while let Some(b) = queue.pop_front() {
        boxes += 1;
        let (lo, hi) = b.range();
        if lo > b.err || hi < -b.err {
            note(&mut witness, b.center(), lo > b.err);
            certified.push((b, lo > 0.0));
        } else {
            // corner coefficients are exact values of Q at the corners
            for corner in 0..(1usize << d) {
                let idx: usize = (0..d)
                    .map(|k| {
                        if corner >> k & 1 == 1 {
                            deg[k] * t.stride[k]
                        } else {
                            0
                        }
                    })
                    .sum();
                let c = b.coeffs[idx];
                if c.abs() > b.err {
                    let p: Vec<f64> = (0..d)
                        .map(|k| {
                            if corner >> k & 1 == 1 {
                                b.hi[k]
                            } else {
                                b.lo[k]
                            }
                        })
                        .collect();
                    note(&mut witness, p, c > 0.0);
                }
            }
            let width = b.width();
            if width < opts.min_box_width {
                if let (Some(p), Some(n)) = (&witness[0], &witness[1]) {
                    return RawVerdict::PoleFound { at: locate(p, n) };
                }
                return RawVerdict::Undecided {
                    reason: format!(
                        "the denominator's range on a sub-box of width {width:.1e} still straddles zero within rounding ({:.1e}); it touches zero in or at the edge of the domain",
                        b.err
                    ),
                    boxes,
                };
            }
            let k = (0..d).fold(0, |best, k| {
                if b.hi[k] - b.lo[k] > b.hi[best] - b.lo[best] {
                    k
                } else {
                    best
                }
            });
            let (l, r) = split(&t, &b, k);
            queue.push_back(l);
            queue.push_back(r);
        }
        if let (Some(p), Some(n)) = (&witness[0], &witness[1]) {
            return RawVerdict::PoleFound { at: locate(p, n) };
        }
        if boxes >= opts.max_boxes && !queue.is_empty() {
            return RawVerdict::Undecided {
                reason: format!("gave up after {boxes} sub-boxes"),
                boxes,
            };
        }
    }
    // all boxes certified with one sign: tighten the weakest bounds a little
    let bound = |b: &SubBox, positive: bool| {
        let (lo, hi) = b.range();
        if positive {
            lo - b.err
        } else {
            -hi - b.err
        }
    };
    for _ in 0..opts.refine_splits {
        let Some((i, _)) = certified
            .iter()
            .enumerate()
            .map(|(i, (b, s))| (i, bound(b, *s)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let (b, s) = certified.swap_remove(i);
        let k = (0..d).fold(0, |best, k| {
            if b.hi[k] - b.lo[k] > b.hi[best] - b.lo[best] {
                k
            } else {
                best
            }
        });
        let (l, r) = split(&t, &b, k);
        if bound(&l, s) > 0.0 && bound(&r, s) > 0.0 {
            certified.push((l, s));
            certified.push((r, s));
            boxes += 2;
        } else {
            certified.push((b, s));
            break;
        }
    }
    let min_lower_bound = certified
        .iter()
        .map(|(b, s)| bound(b, *s))
        .fold(f64::INFINITY, f64::min);
    RawVerdict::Certified {
        min_lower_bound,
        boxes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::basis::exponents;

    fn poly2(coeffs: &[f64]) -> Polynomial {
        let deg = match coeffs.len() {
            3 => 1,
            6 => 2,
            10 => 3,
            _ => panic!("bad test"),
        };
        Polynomial {
            exponents: exponents(2, deg),
            coefficients: coeffs.to_vec(),
        }
    }

    #[test]
    fn positive_polynomial_is_certified_with_a_valid_bound() {
        // Q = 1 + x² + y² − x y on [0,1]²: min is 1 at the origin
        let q = poly2(&[1.0, 0.0, 0.0, 1.0, -1.0, 1.0]);
        match certify_polynomial(&q, &[(0.0, 1.0), (0.0, 1.0)], &CertifyOptions::default()) {
            RawVerdict::Certified {
                min_lower_bound, ..
            } => {
                assert!(
                    min_lower_bound > 0.5 && min_lower_bound <= 1.0,
                    "{min_lower_bound}"
                )
            }
            v => panic!("{v:?}"),
        }
    }

    #[test]
    fn interior_zero_is_found() {
        // Q = (x − 0.3)² + (y − 0.6)² − 0.01: a circle of zeros inside the box
        let q = poly2(&[0.3 * 0.3 + 0.36 - 0.01, -0.6, -1.2, 1.0, 0.0, 1.0]);
        match certify_polynomial(&q, &[(0.0, 1.0), (0.0, 1.0)], &CertifyOptions::default()) {
            RawVerdict::PoleFound { at } => {
                let r = ((at[0] - 0.3).powi(2) + (at[1] - 0.6).powi(2)).sqrt();
                assert!((r - 0.1).abs() < 1e-6, "{at:?}");
            }
            v => panic!("{v:?}"),
        }
    }

    #[test]
    fn zero_between_samples_is_found() {
        // Q(x) = (x − 0.5049)(x − 0.5051) is negative only on (0.5049, 0.5051)
        let q = Polynomial {
            exponents: exponents(1, 2),
            coefficients: vec![0.5049 * 0.5051, -(0.5049 + 0.5051), 1.0],
        };
        assert!(
            (0..=100).all(|i| q.eval(&[i as f64 / 100.0]) > 0.0),
            "sampling must miss it"
        );
        match certify_polynomial(&q, &[(0.0, 1.0)], &CertifyOptions::default()) {
            RawVerdict::PoleFound { at } => assert!((at[0] - 0.505).abs() < 2e-4, "{at:?}"),
            v => panic!("{v:?}"),
        }
    }

    #[test]
    fn touching_zero_is_undecided_not_certified() {
        // Q = x² touches zero at the box edge
        let q = Polynomial {
            exponents: exponents(1, 2),
            coefficients: vec![0.0, 0.0, 1.0],
        };
        let v = certify_polynomial(&q, &[(0.0, 1.0)], &CertifyOptions::default());
        assert!(matches!(v, RawVerdict::Undecided { .. }), "{v:?}");
    }

    #[test]
    fn negative_everywhere_is_certified_3d() {
        let e = exponents(3, 2);
        let mut c = vec![0.0; e.len()];
        c[0] = -2.0;
        c[4] = 1.0; // x²
        let q = Polynomial {
            exponents: e,
            coefficients: c,
        };
        let v = certify_polynomial(
            &q,
            &[(0.0, 1.0), (0.0, 1.0), (0.0, 1.0)],
            &CertifyOptions::default(),
        );
        match v {
            RawVerdict::Certified {
                min_lower_bound, ..
            } => assert!(min_lower_bound > 0.9 && min_lower_bound <= 1.0),
            v => panic!("{v:?}"),
        }
    }
}
