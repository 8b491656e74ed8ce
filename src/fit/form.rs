//! One entry point for every form: [`fit_form`] fits a [`Form`] (polynomial, rational, or P/Q
//! over exponent sets — per-variable degrees and the split-sum form with a shared denominator)
//! and checks beforehand that the data can determine it.

use super::basis::{check_degree, ExponentSet};
use super::data::{FitData, InputTransform};
use super::error::{FitError, Result};
use super::model::Model;
use super::polynomial::{fit_polynomial, fit_polynomial_model, PolynomialOptions};
use super::rational::{fit_rational, fit_rational_model, RationalOptions};
use super::result::{Family, FitResult, Form, Objective, Structure};
use super::structured::{check_structure, fit_structured, StructuredOptions};

/// Settings of [`fit_form`]: the polynomial, rational and structured solvers'.
#[derive(Clone, Debug, Default)]
pub struct FitOptions {
    pub polynomial: PolynomialOptions,
    pub rational: RationalOptions,
    pub structured: StructuredOptions,
}

/// Fits `form` to `data` in the transformed variables and assesses it (metrics on `data`, pole
/// certificate of the denominator on the whole domain box).
///
/// Refused before anything is solved, with the cause and the fix: a degree above
/// [`super::basis::MAX_DEGREE`], an exponent set of the wrong shape, more coefficients than
/// weighted points, and a degree in a variable at or above its number of distinct values in the
/// data (the columns of the least-squares system would be dependent).
///
/// ```
/// use furnace::fit::{fit_form, ExponentSet, FitData, FitOptions, Form, InputTransform, Objective};
/// // f = (1 + x + x y)/(1 + y/2): degree 1 in x over a denominator without x
/// let ax: Vec<f64> = (0..12).map(|i| i as f64 / 11.0).collect();
/// let vals = ax.iter().flat_map(|&x| ax.iter().map(move |&y| (1.0 + x + x * y) / (1.0 + 0.5 * y))).collect();
/// let data = FitData::from_grid(vec!["x".into(), "y".into()], &[ax.clone(), ax], vals).unwrap();
/// let form = Form::Exponents {
///     numerator: ExponentSet::split(2, 0, 1, 1),
///     denominator: Some(ExponentSet::split(2, 0, 0, 1)),
///     structure: None,
/// };
/// let fit = fit_form(&data, &[InputTransform::Identity; 2], &form, Objective::LeastSquares,
///                    &FitOptions::default()).unwrap();
/// assert_eq!(fit.n_coefficients, 4 + 1);
/// assert!(fit.metrics.max_abs_error < 1e-10 && fit.is_usable());
/// ```
pub fn fit_form(
    data: &FitData,
    transforms: &[InputTransform],
    form: &Form,
    objective: Objective,
    opts: &FitOptions,
) -> Result<FitResult> {
    data.validate()?;
    let d = data.dim();
    match form {
        Form::Polynomial { degree } => {
            check_degree(*degree)?;
            check_distinct(data, &ExponentSet::total_degree(d, *degree), form)?;
            fit_polynomial(data, transforms, *degree, objective, &opts.polynomial)
        }
        Form::Rational {
            numerator_degree,
            denominator_degree,
        } => {
            check_degree(*numerator_degree)?;
            check_degree(*denominator_degree)?;
            let top = (*numerator_degree).max(*denominator_degree);
            check_distinct(data, &ExponentSet::total_degree(d, top), form)?;
            fit_rational(
                data,
                transforms,
                *numerator_degree,
                *denominator_degree,
                objective,
                &opts.rational,
            )
        }
        Form::Exponents {
            numerator,
            denominator,
            structure: Some(st),
        } => {
            check_sets(d, &data.names, numerator, denominator.as_ref(), true)?;
            check_structure(d, &data.names, numerator, denominator.as_ref(), st)?;
            check_distinct(data, numerator, form)?;
            if let Some(q) = denominator {
                check_distinct(data, q, form)?;
            }
            // the structure's variable: degree K − 1 (powers) or u_k's degree (low rank)
            let x = st.variable();
            let in_x = match *st {
                Structure::SeparateDenominators { terms, .. } => terms - 1,
                Structure::LowRank { degree, .. } => degree,
            };
            let mut caps = vec![0; d];
            caps[x] = in_x;
            check_distinct(data, &ExponentSet::tensor(&caps), form)?;
            fit_structured(data, transforms, form, objective, &opts.structured)
        }
        Form::Exponents {
            numerator,
            denominator,
            structure: None,
        } => {
            numerator.check(d)?;
            check_distinct(data, numerator, form)?;
            if let Some(q) = denominator {
                q.check(d)?;
                check_distinct(data, q, form)?;
            }
            check_sets(d, &data.names, numerator, denominator.as_ref(), false)?;
            let num_exps = numerator.exponents();
            match denominator {
                None => {
                    let model = Model::from_exponents(d, num_exps, None);
                    fit_polynomial_model(
                        data,
                        transforms,
                        form.clone(),
                        &model,
                        objective,
                        &opts.polynomial,
                    )
                }
                Some(q) => {
                    let model = Model::from_exponents(d, num_exps.clone(), Some(q.exponents()));
                    let poly = Model::from_exponents(d, num_exps, None);
                    fit_rational_model(
                        data,
                        transforms,
                        form.clone(),
                        &model,
                        &poly,
                        objective,
                        &opts.rational,
                    )
                }
            }
        }
    }
}

/// The form families [`parse_form`] reads, with their syntax.
pub const FORM_SYNTAX: &str = "polynomial:<n>, rational:<n>/<m>, split:<variable>:<k>:<n>/<m> (degree k in the variable times total degree n in the others, over a shared denominator of degree m without it; /0: no denominator), tensor:<n1>,<n2>,…/<m1>,<m2>,… (per-variable degrees; no /…: a polynomial), sum:<variable>:<family>:<K>:<n>/<m> (Σ_a φ_a(variable)·P_a/Q_a, a < K, family power: φ_a = t^a; P_a of total degree n and Q_a of total degree m in the others, each term its own denominator), lowrank:<variable>:<K>:<p>:<n>/<m> (Σ_k u_k(variable)·P_k/Q_k, k < K, u_k fitted polynomials of degree p), where a denominator +<m> or +<m1>,<m2>,… is a positive Bernstein polynomial of degree m per other variable (Q > 0 on the box by construction), and a split or tensor numerator followed by @<variable>:<j> keeps of the monomials without that variable only those of total degree ≤ j (tensor:1,4@r:0/1,0 is c + r·(b₀ + b₁μ + … + b₄μ⁴) over 1 + q r), or the JSON of a form";

/// Parses a form: `rational:3/3`, `split:f0:4:5/4`, `tensor:1,2/1,0`, or its JSON
/// (`{"kind": "exponents", …}`), for data with the variables `names`. Errors name the syntax.
pub fn parse_form(text: &str, names: &[String]) -> std::result::Result<Form, String> {
    let text = text.trim();
    let d = names.len();
    if text.starts_with('{') {
        let form: Form = serde_json::from_str(text).map_err(|e| {
            format!("form '{text}' is not the JSON of a form ({e}); use {FORM_SYNTAX}")
        })?;
        if let Form::Exponents {
            numerator,
            denominator,
            structure,
        } = &form
        {
            for s in std::iter::once(numerator).chain(denominator.iter()) {
                s.check(d).map_err(|e| format!("form '{text}': {e}"))?;
            }
            check_sets(
                d,
                names,
                numerator,
                denominator.as_ref(),
                structure.is_some(),
            )
            .map_err(|e| format!("form '{text}': {e}"))?;
            if let Some(st) = structure {
                check_structure(d, names, numerator, denominator.as_ref(), st)
                    .map_err(|e| format!("form '{text}': {e}"))?;
            }
        }
        return Ok(form);
    }
    let (family, rest) = text.split_once(':').unwrap_or((text, ""));
    let bad = |what: &str| format!("form '{text}': {what}; use {FORM_SYNTAX}");
    let int = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| bad(&format!("'{s}' is not a degree")))
    };
    let list = |s: &str| -> std::result::Result<Vec<u32>, String> {
        let v = s
            .split(',')
            .map(int)
            .collect::<std::result::Result<Vec<u32>, String>>()?;
        if v.len() != d {
            return Err(bad(&format!(
                "{} per-variable degrees for the {d} variables {}",
                v.len(),
                names.join(", ")
            )));
        }
        Ok(v)
    };
    // a numerator's `@<variable>:<j>`: the monomials without the variable of total degree ≤ j
    let free_of = |spec: Option<&str>| -> std::result::Result<Option<(usize, u32)>, String> {
        let Some(spec) = spec else {
            return Ok(None);
        };
        let (var, j) = spec.split_once(':').ok_or_else(|| {
            bad(&format!(
                "write the numerator's restriction '@{spec}' as @<variable>:<j>, e.g. @{}:0",
                names.first().map_or("r", String::as_str)
            ))
        })?;
        let k = names.iter().position(|x| x == var.trim()).ok_or_else(|| {
            bad(&format!(
                "unknown variable '{var}' in '@{spec}' (the data's are {})",
                names.join(", ")
            ))
        })?;
        Ok(Some((k, int(j)?)))
    };
    let restrict = |form: Form, free: Option<(usize, u32)>| match (form, free) {
        (
            Form::Exponents {
                numerator,
                denominator,
                structure,
            },
            Some((k, j)),
        ) => Form::Exponents {
            numerator: numerator.free_of(k, j),
            denominator,
            structure,
        },
        (form, _) => form,
    };
    match family {
        "polynomial" => Ok(Form::Polynomial { degree: int(rest)? }),
        "rational" => {
            let (n, m) = rest
                .split_once('/')
                .ok_or_else(|| bad("write rational:<n>/<m>"))?;
            Ok(Form::Rational {
                numerator_degree: int(n)?,
                denominator_degree: int(m)?,
            })
        }
        "split" => {
            // the numerator's `@<variable>:<j>` has a colon of its own
            let f: Vec<&str> = rest.splitn(3, ':').collect();
            let [var, k, nm] = f.as_slice() else {
                return Err(bad("write split:<variable>:<k>:<n>/<m>"));
            };
            let j = names.iter().position(|x| x == var.trim()).ok_or_else(|| {
                bad(&format!(
                    "unknown variable '{var}' (the data's are {})",
                    names.join(", ")
                ))
            })?;
            let (n, m) = nm
                .split_once('/')
                .ok_or_else(|| bad("write split:<variable>:<k>:<n>/<m>"))?;
            if m.contains('@') {
                return Err(bad(DENOMINATOR_UNRESTRICTED));
            }
            let (n, free) = split_restriction(n);
            let free = free_of(free)?;
            Ok(restrict(split_form(d, j, int(k)?, int(n)?, int(m)?), free))
        }
        "tensor" => {
            let (n, m) = rest.split_once('/').unwrap_or((rest, ""));
            if m.contains('@') {
                return Err(bad(DENOMINATOR_UNRESTRICTED));
            }
            let (n, free) = split_restriction(n);
            let free = free_of(free)?;
            let n = list(n)?;
            let m = if rest.contains('/') {
                Some(list(m)?)
            } else {
                None
            };
            Ok(restrict(tensor_form(&n, m.as_deref()), free))
        }
        "sum" | "lowrank" => {
            let f: Vec<&str> = rest.split(':').collect();
            let var_of = |v: &str| {
                names.iter().position(|x| x == v.trim()).ok_or_else(|| {
                    bad(&format!(
                        "unknown variable '{v}' (the data's are {})",
                        names.join(", ")
                    ))
                })
            };
            // the structure with its positivity still open
            let (x, nm, make): (usize, &str, Box<dyn Fn(bool) -> Structure>) = if family == "sum" {
                let [var, fam, k, nm] = f.as_slice() else {
                    return Err(bad("write sum:<variable>:<family>:<K>:<n>/<m>"));
                };
                let variable = var_of(var)?;
                let family = Family::ALL
                    .iter()
                    .find(|(_, n)| *n == fam.trim())
                    .map(|(f, _)| *f)
                    .ok_or_else(|| {
                        bad(&format!(
                            "unknown basis family '{}' (the fitter knows {})",
                            fam.trim(),
                            Family::ALL.map(|(_, n)| n).join(", ")
                        ))
                    })?;
                let terms = int(k)?;
                (
                    variable,
                    nm,
                    Box::new(move |positive| Structure::SeparateDenominators {
                        variable,
                        family,
                        terms,
                        positive,
                    }),
                )
            } else {
                let [var, k, p, nm] = f.as_slice() else {
                    return Err(bad("write lowrank:<variable>:<K>:<p>:<n>/<m>"));
                };
                let variable = var_of(var)?;
                let (terms, degree) = (int(k)?, int(p)?);
                (
                    variable,
                    nm,
                    Box::new(move |positive| Structure::LowRank {
                        variable,
                        terms,
                        degree,
                        positive,
                    }),
                )
            };
            let (n, m) = nm
                .split_once('/')
                .ok_or_else(|| bad("write the per-term degrees as <n>/<m>"))?;
            let numerator = ExponentSet::split(d, x, 0, int(n)?);
            let m = m.trim();
            let (denominator, positive) = match m.strip_prefix('+') {
                Some(degrees) => {
                    let v = degrees
                        .split(',')
                        .map(int)
                        .collect::<std::result::Result<Vec<u32>, String>>()?;
                    let mut caps = vec![0; d];
                    let others: Vec<usize> = (0..d).filter(|&k| k != x).collect();
                    match v.len() {
                        1 => others.iter().for_each(|&k| caps[k] = v[0]),
                        l if l == others.len() => {
                            others.iter().zip(&v).for_each(|(&k, &m)| caps[k] = m)
                        }
                        l => {
                            return Err(bad(&format!(
                                "{l} degrees for the positive denominator; give one, or one per variable other than '{}'",
                                names[x]
                            )))
                        }
                    }
                    (Some(ExponentSet::tensor(&caps)), true)
                }
                None => {
                    let m = int(m)?;
                    ((m > 0).then(|| ExponentSet::split(d, x, 0, m)), false)
                }
            };
            let form = Form::Exponents {
                numerator,
                denominator,
                structure: Some(make(positive)),
            };
            if let Form::Exponents {
                numerator,
                denominator,
                structure: Some(st),
            } = &form
            {
                check_structure(d, names, numerator, denominator.as_ref(), st)
                    .map_err(|e| format!("form '{text}': {e}"))?;
            }
            Ok(form)
        }
        other => Err(format!(
            "unknown form family '{other}' in '{text}'; the fitter knows {FORM_SYNTAX}"
        )),
    }
}

/// Why a denominator takes no `@<variable>:<j>`.
const DENOMINATOR_UNRESTRICTED: &str = "only a numerator takes @<variable>:<j>: the denominator must keep every monomial dividing one of its own (the pole certificate and Q's normalisation expand over them), so write it without the restriction";

/// `1,4@r:0` → (`1,4`, Some(`r:0`)).
fn split_restriction(n: &str) -> (&str, Option<&str>) {
    match n.split_once('@') {
        Some((n, spec)) => (n, Some(spec)),
        None => (n, None),
    }
}

/// The exponent sets a form may combine: a [`super::basis::FreeOf`] restriction only on the
/// numerator of a P/Q form (the pole certificate and Q's normalisation need a downward-closed
/// denominator; a structured form's terms have their own bases), and the restricted variable
/// one of the data's.
fn check_sets(
    d: usize,
    names: &[String],
    numerator: &ExponentSet,
    denominator: Option<&ExponentSet>,
    structured: bool,
) -> Result<()> {
    let name = |k: usize| names.get(k).cloned().unwrap_or_else(|| format!("x{k}"));
    if let Some(f) = denominator.and_then(|q| q.free_of) {
        return Err(FitError::BadExponents {
            problem: format!(
                "the denominator leaves out monomials without '{}' (free_of), so it is not downward closed",
                name(f.variable)
            ),
            fix: "restrict only the numerator (tensor:1,4@r:0/1,0); give the denominator a plain set".into(),
        });
    }
    if let (Some(f), true) = (numerator.free_of, structured) {
        return Err(FitError::BadExponents {
            problem: format!(
                "a structured form's numerator leaves out monomials without '{}' (free_of)",
                name(f.variable)
            ),
            fix: "use the restriction in a tensor or split P/Q form, or drop it".into(),
        });
    }
    if let Some(f) = numerator.free_of {
        if f.variable >= d {
            return Err(FitError::BadExponents {
                problem: format!(
                    "the numerator's restriction names variable {} of {d}",
                    f.variable
                ),
                fix: format!("give a variable index below {d}"),
            });
        }
    }
    Ok(())
}

/// A variable with m distinct values in the data supports degree ≤ m − 1 in it.
fn check_distinct(data: &FitData, set: &ExponentSet, form: &Form) -> Result<()> {
    let d = data.dim();
    for k in 0..d {
        let degree = set.max_exponent_of(k);
        if degree == 0 {
            continue;
        }
        // distinct values, counted only up to degree + 1 (a grid shows them early)
        let mut v: Vec<f64> = Vec::with_capacity(degree as usize + 1);
        for i in (0..data.len()).filter(|&i| data.weight(i) > 0.0) {
            let x = data.point(i)[k];
            if !v.contains(&x) {
                v.push(x);
                if v.len() > degree as usize {
                    break;
                }
            }
        }
        if v.len() <= degree as usize {
            return Err(FitError::TooFewValues {
                form: form.label_with(&data.names),
                name: data.names[k].clone(),
                degree,
                distinct: v.len(),
            });
        }
    }
    Ok(())
}

/// The split-sum form Σ_{a ≤ k} t_j^a·P_a(others) / Q(others): numerator degree `k` in variable
/// `split` times total degree `n` in the other variables, over a shared denominator of total
/// degree `m` without variable `split` (`m` = 0: a polynomial).
pub fn split_form(d: usize, split: usize, k: u32, n: u32, m: u32) -> Form {
    Form::Exponents {
        numerator: ExponentSet::split(d, split, k, n),
        denominator: (m > 0).then(|| ExponentSet::split(d, split, 0, m)),
        structure: None,
    }
}

/// Per-variable degrees: P of degree `num[k]` and Q of degree `den[k]` in variable k (tensor
/// products; `den` None: a polynomial).
pub fn tensor_form(num: &[u32], den: Option<&[u32]>) -> Form {
    Form::Exponents {
        numerator: ExponentSet::tensor(num),
        denominator: den.map(ExponentSet::tensor),
        structure: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid3(n: usize, f: impl Fn(f64, f64, f64) -> f64) -> FitData {
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let mut vals = Vec::new();
        for &x in &ax {
            for &y in &ax {
                for &z in &ax {
                    vals.push(f(x, y, z));
                }
            }
        }
        FitData::from_grid(
            vec!["f0".into(), "r".into(), "mu".into()],
            &[ax.clone(), ax.clone(), ax],
            vals,
        )
        .unwrap()
    }

    #[test]
    fn split_form_recovers_a_split_sum_and_counts_every_coefficient() {
        // E = (A(r, μ) + f0·B(r, μ) + f0²·C)/Q(r, μ): degree 2 in f0, 2 in (r, μ), Q of degree 1
        let f = |x: f64, r: f64, m: f64| {
            (0.3 + 0.2 * r - 0.1 * m * m + x * (0.5 - 0.2 * r * m) + 0.1 * x * x)
                / (1.0 + 0.3 * r + 0.2 * m)
        };
        let data = grid3(9, f);
        let form = split_form(3, 0, 2, 2, 1);
        let fit = fit_form(
            &data,
            &[InputTransform::Identity; 3],
            &form,
            Objective::LeastSquares,
            &FitOptions::default(),
        )
        .unwrap();
        // 3 × 6 numerator + 3 − 1 denominator
        assert_eq!(form.n_coefficients(3), 18 + 2);
        assert_eq!(fit.n_coefficients, 20);
        assert!(fit.metrics.max_abs_error < 1e-10, "{:?}", fit.metrics);
        assert!(fit.is_usable());
        let q = fit.approximant.denominator.as_ref().unwrap();
        assert!(q.exponents.iter().all(|e| e[0] == 0), "Q has no f0");
        assert!((fit.eval(&[0.37, 0.61, 0.23]) - f(0.37, 0.61, 0.23)).abs() < 1e-10);
        // JSON round trip keeps the form
        let back = FitResult::from_json(&fit.to_json().unwrap()).unwrap();
        assert_eq!(back.form, form);
    }

    #[test]
    fn total_degree_forms_are_the_classic_fits() {
        let data = grid3(6, |x, r, m| (1.0 + x * r) / (1.5 + m));
        let t = [InputTransform::Identity; 3];
        let (a, b) = (
            fit_form(
                &data,
                &t,
                &Form::Rational {
                    numerator_degree: 2,
                    denominator_degree: 1,
                },
                Objective::LeastSquares,
                &FitOptions::default(),
            )
            .unwrap(),
            fit_rational(
                &data,
                &t,
                2,
                1,
                Objective::LeastSquares,
                &RationalOptions::default(),
            )
            .unwrap(),
        );
        assert_eq!(a.to_json().unwrap(), b.to_json().unwrap());
        // the same set as an exponent set fits the same function
        let c = fit_form(
            &data,
            &t,
            &Form::Exponents {
                numerator: ExponentSet::total_degree(3, 2),
                denominator: Some(ExponentSet::total_degree(3, 1)),
                structure: None,
            },
            Objective::LeastSquares,
            &FitOptions::default(),
        )
        .unwrap();
        assert_eq!(
            c.approximant.numerator.coefficients,
            a.approximant.numerator.coefficients
        );
    }

    #[test]
    fn tensor_degrees_fit_a_low_order_rational() {
        // degree 1 in r over degree 1 in r, constant in μ's denominator: (a + b r + c μ)/(1 + d r)
        let ax: Vec<f64> = (0..10).map(|i| i as f64 / 9.0).collect();
        let vals = ax
            .iter()
            .flat_map(|&r| {
                ax.iter()
                    .map(move |&m| (0.2 + r + 0.3 * m * r) / (1.0 + 0.7 * r))
            })
            .collect();
        let data =
            FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
        let form = tensor_form(&[1, 1], Some(&[1, 0]));
        let fit = fit_form(
            &data,
            &[InputTransform::Identity; 2],
            &form,
            Objective::LeastSquares,
            &FitOptions::default(),
        )
        .unwrap();
        assert_eq!(fit.n_coefficients, 4 + 1);
        assert!(fit.metrics.max_abs_error < 1e-12, "{:?}", fit.metrics);
    }

    #[test]
    fn a_numerator_restricted_where_r_is_absent_parses_fits_and_refuses_bad_input() {
        let names: Vec<String> = ["r", "mu"].map(String::from).to_vec();
        let form = parse_form("tensor:1,4@r:0/1,0", &names).unwrap();
        let want = Form::Exponents {
            numerator: ExponentSet::tensor(&[1, 4]).free_of(0, 0),
            denominator: Some(ExponentSet::tensor(&[1, 0])),
            structure: None,
        };
        assert_eq!(form, want);
        assert_eq!(form.n_coefficients(2), 6 + 1);
        assert_eq!(form.file_stem(), "rational-1_4t5x01v0d0-1_0t1x01");
        assert_eq!(
            parse_form("split:r:1:3@r:0/0", &names).unwrap(),
            Form::Exponents {
                numerator: ExponentSet::split(2, 0, 1, 3).free_of(0, 0),
                denominator: None,
                structure: None,
            }
        );
        // (0.3 + r·(1 − μ + μ²))/(1 + 0.5 r) is exact in the form; the plain tensor's μ-terms
        // without r are not needed
        let ax: Vec<f64> = (0..9).map(|i| i as f64 / 8.0).collect();
        let f = |r: f64, m: f64| (0.3 + r * (1.0 - m + m * m)) / (1.0 + 0.5 * r);
        let vals = ax
            .iter()
            .flat_map(|&r| ax.iter().map(move |&m| f(r, m)))
            .collect();
        let data = FitData::from_grid(names.clone(), &[ax.clone(), ax], vals).unwrap();
        let t = [InputTransform::Identity; 2];
        let o = FitOptions::default();
        let fit = fit_form(&data, &t, &form, Objective::LeastSquares, &o).unwrap();
        assert_eq!(fit.n_coefficients, 7);
        assert!(fit.metrics.max_abs_error < 1e-12, "{:?}", fit.metrics);
        assert!(fit.is_usable());
        assert!(!fit.approximant.numerator.exponents.contains(&vec![0, 1]));
        // the polynomial (no denominator) too
        let poly = parse_form("tensor:1,2@r:0", &names).unwrap();
        let g = fit_form(&data, &t, &poly, Objective::LeastSquares, &o).unwrap();
        assert_eq!(g.n_coefficients, 4);
        assert!((g.eval(&[0.0, 0.3]) - g.eval(&[0.0, 0.9])).abs() == 0.0);
        // bad syntax and unknown variables name the syntax
        for (text, what) in [
            ("tensor:1,4@r/1,0", "@<variable>:<j>"),
            ("tensor:1,4@eta:0/1,0", "unknown variable 'eta'"),
            ("tensor:1,4@r:x/1,0", "not a degree"),
            ("tensor:1,4@r:0/1,1@r:0", "only a numerator"),
            ("split:r:1:3@r:0/1@r:0", "only a numerator"),
        ] {
            let e = parse_form(text, &names).unwrap_err();
            assert!(e.contains(what) && e.contains("@<variable>:<j>"), "{e}");
        }
        // a restricted denominator, or a restricted structured numerator, is refused with the fix
        let bad = Form::Exponents {
            numerator: ExponentSet::tensor(&[1, 4]),
            denominator: Some(ExponentSet::tensor(&[1, 1]).free_of(0, 0)),
            structure: None,
        };
        let e = fit_form(&data, &t, &bad, Objective::LeastSquares, &o).unwrap_err();
        assert!(
            matches!(e, FitError::BadExponents { .. })
                && e.to_string().contains("only the numerator"),
            "{e}"
        );
        let json = serde_json::to_string(&bad).unwrap();
        assert!(parse_form(&json, &names)
            .unwrap_err()
            .contains("not downward closed"));
        // more coefficients than points
        let few = FitData::new(
            names.clone(),
            vec![0.0, 0.0, 0.0, 0.25, 1.0, 0.5, 1.0, 0.75, 0.5, 1.0, 0.5, 0.1],
            vec![1.0; 6],
            vec![(0.0, 1.0), (0.0, 1.0)],
        )
        .unwrap();
        let e = fit_form(&few, &t, &form, Objective::LeastSquares, &o).unwrap_err();
        assert!(
            matches!(
                e,
                FitError::TooFewPoints {
                    coefficients: 7,
                    points: 6,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn bad_forms_are_refused_with_the_fix() {
        let data = grid3(4, |x, r, m| x + r + m);
        let t = [InputTransform::Identity; 3];
        let o = FitOptions::default();
        // degree 4 in f0 with 4 distinct values
        let e = fit_form(
            &data,
            &t,
            &split_form(3, 0, 4, 1, 0),
            Objective::LeastSquares,
            &o,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                FitError::TooFewValues {
                    distinct: 4,
                    degree: 4,
                    ..
                }
            ),
            "{e}"
        );
        assert!(
            e.to_string().contains("f0") && e.to_string().contains("lower"),
            "{e}"
        );
        // a domain whose data lie on one slice of f0 (f0 = 0.1 only): no degree in f0 is determined
        let mut coords = Vec::new();
        for i in 0..36 {
            coords.extend([0.1, (i / 6) as f64 / 5.0, (i % 6) as f64 / 5.0]);
        }
        let slice = FitData::new(
            vec!["f0".into(), "r".into(), "mu".into()],
            coords,
            vec![0.5; 36],
            vec![(0.0, 1.0); 3],
        )
        .unwrap();
        let e = fit_form(
            &slice,
            &t,
            &split_form(3, 0, 1, 1, 1),
            Objective::LeastSquares,
            &o,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("only 1 distinct values of 'f0'"),
            "{e}"
        );
        // wrong shape
        let bad = Form::Exponents {
            numerator: ExponentSet::total_degree(2, 1),
            denominator: None,
            structure: None,
        };
        let e = fit_form(&data, &t, &bad, Objective::LeastSquares, &o).unwrap_err();
        assert!(matches!(e, FitError::ShapeMismatch { .. }), "{e}");
        // more coefficients than points
        let few = FitData::new(
            vec!["x".into(), "y".into()],
            vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.5, 0.5],
            vec![1.0; 5],
            vec![(0.0, 1.0), (0.0, 1.0)],
        )
        .unwrap();
        let e = fit_form(
            &few,
            &[InputTransform::Identity; 2],
            &tensor_form(&[1, 1], Some(&[1, 1])),
            Objective::LeastSquares,
            &o,
        )
        .unwrap_err();
        assert!(matches!(e, FitError::TooFewPoints { .. }), "{e}");
        // the text syntax, and an unknown family named with the known ones
        let names: Vec<String> = ["f0", "r", "mu"].map(String::from).to_vec();
        assert_eq!(
            parse_form("split:f0:4:5/4", &names).unwrap(),
            split_form(3, 0, 4, 5, 4)
        );
        assert_eq!(
            parse_form("tensor:1,2,0/1,0,0", &names).unwrap(),
            tensor_form(&[1, 2, 0], Some(&[1, 0, 0]))
        );
        let e = parse_form("chebyshev:3", &names).unwrap_err();
        assert!(
            e.contains("unknown form family 'chebyshev'") && e.contains("split:"),
            "{e}"
        );
        assert!(parse_form("split:eta:4:5/4", &names)
            .unwrap_err()
            .contains("unknown variable"));
        assert!(parse_form("tensor:1,2", &names)
            .unwrap_err()
            .contains("2 per-variable"));
        // an unknown form kind in JSON names the known ones
        let e = serde_json::from_str::<Form>(r#"{"kind": "chebyshev_sum", "degree": 3}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("chebyshev_sum") && e.contains("exponents"),
            "{e}"
        );
    }
}
