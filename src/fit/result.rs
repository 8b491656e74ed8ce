//! The fitted function ([`Approximant`]) and the full record of a fit ([`FitResult`]), both
//! serialisable to deterministic JSON (struct fields in declaration order, f64 in shortest
//! round-trip form as serde_json writes them).

use serde::{Deserialize, Serialize};

use super::basis::{n_terms, ExponentSet, Polynomial};
use super::data::{
    inverse_point, transform_point, transformed_box, FitData, InputTransform, MAX_DIM,
};
use super::error::{FitError, Result};
use super::lm::TerminationReason;
use super::metrics::{measure, Metrics};
use super::poles::{certify_polynomial, CertifyOptions, PoleVerdict, RawVerdict};

/// What the fit minimised (of the weighted residuals w_i (f(x_i) − y_i)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Σ (w e)² — the default.
    #[default]
    LeastSquares,
    /// Σ |w e|, by iteratively reweighted least squares.
    MeanAbsolute,
    /// max |w e|, by Lawson-style reweighting.
    Minimax,
}

/// The functional form: what [`super::fit_form`] fits, and what a fit file records.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Form {
    Polynomial {
        degree: u32,
    },
    /// P/Q with the denominator's constant term fixed to 1.
    Rational {
        numerator_degree: u32,
        denominator_degree: u32,
    },
    /// P/Q (or P without `denominator`) over downward-closed exponent sets: per-variable
    /// degrees, and the split-sum form Σ_a t_j^a·P_a(others)/Q(others) with a shared
    /// denominator ([`ExponentSet::split`]).
    Exponents {
        numerator: ExponentSet,
        denominator: Option<ExponentSet>,
    },
}

/// The form specification callers choose from; [`Form`] itself.
pub type FormSpec = Form;

impl Form {
    pub fn label(&self) -> String {
        match self {
            Form::Polynomial { degree } => format!("polynomial of degree {degree}"),
            Form::Rational {
                numerator_degree: n,
                denominator_degree: m,
            } => format!("rational of degree {n}/{m}"),
            Form::Exponents {
                numerator,
                denominator,
            } => match denominator {
                None => format!("polynomial over [{}]", numerator.label(&[])),
                Some(q) => format!(
                    "rational over [{}]/[{}]",
                    numerator.label(&[]),
                    q.label(&[])
                ),
            },
        }
    }

    /// [`Form::label`] with variable names.
    pub fn label_with(&self, names: &[String]) -> String {
        match self {
            Form::Exponents {
                numerator,
                denominator,
            } => match denominator {
                None => format!("polynomial over [{}]", numerator.label(names)),
                Some(q) => format!(
                    "rational over [{}]/[{}]",
                    numerator.label(names),
                    q.label(names)
                ),
            },
            _ => self.label(),
        }
    }

    /// The form part of a fit file name: `polynomial-5`, `rational-3`, and for exponent sets
    /// `rational-<P's set>-<Q's set>` (`polynomial-<P's set>`), a set written as its caps, `t`
    /// and its total, then `x` and the variables outside the total: the split form of degree 3
    /// in variable 0 over degree 4 / 3 in the others is `rational-3_4_4t4x0-0_3_3t3x0`.
    pub fn file_stem(&self) -> String {
        let token = |s: &ExponentSet| {
            let caps: Vec<String> = s.caps.iter().map(u32::to_string).collect();
            let outside: String = (0..s.dim())
                .filter(|&k| !s.in_total[k])
                .map(|k| k.to_string())
                .collect();
            let mut t = format!("{}t{}", caps.join("_"), s.total);
            if !outside.is_empty() {
                t.push('x');
                t.push_str(&outside);
            }
            t
        };
        match self {
            Form::Polynomial { degree } => format!("polynomial-{degree}"),
            Form::Rational {
                numerator_degree, ..
            } => format!("rational-{numerator_degree}"),
            Form::Exponents {
                numerator,
                denominator: None,
            } => format!("polynomial-{}", token(numerator)),
            Form::Exponents {
                numerator,
                denominator: Some(q),
            } => format!("rational-{}-{}", token(numerator), token(q)),
        }
    }

    /// Whether the form has a denominator.
    pub fn is_rational(&self) -> bool {
        match self {
            Form::Polynomial { .. } => false,
            Form::Rational { .. } => true,
            Form::Exponents { denominator, .. } => denominator.is_some(),
        }
    }

    /// The highest total degree of the numerator (the number in fit file names).
    pub fn numerator_degree(&self) -> u32 {
        match self {
            Form::Polynomial { degree } => *degree,
            Form::Rational {
                numerator_degree, ..
            } => *numerator_degree,
            Form::Exponents { numerator, .. } => numerator.max_total_degree(),
        }
    }

    /// Every number a fit of this form stores in `d` variables: P's coefficients and Q's, less
    /// Q's constant (fixed to 1).
    pub fn n_coefficients(&self, d: usize) -> usize {
        match self {
            Form::Polynomial { degree } => n_terms(d, *degree),
            Form::Rational {
                numerator_degree: n,
                denominator_degree: m,
            } => n_terms(d, *n) + n_terms(d, *m) - 1,
            Form::Exponents {
                numerator,
                denominator,
            } => numerator.len() + denominator.as_ref().map_or(0, |q| q.len() - 1),
        }
    }
}

/// f(x) = P(t)/Q(t) (or P(t)), t_k = transform_k(x_k), valid on the domain box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Approximant {
    pub variables: Vec<String>,
    pub transforms: Vec<InputTransform>,
    /// Domain box in the original variables.
    pub domain: Vec<(f64, f64)>,
    pub numerator: Polynomial,
    /// None for a polynomial. Coefficients include the constant term (1 after normalisation).
    pub denominator: Option<Polynomial>,
}

impl Approximant {
    /// Checks shapes so that [`Approximant::eval`] cannot index out of bounds.
    pub fn validate(&self) -> Result<()> {
        let d = self.variables.len();
        if d == 0 || d > MAX_DIM {
            return Err(FitError::BadDimension {
                got: d,
                max: MAX_DIM,
            });
        }
        for (what, n) in [
            ("transforms", self.transforms.len()),
            ("domain", self.domain.len()),
        ] {
            if n != d {
                return Err(FitError::ShapeMismatch {
                    what,
                    expected: d,
                    got: n,
                    fix: "give one entry per variable",
                });
            }
        }
        for p in std::iter::once(&self.numerator).chain(self.denominator.iter()) {
            if p.exponents.len() != p.coefficients.len() {
                return Err(FitError::ShapeMismatch {
                    what: "polynomial coefficients",
                    expected: p.exponents.len(),
                    got: p.coefficients.len(),
                    fix: "give one coefficient per exponent tuple",
                });
            }
            if let Some(e) = p.exponents.iter().find(|e| e.len() != d) {
                return Err(FitError::ShapeMismatch {
                    what: "exponent tuple",
                    expected: d,
                    got: e.len(),
                    fix: "one exponent per variable",
                });
            }
            super::basis::check_degree(p.degree())?;
            if !super::basis::is_downward_closed(&p.exponents) {
                return Err(FitError::ShapeMismatch {
                    what: "exponent tuples closed under lowering one exponent",
                    expected: p.exponents.len(),
                    got: p.exponents.len(),
                    fix: "with every monomial, list every monomial that divides it (a coefficient 0 is fine)",
                });
            }
            if let Some(i) = p.coefficients.iter().position(|c| !c.is_finite()) {
                return Err(FitError::NonFinite {
                    what: "coefficient",
                    index: i,
                    value: p.coefficients[i],
                });
            }
        }
        // every transform defined and monotone on the domain (a boundary layer's `by` in range)
        self.transformed_domain()?;
        Ok(())
    }

    /// Transformed coordinates t of x (original variables, one per variable).
    pub fn transform(&self, x: &[f64]) -> Vec<f64> {
        let mut t = vec![0.0; x.len()];
        transform_point(
            &self.transforms[..x.len().min(self.transforms.len())],
            x,
            &mut t,
        );
        t
    }

    /// f(x) in f64. x in the original variables, one per variable (NaN if the number of
    /// coordinates is wrong: there is no value to give).
    pub fn eval(&self, x: &[f64]) -> f64 {
        if x.len() != self.variables.len() || x.len() > MAX_DIM {
            return f64::NAN;
        }
        let mut t = [0.0f64; MAX_DIM];
        transform_point(&self.transforms, x, &mut t);
        let t = &t[..x.len()];
        let p = self.numerator.eval(t);
        match &self.denominator {
            Some(q) => p / q.eval(t),
            None => p,
        }
    }

    /// [`Self::eval`] at `out.len()` points of `d` coordinates each, one after the other in
    /// `xs` (original variables); the same to the bit, evaluated a block at a time.
    pub fn eval_many(&self, d: usize, xs: &[f64], out: &mut [f64]) {
        if d != self.variables.len() || d > MAX_DIM || xs.len() != d * out.len() {
            out.iter_mut().for_each(|o| *o = f64::NAN);
            return;
        }
        let mut ts = vec![0.0; xs.len()];
        let mut t = [0.0f64; MAX_DIM];
        for (x, tp) in xs.chunks_exact(d).zip(ts.chunks_exact_mut(d)) {
            transform_point(&self.transforms, x, &mut t);
            tp.copy_from_slice(&t[..d]);
        }
        self.numerator.eval_many(d, &ts, out);
        if let Some(q) = &self.denominator {
            let mut den = vec![0.0; out.len()];
            q.eval_many(d, &ts, &mut den);
            for (o, q) in out.iter_mut().zip(&den) {
                *o /= q;
            }
        }
    }

    /// The domain box in transformed variables.
    pub fn transformed_domain(&self) -> Result<Vec<(f64, f64)>> {
        transformed_box(&self.variables, &self.domain, &self.transforms)
    }

    /// Number of stored coefficients, not counting a denominator constant equal to 1.
    pub fn n_coefficients(&self) -> usize {
        let den = self.denominator.as_ref().map_or(0, |q| {
            let fixed = q
                .exponents
                .iter()
                .zip(&q.coefficients)
                .any(|(e, &c)| e.iter().all(|&x| x == 0) && c == 1.0);
            q.coefficients.len() - usize::from(fixed)
        });
        self.numerator.coefficients.len() + den
    }

    /// Proves (or refutes) that the denominator has no zero on the domain box.
    pub fn certify_poles(&self, opts: &CertifyOptions) -> PoleVerdict {
        let Some(q) = &self.denominator else {
            return PoleVerdict::NoDenominator;
        };
        let bounds = match self.transformed_domain() {
            Ok(b) => b,
            Err(e) => {
                return PoleVerdict::Undecided {
                    reason: e.to_string(),
                    boxes: 0,
                }
            }
        };
        match certify_polynomial(q, &bounds, opts) {
            RawVerdict::Certified {
                min_lower_bound,
                boxes,
            } => PoleVerdict::Certified {
                min_lower_bound,
                boxes,
            },
            RawVerdict::Undecided { reason, boxes } => PoleVerdict::Undecided { reason, boxes },
            RawVerdict::PoleFound { at } => PoleVerdict::PoleFound {
                at: inverse_point(&self.transforms, &at),
            },
        }
    }
}

/// How one starting point of a rational fit fared.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartReport {
    pub name: String,
    /// ½ Σ (w e)² after Levenberg–Marquardt on the exploration set (None if it could not start).
    pub cost: Option<f64>,
    /// The same cost on all points (equal to `cost` when nothing was subsampled); starts are
    /// ranked by it.
    pub cost_all_points: Option<f64>,
    pub termination: Option<TerminationReason>,
    pub iterations: usize,
    /// Every trial step had to be certified pole-free (the start was).
    pub certified_steps: bool,
    /// The end point's denominator is proved ≥ the margin on the whole domain.
    pub certified: bool,
    /// Why the start was unusable, if it was.
    pub note: Option<String>,
}

/// How the solver got there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolverReport {
    pub method: String,
    /// Termination of the final Levenberg–Marquardt run (None for a direct linear solve).
    pub termination: Option<TerminationReason>,
    pub converged: bool,
    /// Levenberg–Marquardt steps of the final run (0 for a direct solve).
    pub iterations: usize,
    /// IRLS / Lawson reweighting rounds (0 for least squares).
    pub reweighting_iterations: usize,
    /// Scaled condition number of the final linear solve, if there was one.
    pub condition: Option<f64>,
    /// Points used for the multi-start exploration (all points if not subsampled).
    pub exploration_points: usize,
    pub starts: Vec<StartReport>,
}

/// The full record of a fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitResult {
    pub form: Form,
    pub approximant: Approximant,
    pub n_coefficients: usize,
    pub objective: Objective,
    /// Measured on the fitted data with the emitted (monomial) coefficients.
    pub metrics: Metrics,
    /// None for coefficients that did not come from this solver (e.g. published ones).
    pub solver: Option<SolverReport>,
    pub poles: PoleVerdict,
    /// Wall time of the fit; not serialised, so the JSON is reproducible byte for byte.
    #[serde(skip)]
    pub fit_seconds: f64,
}

impl FitResult {
    /// Records an approximant measured on `data`, with its pole verdict.
    pub fn assess(
        form: Form,
        approximant: Approximant,
        data: &FitData,
        objective: Objective,
        solver: Option<SolverReport>,
        certify: &CertifyOptions,
    ) -> Result<FitResult> {
        approximant.validate()?;
        if approximant.variables.len() != data.dim() {
            return Err(FitError::ShapeMismatch {
                what: "variables of the approximant vs. the data",
                expected: data.dim(),
                got: approximant.variables.len(),
                fix: "evaluate on data with the same variables",
            });
        }
        let metrics = measure(&approximant, data);
        let poles = approximant.certify_poles(certify);
        Ok(FitResult {
            form,
            n_coefficients: approximant.n_coefficients(),
            approximant,
            objective,
            metrics,
            solver,
            poles,
            fit_seconds: 0.0,
        })
    }

    /// f(x) in f64.
    pub fn eval(&self, x: &[f64]) -> f64 {
        self.approximant.eval(x)
    }

    /// Proved pole-free on the domain and finite at every data point: safe to emit.
    pub fn is_usable(&self) -> bool {
        self.poles.is_certified() && self.metrics.non_finite == 0
    }

    /// Pretty, deterministic JSON.
    pub fn to_json(&self) -> Result<String> {
        Ok(serde_json::to_string_pretty(self)?)
    }

    /// Reads JSON written by [`FitResult::to_json`] and validates it.
    pub fn from_json(s: &str) -> Result<FitResult> {
        let r: FitResult = serde_json::from_str(s)?;
        r.approximant.validate()?;
        Ok(r)
    }
}
