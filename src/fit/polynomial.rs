//! Polynomial fits: weighted linear least squares in the Chebyshev basis (TSQR, see
//! [`super::linear`]), converted to monomials; other objectives by reweighting.

use std::time::Instant;

use super::basis::check_degree;
use super::data::{FitData, InputTransform, Prepared};
use super::error::{FitError, Result};
use super::linear::solve_lstsq;
use super::model::{LinearisedRows, Model};
use super::poles::CertifyOptions;
use super::result::{FitResult, Form, Objective, SolverReport};
use super::robust::{reweight, Solve, Solved};

/// Settings of a polynomial fit.
#[derive(Clone, Debug, PartialEq)]
pub struct PolynomialOptions {
    /// Reweighting rounds for MeanAbsolute / Minimax.
    pub reweight_iterations: usize,
}

impl Default for PolynomialOptions {
    fn default() -> Self {
        PolynomialOptions {
            reweight_iterations: 60,
        }
    }
}

/// Least-squares polynomial in Chebyshev parameters (crate-internal: also seeds rationals).
pub(crate) fn solve_polynomial(
    model: &Model,
    data: &Prepared,
    extra: Option<&[f64]>,
    what: &str,
) -> Result<(Vec<f64>, f64)> {
    let s = solve_lstsq(
        &LinearisedRows {
            model,
            data,
            extra,
            phi: None,
        },
        what,
    )?;
    Ok((s.x, s.condition))
}

/// Fits a polynomial of total degree `degree` in the transformed variables.
pub fn fit_polynomial(
    data: &FitData,
    transforms: &[InputTransform],
    degree: u32,
    objective: Objective,
    opts: &PolynomialOptions,
) -> Result<FitResult> {
    check_degree(degree)?;
    let model = Model::polynomial(data.dim(), degree);
    fit_polynomial_model(
        data,
        transforms,
        Form::Polynomial { degree },
        &model,
        objective,
        opts,
    )
}

/// [`fit_polynomial`] for any (polynomial) model.
pub(crate) fn fit_polynomial_model(
    data: &FitData,
    transforms: &[InputTransform],
    form: Form,
    model: &Model,
    objective: Objective,
    opts: &PolynomialOptions,
) -> Result<FitResult> {
    let start = Instant::now();
    let prep = Prepared::new(data, transforms)?;
    let model = &model.clone().with_scales(&prep.scales);
    let n_coef = model.n_params();
    if prep.n_weighted() < n_coef {
        return Err(FitError::TooFewPoints {
            form: form.label(),
            coefficients: n_coef,
            points: prep.n_weighted(),
        });
    }
    let (p0, condition) = solve_polynomial(model, &prep, None, &form.label())?;
    let e0 = model.errors(&prep, None, &p0).unwrap_or_default();
    let mut solve = |extra: &[f64], _warm: &[f64]| -> Result<Option<Solved>> {
        match solve_polynomial(model, &prep, Some(extra), &form.label()) {
            Ok((p, _)) => {
                let e = model.errors(&prep, None, &p).unwrap_or_default();
                Ok(Some((p, e, None, 0)))
            }
            // a reweighted system can lose rank when the weights concentrate: keep the best so far
            Err(FitError::Singular { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    };
    let rw = reweight(
        objective,
        opts.reweight_iterations,
        &prep.w,
        (p0, e0),
        &mut solve as &mut Solve<'_>,
        None,
        &mut |_| true,
    )?;
    let approximant = model.to_approximant(data, transforms, &prep, &rw.params);
    let solver = SolverReport {
        method: match objective {
            Objective::LeastSquares => "linear least squares (Chebyshev basis, TSQR + SVD)".into(),
            Objective::MeanAbsolute => {
                "IRLS on linear least squares (Chebyshev basis, TSQR + SVD)".into()
            }
            Objective::Minimax => {
                "Lawson reweighting of linear least squares (Chebyshev basis, TSQR + SVD)".into()
            }
        },
        termination: None,
        converged: rw.converged,
        iterations: 0,
        reweighting_iterations: rw.rounds,
        lawson_path: None,
        condition: Some(condition),
        exploration_points: prep.len(),
        starts: Vec::new(),
    };
    let certify = CertifyOptions::default();
    let mut result = FitResult::assess(form, approximant, data, objective, Some(solver), &certify)?
        .with_path(&rw.path, data, &certify, &|p| {
            model.to_approximant(data, transforms, &prep, p)
        })?;
    result.fit_seconds = start.elapsed().as_secs_f64();
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid2(n: usize, f: impl Fn(f64, f64) -> f64) -> FitData {
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let vals = ax
            .iter()
            .flat_map(|&x| ax.iter().map(move |&y| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap()
    }

    #[test]
    fn recovers_an_exact_polynomial_in_monomial_form() {
        let data = grid2(12, |x, y| 0.5 - x + 2.0 * y + 3.0 * x * y - y * y * y);
        let r = fit_polynomial(
            &data,
            &[InputTransform::Identity; 2],
            3,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        let want = [0.5, -1.0, 2.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, -1.0];
        for (c, w) in r.approximant.numerator.coefficients.iter().zip(want) {
            assert!((c - w).abs() < 1e-12, "{c} vs {w}");
        }
        assert!(r.metrics.max_abs_error < 1e-13);
        assert_eq!(r.n_coefficients, 10);
        assert!(r.is_usable());
    }

    #[test]
    fn transform_is_applied_before_the_basis() {
        // y = √x is a degree-1 polynomial in t = √x
        let ax: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
        let data = FitData::from_grid(
            vec!["x".into()],
            std::slice::from_ref(&ax),
            ax.iter().map(|x| x.sqrt()).collect(),
        )
        .unwrap();
        let r = fit_polynomial(
            &data,
            &[InputTransform::Sqrt],
            1,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        assert!(r.metrics.max_abs_error < 1e-14, "{:?}", r.metrics);
        assert!((r.eval(&[0.25]) - 0.5).abs() < 1e-14);
    }

    #[test]
    fn too_high_degree_is_an_error_that_names_the_fix() {
        let data = grid2(3, |x, y| x + y);
        let e = fit_polynomial(
            &data,
            &[InputTransform::Identity; 2],
            3,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                FitError::TooFewPoints {
                    coefficients: 10,
                    points: 9,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("lower the degree"));
    }

    #[test]
    fn objectives_order_their_own_metric() {
        // |x − 0.3| is not polynomial: each objective should win on its own metric
        let ax: Vec<f64> = (0..201).map(|i| i as f64 / 200.0).collect();
        let data = FitData::from_grid(
            vec!["x".into()],
            std::slice::from_ref(&ax),
            ax.iter().map(|x| (x - 0.3f64).abs()).collect(),
        )
        .unwrap();
        let fit = |o| {
            fit_polynomial(
                &data,
                &[InputTransform::Identity],
                4,
                o,
                &Default::default(),
            )
            .unwrap()
        };
        let (ls, mae, mm) = (
            fit(Objective::LeastSquares),
            fit(Objective::MeanAbsolute),
            fit(Objective::Minimax),
        );
        assert!(
            mae.metrics.mae < ls.metrics.mae,
            "{} vs {}",
            mae.metrics.mae,
            ls.metrics.mae
        );
        assert!(mm.metrics.max_abs_error < ls.metrics.max_abs_error);
        assert!(ls.metrics.rmse <= mae.metrics.rmse && ls.metrics.rmse <= mm.metrics.rmse);
    }

    #[test]
    fn weights_are_respected() {
        // two clusters with different constants; weight one cluster out
        let data = FitData::new(
            vec!["x".into()],
            vec![0.0, 0.1, 0.9, 1.0],
            vec![1.0, 1.0, 5.0, 5.0],
            vec![(0.0, 1.0)],
        )
        .unwrap()
        .with_weights(vec![1.0, 1.0, 0.0, 0.0])
        .unwrap();
        let r = fit_polynomial(
            &data,
            &[InputTransform::Identity],
            0,
            Objective::LeastSquares,
            &Default::default(),
        )
        .unwrap();
        assert!((r.eval(&[0.5]) - 1.0).abs() < 1e-14);
    }
}
