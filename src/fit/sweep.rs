//! Degree sweeps (the paper's Fig. 3: polynomials and rationals of increasing degree, MAE
//! against number of coefficients) and the choice of the best certified fit under a budget.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::basis::n_terms;
use super::data::{FitData, InputTransform};
use super::error::Result;
use super::polynomial::{fit_polynomial, PolynomialOptions};
use super::rational::{fit_rational, RationalOptions};
use super::result::{FitResult, Objective};

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    pub polynomial_degrees: Vec<u32>,
    /// Total degree n of P and Q (n/n rationals, as in the paper).
    pub rational_degrees: Vec<u32>,
    /// Input-transform sets to try (one transform per variable each).
    pub transform_sets: Vec<Vec<InputTransform>>,
    pub objective: Objective,
    pub polynomial: PolynomialOptions,
    pub rational: RationalOptions,
    /// Seed each rational degree with the previous degree's result (recommended: the error
    /// then never grows with degree, up to the subsampled exploration).
    pub continue_degrees: bool,
}

impl SweepOptions {
    /// The paper's sweep (Sforza & Pellacini 2022, §3.5): 2D polynomials and rationals of degree
    /// 1–10; 3D polynomials 1–7 and rationals 1–5; 1D like 2D. Identity transforms.
    pub fn for_dimension(d: usize) -> SweepOptions {
        let (poly, rat) = if d >= 3 {
            (1..=7, 1..=5)
        } else {
            (1..=10, 1..=10)
        };
        SweepOptions {
            polynomial_degrees: poly.collect(),
            rational_degrees: rat.collect(),
            transform_sets: vec![vec![InputTransform::Identity; d]],
            objective: Objective::LeastSquares,
            polynomial: PolynomialOptions::default(),
            rational: RationalOptions::default(),
            continue_degrees: true,
        }
    }
}

/// A degree that was not fitted, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkippedFit {
    pub form: String,
    pub transforms: Vec<InputTransform>,
    pub reason: String,
}

/// All fits of a sweep plus the ones that could not be made.
#[derive(Clone, Debug)]
pub struct SweepReport {
    pub results: Vec<FitResult>,
    pub skipped: Vec<SkippedFit>,
}

/// Runs the sweep; degrees that cannot be fitted (too few points, singular, no feasible start)
/// are listed in `skipped` with the reason. Results are in the order transform set →
/// polynomials by degree → rationals by degree; each carries its fit time.
pub fn sweep_detailed(data: &FitData, opts: &SweepOptions) -> Result<SweepReport> {
    sweep_with_progress(data, opts, &mut |_| {})
}

/// One finished step of a sweep, for progress reports.
pub enum SweepEvent<'a> {
    Fitted(&'a FitResult),
    Skipped(&'a SkippedFit),
}

/// [`sweep_detailed`], calling `progress` after every fit made or skipped.
pub fn sweep_with_progress(
    data: &FitData,
    opts: &SweepOptions,
    progress: &mut dyn FnMut(SweepEvent<'_>),
) -> Result<SweepReport> {
    data.validate()?;
    let d = data.dim();
    let mut results = Vec::new();
    let mut skipped = Vec::new();
    for transforms in &opts.transform_sets {
        for &deg in &opts.polynomial_degrees {
            match fit_polynomial(data, transforms, deg, opts.objective, &opts.polynomial) {
                Ok(r) => {
                    progress(SweepEvent::Fitted(&r));
                    results.push(r);
                }
                Err(e) => {
                    let s = SkippedFit {
                        form: format!("polynomial of degree {deg}"),
                        transforms: transforms.clone(),
                        reason: e.to_string(),
                    };
                    progress(SweepEvent::Skipped(&s));
                    skipped.push(s);
                }
            }
        }
        let mut previous: Option<FitResult> = None;
        for &deg in &opts.rational_degrees {
            let form = format!("rational of degree {deg}/{deg}");
            let coefficients = 2 * n_terms(d, deg) - 1;
            if coefficients > data.n_weighted() {
                let reason = format!("{coefficients} coefficients but only {} data points; lower the degree or use a finer table", data.n_weighted());
                let s = SkippedFit {
                    form,
                    transforms: transforms.clone(),
                    reason,
                };
                progress(SweepEvent::Skipped(&s));
                skipped.push(s);
                continue;
            }
            let mut ro = opts.rational.clone();
            if opts.continue_degrees {
                if let Some(p) = previous.as_ref().filter(|p| p.is_usable()) {
                    ro.extra_starts.push((
                        format!("previous degree ({})", p.form.label()),
                        p.approximant.clone(),
                    ));
                }
            }
            let t = Instant::now();
            match fit_rational(data, transforms, deg, deg, opts.objective, &ro) {
                Ok(mut r) => {
                    r.fit_seconds = t.elapsed().as_secs_f64();
                    progress(SweepEvent::Fitted(&r));
                    previous = Some(r.clone());
                    results.push(r);
                }
                Err(e) => {
                    let s = SkippedFit {
                        form,
                        transforms: transforms.clone(),
                        reason: e.to_string(),
                    };
                    progress(SweepEvent::Skipped(&s));
                    skipped.push(s);
                }
            }
        }
    }
    Ok(SweepReport { results, skipped })
}

/// Runs the sweep and returns the fits made (see [`sweep_detailed`] for the skipped ones).
pub fn sweep(data: &FitData, opts: &SweepOptions) -> Result<Vec<FitResult>> {
    Ok(sweep_detailed(data, opts)?.results)
}

/// The usable (pole-certified, finite) fit with at most `max_coefficients` coefficients and the
/// lowest maximum absolute error (ties: fewer coefficients, then earlier in the list).
pub fn best_under_budget(results: &[FitResult], max_coefficients: usize) -> Option<&FitResult> {
    results
        .iter()
        .filter(|r| r.is_usable() && r.n_coefficients <= max_coefficients)
        .min_by(|a, b| {
            a.metrics
                .max_abs_error
                .total_cmp(&b.metrics.max_abs_error)
                .then(a.n_coefficients.cmp(&b.n_coefficients))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_and_budget() {
        let ax: Vec<f64> = (0..15).map(|i| i as f64 / 14.0).collect();
        let vals = ax
            .iter()
            .flat_map(|&x| ax.iter().map(move |&y| (x, y)))
            .map(|(x, y)| (1.0 + x * y).sqrt() / (1.1 + x))
            .collect();
        let data =
            FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap();
        let opts = SweepOptions {
            polynomial_degrees: vec![1, 2, 3, 4],
            rational_degrees: vec![1, 2, 3],
            transform_sets: vec![
                vec![InputTransform::Identity; 2],
                vec![InputTransform::Identity, InputTransform::Sqrt],
            ],
            ..SweepOptions::for_dimension(2)
        };
        let rep = sweep_detailed(&data, &opts).unwrap();
        assert_eq!(
            rep.results.len() + rep.skipped.len(),
            14,
            "{:?}",
            rep.skipped
        );
        // polynomial errors fall with degree
        let poly: Vec<f64> = rep.results[..4].iter().map(|r| r.metrics.rmse).collect();
        assert!(poly.windows(2).all(|w| w[1] <= w[0]), "{poly:?}");
        let best = best_under_budget(&rep.results, 11).unwrap();
        assert!(best.n_coefficients <= 11 && best.is_usable());
        assert!(rep
            .results
            .iter()
            .filter(|r| r.n_coefficients <= 11 && r.is_usable())
            .all(|r| r.metrics.max_abs_error >= best.metrics.max_abs_error));
        assert!(best_under_budget(&rep.results, 0).is_none());
    }
}
