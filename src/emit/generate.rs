//! The one expression generator behind every language: a fit becomes an [`ir::Function`]
//! (inputs clamped to the fitted domain, input transforms, nested Horner evaluation of P and Q,
//! the division, the output clamp), and the energy-compensation helpers become small functions
//! that call it.
//!
//! # Evaluation forms
//! * [`EvalForm::Monomial`]: Horner in the transformed variables t, with the fit's own
//!   coefficients (scikit-learn order, as in the JSON). Cheapest; cancels when the coefficients
//!   are large against the values (the paper's glossy fit has ±400 for values in [0, 1]).
//! * [`EvalForm::Shifted`]: Horner in s_k = (t_k − c_k)/h_k ∈ [−1, 1], c_k and h_k the centre and
//!   half-width of t_k's range; coefficients re-expanded exactly, t_k = c_k + h_k s_k (binomial
//!   theorem). Same cost plus one multiply–add per variable.
//! * [`EvalForm::Bernstein`]: the tensor-product Bernstein form on the domain box,
//!   P = Σ b_i Π_k C(n_k, i_k) u_k^{i_k} (1 − u_k)^{n_k − i_k}, u_k = (t_k − lo_k)/(hi_k − lo_k)
//!   ∈ [0, 1], the basis products computed once and shared by P and Q. Every basis value is a
//!   product of non-negative numbers, so the evaluation's condition number is
//!   Σ|b_i B_i(u)| / |P(u)|, which is ≥ 1 and equals 1 when all b_i ≥ 0 (Farouki & Rajan 1987,
//!   "On the numerical condition of polynomials in Bernstein form"): for these fits 5–15 where the
//!   monomial forms reach 100–600. Costs about 2× (2-D) to 5× (3-D) the monomial form.
//!
//! [`choose_form`] builds all three, measures their f32 error against the f64 fit on a grid over
//! the domain in three rounding models (each operation rounded, fused multiply–adds, GPU-allowed
//! ÷ and sqrt errors), and keeps the cheapest whose error stays under [`STABLE_ERROR`]; the
//! header says which form was used and why, with the numbers.
//!
//! Horner nesting (variables outermost first): P = Σ_i x₀ⁱ P_i(x₁, …), each P_i nested the same
//! way in the remaining variables, evaluated as ((P_m x₀ + P_{m−1}) x₀ + …) x₀ + P_0
//! (Horner 1819; pbrt-v4 `EvaluatePolynomial`). For d ≥ 2 the P_i of the first variable are
//! `let` bindings, which changes no rounding.

use std::collections::HashMap;

use super::ir::build::*;
use super::ir::{Arith, Compiled, Expr, Function, Lit, Stmt};
use crate::fit::{FitResult, InputTransform, Polynomial};
use crate::math::CompensatedSum;

/// A form is stable enough if its measured max |f32 − f64| on the measurement grid, in every
/// rounding model, stays under this: a quarter of the stress test's limit of 1e-5, a margin for
/// the points between grid nodes the stress test visits. (The first-order bound is reported but
/// not used to choose: it grows with the number of operations, so it overstates the error of
/// the longer but better-conditioned Bernstein sums by 10–100×.)
pub const STABLE_ERROR: f64 = 2.5e-6;

/// The division guard of the normalisation helpers: the emitted albedo is clamped to [0, 1], so
/// 1/E needs a floor. It never binds for a sane fit: over the default domains the tables have
/// E ≥ 0.307 (conductor; 1 − ln 2 at r = 1, μ = 0), ≥ 0.67 (dielectric entering) and ≥ 0.30
/// (leaving), measured on 64² and 16³ tables.
pub const ALBEDO_FLOOR: f64 = 1e-3;

/// How P and Q are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EvalForm {
    Monomial,
    Shifted,
    Bernstein,
}

impl EvalForm {
    /// Cheapest first.
    pub const ALL: [EvalForm; 3] = [EvalForm::Monomial, EvalForm::Shifted, EvalForm::Bernstein];

    pub fn describe(self) -> &'static str {
        match self {
            EvalForm::Monomial => "nested Horner in the transformed variables t, with the fit's monomial coefficients",
            EvalForm::Shifted => "nested Horner in the shifted variables s = (t − c)/h ∈ [−1, 1] (c, h: centre and half-width of t's range), coefficients re-expanded exactly from the fit's",
            EvalForm::Bernstein => "tensor-product Bernstein form on the domain box, u = (t − lo)/(hi − lo) ∈ [0, 1], coefficients converted exactly from the fit's (non-negative basis values: far less cancellation in f32)",
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            EvalForm::Monomial => "monomial",
            EvalForm::Shifted => "shifted",
            EvalForm::Bernstein => "bernstein",
        }
    }
}

/// What the user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FormChoice {
    /// The cheapest form whose measured f32 error is under [`STABLE_ERROR`] (else the most accurate).
    #[default]
    Auto,
    Force(EvalForm),
}

/// A Rust/WGSL/GLSL identifier from a model or variable name: lower case, `[a-z0-9_]`, not
/// starting with a digit.
pub fn ident(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, 'v');
    }
    if RESERVED.contains(&s.as_str()) {
        s.push_str("_v");
    }
    s
}

/// Keywords and reserved words of Rust, WGSL, GLSL, HLSL or C/C++ a variable name could collide
/// with, and the names the generated bodies use themselves.
const RESERVED: &[&str] = &[
    "as",
    "break",
    "const",
    "continue",
    "else",
    "enum",
    "false",
    "fn",
    "for",
    "if",
    "impl",
    "in",
    "let",
    "loop",
    "match",
    "mod",
    "move",
    "mut",
    "pub",
    "ref",
    "return",
    "self",
    "struct",
    "super",
    "true",
    "type",
    "use",
    "where",
    "while",
    "var",
    "out",
    "inout",
    "sample",
    "filter",
    "input",
    "output",
    "float",
    "int",
    "bool",
    "f32",
    "f16",
    "i32",
    "u32",
    "vec2",
    "vec3",
    "vec4",
    "uniform",
    "buffer",
    "shared",
    "attribute",
    "varying",
    "precise",
    "invariant",
    "discard",
    "switch",
    "case",
    "default",
    "half",
    "double",
    "float3",
    "line",
    "point",
    "triangle",
    "linear",
    "centroid",
    "nointerpolation",
    "noperspective",
    "register",
    "static",
    "inline",
    "extern",
    "export",
    "volatile",
    "vector",
    "matrix",
    "string",
    "texture",
    "sampler",
    "groupshared",
    "cbuffer",
    "tbuffer",
    "packoffset",
    "snorm",
    "unorm",
    "void",
    "char",
    "short",
    "long",
    "signed",
    "unsigned",
    "auto",
    "do",
    "goto",
    "sizeof",
    "typedef",
    "union",
    "restrict",
    "class",
    "new",
    "delete",
    "this",
    "template",
    "typename",
    "namespace",
    "operator",
    "virtual",
    "asm",
    "furnace_rgb",
    "e_avg",
    "f_avg",
    "mu_o",
    "mu_i",
    "e_o",
    "e_i",
    "f_ms",
    "one_minus_e_avg",
    "p",
    "q",
    "e",
    "cos_o",
];

/// `ggx-conductor` → `ggx_conductor`; output `E` → `…_albedo`, `E_R` → `…_albedo_r`.
pub fn albedo_function_name(model: &str, output: &str) -> String {
    let suffix = match output {
        "E" => String::new(),
        o => format!(
            "_{}",
            ident(o.trim_start_matches("E_").trim_start_matches('E'))
        ),
    };
    format!("{}_albedo{suffix}", ident(model))
}

/// The largest f32 ≤ x.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}
/// The smallest f32 ≥ x.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// The fitted domain rounded inwards to f32: clamping to it never leaves the domain on which
/// the denominator was proved positive.
pub fn domain_f32(fit: &FitResult) -> Vec<(f32, f32)> {
    fit.approximant
        .domain
        .iter()
        .map(|&(lo, hi)| (f32_up(lo), f32_down(hi)))
        .collect()
}

/// Centre and half-width of each transformed variable's range.
pub fn shifts(fit: &FitResult) -> crate::fit::Result<Vec<(f64, f64)>> {
    Ok(fit
        .approximant
        .transformed_domain()?
        .into_iter()
        .map(|(lo, hi)| (0.5 * (lo + hi), 0.5 * (hi - lo)))
        .collect())
}

/// The same polynomial in s, t_k = c_k + h_k s_k: Σ_e a_e Π_k Σ_{j ≤ e_k} C(e_k, j) c_k^{e_k−j} h_k^j s_k^j,
/// summed with compensation. A downward-closed exponent set is unchanged; any other (a
/// numerator without some monomials free of a variable) is first closed downwards
/// ([`closed_downwards`]), since a shift gives every monomial dividing a member a term.
pub fn shift_polynomial(p: &Polynomial, shifts: &[(f64, f64)]) -> Polynomial {
    if !crate::fit::basis::is_downward_closed(&p.exponents) {
        return shift_polynomial(&closed_downwards(p), shifts);
    }
    let index: HashMap<&[u32], usize> = p
        .exponents
        .iter()
        .enumerate()
        .map(|(i, e)| (e.as_slice(), i))
        .collect();
    let mut sums = vec![CompensatedSum::default(); p.exponents.len()];
    for (e, &a) in p.exponents.iter().zip(&p.coefficients) {
        if a == 0.0 {
            continue;
        }
        // every j ≤ e componentwise
        let mut j = vec![0u32; e.len()];
        loop {
            let mut term = a;
            for k in 0..e.len() {
                let (c, h) = shifts[k];
                term *= binomial(e[k], j[k]) * c.powi((e[k] - j[k]) as i32) * h.powi(j[k] as i32);
            }
            sums[index[j.as_slice()]].add(term);
            let mut k = 0;
            loop {
                if k == e.len() {
                    break;
                }
                if j[k] < e[k] {
                    j[k] += 1;
                    break;
                }
                j[k] = 0;
                k += 1;
            }
            if k == e.len() {
                break;
            }
        }
    }
    Polynomial {
        exponents: p.exponents.clone(),
        coefficients: sums.iter().map(CompensatedSum::value).collect(),
    }
}

fn binomial(n: u32, k: u32) -> f64 {
    (0..k)
        .fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
        .round()
}

/// `acc + g`, written `acc − |g|` when g is a negative literal (same value, and no `+ -` in the
/// printed code).
fn add_signed(acc: Expr, g: Expr) -> Expr {
    match g {
        Expr::Lit(l) if l.value.is_sign_negative() => sub(
            acc,
            Expr::Lit(Lit {
                value: -l.value,
                exact: -l.exact,
            }),
        ),
        g => add(acc, g),
    }
}

/// Nested Horner of the terms (exponent tuples from variable `k` on) in `vars[k..]`; None if all
/// coefficients are zero.
fn horner(terms: &[(&[u32], f64)], vars: &[Expr], k: usize) -> Option<Expr> {
    let terms: Vec<(&[u32], f64)> = terms.iter().copied().filter(|&(_, c)| c != 0.0).collect();
    if terms.is_empty() {
        return None;
    }
    if k == vars.len() {
        debug_assert_eq!(terms.len(), 1, "distinct exponent tuples");
        return Some(lit(terms[0].1));
    }
    let m = terms.iter().map(|(e, _)| e[k]).max().unwrap_or(0);
    let groups: Vec<Option<Expr>> = (0..=m)
        .map(|i| {
            let sub: Vec<(&[u32], f64)> =
                terms.iter().copied().filter(|(e, _)| e[k] == i).collect();
            horner(&sub, vars, k + 1)
        })
        .collect();
    let mut acc = groups[m as usize]
        .clone()
        .expect("the top power has a term");
    for i in (0..m as usize).rev() {
        acc = mul(acc, vars[k].clone());
        if let Some(g) = groups[i].clone() {
            acc = add_signed(acc, g);
        }
    }
    Some(acc)
}

/// Horner of `p` in `vars`, as `let`s `{name}_{i}` for the powers of the first variable (d ≥ 2)
/// and the final expression.
fn horner_lets(name: &str, what: &str, p: &Polynomial, vars: &[Expr]) -> Vec<Stmt> {
    let terms: Vec<(&[u32], f64)> = p
        .exponents
        .iter()
        .map(Vec::as_slice)
        .zip(p.coefficients.iter().copied())
        .collect();
    let zero = || Stmt {
        name: name.into(),
        value: lit(0.0),
        comment: Some(format!("{what}: every coefficient is zero")),
    };
    if vars.len() < 2 {
        return vec![horner(&terms, vars, 0).map_or_else(zero, |e| Stmt {
            name: name.into(),
            value: e,
            comment: Some(what.into()),
        })];
    }
    let m = terms
        .iter()
        .filter(|(_, c)| *c != 0.0)
        .map(|(e, _)| e[0])
        .max();
    let Some(m) = m else { return vec![zero()] };
    let mut out = Vec::new();
    let mut group_vars = Vec::new();
    for i in 0..=m {
        let sub: Vec<(&[u32], f64)> = terms.iter().copied().filter(|(e, _)| e[0] == i).collect();
        let g = horner(&sub, vars, 1);
        if let Some(g) = g {
            let n = format!("{name}_{i}");
            let comment =
                (i == 0).then(|| format!("{what}, grouped by powers of the first variable"));
            out.push(Stmt {
                name: n.clone(),
                value: g,
                comment,
            });
            group_vars.push(Some(var(&n)));
        } else {
            group_vars.push(None);
        }
    }
    let mut acc = group_vars[m as usize].clone().expect("top power present");
    for i in (0..m as usize).rev() {
        acc = mul(acc, vars[0].clone());
        if let Some(g) = group_vars[i].clone() {
            acc = add(acc, g);
        }
    }
    out.push(Stmt {
        name: name.into(),
        value: acc,
        comment: None,
    });
    out
}

/// A polynomial in the basis of an evaluation form.
#[derive(Clone, Debug, PartialEq)]
pub enum FormPoly {
    /// Monomials (in t or s).
    Monomial(Polynomial),
    /// Tensor-product Bernstein coefficients with the binomials folded in: b_i·Π C(n_k, i_k),
    /// row-major (last variable fastest) over i ∈ Π [0, n_k].
    Bernstein {
        degrees: Vec<u32>,
        coefficients: Vec<f64>,
    },
}

impl FormPoly {
    /// (Σ terms, Σ |terms|) at the form's variables v (t, s or u).
    pub fn eval_abs(&self, v: &[f64]) -> (f64, f64) {
        // per-variable power tables, so each term is a product of lookups
        const MAXP: usize = crate::fit::basis::MAX_DEGREE as usize + 1;
        let d = v.len().min(crate::fit::data::MAX_DIM);
        let mut up = [[1.0f64; MAXP]; crate::fit::data::MAX_DIM];
        let mut vp = [[1.0f64; MAXP]; crate::fit::data::MAX_DIM];
        for k in 0..d {
            for j in 1..MAXP {
                up[k][j] = up[k][j - 1] * v[k];
                vp[k][j] = vp[k][j - 1] * (1.0 - v[k]);
            }
        }
        let mut sum = CompensatedSum::default();
        let mut abs = 0.0;
        match self {
            FormPoly::Monomial(p) => {
                for (e, &c) in p.exponents.iter().zip(&p.coefficients) {
                    let m = e
                        .iter()
                        .enumerate()
                        .take(d)
                        .fold(c, |acc, (k, &x)| acc * up[k][x as usize]);
                    abs += m.abs();
                    sum.add(m);
                }
            }
            FormPoly::Bernstein {
                degrees,
                coefficients,
            } => {
                for (idx, &c) in coefficients.iter().enumerate() {
                    let mut rest = idx;
                    let mut m = c;
                    for k in (0..d).rev() {
                        let n = degrees[k] as usize;
                        let i = rest % (n + 1);
                        rest /= n + 1;
                        m *= up[k][i] * vp[k][n - i];
                    }
                    abs += m.abs();
                    sum.add(m);
                }
            }
        }
        (sum.value(), abs)
    }
}

/// Per-axis power basis → Bernstein basis of degree n: b_i = Σ_{j ≤ i} C(i, j)/C(n, j) a_j
/// (Farouki & Rajan 1987), applied along axis `k` of a row-major tensor.
fn power_to_bernstein_axis(t: &mut [f64], degrees: &[u32], k: usize) {
    let n = degrees[k] as usize;
    let stride: usize = degrees[k + 1..].iter().map(|&m| m as usize + 1).product();
    let size = t.len();
    for base in 0..size {
        if !(base / stride).is_multiple_of(n + 1) {
            continue; // not the start of a fibre along axis k
        }
        let a: Vec<f64> = (0..=n).map(|j| t[base + j * stride]).collect();
        for i in 0..=n {
            let mut acc = CompensatedSum::default();
            for (j, &aj) in a.iter().enumerate().take(i + 1) {
                acc.add(binomial(i as u32, j as u32) / binomial(n as u32, j as u32) * aj);
            }
            t[base + i * stride] = acc.value();
        }
    }
}

/// Largest exponent of each variable in `p`.
pub fn axis_degrees(p: &Polynomial) -> Vec<u32> {
    (0..p.dim())
        .map(|k| p.exponents.iter().map(|e| e[k]).max().unwrap_or(0))
        .collect()
}

/// The tensor Bernstein coefficients (binomials folded in) of `p` on the box `bounds` of its
/// variables, of degree `degrees[k]` (≥ the degree of `p` in variable k) along each.
pub fn bernstein(p: &Polynomial, bounds: &[(f64, f64)], degrees: &[u32]) -> FormPoly {
    let d = bounds.len();
    let degrees = degrees.to_vec();
    // monomials in u, t = lo + (hi − lo) u
    let sh: Vec<(f64, f64)> = bounds.iter().map(|&(lo, hi)| (lo, hi - lo)).collect();
    let pu = shift_polynomial(p, &sh);
    let size: usize = degrees.iter().map(|&n| n as usize + 1).product();
    let mut t = vec![0.0; size];
    for (e, &c) in pu.exponents.iter().zip(&pu.coefficients) {
        let idx = e
            .iter()
            .zip(&degrees)
            .fold(0usize, |acc, (&x, &n)| acc * (n as usize + 1) + x as usize);
        t[idx] += c;
    }
    for k in 0..d {
        power_to_bernstein_axis(&mut t, &degrees, k);
    }
    // fold the binomials C(n_k, i_k) into the coefficients
    for (idx, c) in t.iter_mut().enumerate() {
        let mut rest = idx;
        for k in (0..d).rev() {
            let n = degrees[k] as usize;
            let i = rest % (n + 1);
            rest /= n + 1;
            *c *= binomial(n as u32, i as u32);
        }
    }
    FormPoly::Bernstein {
        degrees,
        coefficients: t,
    }
}

/// P and Q in the basis of `form`.
pub fn form_polynomials(
    fit: &FitResult,
    form: EvalForm,
) -> crate::fit::Result<(FormPoly, Option<FormPoly>)> {
    let a = &fit.approximant;
    Ok(match form {
        EvalForm::Monomial => (
            FormPoly::Monomial(a.numerator.clone()),
            a.denominator.clone().map(FormPoly::Monomial),
        ),
        EvalForm::Shifted => {
            let sh = shifts(fit)?;
            (
                FormPoly::Monomial(shift_polynomial(&a.numerator, &sh)),
                a.denominator
                    .as_ref()
                    .map(|q| FormPoly::Monomial(shift_polynomial(q, &sh))),
            )
        }
        EvalForm::Bernstein => {
            let b = a.transformed_domain()?;
            // one degree per axis for P and Q, so they share the basis values
            let mut degrees = axis_degrees(&a.numerator);
            if let Some(q) = &a.denominator {
                for (d, qd) in degrees.iter_mut().zip(axis_degrees(q)) {
                    *d = (*d).max(qd);
                }
            }
            (
                bernstein(&a.numerator, &b, &degrees),
                a.denominator.as_ref().map(|q| bernstein(q, &b, &degrees)),
            )
        }
    })
}

/// The variables of `form` at an original-variable point x (clamped to the domain): t, s or u.
pub fn form_variables(fit: &FitResult, form: EvalForm, x: &[f64]) -> crate::fit::Result<Vec<f64>> {
    let a = &fit.approximant;
    let clamped: Vec<f64> = x
        .iter()
        .zip(&a.domain)
        .map(|(&v, &(lo, hi))| v.clamp(lo, hi))
        .collect();
    let t = a.transform(&clamped);
    Ok(match form {
        EvalForm::Monomial => t,
        EvalForm::Shifted => t
            .iter()
            .zip(shifts(fit)?)
            .map(|(&t, (c, h))| (t - c) / h)
            .collect(),
        EvalForm::Bernstein => t
            .iter()
            .zip(a.transformed_domain()?)
            .map(|(&t, (lo, hi))| (t - lo) / (hi - lo))
            .collect(),
    })
}

/// Condition number of evaluating `p` at v: Σ|terms| / |Σ terms| (Higham 2002, §5.1; for the
/// Bernstein form the terms are b_i B_i(u)), ∞ where p(v) = 0.
pub fn condition(p: &FormPoly, v: &[f64]) -> f64 {
    let (s, abs) = p.eval_abs(v);
    if s != 0.0 {
        abs / s.abs()
    } else if abs == 0.0 {
        1.0
    } else {
        f64::INFINITY
    }
}

/// Σ_i c_i·m_i as a left-to-right sum of products (`acc ± |c|·m`), zero coefficients skipped.
fn sum_of_products(terms: &[(f64, Expr)]) -> Option<Expr> {
    let mut acc: Option<Expr> = None;
    for (c, m) in terms {
        if *c == 0.0 {
            continue;
        }
        acc = Some(match acc {
            None => mul(lit(*c), m.clone()),
            Some(a) if *c < 0.0 => sub(a, mul(lit(-*c), m.clone())),
            Some(a) => add(a, mul(lit(*c), m.clone())),
        });
    }
    acc
}

/// Bernstein evaluation of `coefficients` given the basis values `basis[k][i]` =
/// u_k^i (1 − u_k)^{n_k − i}: sums of products over the last variable, then, with the partial
/// sums bound as `let`s `{name}_{i}_{j}…`, over the earlier ones.
fn bernstein_lets(
    name: &str,
    what: &str,
    degrees: &[u32],
    coefficients: &[f64],
    basis: &[Vec<Expr>],
) -> Vec<Stmt> {
    fn level(
        degrees: &[u32],
        coefficients: &[f64],
        basis: &[Vec<Expr>],
        k: usize,
        prefix: &str,
        offset: usize,
        out: &mut Vec<Stmt>,
    ) -> Option<Expr> {
        let n = degrees[k] as usize;
        let stride: usize = degrees[k + 1..].iter().map(|&m| m as usize + 1).product();
        if k + 1 == degrees.len() {
            let terms: Vec<(f64, Expr)> = (0..=n)
                .map(|i| (coefficients[offset + i], basis[k][i].clone()))
                .collect();
            return sum_of_products(&terms);
        }
        let mut acc: Option<Expr> = None;
        for i in 0..=n {
            let sub_name = format!("{prefix}_{i}");
            let Some(e) = level(
                degrees,
                coefficients,
                basis,
                k + 1,
                &sub_name,
                offset + i * stride,
                out,
            ) else {
                continue;
            };
            out.push(Stmt {
                name: sub_name.clone(),
                value: e,
                comment: None,
            });
            let term = mul(var(&sub_name), basis[k][i].clone());
            acc = Some(match acc {
                None => term,
                Some(a) => add(a, term),
            });
        }
        acc
    }
    let mut out = Vec::new();
    let e = level(degrees, coefficients, basis, 0, name, 0, &mut out);
    let comment = Some(format!(
        "{what}: Bernstein sums over the last variable, then the earlier ones"
    ));
    if let Some(first) = out.first_mut() {
        first.comment = comment.clone();
    }
    let top_comment = if out.is_empty() { comment } else { None };
    match e {
        Some(e) => out.push(Stmt {
            name: name.into(),
            value: e,
            comment: top_comment,
        }),
        None => out.push(Stmt {
            name: name.into(),
            value: lit(0.0),
            comment: Some(format!("{what}: every coefficient is zero")),
        }),
    }
    out
}

/// `let`s of the Bernstein basis values of variable `p` (u given): v = 1 − u, powers, and
/// m_i = u^i v^(n−i), i = 0…n; returns the statements and the m_i.
fn bernstein_basis(p: &str, u: &Expr, n: u32) -> (Vec<Stmt>, Vec<Expr>) {
    let mut out = Vec::new();
    let v = format!("{p}_v");
    out.push(Stmt {
        name: v.clone(),
        value: sub(lit(1.0), u.clone()),
        comment: Some(format!(
            "Bernstein basis of {p}: u^i (1 − u)^(n − i), n = {n}"
        )),
    });
    let n = n as usize;
    // powers u^1..u^n and v^1..v^n (u^0 = v^0 = 1 are not materialised)
    let mut up = vec![None, Some(u.clone())];
    let mut vp = vec![None, Some(var(&v))];
    for j in 2..=n {
        for (base, pows, tag) in [(u.clone(), &mut up, "u"), (var(&v), &mut vp, "v")] {
            let name = format!("{p}_{tag}{j}");
            out.push(Stmt {
                name: name.clone(),
                value: mul(pows[j - 1].clone().expect("lower power"), base),
                comment: None,
            });
            pows.push(Some(var(&name)));
        }
    }
    let mut m = Vec::new();
    for i in 0..=n {
        let e = match (i, n - i) {
            (0, 0) => lit(1.0),
            (0, b) => vp[b].clone().expect("power"),
            (a, 0) => up[a].clone().expect("power"),
            (a, b) => {
                let name = format!("{p}_b{i}");
                out.push(Stmt {
                    name: name.clone(),
                    value: mul(up[a].clone().expect("power"), vp[b].clone().expect("power")),
                    comment: None,
                });
                var(&name)
            }
        };
        m.push(e);
    }
    (out, m)
}

/// The `let`s of [`albedo_function`]'s body that hold the transformed variables t, one per
/// variable (`{p}_t`, or the clamped input `{p}_c` without a transform): where its polynomial
/// part starts, which [`super::bound`] bounds box by box.
pub fn transformed_lets(fit: &FitResult) -> Vec<String> {
    let a = &fit.approximant;
    a.variables
        .iter()
        .zip(&a.transforms)
        .map(|(v, t)| {
            let p = ident(v);
            if *t == InputTransform::Identity {
                format!("{p}_c")
            } else {
                format!("{p}_t")
            }
        })
        .collect()
}

/// The log-corrected `x`: v = (x + b·λ(x))/(1 + b·λ(1)), λ(x) = 16·x^(15/16)·((1 + x)^(1/16) −
/// x^(1/16)) as in [`crate::fit::data::log_term`] (by square roots, products and one division),
/// b the expression given (`b_text` for the comment). Pushes its steps as `{p}_logs`,
/// `{p}_logq`, `{p}_logv` and returns the name of v.
fn log_corrected(x: &str, b: Expr, b_text: &str, p: &str, body: &mut Vec<Stmt>) -> String {
    let n = crate::fit::data::LOG_ROOT_ORDER;
    let roots = |e: Expr| (0..n.trailing_zeros()).fold(e, |e, _| sqrt(e));
    let r = format!("{p}_logs");
    body.push(Stmt {
        name: r.clone(),
        value: roots(max(var(x), lit(crate::fit::data::LOG_FLOOR))),
        comment: Some(format!(
            "log-corrected {p}: v = ({p} + b*l({p}))/(1 + b*l(1)), b = {b_text}, l(x) = 16*x^(15/16)*((1 + x)^(1/16) - x^(1/16)) ~ x*ln(1 + 1/x), as 16*x/(s*(q + s)*(q^2 + s^2)*(q^4 + s^4)*(q^8 + s^8)) with s = max(x, 2^-64)^(1/16), q = (1 + x)^(1/16)"
        )),
    });
    let qn = format!("{p}_logq");
    body.push(Stmt {
        name: qn.clone(),
        value: roots(add(lit(1.0), var(x))),
        comment: None,
    });
    let (s1, q1) = (var(&r), var(&qn));
    let s2 = mul(s1.clone(), s1.clone());
    let q2 = mul(q1.clone(), q1.clone());
    let s4 = mul(s2.clone(), s2.clone());
    let q4 = mul(q2.clone(), q2.clone());
    let s8 = mul(s4.clone(), s4.clone());
    let q8 = mul(q4.clone(), q4.clone());
    let sums = mul(
        mul(mul(mul(s1.clone(), add(q1, s1)), add(q2, s2)), add(q4, s4)),
        add(q8, s8),
    );
    let lam = div(mul(lit(n as f64), var(x)), sums);
    let v = format!("{p}_logv");
    body.push(Stmt {
        name: v.clone(),
        value: div(
            add(var(x), mul(b.clone(), lam)),
            add(lit(1.0), mul(b, lit(crate::fit::data::log_term(1.0)))),
        ),
        comment: None,
    });
    v
}

/// sin²x of x ∈ [0, π/2] without a sine ([`InputTransform::SinSquared`]): (1 + sin u)/2 with
/// u = 2x − π/2 and sin u = u·Σ_j c_j u^(2j) by Horner in u² (Taylor to u¹⁵,
/// [`crate::fit::sin_squared_series`]). Pushes u and u² as `{prefix}u`, `{prefix}u2`.
fn sin_squared(x: Expr, prefix: &str, body: &mut Vec<Stmt>) -> Expr {
    let u = format!("{prefix}u");
    let u2 = format!("{prefix}u2");
    body.push(Stmt {
        name: u.clone(),
        value: sub(mul(x, lit(2.0)), lit(std::f64::consts::FRAC_PI_2)),
        comment: Some(
            "sin²φ = (1 + sin u)/2, u = 2φ − π/2 (Taylor series of sin to u¹⁵)".to_string(),
        ),
    });
    body.push(Stmt {
        name: u2.clone(),
        value: mul(var(&u), var(&u)),
        comment: None,
    });
    let c = crate::fit::sin_squared_series();
    let mut h = lit(c[c.len() - 1]);
    for &cj in c[..c.len() - 1].iter().rev() {
        h = add(mul(h, var(&u2)), lit(cj));
    }
    add(lit(0.5), mul(lit(0.5), mul(var(&u), h)))
}
/// Terms of a structured form cancel when, somewhere on the measurement grid, Σ_k |e_k| exceeds
/// this multiple of max(1, |Σ_k e_k|): each term's f32 rounding error is relative to |e_k|, so
/// the sum's error grows by that factor over one quotient's ([`one_quotient`]).
pub const TERM_CANCELLATION: f64 = 8.0;

/// One quotient may store at most this multiple of the structured form's numbers.
pub const ONE_QUOTIENT_GROWTH: usize = 2;

/// Σ_k |e_k| / max(1, |Σ_k e_k|), largest over the emitter's measurement grid
/// ([`measurement_nodes`] per axis), of a structured approximant's terms e_k = (u_k·P_k)/Q_k;
/// 1 for an approximant of one term.
pub fn term_cancellation(fit: &FitResult) -> f64 {
    let a = &fit.approximant;
    if a.terms.is_empty() {
        return 1.0;
    }
    let d = a.variables.len();
    let terms = a.all_terms();
    let points = grid_points(&domain_f32(fit), measurement_nodes(d));
    points
        .chunks(d)
        .map(|x| {
            let x: Vec<f64> = x.iter().map(|&v| v as f64).collect();
            let t = a.transform(&x);
            let (sum, abs) = terms.iter().fold((0.0, 0.0), |(s, m), term| {
                let e = term.eval(&t);
                (s + e, m + e.abs())
            });
            abs / f64::max(1.0, sum.abs())
        })
        .fold(1.0, f64::max)
}

/// Product of two polynomials in the same variables (exponents in lexicographic order).
fn poly_product(p: &Polynomial, q: &Polynomial) -> Polynomial {
    let mut out: std::collections::BTreeMap<Vec<u32>, CompensatedSum> = Default::default();
    for (e, &c) in p.exponents.iter().zip(&p.coefficients) {
        for (f, &b) in q.exponents.iter().zip(&q.coefficients) {
            let k: Vec<u32> = e.iter().zip(f).map(|(x, y)| x + y).collect();
            out.entry(k).or_default().add(c * b);
        }
    }
    Polynomial {
        exponents: out.keys().cloned().collect(),
        coefficients: out.values().map(|s| s.value()).collect(),
    }
}

/// Sum of polynomials in the same variables (exponents in lexicographic order).
fn poly_sum(ps: &[Polynomial]) -> Polynomial {
    let mut out: std::collections::BTreeMap<Vec<u32>, CompensatedSum> = Default::default();
    for p in ps {
        for (e, &c) in p.exponents.iter().zip(&p.coefficients) {
            out.entry(e.clone()).or_default().add(c);
        }
    }
    Polynomial {
        exponents: out.keys().cloned().collect(),
        coefficients: out.values().map(|s| s.value()).collect(),
    }
}

/// A structured fit Σ_k (u_k·P_k)/Q_k written as one quotient N/D over the product of its
/// denominators, N = Σ_k u_k·P_k·Π_{j≠k} Q_j, D = Π_k Q_k (coefficients multiplied out in f64
/// with compensated sums; the same function to rounding), for the emitters to evaluate when the
/// terms cancel: at the leaving dielectric's low-rank fits two terms of size ~16 add up to an
/// albedo of ~0.5, and each term's f32 rounding error (relative to the term) becomes ~30× the
/// albedo's, where N's coefficients carry the cancellation out in f64 already.
/// None when the fit is not structured, its terms do not cancel ([`term_cancellation`] below
/// [`TERM_CANCELLATION`]) or N/D would store more than [`ONE_QUOTIENT_GROWTH`] times its numbers.
pub fn one_quotient(fit: &FitResult) -> Option<FitResult> {
    let a = &fit.approximant;
    if a.terms.is_empty() || term_cancellation(fit) < TERM_CANCELLATION {
        return None;
    }
    let d = a.variables.len();
    let one = Polynomial {
        exponents: vec![vec![0; d]],
        coefficients: vec![1.0],
    };
    let terms = a.all_terms();
    let den_of =
        |t: &crate::fit::result::Term| t.denominator.clone().unwrap_or_else(|| one.clone());
    let den = terms
        .iter()
        .fold(one.clone(), |acc, t| poly_product(&acc, &den_of(t)));
    let parts: Vec<Polynomial> = terms
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let mut p = t.numerator.clone();
            if let Some(u) = &t.factor {
                p = poly_product(&p, u);
            }
            for (j, s) in terms.iter().enumerate() {
                if j != k {
                    p = poly_product(&p, &den_of(s));
                }
            }
            p
        })
        .collect();
    let num = poly_sum(&parts);
    let stored = num.coefficients.len() + den.coefficients.len() - 1;
    if stored > ONE_QUOTIENT_GROWTH * fit.n_coefficients {
        return None;
    }
    let mut out = fit.clone();
    out.approximant.numerator = num;
    out.approximant.denominator = Some(den);
    out.approximant.factor = None;
    out.approximant.terms = Vec::new();
    Some(out)
}

/// The albedo function of a fit: `name(x_1, …, x_d) -> f32`.
///
/// Body: clamp each input to the f32-rounded domain; apply the input transforms; shift (for
/// [`EvalForm::Shifted`]); `p`, `q` by Horner; `e = p / q` (the unclamped value, which the
/// stress test inspects); result `clamp(e, 0, 1)` — an albedo of an energy-conserving BSDF.
/// A structured form's terms are evaluated each as (u_k·P_k)/Q_k and added, or as one quotient
/// where they cancel ([`one_quotient`]).
pub fn albedo_function(
    name: &str,
    doc: Vec<String>,
    fit: &FitResult,
    form: EvalForm,
) -> crate::fit::Result<Function> {
    fit.approximant.validate()?;
    match one_quotient(fit) {
        Some(one) => albedo_function_of(name, doc, &one, form),
        None => albedo_function_of(name, doc, fit, form),
    }
}

/// [`albedo_function`] with a structured form's terms evaluated one by one.
fn albedo_function_of(
    name: &str,
    doc: Vec<String>,
    fit: &FitResult,
    form: EvalForm,
) -> crate::fit::Result<Function> {
    let a = &fit.approximant;
    a.validate()?;
    let params: Vec<String> = a.variables.iter().map(|v| ident(v)).collect();
    let dom = domain_f32(fit);
    let mut body = Vec::new();
    let mut tvars = Vec::new();
    for (k, p) in params.iter().enumerate() {
        let c = format!("{p}_c");
        body.push(Stmt {
            name: c.clone(),
            value: clamp(
                var(p),
                Expr::Lit(Lit::exact(dom[k].0)),
                Expr::Lit(Lit::exact(dom[k].1)),
            ),
            comment: (k == 0).then(|| "inputs clamped to the fitted domain".to_string()),
        });
        let (lo, hi) = a.domain[k];
        let t = match a.transforms[k] {
            InputTransform::Identity => None,
            // x ≥ lo ≥ 0 after the clamp (the transform is valid on the domain)
            InputTransform::Sqrt => Some(sqrt(var(&c))),
            InputTransform::OneMinus => Some(sub(lit(1.0), var(&c))),
            InputTransform::Square => Some(mul(var(&c), var(&c))),
            InputTransform::ClampNormalize { lo: a0, hi: b0 } => {
                let x = if lo >= a0 && hi <= b0 {
                    var(&c)
                } else {
                    clamp(var(&c), lit(a0), lit(b0))
                };
                Some(mul(sub(x, lit(a0)), lit(1.0 / (b0 - a0))))
            }
            // (x(1 + k y²) + τ)/(x + k y² + τ), y = an earlier (already clamped) argument
            InputTransform::BoundaryLayer { by, k: scale } => {
                let y = var(&format!("{}_c", params[by]));
                let s = || mul(lit(scale), mul(y.clone(), y.clone()));
                let tau = || lit(crate::fit::data::LAYER_TAU);
                Some(div(
                    add(mul(var(&c), add(lit(1.0), s())), tau()),
                    add(add(var(&c), s()), tau()),
                ))
            }
            // (q(clamp(x, lo, hi)) − q(lo))·(1/(q(hi) − q(lo))), q(x) = x^(1/n) + b·x, the root
            // as repeated square roots of a non-negative number
            InputTransform::RootNormalize {
                lo: a0,
                hi: b0,
                root,
                linear,
            } => {
                let x = if lo >= a0 && hi <= b0 {
                    var(&c)
                } else {
                    clamp(var(&c), lit(a0), lit(b0))
                };
                let q = |v: f64| (0..root.trailing_zeros()).fold(v, |v, _| v.sqrt()) + linear * v;
                let rx = (0..root.trailing_zeros()).fold(x.clone(), |e, _| sqrt(e));
                let qx = if linear == 0.0 {
                    rx
                } else {
                    add(rx, mul(lit(linear), x))
                };
                let (qa, qb) = (q(a0), q(b0));
                let shifted = if qa == 0.0 { qx } else { sub(qx, lit(qa)) };
                Some(mul(shifted, lit(1.0 / (qb - qa))))
            }
            // (2q/(1 + q²) − μ_c(lo))·(1/(μ_c(hi) − μ_c(lo))), q = clamp(x, lo, hi)^¼ as two
            // square roots of a non-negative number
            InputTransform::CriticalAngle { lo: a0, hi: b0 } => {
                let x = if lo >= a0 && hi <= b0 {
                    var(&c)
                } else {
                    clamp(var(&c), lit(a0), lit(b0))
                };
                let q = format!("{p}_q");
                body.push(Stmt {
                    name: q.clone(),
                    value: sqrt(sqrt(x)),
                    comment: Some(format!("q = {p}^(1/4)")),
                });
                let (ma, mb) = (
                    crate::fit::data::critical_cosine(a0),
                    crate::fit::data::critical_cosine(b0),
                );
                let mc = div(mul(lit(2.0), var(&q)), add(lit(1.0), mul(var(&q), var(&q))));
                Some(mul(sub(mc, lit(ma)), lit(1.0 / (mb - ma))))
            }
            // ((1 − w)·(x(1 + k y²) + τ)/(x + k y² + τ) + w·x)^(1/n), y = an earlier clamped
            // argument, the root as repeated square roots of a non-negative number
            InputTransform::GrazingLayer {
                by,
                k: scale,
                w,
                root,
                beta,
            } => {
                let y = var(&format!("{}_c", params[by]));
                let s = || mul(lit(scale), mul(y.clone(), y.clone()));
                let tau = || lit(crate::fit::data::LAYER_TAU);
                // with β > 0, x is first the log-corrected v = (x + b·λ(x))/(1 + b·λ(1)),
                // b = β y⁴, λ(x) = 16·x^(15/16)·((1 + x)^(1/16) − x^(1/16)) as in fit::data::log_term
                let x = if beta > 0.0 {
                    let b = mul(
                        lit(beta),
                        mul(mul(y.clone(), y.clone()), mul(y.clone(), y.clone())),
                    );
                    log_corrected(&c, b, &format!("{beta}*{}^4", params[by]), p, &mut body)
                } else {
                    c.clone()
                };
                let l = div(
                    add(mul(var(&x), add(lit(1.0), s())), tau()),
                    add(add(var(&x), s()), tau()),
                );
                let blend = if w == 0.0 {
                    l
                } else {
                    add(mul(lit(1.0 - w), l), mul(lit(w), var(&x)))
                };
                Some((0..root.trailing_zeros()).fold(blend, |e, _| sqrt(e)))
            }
            // x·(√(1 + s) + √s)/(√(x + s) + √s + τ), s = k yᵉ, y = an earlier clamped argument
            // (x ≥ 0 after the clamp: the transform is valid on the domain); yᵉ multiplied left
            // to right, as `fit::data::layer_power`
            InputTransform::RootLayer {
                by,
                k: scale,
                power,
            } => {
                let y = var(&format!("{}_c", params[by]));
                let s = format!("{p}_s");
                let y_e = (1..power).fold(y.clone(), |acc, _| mul(acc, y.clone()));
                body.push(Stmt {
                    name: s.clone(),
                    value: mul(lit(scale), y_e),
                    comment: None,
                });
                let rs = format!("{p}_rs");
                body.push(Stmt {
                    name: rs.clone(),
                    value: sqrt(var(&s)),
                    comment: None,
                });
                Some(div(
                    mul(var(&c), add(sqrt(add(lit(1.0), var(&s))), var(&rs))),
                    add(
                        add(sqrt(add(var(&c), var(&s))), var(&rs)),
                        lit(crate::fit::data::LAYER_TAU),
                    ),
                ))
            }
            // (`{p}_sin_` keeps its steps apart from `{p}_u`, the Bernstein form's coordinate)
            InputTransform::SinSquared => {
                Some(sin_squared(var(&c), &format!("{p}_sin_"), &mut body))
            }
            // ((x(1 + k α_o) + τ)/(x + k α_o + τ))^(1/n), α_o the projected roughness of the
            // clamped r, aniso and φ (φ clamped here: it may come after this variable)
            InputTransform::ProjectedLayer {
                r,
                aniso,
                phi,
                k: scale,
                root,
                beta,
            } => {
                let dom_phi = (
                    Expr::Lit(Lit::exact(dom[phi].0)),
                    Expr::Lit(Lit::exact(dom[phi].1)),
                );
                let phi_c = clamp(var(&params[phi]), dom_phi.0, dom_phi.1);
                let s2 = sin_squared(phi_c, &format!("{p}_phi_"), &mut body);
                let b = format!("{p}_b");
                body.push(Stmt {
                    name: b.clone(),
                    value: sub(lit(1.0), var(&format!("{}_c", params[aniso]))),
                    comment: Some("1 − aniso = α_b/α_t".to_string()),
                });
                let rc = var(&format!("{}_c", params[r]));
                let bb = || mul(var(&b), var(&b));
                // α_t = r²·√(2/(1 + b²)) (OpenPBR, "Microfacet model"); α_o = α_t·√(1 − (1 − b²)·sin²φ)
                let alpha_t = mul(
                    mul(rc.clone(), rc),
                    sqrt(div(lit(2.0), add(lit(1.0), bb()))),
                );
                let ao = format!("{p}_alpha_o");
                body.push(Stmt {
                    name: ao.clone(),
                    value: mul(
                        alpha_t,
                        sqrt(max(sub(lit(1.0), mul(sub(lit(1.0), bb()), s2)), lit(0.0))),
                    ),
                    comment: Some(
                        "projected roughness of the azimuth (Heitz 2014, eq. 80)".to_string(),
                    ),
                });
                let s = || mul(lit(scale), var(&ao));
                let tau = || lit(crate::fit::data::LAYER_TAU);
                // with β > 0, μ is first the log-corrected v of the grazing layer, b = β α_o²
                let x = if beta > 0.0 {
                    let b = mul(lit(beta), mul(var(&ao), var(&ao)));
                    log_corrected(&c, b, &format!("{beta}*{p}_alpha_o^2"), p, &mut body)
                } else {
                    c.clone()
                };
                let l = div(
                    add(mul(var(&x), add(lit(1.0), s())), tau()),
                    add(add(var(&x), s()), tau()),
                );
                Some((0..root.trailing_zeros()).fold(l, |e, _| sqrt(e)))
            }
            // √(max(1 − (1 − b²)·sin²φ, b²)), b = 1 − aniso (aniso an earlier or later argument,
            // clamped here): the argument of the root never falls below its exact bound b²
            InputTransform::ProjectedRatio { aniso } => {
                let dom_a = (
                    Expr::Lit(Lit::exact(dom[aniso].0)),
                    Expr::Lit(Lit::exact(dom[aniso].1)),
                );
                let a_c = clamp(var(&params[aniso]), dom_a.0, dom_a.1);
                // (`{p}_s_` keeps its steps apart from `{p}_u`, the shifted coordinate below)
                let s2 = sin_squared(var(&c), &format!("{p}_s_"), &mut body);
                let b = format!("{p}_b");
                body.push(Stmt {
                    name: b.clone(),
                    value: sub(lit(1.0), a_c),
                    comment: Some("1 − aniso = α_b/α_t".to_string()),
                });
                let bb = || mul(var(&b), var(&b));
                Some(sqrt(max(sub(lit(1.0), mul(sub(lit(1.0), bb()), s2)), bb())))
            }
        };
        let tname = match t {
            Some(t) => {
                let n = format!("{p}_t");
                body.push(Stmt {
                    name: n.clone(),
                    value: t,
                    comment: Some(format!("t = {}", a.transforms[k].formula(k, &params))),
                });
                n
            }
            None => c,
        };
        tvars.push(tname);
    }
    if a.is_structured() {
        return structured_function(name, doc, fit, form, params, body, &tvars);
    }
    let (num, den) = form_polynomials(fit, form)?;
    let all_coefficients = |p: &FormPoly| -> Vec<f64> {
        match p {
            FormPoly::Monomial(m) => m.coefficients.clone(),
            FormPoly::Bernstein { coefficients, .. } => coefficients.clone(),
        }
    };
    let mut coeffs = all_coefficients(&num);
    if let Some(q) = &den {
        coeffs.extend(all_coefficients(q));
    }
    if let Some(bad) = coeffs.iter().find(|c| !((**c as f32).is_finite())) {
        return Err(crate::fit::FitError::NonFinite {
            what: "coefficient in f32",
            index: 0,
            value: *bad,
        });
    }
    match form {
        EvalForm::Monomial | EvalForm::Shifted => {
            let vars: Vec<Expr> = if form == EvalForm::Monomial {
                tvars.iter().map(|t| var(t)).collect()
            } else {
                let sh = shifts(fit)?;
                let mut vars = Vec::new();
                for (k, t) in tvars.iter().enumerate() {
                    let (c, h) = sh[k];
                    let n = format!("{}_s", params[k]);
                    // s = t·(1/h) − c/h
                    let scaled = mul(var(t), lit(1.0 / h));
                    let value = if c == 0.0 {
                        scaled
                    } else {
                        add_signed(scaled, lit(-c / h))
                    };
                    body.push(Stmt {
                        name: n.clone(),
                        value,
                        comment: Some(format!("s = (t − {c})/{h} ∈ [−1, 1]")),
                    });
                    vars.push(var(&n));
                }
                vars
            };
            let mono = |p: &FormPoly| match p {
                FormPoly::Monomial(m) => m.clone(),
                FormPoly::Bernstein { .. } => unreachable!("monomial forms"),
            };
            body.extend(horner_lets("p", "numerator P", &mono(&num), &vars));
            if let Some(q) = &den {
                body.extend(horner_lets(
                    "q",
                    "denominator Q (proved positive on the domain)",
                    &mono(q),
                    &vars,
                ));
            }
        }
        EvalForm::Bernstein => {
            let bounds = a.transformed_domain()?;
            let FormPoly::Bernstein {
                degrees,
                coefficients: pc,
            } = &num
            else {
                unreachable!("bernstein form")
            };
            let mut basis = Vec::new();
            for (k, t) in tvars.iter().enumerate() {
                let (lo, hi) = bounds[k];
                let u = if lo == 0.0 && hi == 1.0 {
                    var(t)
                } else {
                    let n = format!("{}_u", params[k]);
                    body.push(Stmt {
                        name: n.clone(),
                        value: mul(sub(var(t), lit(lo)), lit(1.0 / (hi - lo))),
                        comment: Some(format!("u = (t − {lo})/({hi} − {lo}) ∈ [0, 1]")),
                    });
                    var(&n)
                };
                let (stmts, m) = bernstein_basis(&params[k], &u, degrees[k]);
                body.extend(stmts);
                basis.push(m);
            }
            body.extend(bernstein_lets("p", "numerator P", degrees, pc, &basis));
            if let Some(FormPoly::Bernstein {
                coefficients: qc, ..
            }) = &den
            {
                body.extend(bernstein_lets(
                    "q",
                    "denominator Q (proved positive on the domain)",
                    degrees,
                    qc,
                    &basis,
                ));
            }
        }
    }
    match &den {
        Some(_) => body.push(Stmt {
            name: "e".into(),
            value: div(var("p"), var("q")),
            comment: None,
        }),
        None => body.push(Stmt {
            name: "e".into(),
            value: var("p"),
            comment: None,
        }),
    }
    Ok(Function {
        name: name.into(),
        doc,
        params,
        body,
        result: clamp(var("e"), lit(0.0), lit(1.0)),
    })
}

/// The exponent set of `p` closed downwards (every monomial dividing one of its monomials
/// listed, with coefficient 0 where it had none): the shape the shifted and Bernstein
/// conversions expand over. A structured form's term t_x^a·P_a(y) is not closed.
fn closed_downwards(p: &Polynomial) -> Polynomial {
    let mut exps: Vec<Vec<u32>> = Vec::new();
    for e in &p.exponents {
        let mut j = vec![0u32; e.len()];
        loop {
            if !exps.contains(&j) {
                exps.push(j.clone());
            }
            let mut k = 0;
            while k < e.len() {
                if j[k] < e[k] {
                    j[k] += 1;
                    break;
                }
                j[k] = 0;
                k += 1;
            }
            if k == e.len() {
                break;
            }
        }
    }
    exps.sort_by(|a, b| {
        a.iter()
            .sum::<u32>()
            .cmp(&b.iter().sum::<u32>())
            .then_with(|| b.cmp(a))
    });
    let coefficients = exps
        .iter()
        .map(|e| {
            p.exponents
                .iter()
                .position(|x| x == e)
                .map_or(0.0, |i| p.coefficients[i])
        })
        .collect();
    Polynomial {
        exponents: exps,
        coefficients,
    }
}

/// The body of a structured form's albedo function after the transformed variables: per term
/// i the factor `u{i}`, numerator `p{i}` and denominator `q{i}` (each in the evaluation form),
/// the term `(p{i}·u{i})/q{i}`, and `e` their sum from the first term on — the order of
/// [`crate::fit::Approximant::eval`].
fn structured_function(
    name: &str,
    doc: Vec<String>,
    fit: &FitResult,
    form: EvalForm,
    params: Vec<String>,
    mut body: Vec<Stmt>,
    tvars: &[String],
) -> crate::fit::Result<Function> {
    let a = &fit.approximant;
    let terms = a.all_terms();
    for p in terms.iter().flat_map(|t| {
        std::iter::once(&t.numerator)
            .chain(t.factor.iter())
            .chain(t.denominator.iter())
    }) {
        if let Some(bad) = p.coefficients.iter().find(|c| !((**c as f32).is_finite())) {
            return Err(crate::fit::FitError::NonFinite {
                what: "coefficient in f32",
                index: 0,
                value: *bad,
            });
        }
    }
    // the evaluation form's variables, and a converter of each polynomial into its statements
    let bounds = a.transformed_domain()?;
    let mut vars: Vec<Expr> = tvars.iter().map(|t| var(t)).collect();
    let mut u_vars: Vec<Expr> = Vec::new();
    match form {
        EvalForm::Monomial => {}
        EvalForm::Shifted => {
            let sh = shifts(fit)?;
            vars.clear();
            for (k, t) in tvars.iter().enumerate() {
                let (c, h) = sh[k];
                let n = format!("{}_s", params[k]);
                let scaled = mul(var(t), lit(1.0 / h));
                let value = if c == 0.0 {
                    scaled
                } else {
                    add_signed(scaled, lit(-c / h))
                };
                body.push(Stmt {
                    name: n.clone(),
                    value,
                    comment: Some(format!("s = (t − {c})/{h} ∈ [−1, 1]")),
                });
                vars.push(var(&n));
            }
        }
        EvalForm::Bernstein => {
            for (k, t) in tvars.iter().enumerate() {
                let (lo, hi) = bounds[k];
                u_vars.push(if lo == 0.0 && hi == 1.0 {
                    var(t)
                } else {
                    let n = format!("{}_u", params[k]);
                    body.push(Stmt {
                        name: n.clone(),
                        value: mul(sub(var(t), lit(lo)), lit(1.0 / (hi - lo))),
                        comment: Some(format!("u = (t − {lo})/({hi} − {lo}) ∈ [0, 1]")),
                    });
                    var(&n)
                });
            }
        }
    }
    // Bernstein basis values of each (variable, degree) used, made once
    let mut bases: HashMap<(usize, u32), Vec<Expr>> = HashMap::new();
    let sh = shifts(fit)?;
    let mut poly_lets = |body: &mut Vec<Stmt>, n: &str, what: &str, p: &Polynomial| match form {
        EvalForm::Monomial => body.extend(horner_lets(n, what, p, &vars)),
        EvalForm::Shifted => body.extend(horner_lets(
            n,
            what,
            &shift_polynomial(&closed_downwards(p), &sh),
            &vars,
        )),
        EvalForm::Bernstein => {
            let degrees = axis_degrees(p);
            let FormPoly::Bernstein { coefficients, .. } =
                bernstein(&closed_downwards(p), &bounds, &degrees)
            else {
                unreachable!("bernstein() gives the Bernstein form")
            };
            let mut basis = Vec::new();
            for (k, &deg) in degrees.iter().enumerate() {
                let b = bases.entry((k, deg)).or_insert_with(|| {
                    if deg == 0 {
                        vec![Expr::Lit(Lit::exact(1.0))]
                    } else {
                        let (stmts, m) =
                            bernstein_basis(&format!("{}_b{deg}", params[k]), &u_vars[k], deg);
                        body.extend(stmts);
                        m
                    }
                });
                basis.push(b.clone());
            }
            body.extend(bernstein_lets(n, what, &degrees, &coefficients, &basis));
        }
    };
    let mut sum: Option<Expr> = None;
    for (i, t) in terms.iter().enumerate() {
        let (pn, un, qn) = (format!("p{i}"), format!("u{i}"), format!("q{i}"));
        poly_lets(
            &mut body,
            &pn,
            &format!("term {i}: numerator P_{i}"),
            &t.numerator,
        );
        let mut value = var(&pn);
        if let Some(u) = &t.factor {
            poly_lets(&mut body, &un, &format!("term {i}: factor u_{i}"), u);
            value = mul(value, var(&un));
        }
        if let Some(q) = &t.denominator {
            poly_lets(
                &mut body,
                &qn,
                &format!("term {i}: denominator Q_{i} (proved positive on the domain)"),
                q,
            );
            value = div(value, var(&qn));
        }
        let en = format!("e{i}");
        body.push(Stmt {
            name: en.clone(),
            value,
            comment: None,
        });
        sum = Some(match sum {
            None => var(&en),
            Some(acc) => add(acc, var(&en)),
        });
    }
    body.push(Stmt {
        name: "e".into(),
        value: sum.unwrap_or_else(|| lit(0.0)),
        comment: Some(format!("the sum of the {} terms", terms.len())),
    });
    Ok(Function {
        name: name.into(),
        doc,
        params,
        body,
        result: clamp(var("e"), lit(0.0), lit(1.0)),
    })
}

/// Accuracy of an emitted function's f32 evaluation against the f64 fit on a point set.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct F32Accuracy {
    pub points: usize,
    /// max |f32 − f64| with every operation rounded once (the emitted Rust on a CPU).
    pub max_diff_ieee: f64,
    /// The same with multiply–adds fused.
    pub max_diff_fused: f64,
    /// The same with GPU-allowed division and square-root errors.
    pub max_diff_gpu: f64,
    /// Largest |f64 fit| outside [0, 1] before the output clamp (0 if none).
    pub max_overshoot: f64,
}

impl F32Accuracy {
    pub fn max_diff(&self) -> f64 {
        self.max_diff_ieee
            .max(self.max_diff_fused)
            .max(self.max_diff_gpu)
    }
}

/// x clamped to the fit's domain into `out` (a coordinate without a domain interval gives 0).
fn clamp_to_domain(fit: &FitResult, x: impl Iterator<Item = f64>, out: &mut [f64]) {
    out.fill(0.0);
    for ((o, v), &(lo, hi)) in out.iter_mut().zip(x).zip(&fit.approximant.domain) {
        *o = v.clamp(lo, hi);
    }
}

/// The function every emitted albedo computes, in f64: the fit at the input clamped to its
/// domain, clamped to [0, 1]. Also returns the value before the output clamp.
pub fn clamped(fit: &FitResult, x: &[f64]) -> (f64, f64) {
    let mut buf = [0.0f64; crate::fit::data::MAX_DIM];
    let buf = &mut buf[..x.len()];
    clamp_to_domain(fit, x.iter().copied(), buf);
    let raw = fit.eval(buf);
    (raw.clamp(0.0, 1.0), raw)
}

/// The f64 reference of an emitted albedo at an f32 input ([`clamped`]).
pub fn reference(fit: &FitResult, x: &[f32]) -> (f64, f64) {
    let mut buf = [0.0f64; crate::fit::data::MAX_DIM];
    for (b, &v) in buf.iter_mut().zip(x) {
        *b = v as f64;
    }
    clamped(fit, &buf[..x.len()])
}

/// [`reference`] at every point of `xs` (row-major f32 coordinates, `d` per point), evaluated a
/// block at a time: the same bits as point by point.
pub fn references(fit: &FitResult, d: usize, xs: &[f32]) -> Vec<(f64, f64)> {
    let mut buf = vec![0.0f64; xs.len()];
    for (p, x) in buf
        .chunks_exact_mut(d.max(1))
        .zip(xs.chunks_exact(d.max(1)))
    {
        clamp_to_domain(fit, x.iter().map(|&v| v as f64), p);
    }
    let mut raw = vec![0.0; xs.len() / d.max(1)];
    fit.approximant.eval_many(d, &buf, &mut raw);
    raw.into_iter().map(|r| (r.clamp(0.0, 1.0), r)).collect()
}

/// Measures `compiled` (an albedo function of `fit`) at `points` (row-major f32 coordinates).
pub fn measure(compiled: &Compiled, fit: &FitResult, points: &[f32]) -> F32Accuracy {
    use super::ir::BLOCK;
    let d = compiled.n_params();
    let mut acc = F32Accuracy {
        points: points.len() / d,
        ..Default::default()
    };
    let result = compiled.results()[0];
    let mut regs = Vec::new();
    for (b, xs) in points.chunks(BLOCK * d).enumerate() {
        let refs: Vec<f64> = references(fit, d, xs)
            .into_iter()
            .map(|(reference, raw)| {
                acc.max_overshoot = acc.max_overshoot.max(raw - 1.0).max(-raw);
                reference
            })
            .collect();
        let seeds: Vec<u64> = (0..refs.len()).map(|j| (b * BLOCK + j) as u64).collect();
        for (arith, max) in [
            (Arith::Ieee, &mut acc.max_diff_ieee),
            (Arith::Fused, &mut acc.max_diff_fused),
            (Arith::Gpu { seed: 0 }, &mut acc.max_diff_gpu),
        ] {
            compiled.eval_block(xs, arith, &seeds, &mut regs);
            for (j, &r) in refs.iter().enumerate() {
                let v = regs[result * BLOCK + j];
                // a NaN or ∞ (a pole) must not vanish in max()
                let diff = if v.is_finite() && r.is_finite() {
                    (v as f64 - r).abs()
                } else {
                    f64::INFINITY
                };
                *max = max.max(diff);
            }
        }
    }
    acc
}

/// A tensor grid of `n` nodes per axis over the f32 domain, endpoints included.
pub fn grid_points(domain: &[(f32, f32)], n: usize) -> Vec<f32> {
    let d = domain.len();
    let total = n.pow(d as u32);
    let mut out = Vec::with_capacity(total * d);
    for idx in 0..total {
        let mut rest = idx;
        let mut x = vec![0.0f32; d];
        for k in (0..d).rev() {
            let i = rest % n;
            rest /= n;
            let (lo, hi) = domain[k];
            x[k] = if i + 1 == n {
                hi
            } else {
                (lo as f64 + (hi as f64 - lo as f64) * i as f64 / (n - 1) as f64) as f32
            };
        }
        out.extend_from_slice(&x);
    }
    out
}

/// Nodes per axis of the grid on which [`choose_form`] measures: 129² in 2-D, 33³ in 3-D.
pub fn measurement_nodes(d: usize) -> usize {
    match d {
        1 => 4097,
        2 => 129,
        _ => 33,
    }
}

/// Why a form was chosen, with the numbers.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FormReport {
    pub form: EvalForm,
    pub forced: bool,
    /// The cheapest stable form failed the stress test, and this one passed it.
    pub stress_fallback: bool,
    /// Every form, cheapest first, with its accuracy on the measurement grid.
    pub candidates: Vec<(EvalForm, F32Accuracy)>,
}

impl FormReport {
    /// The accuracy of the chosen form.
    pub fn chosen(&self) -> &F32Accuracy {
        &self
            .candidates
            .iter()
            .find(|(f, _)| *f == self.form)
            .expect("the chosen form was measured")
            .1
    }

    /// Header lines saying which form and why.
    pub fn explain(&self) -> Vec<String> {
        let mut v = vec![format!("Evaluation: {}.", self.form.describe())];
        let numbers = self
            .candidates
            .iter()
            .map(|(f, a)| format!("{} {:.1e}", f.name(), a.max_diff()))
            .collect::<Vec<_>>()
            .join(", ");
        let why = if self.forced {
            "chosen by --form".to_string()
        } else if self.stress_fallback {
            "the cheaper forms fail the stress test; this is the most accurate that passes"
                .to_string()
        } else if self.chosen().max_diff() <= STABLE_ERROR {
            if self.form == EvalForm::Monomial {
                format!(
                    "the cheapest form, and stable in f32 (max |f32 − f64| ≤ {STABLE_ERROR:.1e} on the measurement grid)"
                )
            } else {
                format!("the cheapest form with max |f32 − f64| ≤ {STABLE_ERROR:.1e} on the measurement grid; the monomial form cancels in f32")
            }
        } else {
            format!(
                "no form keeps max |f32 − f64| ≤ {STABLE_ERROR:.1e} on the measurement grid; this one is the most accurate"
            )
        };
        v.push(format!(
            "  Why: {why}. Max |f32 − f64| of each form on the {} points of the measurement grid: {numbers}.",
            self.chosen().points
        ));
        v
    }
}

/// Builds every form, measures them on the grid and picks the cheapest whose error is under
/// [`STABLE_ERROR`], else the most accurate (or the forced one).
pub fn choose_form(
    name: &str,
    doc: &[String],
    fit: &FitResult,
    choice: FormChoice,
) -> crate::Result<(Function, FormReport)> {
    let points = grid_points(
        &domain_f32(fit),
        measurement_nodes(fit.approximant.variables.len()),
    );
    let mut built = Vec::new();
    for form in EvalForm::ALL {
        let f = albedo_function(name, doc.to_vec(), fit, form)?;
        let program = super::ir::Program {
            functions: vec![f.clone()],
        };
        let c =
            Compiled::new(&program, name).map_err(|e| crate::Error::InvalidInput(e.to_string()))?;
        let acc = measure(&c, fit, &points);
        built.push((form, f, acc));
    }
    let form = match choice {
        FormChoice::Force(f) => f,
        FormChoice::Auto => match built.iter().find(|(_, _, a)| a.max_diff() <= STABLE_ERROR) {
            Some((f, _, _)) => *f,
            None => {
                built
                    .iter()
                    .min_by(|a, b| a.2.max_diff().total_cmp(&b.2.max_diff()))
                    .expect("three forms")
                    .0
            }
        },
    };
    let candidates = built.iter().map(|(f, _, a)| (*f, a.clone())).collect();
    let function = built
        .into_iter()
        .find(|(f, _, _)| *f == form)
        .expect("built")
        .1;
    Ok((
        function,
        FormReport {
            form,
            forced: matches!(choice, FormChoice::Force(_)),
            stress_fallback: false,
            candidates,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::basis::exponents;

    /// u_0·P_0/Q_0 + u_1·P_1/Q_1 in (f0, r, μ) on [0, 1]³ with u_0 = s·(1 + x/5), u_1 = −s·(1 +
    /// x/5 − x²/50) and P_1/Q_1 close to P_0/Q_0: for s = 20 the terms are ~±20 about an albedo
    /// ~0.3, as in the leaving dielectric's low-rank fits; for s = 0.5 they do not cancel.
    fn cancelling_fit(s: f64) -> FitResult {
        let poly = |exponents: Vec<Vec<u32>>, coefficients: Vec<f64>| Polynomial {
            exponents,
            coefficients,
        };
        let rm = vec![vec![0, 0, 0], vec![0, 1, 0], vec![0, 0, 1]];
        let f0 = vec![vec![0, 0, 0], vec![1, 0, 0], vec![2, 0, 0]];
        let approximant = crate::fit::result::Approximant {
            variables: vec!["f0".into(), "r".into(), "mu".into()],
            transforms: vec![InputTransform::Identity; 3],
            domain: vec![(0.0, 1.0); 3],
            numerator: poly(rm.clone(), vec![0.5, 0.2, 0.3]),
            denominator: Some(poly(rm.clone(), vec![1.0, 0.1, 0.5])),
            factor: Some(poly(f0.clone(), vec![s, s / 5.0, 0.0])),
            terms: vec![crate::fit::result::Term {
                factor: Some(poly(f0, vec![-s, -s / 5.0, s / 50.0])),
                numerator: poly(rm.clone(), vec![0.48, 0.2, 0.31]),
                denominator: Some(poly(rm, vec![1.0, 0.12, 0.45])),
            }],
        };
        let ax: Vec<f64> = (0..5).map(|i| i as f64 / 4.0).collect();
        let mut values = Vec::new();
        for &x in &ax {
            for &r in &ax {
                for &m in &ax {
                    values.push(approximant.eval(&[x, r, m]));
                }
            }
        }
        let data = crate::fit::FitData::from_grid(
            approximant.variables.clone(),
            &[ax.clone(), ax.clone(), ax],
            values,
        )
        .unwrap();
        FitResult::assess(
            crate::fit::result::Form::Polynomial { degree: 1 },
            approximant,
            &data,
            crate::fit::result::Objective::LeastSquares,
            None,
            &crate::fit::CertifyOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn cancelling_terms_are_evaluated_as_one_quotient() {
        let fit = cancelling_fit(20.0);
        let c = term_cancellation(&fit);
        assert!(c > TERM_CANCELLATION, "{c}");
        let one = one_quotient(&fit).expect("the terms cancel");
        assert!(!one.approximant.is_structured());
        // N = Σ u_k·P_k·Q_j: f0^0..2 times the 6 monomials of degree ≤ 2 in (r, μ); D = Q_0·Q_1:
        // 18 + 6 − 1 numbers, within twice the 16 stored
        assert_eq!(one.approximant.numerator.coefficients.len(), 18);
        assert_eq!(
            one.approximant
                .denominator
                .as_ref()
                .unwrap()
                .coefficients
                .len(),
            6
        );
        // the same function in f64 at points off any grid
        let mut rng = crate::fit::data::SplitMix64(7);
        let mut worst: f64 = 0.0;
        for _ in 0..2000 {
            let x: Vec<f64> = (0..3).map(|_| rng.next_f64()).collect();
            worst = worst.max((one.eval(&x) - fit.eval(&x)).abs());
        }
        assert!(worst < 1e-13, "{worst}");
        // the emitted code evaluates N/D: one e, no per-term e0, e1
        let f = albedo_function("a", vec![], &fit, EvalForm::Bernstein).unwrap();
        assert!(f.body.iter().all(|s| s.name != "e0" && s.name != "e1"));
        assert!(f.body.iter().any(|s| s.name == "q"));
        // in f32 one quotient errs far less than the sum of the ±20 terms, each rounded alone
        let points = grid_points(&domain_f32(&fit), 17);
        let err = |f: Function| {
            let program = super::super::ir::Program { functions: vec![f] };
            measure(&Compiled::new(&program, "a").unwrap(), &fit, &points).max_diff()
        };
        let one_err = err(albedo_function("a", vec![], &fit, EvalForm::Bernstein).unwrap());
        let sum_err = err(albedo_function_of("a", vec![], &fit, EvalForm::Bernstein).unwrap());
        assert!(
            one_err < 3e-7 && 5.0 * one_err < sum_err,
            "{one_err} {sum_err}"
        );
        // terms that do not cancel keep their own quotients
        let mild = cancelling_fit(0.5);
        assert!(term_cancellation(&mild) < TERM_CANCELLATION);
        assert!(one_quotient(&mild).is_none());
        let f = albedo_function("a", vec![], &mild, EvalForm::Bernstein).unwrap();
        assert!(f.body.iter().any(|s| s.name == "e1"));
    }

    #[test]
    fn shifting_preserves_the_polynomial() {
        let e = exponents(3, 3);
        let c: Vec<f64> = (0..e.len())
            .map(|i| ((i * 37 % 11) as f64 - 5.0) * 40.0)
            .collect();
        let p = Polynomial {
            exponents: e,
            coefficients: c,
        };
        let sh = [(0.5, 0.5), (0.3, 0.2), (0.75, 0.25)];
        let q = shift_polynomial(&p, &sh);
        for &(a, b, cc) in &[(0.1, 0.2, 0.6), (1.0, 0.5, 1.0), (0.0, 0.1, 0.5)] {
            let t = [a, b, cc];
            let s: Vec<f64> = t.iter().zip(&sh).map(|(&t, &(c, h))| (t - c) / h).collect();
            assert!(
                (p.eval(&t) - q.eval(&s)).abs() < 1e-11,
                "{} vs {}",
                p.eval(&t),
                q.eval(&s)
            );
        }
    }

    #[test]
    fn identifiers_and_names() {
        assert_eq!(ident("F0"), "f0");
        assert_eq!(ident("ggx-dielectric-inv"), "ggx_dielectric_inv");
        assert_eq!(ident("3d"), "v3d");
        assert_eq!(
            albedo_function_name("ggx-conductor", "E"),
            "ggx_conductor_albedo"
        );
        assert_eq!(
            albedo_function_name("ggx-dielectric", "E_T"),
            "ggx_dielectric_albedo_t"
        );
    }

    #[test]
    fn inward_rounding_of_the_domain() {
        assert!(f32_up(0.0125) as f64 >= 0.0125 && (f32_up(0.0125).next_down() as f64) < 0.0125);
        assert!(f32_down(0.1) as f64 <= 0.1 && (f32_down(0.1).next_up() as f64) > 0.1);
        assert_eq!(f32_up(1.0), 1.0);
    }
}
