//! Globally adaptive Gauss–Kronrod quadrature (G7–K15), the white furnace test's own integrator.
//!
//! It is deliberately *not* the engine's rule ([`crate::quadrature`]): the furnace test must
//! integrate the compensated BSDF independently of the tables it checks. The scheme is QUADPACK's
//! QAG (Piessens et al. 1983): keep a list of intervals with their 15-point Kronrod estimates,
//! split the one with the largest error estimate until the total estimate meets the tolerance or
//! the interval budget is spent. Initial breakpoints (known kinks) seed the list. Deterministic:
//! intervals are chosen by error with ties broken by position, and summed in order.

// The Gauss–Kronrod constants are quoted to QUADPACK's 33 digits, as published.
#![allow(clippy::excessive_precision)]

use crate::math::CompensatedSum;

/// Kronrod nodes on [−1, 1] (non-negative half; QUADPACK `qk15`).
const XGK: [f64; 8] = [
    0.991_455_371_120_812_639_206_854_697_526_329,
    0.949_107_912_342_758_524_526_189_684_047_851,
    0.864_864_423_359_769_072_789_712_788_640_926,
    0.741_531_185_599_394_439_863_864_773_280_788,
    0.586_087_235_467_691_130_294_144_845_693_013,
    0.405_845_151_377_397_166_906_606_412_076_961,
    0.207_784_955_007_898_467_600_689_403_773_245,
    0.0,
];
/// Kronrod weights (QUADPACK `qk15`).
const WGK: [f64; 8] = [
    0.022_935_322_010_529_224_963_732_008_058_970,
    0.063_092_092_629_978_553_290_700_663_189_204,
    0.104_790_010_322_250_183_839_876_322_541_518,
    0.140_653_259_715_525_918_745_189_590_510_238,
    0.169_004_726_639_267_902_826_583_426_598_550,
    0.190_350_578_064_785_409_913_256_402_421_014,
    0.204_432_940_075_298_892_414_161_999_234_649,
    0.209_482_141_084_727_828_012_999_174_891_714,
];
/// Gauss weights of the embedded 7-point rule, at XGK[1], XGK[3], XGK[5], XGK[7].
const WG: [f64; 4] = [
    0.129_484_966_168_869_693_270_611_432_679_082,
    0.279_705_391_489_276_667_901_467_771_423_780,
    0.381_830_050_505_118_944_950_369_775_488_975,
    0.417_959_183_673_469_387_755_102_040_816_327,
];

/// Result of an adaptive integration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Integral {
    pub value: f64,
    /// Sum of the per-interval error estimates (QUADPACK's scaled |K15 − G7|).
    pub error: f64,
    /// Integrand evaluations used.
    pub evaluations: usize,
    /// False when the interval budget ran out before the tolerance was met.
    pub converged: bool,
}

/// Tolerances and budget of [`integrate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Absolute tolerance on the total error estimate.
    pub abs: f64,
    /// Relative tolerance (of |value|); the looser of the two applies.
    pub rel: f64,
    /// Most intervals kept.
    pub max_intervals: usize,
}

/// One 15-point Kronrod estimate on [a, b]: (value, error estimate).
fn kronrod(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut resk = fc * WGK[7];
    let mut resg = fc * WG[3];
    let mut resabs = resk.abs();
    let mut fv = [(0.0, 0.0); 7];
    for (j, v) in fv.iter_mut().enumerate() {
        let dx = h * XGK[j];
        let (f1, f2) = (f(c - dx), f(c + dx));
        *v = (f1, f2);
        resk += WGK[j] * (f1 + f2);
        resabs += WGK[j] * (f1.abs() + f2.abs());
        if j % 2 == 1 {
            resg += WG[j / 2] * (f1 + f2);
        }
    }
    let mean = 0.5 * resk;
    let mut resasc = WGK[7] * (fc - mean).abs();
    for (j, &(f1, f2)) in fv.iter().enumerate() {
        resasc += WGK[j] * ((f1 - mean).abs() + (f2 - mean).abs());
    }
    let (value, resabs, resasc) = (resk * h, resabs * h.abs(), resasc * h.abs());
    let mut err = ((resk - resg) * h).abs();
    // QUADPACK's scaling: |K − G| over-estimates the error of K15 for smooth integrands.
    if resasc != 0.0 && err != 0.0 {
        err = resasc * (200.0 * err / resasc).powf(1.5).min(1.0);
    }
    // Round-off floor (QUADPACK: 50·ε·∫|f|).
    let floor = 50.0 * f64::EPSILON * resabs;
    if resabs > f64::MIN_POSITIVE / (50.0 * f64::EPSILON) {
        err = err.max(floor);
    }
    (value, err)
}

/// ∫ f over [breaks[0], breaks.last()], the breaks (sorted, at least two) seeding the intervals.
/// A non-finite integrand value is a bug in the caller; it propagates into the result.
pub fn integrate(mut f: impl FnMut(f64) -> f64, breaks: &[f64], tol: &Tolerance) -> Integral {
    let mut intervals: Vec<(f64, f64, f64, f64)> =
        Vec::with_capacity(tol.max_intervals.max(breaks.len()));
    let mut evaluations = 0;
    for w in breaks.windows(2) {
        if w[1] > w[0] {
            let (v, e) = kronrod(&mut f, w[0], w[1]);
            evaluations += 15;
            intervals.push((w[0], w[1], v, e));
        }
    }
    loop {
        let mut value = CompensatedSum::default();
        let mut error = 0.0;
        let mut worst = None::<usize>;
        for (k, iv) in intervals.iter().enumerate() {
            value.add(iv.2);
            error += iv.3;
            if worst.is_none_or(|w| iv.3 > intervals[w].3) {
                worst = Some(k);
            }
        }
        let value = value.value();
        let target = tol.abs.max(tol.rel * value.abs());
        let Some(w) = worst else {
            return Integral {
                value: 0.0,
                error: 0.0,
                evaluations,
                converged: true,
            };
        };
        let (a, b, _, e) = intervals[w];
        let m = 0.5 * (a + b);
        // Converged, out of budget, or the worst interval cannot be split in floating point.
        if error <= target || intervals.len() >= tol.max_intervals || !(m > a && m < b) || e == 0.0
        {
            return Integral {
                value,
                error,
                evaluations,
                converged: error <= target,
            };
        }
        let (v1, e1) = kronrod(&mut f, a, m);
        let (v2, e2) = kronrod(&mut f, m, b);
        evaluations += 30;
        intervals[w] = (a, m, v1, e1);
        intervals.insert(w + 1, (m, b, v2, e2));
    }
}

/// Like [`integrate`], but each piece between consecutive breaks is mapped by the sigmoidal
/// x = a + (b − a)(3t² − 2t³) (Sidi 1993), whose derivative vanishes at both ends: square-root
/// behaviour at a break (a kink curve tangent to a line, a critical angle) becomes smooth in t, so
/// breaks may sit at such points without the adaptive rule crawling towards them.
pub fn integrate_smoothed(
    mut f: impl FnMut(f64) -> f64,
    breaks: &[f64],
    tol: &Tolerance,
) -> Integral {
    let pieces: Vec<(f64, f64)> = breaks
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| (w[0], w[1]))
        .collect();
    let seeds: Vec<f64> = (0..=pieces.len()).map(|k| k as f64).collect();
    integrate(
        |t: f64| {
            let k = (t.floor() as usize).min(pieces.len().saturating_sub(1));
            let (a, b) = pieces[k];
            let u = t - k as f64;
            let x = a + (b - a) * u * u * (3.0 - 2.0 * u);
            let dx = (b - a) * 6.0 * u * (1.0 - u);
            if dx == 0.0 {
                0.0
            } else {
                f(x) * dx
            }
        },
        &seeds,
        tol,
    )
}

/// Adds breaks at `at ± width·4^k` (k = 0, 1, …) between `lo` and `hi`: a geometric grading
/// towards a feature of the given width (a near-singularity at distance ~width from `at`), so that
/// the adaptive rule sees it from its first estimate. Nothing is added for a feature as wide as a
/// quarter of the range.
// `!(width > 0.0)` is deliberate: it refuses NaN too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn grade_towards(breaks: &mut Vec<f64>, at: f64, width: f64, lo: f64, hi: f64) {
    const RATIO: f64 = 4.0;
    if !(width > 0.0) || !width.is_finite() {
        return;
    }
    for (side, room) in [(-1.0, at - lo), (1.0, hi - at)] {
        let mut d = width;
        while d < 0.25 * room {
            breaks.push(at + side * d);
            d *= RATIO;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TIGHT: Tolerance = Tolerance {
        abs: 1e-13,
        rel: 0.0,
        max_intervals: 500,
    };

    #[test]
    fn smooth_integrals_are_exact() {
        let r = integrate(|x: f64| x.exp(), &[0.0, 1.0], &TIGHT);
        assert!(
            (r.value - (std::f64::consts::E - 1.0)).abs() < 1e-14,
            "{r:?}"
        );
        assert!(r.converged && r.evaluations == 15);
    }

    #[test]
    fn endpoint_and_interior_singularities_converge() {
        // ∫0^1 √x dx = 2/3: square-root end point, refined adaptively.
        let r = integrate(|x: f64| x.sqrt(), &[0.0, 1.0], &TIGHT);
        assert!((r.value - 2.0 / 3.0).abs() < 1e-12, "{r:?}");
        assert!(r.converged);
        // ∫0^1 √|x − 1/3| dx with the kink unknown to the integrator.
        let exact = 2.0 / 3.0 * ((1.0f64 / 3.0).powf(1.5) + (2.0f64 / 3.0).powf(1.5));
        let r = integrate(|x: f64| (x - 1.0 / 3.0).abs().sqrt(), &[0.0, 1.0], &TIGHT);
        assert!((r.value - exact).abs() < 1e-12, "{} vs {exact}", r.value);
    }

    #[test]
    fn smoothed_pieces_absorb_square_root_ends() {
        // ∫0^1 √(x(1 − x)) dx = π/8 with both ends square-root singular
        let r = integrate_smoothed(
            |x: f64| (x * (1.0 - x)).max(0.0).sqrt(),
            &[0.0, 1.0],
            &TIGHT,
        );
        assert!(
            (r.value - std::f64::consts::PI / 8.0).abs() < 1e-13,
            "{r:?}"
        );
        assert!(r.evaluations < 200, "{}", r.evaluations);
    }

    #[test]
    fn grading_finds_a_narrow_feature() {
        // a bump of width 1e-6 at 0.3: invisible to the first 15-point estimate on [0, 1]
        let w = 1e-6;
        let f = |x: f64| 1.0 / (1.0 + ((x - 0.3) / w).powi(2));
        let exact = w * ((0.7 / w).atan() + (0.3 / w).atan());
        let mut breaks = vec![0.0, 1.0];
        grade_towards(&mut breaks, 0.3, w, 0.0, 1.0);
        breaks.sort_by(f64::total_cmp);
        let r = integrate(f, &breaks, &TIGHT);
        assert!((r.value - exact).abs() < 1e-14, "{} vs {exact}", r.value);
    }

    #[test]
    fn budget_exhaustion_is_reported() {
        let tol = Tolerance {
            abs: 1e-15,
            rel: 0.0,
            max_intervals: 3,
        };
        let r = integrate(|x: f64| (x - 0.3).abs().sqrt(), &[0.0, 1.0], &tol);
        assert!(!r.converged && r.error > 0.0);
    }
}
