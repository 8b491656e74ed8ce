//! Errors of the fitting library: each names the cause and, where there is one, the fix.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error("{what}: expected {expected} values but got {got}; {fix}")]
    ShapeMismatch {
        what: &'static str,
        expected: usize,
        got: usize,
        fix: &'static str,
    },

    #[error("{what} {index} is {value}, not a finite number; remove or repair NaN/infinite entries before fitting")]
    NonFinite {
        what: &'static str,
        index: usize,
        value: f64,
    },

    #[error("{what} {index} is {value}, beyond the largest magnitude a fit accepts, ±{max:e}: the squared errors of such values overflow f64; rescale the values (e.g. divide them by their largest magnitude) before fitting")]
    ValueTooLarge {
        what: &'static str,
        index: usize,
        value: f64,
        max: f64,
    },

    #[error("variable '{name}' is named twice; give every variable its own name")]
    DuplicateVariable { name: String },

    #[error("a fit needs between 1 and {max} variables, got {got}; fit fewer variables at a time")]
    BadDimension { got: usize, max: usize },

    #[error("the domain of variable '{name}' is [{lo}, {hi}]; it must be finite with lo < hi (a constant variable carries no information: drop it)")]
    InvalidDomain { name: String, lo: f64, hi: f64 },

    #[error("point {index} has {name} = {value}, outside its domain [{lo}, {hi}]; widen the domain or drop the point")]
    OutsideDomain {
        index: usize,
        name: String,
        value: f64,
        lo: f64,
        hi: f64,
    },

    #[error(
        "transform '{transform}' of variable '{name}' is not usable on [{lo}, {hi}]: {reason}"
    )]
    InvalidTransform {
        transform: String,
        name: String,
        lo: f64,
        hi: f64,
        reason: &'static str,
    },

    #[error("weight {index} is {value}; weights must be finite and non-negative (use 0 to drop a point)")]
    InvalidWeight { index: usize, value: f64 },

    #[error("{form} has {coefficients} free coefficients but only {points} data points carry weight; lower the degree or supply more points")]
    TooFewPoints {
        form: String,
        coefficients: usize,
        points: usize,
    },

    #[error("{form} has degree {degree} in '{name}', but the data have only {distinct} distinct values of '{name}', which determine a degree of at most {}; lower the degree in '{name}' or supply data at more values of it", distinct.saturating_sub(1))]
    TooFewValues {
        form: String,
        name: String,
        degree: u32,
        distinct: usize,
    },

    #[error("degree {degree} is above the supported maximum {max}; monomial coefficients of such degrees are meaningless in f64 — lower the degree")]
    DegreeTooHigh { degree: u32, max: u32 },

    #[error("the least-squares system for {what} is singular or nearly so (scaled condition number {condition:.3e}); lower the degree, remove duplicate points, or check that every variable varies over the data")]
    Singular { what: String, condition: f64 },

    #[error("invalid setting {name} = {value}: {expected}")]
    InvalidSetting {
        name: &'static str,
        value: String,
        expected: &'static str,
    },

    #[error("no usable starting point for {form}: every start ({tried}) has a denominator that vanishes or changes sign at the data; lower the degree or fit a polynomial")]
    NoFeasibleStart { form: String, tried: String },

    #[error("exponent set: {problem}; {fix}")]
    BadExponents { problem: String, fix: String },

    #[error("structured form: {problem}; {fix}")]
    BadStructure { problem: String, fix: String },

    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },

    #[error("the {solver} solver failed: {message}")]
    Solver {
        solver: &'static str,
        message: String,
    },

    #[error("invalid fit JSON ({0}); load only files written by FitResult::to_json")]
    Json(#[from] serde_json::Error),
}

/// Result type of the fitting library.
pub type Result<T> = std::result::Result<T, FitError>;
