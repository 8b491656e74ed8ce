//! Error metrics of an approximant on a data set, whatever objective produced it: mean absolute,
//! RMS, maximum absolute (with its location) and maximum relative error. Computed in parallel over
//! fixed chunks combined in order, so the numbers are reproducible bit for bit.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::data::FitData;
use super::result::Approximant;
use crate::math::CompensatedSum;

/// Values with |y| below this are left out of the maximum relative error: relative error is
/// meaningless at y ≈ 0 (e.g. the paper's glossy F0 = 0 slice, where E = 0).
pub const RELATIVE_ERROR_FLOOR: f64 = 1e-6;

const CHUNK: usize = 4096;

/// 2⁻⁶⁰⁰, exact: errors are also summed multiplied by it, so that the sums of |e| and e² stay
/// finite when the plain sums overflow (errors near the top of the f64 range; the plain sums
/// give the metrics whenever they are finite).
const SCALE: f64 = f64::from_bits((1023 - 600) << 52);

/// Unweighted error statistics of f(x_i) − y_i over all points of a data set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    pub n_points: usize,
    #[serde(with = "finite_or_string")]
    pub mae: f64,
    #[serde(with = "finite_or_string")]
    pub rmse: f64,
    #[serde(with = "finite_or_string")]
    pub max_abs_error: f64,
    /// Coordinates (original variables) of the worst absolute error.
    pub max_abs_error_at: Vec<f64>,
    #[serde(with = "finite_or_string")]
    pub max_rel_error: f64,
    pub max_rel_error_at: Vec<f64>,
    /// Points where the approximant is not finite (a pole or overflow); 0 for a usable fit.
    pub non_finite: usize,
}

#[derive(Clone, Copy)]
struct Partial {
    abs: f64,
    sq: f64,
    /// Σ |e|·[`SCALE`] and Σ (e·[`SCALE`])².
    abs_scaled: f64,
    sq_scaled: f64,
    max_abs: (f64, usize),
    max_rel: (f64, usize),
    non_finite: usize,
    n: usize,
}

impl Partial {
    const EMPTY: Partial = Partial {
        abs: 0.0,
        sq: 0.0,
        abs_scaled: 0.0,
        sq_scaled: 0.0,
        max_abs: (-1.0, usize::MAX),
        max_rel: (-1.0, usize::MAX),
        non_finite: 0,
        n: 0,
    };
}

/// Compensated running sums of one chunk.
struct Running {
    abs: CompensatedSum,
    sq: CompensatedSum,
    p: Partial,
}

impl Running {
    fn new() -> Running {
        Running {
            abs: CompensatedSum::default(),
            sq: CompensatedSum::default(),
            p: Partial::EMPTY,
        }
    }

    #[inline]
    fn add(&mut self, i: usize, f: f64, y: f64) {
        self.p.n += 1;
        let e = (f - y).abs();
        if !e.is_finite() {
            self.p.non_finite += 1;
            return;
        }
        self.abs.add(e);
        self.sq.add(e * e);
        let scaled = e * SCALE;
        self.p.abs_scaled += scaled;
        self.p.sq_scaled += scaled * scaled;
        if e > self.p.max_abs.0 {
            self.p.max_abs = (e, i);
        }
        if y.abs() >= RELATIVE_ERROR_FLOOR && e / y.abs() > self.p.max_rel.0 {
            self.p.max_rel = (e / y.abs(), i);
        }
    }

    fn finish(mut self) -> Partial {
        self.p.abs = self.abs.value();
        self.p.sq = self.sq.value();
        self.p
    }
}

/// Combines chunk partials in chunk order into metrics.
fn combine(parts: impl Iterator<Item = Partial>, data: &FitData) -> Metrics {
    let mut abs = CompensatedSum::default();
    let mut sq = CompensatedSum::default();
    let (mut abs_scaled, mut sq_scaled) = (0.0, 0.0);
    let (mut max_abs, mut max_rel, mut non_finite, mut n) =
        ((-1.0f64, usize::MAX), (-1.0f64, usize::MAX), 0usize, 0usize);
    for p in parts {
        abs.add(p.abs);
        sq.add(p.sq);
        abs_scaled += p.abs_scaled;
        sq_scaled += p.sq_scaled;
        if p.max_abs.0 > max_abs.0 {
            max_abs = p.max_abs;
        }
        if p.max_rel.0 > max_rel.0 {
            max_rel = p.max_rel;
        }
        non_finite += p.non_finite;
        n += p.n;
    }
    let at = |i: usize| {
        if i == usize::MAX {
            Vec::new()
        } else {
            data.point(i).to_vec()
        }
    };
    let finite = n - non_finite;
    let (mae, rmse, max_abs_error) = if non_finite > 0 || n == 0 {
        (f64::INFINITY, f64::INFINITY, f64::INFINITY)
    } else {
        // every error is finite, so are the means: from the scaled sums where the plain ones
        // overflow (they are at most the largest error)
        let max_abs_error = max_abs.0.max(0.0);
        let mean = |plain: f64, scaled: f64| {
            if plain.is_finite() {
                plain
            } else {
                scaled.min(max_abs_error)
            }
        };
        (
            mean(
                abs.value() / finite as f64,
                abs_scaled / finite as f64 / SCALE,
            ),
            mean(
                (sq.value() / finite as f64).sqrt(),
                (sq_scaled / finite as f64).sqrt() / SCALE,
            ),
            max_abs_error,
        )
    };
    Metrics {
        n_points: n,
        mae,
        rmse,
        max_abs_error,
        max_abs_error_at: at(max_abs.1),
        max_rel_error: if non_finite > 0 {
            f64::INFINITY
        } else {
            max_rel.0.max(0.0)
        },
        max_rel_error_at: at(max_rel.1),
        non_finite,
    }
}

/// Measures `approx` on `data` (every point, weights ignored).
pub fn measure(approx: &Approximant, data: &FitData) -> Metrics {
    measure_with_subset(approx, data, None).0
}

/// [`measure`] on all of `data` and, in the same pass, on the points i with `subset[i]` (e.g.
/// a sub-box); the subset's metrics are None without a subset or if it is empty.
pub fn measure_with_subset(
    approx: &Approximant,
    data: &FitData,
    subset: Option<&[bool]>,
) -> (Metrics, Option<Metrics>) {
    let n = data.len();
    let parts: Vec<(Partial, Partial)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut all, mut sub) = (Running::new(), Running::new());
            let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(n));
            let d = data.dim();
            let mut fs = vec![0.0; hi - lo];
            approx.eval_many(d, &data.coords[lo * d..hi * d], &mut fs);
            for i in lo..hi {
                let (f, y) = (fs[i - lo], data.values[i]);
                all.add(i, f, y);
                if subset.is_some_and(|s| s[i]) {
                    sub.add(i, f, y);
                }
            }
            (all.finish(), sub.finish())
        })
        .collect();
    let all = combine(parts.iter().map(|p| p.0), data);
    let sub = subset.and_then(|_| {
        let m = combine(parts.iter().map(|p| p.1), data);
        (m.n_points > 0).then_some(m)
    });
    (all, sub)
}

/// One point of a data set with the fit's error there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointError {
    /// Index of the point in the data set.
    pub index: usize,
    /// Its coordinates (original variables).
    pub at: Vec<f64>,
    /// The data value.
    pub value: f64,
    /// The approximant's value (NaN or ±∞ at a pole).
    #[serde(with = "finite_or_string")]
    pub fit: f64,
    /// |fit − value| (∞ where the fit is not finite).
    #[serde(with = "finite_or_string")]
    pub abs_error: f64,
}

/// The `n` points with the largest absolute error, largest first (ties: lower index first), so
/// one can see where a fit fails and what the data does there.
pub fn worst_points(approx: &Approximant, data: &FitData, n: usize) -> Vec<PointError> {
    let errors: Vec<(f64, f64)> = (0..data.len())
        .into_par_iter()
        .with_min_len(CHUNK)
        .map(|i| {
            let f = approx.eval(data.point(i));
            let e = (f - data.values[i]).abs();
            (f, if e.is_finite() { e } else { f64::INFINITY })
        })
        .collect();
    let mut order: Vec<usize> = (0..data.len()).collect();
    order.sort_by(|&a, &b| errors[b].1.total_cmp(&errors[a].1).then(a.cmp(&b)));
    order
        .into_iter()
        .take(n)
        .map(|i| PointError {
            index: i,
            at: data.point(i).to_vec(),
            value: data.values[i],
            fit: errors[i].0,
            abs_error: errors[i].1,
        })
        .collect()
}

/// Serialises a finite f64 as a JSON number (shortest round-trip) and ±∞/NaN as the strings
/// "inf", "-inf", "nan" — plain JSON has no non-finite numbers and serde_json would write null.
pub(crate) mod finite_or_string {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else if v.is_nan() {
            s.serialize_str("nan")
        } else if *v > 0.0 {
            s.serialize_str("inf")
        } else {
            s.serialize_str("-inf")
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Num {
        F(f64),
        S(String),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Num::deserialize(d)? {
            Num::F(x) => Ok(x),
            Num::S(s) => match s.as_str() {
                "inf" => Ok(f64::INFINITY),
                "-inf" => Ok(f64::NEG_INFINITY),
                "nan" => Ok(f64::NAN),
                other => Err(serde::de::Error::custom(format!(
                    "expected a number, \"inf\", \"-inf\" or \"nan\", got \"{other}\""
                ))),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::basis::Polynomial;
    use crate::fit::data::InputTransform;

    /// The constant `c` on x ∈ [0, 1].
    fn constant(c: f64) -> Approximant {
        Approximant {
            variables: vec!["x".into()],
            transforms: vec![InputTransform::Identity],
            domain: vec![(0.0, 1.0)],
            numerator: Polynomial {
                exponents: vec![vec![0]],
                coefficients: vec![c],
            },
            denominator: None,
            factor: None,
            terms: Vec::new(),
        }
    }

    #[test]
    fn worst_points_are_sorted_and_located() {
        // f = 0 against values 0, 3, 1, 3, 2: the worst are index 1 and 3 (tie: lower index first), then 4
        let data = FitData::new(
            vec!["x".into()],
            vec![0.0, 0.25, 0.5, 0.75, 1.0],
            vec![0.0, 3.0, 1.0, 3.0, 2.0],
            vec![(0.0, 1.0)],
        )
        .unwrap();
        let zero = constant(0.0);
        let w = worst_points(&zero, &data, 3);
        assert_eq!(w.iter().map(|p| p.index).collect::<Vec<_>>(), vec![1, 3, 4]);
        assert_eq!(
            (w[0].at.clone(), w[0].value, w[0].fit, w[0].abs_error),
            (vec![0.25], 3.0, 0.0, 3.0)
        );
        assert_eq!(w[2].abs_error, measure(&zero, &data).max_abs_error - 1.0);
        assert_eq!(worst_points(&zero, &data, 10).len(), 5);
    }

    #[test]
    fn errors_near_the_top_of_the_f64_range_give_finite_metrics() {
        assert_eq!(SCALE, 2f64.powi(-600));
        // f = 10³⁰⁰ against values 0 and 1: every e² overflows, the sums of |e| too
        let data = FitData::new(
            vec!["x".into()],
            (0..10_000).map(|i| i as f64 / 9_999.0).collect(),
            (0..10_000).map(|i| (i % 2) as f64).collect(),
            vec![(0.0, 1.0)],
        )
        .unwrap();
        let huge = constant(1e300);
        let m = measure(&huge, &data);
        assert_eq!(m.non_finite, 0);
        for v in [m.mae, m.rmse, m.max_abs_error] {
            assert!((v / 1e300 - 1.0).abs() < 1e-12, "{m:?}");
        }
    }
}
