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
    /// P/Q (or P without `denominator`) over exponent sets: per-variable degrees, and the
    /// split-sum form Σ_a t_j^a·P_a(others)/Q(others) with a shared denominator
    /// ([`ExponentSet::split`]); the numerator's may restrict its monomials free of one
    /// variable ([`super::basis::FreeOf`]), the denominator's is downward closed.
    ///
    /// With a [`Structure`], the sets are those of every term's P_k and Q_k in the variables
    /// other than the structure's, and the form is a sum of K such terms
    /// (Σ_k φ_k·P_k/Q_k: separate denominators, or Σ_k u_k·P_k/Q_k: a low-rank separation).
    Exponents {
        numerator: ExponentSet,
        denominator: Option<ExponentSet>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        structure: Option<Structure>,
    },
}

/// The 1-D functions φ_a of a structured form's variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// φ_a = t^a, t the variable's transformed coordinate (with t = F0^¼: 1, F0^¼, √F0, …).
    Power,
}

impl Family {
    /// Every family, with its name in form specifications.
    pub const ALL: [(Family, &'static str); 1] = [(Family::Power, "power")];

    pub fn name(self) -> &'static str {
        match self {
            Family::Power => "power",
        }
    }
}

/// How a structured form combines its terms, each P_k(y)/Q_k(y) in the variables y other than
/// `variable` (x): Σ_k g_k(x)·P_k(y)/Q_k(y).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Structure {
    /// g_a = φ_a(x) of `family`, a = 0 … terms − 1: fixed functions, one numerator and one
    /// denominator per term (the split sum with separate denominators).
    SeparateDenominators {
        variable: usize,
        family: Family,
        terms: u32,
        /// Every Q_k is a tensor-product Bernstein polynomial on the box with positive
        /// coefficients (positive on the box by construction).
        positive: bool,
    },
    /// g_k = u_k(x), fitted polynomials of degree `degree` in x's transformed coordinate: the
    /// low-rank separation Σ_k u_k(x)·v_k(y), v_k = P_k/Q_k.
    LowRank {
        variable: usize,
        terms: u32,
        degree: u32,
        positive: bool,
    },
}

impl Structure {
    pub fn variable(&self) -> usize {
        match *self {
            Structure::SeparateDenominators { variable, .. }
            | Structure::LowRank { variable, .. } => variable,
        }
    }
    pub fn terms(&self) -> u32 {
        match *self {
            Structure::SeparateDenominators { terms, .. } | Structure::LowRank { terms, .. } => {
                terms
            }
        }
    }
    pub fn positive(&self) -> bool {
        match *self {
            Structure::SeparateDenominators { positive, .. }
            | Structure::LowRank { positive, .. } => positive,
        }
    }
    /// Numbers stored per term besides P_k and Q_k: u_k's coefficients.
    pub fn factor_len(&self) -> usize {
        match *self {
            Structure::SeparateDenominators { .. } => 0,
            Structure::LowRank { degree, .. } => degree as usize + 1,
        }
    }
    /// `sum-<family>-f0-K` or `lowrank-f0-K-p`, `+` marks positive denominators.
    fn token(&self, names: &[String]) -> String {
        let v = |k: usize| names.get(k).cloned().unwrap_or_else(|| k.to_string());
        let pos = if self.positive() { "pos" } else { "" };
        match *self {
            Structure::SeparateDenominators {
                variable,
                family,
                terms,
                ..
            } => format!("sum{pos}_{}_{}_{terms}", family.name(), v(variable)),
            Structure::LowRank {
                variable,
                terms,
                degree,
                ..
            } => format!("lowrank{pos}_{}_{terms}_{degree}", v(variable)),
        }
    }
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
                structure: Some(st),
                ..
            } => self.structure_label(st, &[]),
            Form::Exponents {
                numerator,
                denominator,
                ..
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
                structure: Some(st),
                ..
            } => self.structure_label(st, names),
            Form::Exponents {
                numerator,
                denominator,
                ..
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
    /// and its total, then `x` and the variables outside the total, then `v<j>d<n>` for a
    /// [`super::basis::FreeOf`] restriction: the split form of degree 3 in variable 0 over
    /// degree 4 / 3 in the others is `rational-3_4_4t4x0-0_3_3t3x0`, and `tensor:1,4@r:0/1,0`
    /// in (r, μ) is `rational-1_4t5x01v0d0-1_0t1x01`.
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
            if let Some(f) = s.free_of {
                t.push_str(&format!("v{}d{}", f.variable, f.degree));
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
                denominator,
                structure: Some(st),
            } => format!(
                "{}-{}-{}",
                st.token(&[]),
                token(numerator),
                denominator.as_ref().map_or("1".into(), token)
            ),
            Form::Exponents {
                numerator,
                denominator: None,
                ..
            } => format!("polynomial-{}", token(numerator)),
            Form::Exponents {
                numerator,
                denominator: Some(q),
                ..
            } => format!("rational-{}-{}", token(numerator), token(q)),
        }
    }

    /// "sum of 4 terms t_f0^a·P_a/Q_a over […]/[…]".
    fn structure_label(&self, st: &Structure, names: &[String]) -> String {
        let Form::Exponents {
            numerator,
            denominator,
            ..
        } = self
        else {
            return String::new();
        };
        let v = |k: usize| names.get(k).cloned().unwrap_or_else(|| format!("x{k}"));
        let q = denominator.as_ref().map_or("1".into(), |q| {
            format!(
                "[{}]{}",
                q.label(names),
                if st.positive() {
                    " (positive Bernstein)"
                } else {
                    ""
                }
            )
        });
        match *st {
            Structure::SeparateDenominators {
                variable,
                family,
                terms,
                ..
            } => format!(
                "sum of {terms} terms {}^a·P_a/Q_a ({} family) over [{}]/{q}",
                v(variable),
                family.name(),
                numerator.label(names)
            ),
            Structure::LowRank {
                variable,
                terms,
                degree,
                ..
            } => format!(
                "low rank {terms}: u_k({}) of degree {degree} times [{}]/{q}",
                v(variable),
                numerator.label(names)
            ),
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
                structure: None,
            } => numerator.len() + denominator.as_ref().map_or(0, |q| q.len() - 1),
            Form::Exponents {
                numerator,
                denominator,
                structure: Some(st),
            } => {
                st.terms() as usize
                    * (st.factor_len()
                        + numerator.len()
                        + denominator.as_ref().map_or(0, |q| q.len() - 1))
            }
        }
    }
}

/// f(x) = P(t)/Q(t) (or P(t)), t_k = transform_k(x_k), valid on the domain box; a structured
/// form adds terms: f = [u_0(t)·]P(t)/Q(t) + Σ_k [u_k(t)·]P_k(t)/Q_k(t).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Approximant {
    pub variables: Vec<String>,
    pub transforms: Vec<InputTransform>,
    /// Domain box in the original variables.
    pub domain: Vec<(f64, f64)>,
    pub numerator: Polynomial,
    /// None for a polynomial. Coefficients include the constant term (1 after normalisation).
    pub denominator: Option<Polynomial>,
    /// A factor of the first term (a low-rank form's u_0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub factor: Option<Polynomial>,
    /// The further terms of a structured form, added in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub terms: Vec<Term>,
}

/// One term [u·]P/Q of a structured approximant, evaluated as (u·P)/Q.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Term {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub factor: Option<Polynomial>,
    pub numerator: Polynomial,
    pub denominator: Option<Polynomial>,
}

impl Term {
    /// (u·P)/Q at transformed coordinates t.
    pub fn eval(&self, t: &[f64]) -> f64 {
        let mut v = self.numerator.eval(t);
        if let Some(u) = &self.factor {
            v *= u.eval(t);
        }
        match &self.denominator {
            Some(q) => v / q.eval(t),
            None => v,
        }
    }

    /// Stored numbers, not counting a denominator constant equal to 1.
    pub fn n_coefficients(&self) -> usize {
        let den = self.denominator.as_ref().map_or(0, |q| {
            let fixed = q
                .exponents
                .iter()
                .zip(&q.coefficients)
                .any(|(e, &c)| e.iter().all(|&x| x == 0) && c == 1.0);
            q.coefficients.len() - usize::from(fixed)
        });
        self.numerator.coefficients.len()
            + self.factor.as_ref().map_or(0, |u| u.coefficients.len())
            + den
    }
}

impl Approximant {
    /// A P/Q (or P) approximant.
    pub fn rational(
        variables: Vec<String>,
        transforms: Vec<InputTransform>,
        domain: Vec<(f64, f64)>,
        numerator: Polynomial,
        denominator: Option<Polynomial>,
    ) -> Approximant {
        Approximant {
            variables,
            transforms,
            domain,
            numerator,
            denominator,
            factor: None,
            terms: Vec::new(),
        }
    }

    /// Whether the approximant is more than one P/Q (a structured form's sum or factor).
    pub fn is_structured(&self) -> bool {
        self.factor.is_some() || !self.terms.is_empty()
    }

    /// Every term, the first one (`factor`, `numerator`, `denominator`) included.
    pub fn all_terms(&self) -> Vec<Term> {
        let mut v = vec![Term {
            factor: self.factor.clone(),
            numerator: self.numerator.clone(),
            denominator: self.denominator.clone(),
        }];
        v.extend(self.terms.iter().cloned());
        v
    }

    /// Every denominator, the first term's first.
    pub fn denominators(&self) -> impl Iterator<Item = &Polynomial> {
        self.denominator
            .iter()
            .chain(self.terms.iter().filter_map(|t| t.denominator.as_ref()))
    }

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
        let polys = std::iter::once(&self.numerator)
            .chain(self.denominator.iter())
            .chain(self.factor.iter())
            .chain(self.terms.iter().flat_map(|t| {
                std::iter::once(&t.numerator)
                    .chain(t.denominator.iter())
                    .chain(t.factor.iter())
            }));
        for p in polys {
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
            // a structured form's term t_x^a·P_a(y) has its exponents of x raised by a; a
            // numerator may leave out monomials free of a variable (support closed), a
            // denominator must be downward closed (the pole certificate expands over it)
            let numerator = std::ptr::eq(p, &self.numerator);
            if !self.is_structured() {
                let closed = if numerator {
                    super::basis::is_support_closed(&p.exponents)
                } else {
                    super::basis::is_downward_closed(&p.exponents)
                };
                if !closed {
                    return Err(FitError::BadExponents {
                        problem: format!(
                            "the {} lists a monomial without {}",
                            if numerator {
                                "numerator"
                            } else {
                                "denominator"
                            },
                            if numerator {
                                "the one with a positive exponent lowered by 1 (a zero exponent may stay zero)"
                            } else {
                                "every monomial that divides it"
                            }
                        ),
                        fix: "list those monomials too (a coefficient 0 is fine)".into(),
                    });
                }
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
        if self.is_structured() {
            return self.eval_terms(t);
        }
        let p = self.numerator.eval(t);
        match &self.denominator {
            Some(q) => p / q.eval(t),
            None => p,
        }
    }

    /// A structured approximant at transformed coordinates t: the terms added in order.
    fn eval_terms(&self, t: &[f64]) -> f64 {
        let mut v = self.numerator.eval(t);
        if let Some(u) = &self.factor {
            v *= u.eval(t);
        }
        if let Some(q) = &self.denominator {
            v /= q.eval(t);
        }
        for term in &self.terms {
            v += term.eval(t);
        }
        v
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
        if self.is_structured() {
            // the operations of `eval_terms`, each across all points
            let mut part = vec![0.0; out.len()];
            self.numerator.eval_many(d, &ts, out);
            if let Some(u) = &self.factor {
                u.eval_many(d, &ts, &mut part);
                out.iter_mut().zip(&part).for_each(|(o, u)| *o *= u);
            }
            if let Some(q) = &self.denominator {
                q.eval_many(d, &ts, &mut part);
                out.iter_mut().zip(&part).for_each(|(o, q)| *o /= q);
            }
            let mut den = vec![0.0; out.len()];
            for term in &self.terms {
                term.numerator.eval_many(d, &ts, &mut part);
                if let Some(u) = &term.factor {
                    u.eval_many(d, &ts, &mut den);
                    part.iter_mut().zip(&den).for_each(|(v, u)| *v *= u);
                }
                if let Some(q) = &term.denominator {
                    q.eval_many(d, &ts, &mut den);
                    part.iter_mut().zip(&den).for_each(|(v, q)| *v /= q);
                }
                out.iter_mut().zip(&part).for_each(|(o, v)| *o += v);
            }
            return;
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

    /// Number of stored coefficients (every term's factor, numerator and denominator), not
    /// counting a denominator constant equal to 1.
    pub fn n_coefficients(&self) -> usize {
        self.all_terms().iter().map(Term::n_coefficients).sum()
    }

    /// Proves (or refutes) that no denominator has a zero on the domain box: every one is
    /// certified (the verdict's bound is the smallest), else the first that is not.
    pub fn certify_poles(&self, opts: &CertifyOptions) -> PoleVerdict {
        let mut verdict = PoleVerdict::NoDenominator;
        for q in self.denominators() {
            match self.certify_denominator(q, opts) {
                PoleVerdict::Certified {
                    min_lower_bound,
                    boxes,
                } => {
                    verdict = match verdict {
                        PoleVerdict::Certified {
                            min_lower_bound: m,
                            boxes: b,
                        } => PoleVerdict::Certified {
                            min_lower_bound: m.min(min_lower_bound),
                            boxes: b + boxes,
                        },
                        _ => PoleVerdict::Certified {
                            min_lower_bound,
                            boxes,
                        },
                    }
                }
                other => return other,
            }
        }
        verdict
    }

    fn certify_denominator(&self, q: &Polynomial, opts: &CertifyOptions) -> PoleVerdict {
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
    /// IRLS / Lawson reweighting rounds (0 for least squares); for an iterate of the Lawson
    /// path, the round it stopped at.
    pub reweighting_iterations: usize,
    /// Set when these coefficients are an iterate of the Lawson path kept beside the
    /// lowest-max one (absent in fit files of the path's end).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lawson_path: Option<LawsonPathIterate>,
    /// Scaled condition number of the final linear solve, if there was one.
    pub condition: Option<f64>,
    /// Points used for the multi-start exploration (all points if not subsampled).
    pub exploration_points: usize,
    pub starts: Vec<StartReport>,
}

/// An iterate of the Lawson path (Lawson 1961) kept beside the lowest-max one: the lowest max
/// error among the path's iterates whose MAE on the fitting points is at most `mae_bound` × the
/// least-squares start's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LawsonPathIterate {
    /// The reweighting round it stopped at.
    pub round: usize,
    /// Rounds Lawson's own path ran.
    pub of_rounds: usize,
    /// Its MAE bound, a multiple of the least-squares start's MAE on the fitting points (for
    /// an iterate of the L_p polish: its own MAE there as such a multiple).
    pub mae_bound: f64,
    /// λ of the round's weights (1 − λ)·1 + λ·u, u Lawson's: below 1 for the path's blended
    /// branch, 1 for Lawson's own iterates.
    pub blend: f64,
    /// p of the L_p polish (IRLS for Σ |e_i|^p) the iterate came from; absent for Lawson's path.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pnorm: Option<f64>,
    /// λ of the max–mean polish (the exact best linear coefficients in max + λ·mean error, the
    /// rest of the minimax fit held) the iterate came from; absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_mean: Option<f64>,
}

impl LawsonPathIterate {
    /// `round<sep>7`, `blend<sep>0.75<gap>round<sep>3` for the blended branch, `p<sep>16`
    /// for the L_p polish or `maxmean<sep>4` for the max–mean polish.
    pub fn label(&self, gap: &str, sep: &str) -> String {
        let round = format!("round{sep}{}", self.round);
        if let Some(l) = self.max_mean {
            match self.pnorm {
                Some(p) => format!("p{sep}{p}{gap}maxmean{sep}{l}"),
                None => format!("maxmean{sep}{l}"),
            }
        } else if let Some(p) = self.pnorm {
            format!("p{sep}{p}")
        } else if self.blend < 1.0 {
            format!("blend{sep}{}{gap}{round}", self.blend)
        } else {
            round
        }
    }
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
    /// Other iterates of a minimax fit's Lawson path, each a fit of its own
    /// ([`SolverReport::lawson_path`]); the sweep measures them as rows. Not serialised.
    #[serde(skip)]
    pub path: Vec<FitResult>,
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
            path: Vec::new(),
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

    /// The fits of `path` (a reweighting loop's [`super::robust::PathIterate`]s) with this fit's
    /// form, objective and solver report, each recording its round; `to_approximant` turns
    /// solver parameters into the emitted form.
    pub(crate) fn with_path(
        mut self,
        path: &[super::robust::PathIterate],
        data: &FitData,
        certify: &CertifyOptions,
        to_approximant: &dyn Fn(&[f64]) -> Approximant,
    ) -> Result<FitResult> {
        let Some(solver) = self.solver.clone() else {
            return Ok(self);
        };
        let of_rounds = solver.reweighting_iterations;
        for it in path {
            let which = if let Some(l) = it.max_mean {
                let from = match it.pnorm {
                    Some(p) => format!("the L_p polish's solve of p = {p}"),
                    None => "the minimax fit".to_string(),
                };
                format!(
                    "then a max–mean polish of {from}: its denominators and factors held, the coefficients in which it is linear set to the exact minimiser of max error + λ·mean error on the fitting points (a linear program, primal–dual interior point), λ = {l}, its MAE there {:.3}× the least-squares start's",
                    it.mae_bound
                )
            } else if let Some(p) = it.pnorm {
                format!(
                    "then an L_p polish from the least-squares fit: Levenberg–Marquardt on the sum of |e_i|^p for each p in turn, this the solve of p = {p} (step {} of the polish), its MAE on the fitting points {:.3}× the least-squares start's",
                    it.round, it.mae_bound
                )
            } else if it.blend < 1.0 {
                format!(
                    "the iterate of round {} of a branch of the Lawson path solved with weights (1 − λ)·1 + λ·u (u Lawson's), λ = {}",
                    it.round, it.blend
                )
            } else {
                format!("the Lawson iterate of round {} of {of_rounds}", it.round)
            };
            let method = if it.pnorm.is_some() || it.max_mean.is_some() {
                format!("{}; {which}", solver.method)
            } else {
                format!(
                    "{}; {which}, the lowest max error among the path's iterates whose MAE on the fitting points is ≤ {}× the least-squares start's",
                    solver.method, it.mae_bound
                )
            };
            let report = SolverReport {
                method,
                reweighting_iterations: it.round,
                lawson_path: Some(LawsonPathIterate {
                    round: it.round,
                    of_rounds,
                    mae_bound: it.mae_bound,
                    blend: it.blend,
                    pnorm: it.pnorm,
                    max_mean: it.max_mean,
                }),
                ..solver.clone()
            };
            let fit = FitResult::assess(
                self.form.clone(),
                to_approximant(&it.params),
                data,
                self.objective,
                Some(report),
                certify,
            )?;
            self.path.push(fit);
        }
        Ok(self)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn poly(exponents: Vec<Vec<u32>>, coefficients: Vec<f64>) -> Polynomial {
        Polynomial {
            exponents,
            coefficients,
        }
    }

    /// 1/(1 + y) + x·(0.2 + y)/(c + y) on [0, 1]²: the second denominator has a zero in the box
    /// for c = −0.5.
    fn two_terms(c: f64) -> Approximant {
        Approximant {
            variables: vec!["x".into(), "y".into()],
            transforms: vec![InputTransform::Identity; 2],
            domain: vec![(0.0, 1.0); 2],
            numerator: poly(vec![vec![0, 0]], vec![1.0]),
            denominator: Some(poly(vec![vec![0, 0], vec![0, 1]], vec![1.0, 1.0])),
            factor: None,
            terms: vec![Term {
                factor: Some(poly(vec![vec![0, 0], vec![1, 0]], vec![0.0, 1.0])),
                numerator: poly(vec![vec![0, 0], vec![0, 1]], vec![0.2, 1.0]),
                denominator: Some(poly(vec![vec![0, 0], vec![0, 1]], vec![c, 1.0])),
            }],
        }
    }

    #[test]
    fn a_numerator_may_leave_out_monomials_free_of_a_variable_a_denominator_may_not() {
        // c + r·(b₀ + b₂μ²) lacks r·μ, which r·μ² lowers to; c + r·(b₀ + b₁μ) is fine
        let approximant = |num: Vec<Vec<u32>>, den: Vec<Vec<u32>>| {
            let (n, m) = (num.len(), den.len());
            Approximant::rational(
                vec!["r".into(), "mu".into()],
                vec![InputTransform::Identity; 2],
                vec![(0.0, 1.0); 2],
                poly(num, vec![0.5; n]),
                Some(poly(den, vec![1.0; m])),
            )
        };
        let q = vec![vec![0, 0], vec![1, 0]];
        let good = approximant(vec![vec![0, 0], vec![1, 0], vec![1, 1]], q.clone());
        good.validate().unwrap();
        assert_eq!(good.eval(&[0.0, 0.7]), 0.5);
        let gap = approximant(vec![vec![0, 0], vec![1, 0], vec![1, 2]], q.clone());
        let e = gap.validate().unwrap_err();
        assert!(
            matches!(e, FitError::BadExponents { .. })
                && e.to_string().contains("numerator")
                && e.to_string().contains("list those monomials too"),
            "{e}"
        );
        let den = approximant(vec![vec![0, 0]], vec![vec![0, 0], vec![1, 1]]);
        let e = den.validate().unwrap_err();
        assert!(e.to_string().contains("denominator"), "{e}");
    }

    #[test]
    fn every_denominator_of_a_structured_form_is_certified() {
        let good = two_terms(0.5);
        good.validate().unwrap();
        assert!(good.is_structured());
        let x = [0.3, 0.6];
        let want = 1.0 / 1.6 + 0.3 * 0.8 / 1.1;
        assert!((good.eval(&x) - want).abs() < 1e-15);
        let mut many = [0.0];
        good.eval_many(2, &x, &mut many);
        assert_eq!(many[0].to_bits(), good.eval(&x).to_bits());
        // (1 + 2 − 1) + (2 + 2 + 2): a denominator constant counts unless it is 1
        assert_eq!(good.n_coefficients(), 8);
        match good.certify_poles(&CertifyOptions::default()) {
            PoleVerdict::Certified {
                min_lower_bound, ..
            } => assert!(min_lower_bound > 0.0 && min_lower_bound <= 0.5),
            v => panic!("{v:?}"),
        }
        // the second term's Q = y − 0.5 vanishes at y = 0.5: refused
        let bad = two_terms(-0.5);
        let v = bad.certify_poles(&CertifyOptions::default());
        assert!(matches!(v, PoleVerdict::PoleFound { .. }), "{v:?}");
        assert!(!v.is_certified());
        // a P/Q approximant's JSON has no structured fields
        let plain = Approximant::rational(
            vec!["x".into()],
            vec![InputTransform::Identity],
            vec![(0.0, 1.0)],
            poly(vec![vec![0]], vec![1.0]),
            None,
        );
        let json = serde_json::to_string(&plain).unwrap();
        assert!(
            !json.contains("terms") && !json.contains("factor"),
            "{json}"
        );
    }
}
