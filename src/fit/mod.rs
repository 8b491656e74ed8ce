//! Fitting: polynomial and rational approximations of tabulated albedos.
//!
//! Data flow: [`FitData`] (scattered points, values, weights, domain) + per-variable
//! [`InputTransform`]s → [`fit_polynomial`] / [`fit_rational`] / [`sweep`] → [`FitResult`]
//! (monomial coefficients in scikit-learn `PolynomialFeatures` order, metrics, solver record,
//! pole certificate), serialisable to deterministic JSON.
//!
//! - [`basis`]: monomial exponents, the Chebyshev solving basis and the exact conversion between them.
//! - [`linear`]: tall linear least squares by TSQR (chunked, deterministic).
//! - [`lm`]: Levenberg–Marquardt with accumulated normal equations, an argmin `Solver` run by argmin's `Executor`.
//! - [`trust_region`]: argmin's trust-region method (dogleg) on the same problems, the second solver.
//! - [`polynomial`], [`rational`]: the fits; [`robust`]: mean-absolute and minimax objectives;
//!   [`maxmean`]: the exact best linear coefficients in max + λ·mean error (a linear program).
//! - [`metrics`]: MAE, RMSE, max absolute / relative error and where they occur.
//! - [`poles`]: Bernstein-subdivision proof that the denominator has no zero on the domain.
//! - [`sweep`]: degree sweeps, their Pareto front and the best certified fit under a coefficient budget.
//! - [`defaults`]: the default sweep plan of a table (degrees, transforms, budgets).
//! - [`check`]: off-grid check points of a model's table with exact values, the headline errors.
//! - [`file`]: fit files, the one format every fit is written in and read back from.
//! - [`paper`]: the published coefficients and tables of Sforza & Pellacini 2022.
//!
//! ```
//! use furnace::fit::{fit_rational, FitData, InputTransform, Objective, RationalOptions};
//! let ax: Vec<f64> = (0..16).map(|i| i as f64 / 15.0).collect();
//! let vals = ax.iter().flat_map(|&r| ax.iter().map(move |&m| (1.0 + r) / (2.0 + m))).collect();
//! let data = FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
//! let fit = fit_rational(&data, &[InputTransform::Identity; 2], 1, 1, Objective::LeastSquares,
//!                        &RationalOptions::default()).unwrap();
//! assert!(fit.metrics.max_abs_error < 1e-10 && fit.is_usable());
//! assert!((fit.eval(&[0.5, 0.5]) - 0.6).abs() < 1e-10);
//! ```

// Negated comparisons (`!(x > 0.0)`) are deliberate: they treat NaN as failure.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops mirror the formulas they implement.
#![allow(clippy::needless_range_loop)]

/// Version of the fitter's arithmetic: the same table, options and version give the same fits
/// bit for bit. Raised whenever a change to the solvers, forms or selection changes any fit for
/// unchanged inputs, so that `furnace run` refits instead of reusing a previous sweep's files.
pub const FITTER_VERSION: u32 = 3;

pub mod basis;
pub mod check;
pub mod compare;
pub mod data;
pub mod defaults;
pub mod error;
pub mod file;
pub mod form;
pub mod job;
pub mod linear;
pub mod lm;
mod maxmean;
pub mod metrics;
mod model;
pub mod paper;
pub mod poles;
pub mod polynomial;
pub mod rational;
pub mod result;
mod robust;
pub mod source;
pub mod structured;
pub mod sweep;
pub mod trust_region;

pub use basis::{exponents, n_terms, ExponentSet, Polynomial};
pub use data::{sin_squared_series, FitData, InputTransform};
pub use error::{FitError, Result};
pub use form::{fit_form, parse_form, split_form, tensor_form, FitOptions};
pub use lm::{
    LeastSquares, LeastSquaresProblem, LevenbergMarquardt, LmReport, LmSolver, LmState, LsqMethod,
    LsqState, TerminationReason,
};
pub use metrics::{measure, Metrics};
pub use poles::{CertifyOptions, PoleVerdict};
pub use polynomial::{fit_polynomial, PolynomialOptions};
pub use rational::{fit_rational, RationalOptions};
pub use result::{
    Approximant, Family, FitResult, Form, FormSpec, LawsonPathIterate, Objective, SolverReport,
    StartReport, Structure, Term,
};
pub use structured::{fit_structured, StructuredOptions};
pub use sweep::{
    best_under_budget, pareto_front, select_under_budget, sweep, sweep_detailed,
    sweep_with_progress, Score, SkippedFit, SweepEvent, SweepOptions, SweepReport,
};
pub use trust_region::{TrustRegionSettings, TrustRegionSolver};

#[cfg(test)]
mod paper_tests;
