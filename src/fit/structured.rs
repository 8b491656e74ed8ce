//! Structured forms: sums of K rational terms g_k(x)·P_k(y)/Q_k(y) in one variable x (the
//! [`Structure`]'s) and the others y, fitted jointly by Levenberg–Marquardt ([`super::lm`]).
//!
//! - Separate denominators: g_a = φ_a(x) fixed (the power family t_x^a), a = 0 … K − 1; the
//!   split sum Σ_a t_x^a·P_a(y)/Q(y) with one denominator per power.
//! - Low rank: g_k = u_k(x), fitted polynomials of degree p: E ≈ Σ_k u_k(x)·v_k(y), v_k = P_k/Q_k,
//!   started from the truncated SVD (Eckart & Young 1936) of the coefficient matrix of the
//!   least-squares polynomial of degree p in x times P's set in y (Chebyshev bases on both
//!   sides), which is the rank-K separation of that polynomial.
//!
//! Denominators are either free (Chebyshev coefficients, Q's mean fixed to 1, kept positive at
//! the data by the solver's barrier and certified on the box afterwards) or *positive by
//! construction*: tensor-product Bernstein polynomials on the transformed box of y with
//! coefficients c_i = σ_i² + [`BERNSTEIN_FLOOR`] (c_0 = 1), so Q ≥ the floor on the whole box (Farouki & Rajan 1987: a
//! Bernstein polynomial lies in the convex hull of its coefficients) and the pole certificate
//! passes by construction.
//!
//! Every term starts with Q_k = 1 from the least-squares polynomial solution; the joint run then
//! explores on a deterministic random subset of the points and refines on all of them. For the
//! mean-absolute and minimax objectives, Lawson-style reweighted runs (Lawson 1961) follow and the
//! iterate with the best objective on all points is kept; for minimax a short branch with the
//! weights blended towards uniform comes first, and iterates of both are kept as the Lawson
//! path's candidates ([`super::robust::path_iterates`]).

use std::ops::Range;
use std::time::Instant;

use nalgebra::DMatrix;

use super::basis::{binomial, chebyshev_to_monomial, ChebyshevBasis, ExponentSet, Polynomial};
use super::data::{FitData, InputTransform, Prepared};
use super::error::{FitError, Result};
use super::lm::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use super::model::Q_FLOOR;
use super::poles::CertifyOptions;
use super::result::{
    Approximant, Family, FitResult, Form, Objective, SolverReport, StartReport, Structure, Term,
};
use super::robust::{
    blended_roots, check_lp_polish, check_max_mean, lawson_update, max_mean_path, path_iterates,
    pnorm_branch, pnorm_path, Iterate, PnormProblem, Solved, LAWSON_BLEND,
};

/// Settings of a structured fit.
#[derive(Clone, Debug)]
pub struct StructuredOptions {
    /// Levenberg–Marquardt settings of the exploration run.
    pub lm: LevenbergMarquardt,
    /// Points of the exploration subset (0 = automatic: max(40 000, 300 × parameters)).
    pub exploration_points: usize,
    /// Levenberg–Marquardt steps on all points after a subsampled exploration.
    pub refine_iterations: usize,
    /// Reweighting rounds for the mean-absolute and minimax objectives.
    pub reweight_iterations: usize,
    /// Levenberg–Marquardt steps per reweighting round.
    pub reweight_lm_iterations: usize,
    /// Pole certificate of the result.
    pub certify: CertifyOptions,
    /// Minimax only: the p values of an L_p polish from the least-squares fit, as
    /// [`super::RationalOptions::lp_polish`]. Empty (the default): none.
    pub lp_polish: Vec<f64>,
    /// Minimax only: the λ values of a max–mean polish of the minimax fit (factors and
    /// denominators held, the numerators set to the exact minimiser of max error + λ·mean error,
    /// [`super::maxmean`]), as [`super::RationalOptions::max_mean_polish`]. Empty: none.
    pub max_mean_polish: Vec<f64>,
}

impl Default for StructuredOptions {
    fn default() -> Self {
        StructuredOptions {
            lm: LevenbergMarquardt::new(),
            exploration_points: 0,
            refine_iterations: 8,
            reweight_iterations: 12,
            reweight_lm_iterations: 15,
            certify: CertifyOptions::default(),
            lp_polish: Vec::new(),
            max_mean_polish: Vec::new(),
        }
    }
}

/// How g_k of each term is computed.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Factor {
    /// g_k = t_x^k, fixed.
    Power,
    /// g_k = T_k(s_x), fixed (the start of a low-rank fit).
    Chebyshev,
    /// g_k = Σ_a c_ka T_a(s_x), a ≤ degree, fitted.
    Fitted(u32),
}

/// The denominators' parametrisation.
#[derive(Clone, Debug)]
enum Denominator {
    None,
    /// Chebyshev in s over `exps` (constant first, fixed to 1).
    Free(ChebyshevBasis),
    /// Tensor Bernstein of per-variable degrees `degrees` (0 in x) on the box, c = σ², c_0 = 1.
    Positive(Vec<u32>),
}

/// The terms' shapes and the parameter layout: per term [factor][P][Q].
#[derive(Clone, Debug)]
struct Layout {
    d: usize,
    x: usize,
    k: usize,
    factor: Factor,
    num: ChebyshevBasis,
    den: Denominator,
}

impl Layout {
    fn n_factor(&self) -> usize {
        match self.factor {
            Factor::Fitted(p) => p as usize + 1,
            _ => 0,
        }
    }
    fn n_den_basis(&self) -> usize {
        match &self.den {
            Denominator::None => 0,
            Denominator::Free(b) => b.len(),
            Denominator::Positive(deg) => deg.iter().map(|&m| m as usize + 1).product(),
        }
    }
    fn n_den(&self) -> usize {
        self.n_den_basis().saturating_sub(1)
    }
    fn per_term(&self) -> usize {
        self.n_factor() + self.num.len() + self.n_den()
    }
    fn n_params(&self) -> usize {
        self.k * self.per_term()
    }
}

/// Basis values at one point: factor (T_a(s_x) or t_x^a), P's Chebyshev, Q's basis.
struct Values {
    g: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    table: Vec<f64>,
}

impl Layout {
    fn values(&self) -> Values {
        let ng = match self.factor {
            Factor::Fitted(p) => p as usize + 1,
            _ => self.k,
        };
        let table = self
            .num
            .table_len()
            .max(match &self.den {
                Denominator::Free(b) => b.table_len(),
                _ => 0,
            })
            .max(1);
        Values {
            g: vec![0.0; ng],
            p: vec![0.0; self.num.len()],
            q: vec![0.0; self.n_den_basis()],
            table: vec![0.0; table],
        }
    }

    /// Fills `v` at scaled point s (t_x = `tx`).
    fn fill(&self, s: &[f64], tx: f64, v: &mut Values) {
        let sx = s[self.x];
        match self.factor {
            Factor::Power => {
                let mut a = 1.0;
                for g in v.g.iter_mut() {
                    *g = a;
                    a *= tx;
                }
            }
            Factor::Chebyshev | Factor::Fitted(_) => chebyshev_1d(sx, &mut v.g),
        }
        self.num.eval(s, &mut v.table, &mut v.p);
        match &self.den {
            Denominator::None => {}
            Denominator::Free(b) => b.eval(s, &mut v.table, &mut v.q),
            Denominator::Positive(deg) => bernstein_tensor(s, deg, &mut v.q),
        }
    }

    /// Value and per-term parts (g_k, P_k, Q_k) at the filled basis values.
    fn eval_terms(&self, p: &[f64], v: &Values, parts: &mut [(f64, f64, f64)]) -> f64 {
        let pt = self.per_term();
        let nf = self.n_factor();
        let np = self.num.len();
        let mut f = 0.0;
        for (k, part) in parts.iter_mut().enumerate() {
            let c = &p[k * pt..(k + 1) * pt];
            let g = match self.factor {
                Factor::Fitted(_) => dot(&c[..nf], &v.g),
                _ => v.g[k],
            };
            let pk = dot(&c[nf..nf + np], &v.p);
            let qk = match &self.den {
                Denominator::None => 1.0,
                Denominator::Free(_) => v.q[0] + dot(&c[nf + np..], &v.q[1..]),
                Denominator::Positive(_) => {
                    v.q[0]
                        + c[nf + np..]
                            .iter()
                            .zip(&v.q[1..])
                            .map(|(s, b)| (s * s + BERNSTEIN_FLOOR) * b)
                            .sum::<f64>()
                }
            };
            *part = (g, pk, qk);
            f += g * pk / qk;
        }
        f
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// T_0 … T_n at s (T_j = 2s T_{j−1} − T_{j−2}).
fn chebyshev_1d(s: f64, out: &mut [f64]) {
    for j in 0..out.len() {
        out[j] = match j {
            0 => 1.0,
            1 => s,
            _ => 2.0 * s * out[j - 1] - out[j - 2],
        };
    }
}

/// Tensor Bernstein basis Π_k C(m_k, i_k) u_k^{i_k} (1 − u_k)^{m_k − i_k}, u = (s + 1)/2,
/// row-major over i (last variable fastest; axes of degree 0 contribute 1).
fn bernstein_tensor(s: &[f64], degrees: &[u32], out: &mut [f64]) {
    out.iter_mut().for_each(|o| *o = 1.0);
    let mut stride = out.len();
    for (k, &m) in degrees.iter().enumerate() {
        let n = m as usize + 1;
        stride /= n;
        if m == 0 {
            continue;
        }
        let u = 0.5 * (s[k] + 1.0);
        let b: Vec<f64> = (0..=m)
            .map(|i| binomial(m, i) * u.powi(i as i32) * (1.0 - u).powi((m - i) as i32))
            .collect();
        for (idx, o) in out.iter_mut().enumerate() {
            *o *= b[(idx / stride) % n];
        }
    }
}

/// The least-squares problem of a layout on prepared data, with optional extra row weights.
struct Problem<'a> {
    layout: &'a Layout,
    data: &'a Prepared,
    extra: Option<&'a [f64]>,
}

impl Problem<'_> {
    fn tx(&self, s: &[f64]) -> f64 {
        let sc = self.data.scales[self.layout.x];
        sc.center + sc.half * s[self.layout.x]
    }
    fn weight(&self, i: usize) -> f64 {
        self.data.w[i] * self.extra.map_or(1.0, |e| e[i])
    }
}

impl LeastSquaresProblem for Problem<'_> {
    fn n_params(&self) -> usize {
        self.layout.n_params()
    }
    fn n_residuals(&self) -> usize {
        self.data.len()
    }
    fn residuals(&self, p: &[f64], rows: Range<usize>, r: &mut [f64]) -> bool {
        let l = self.layout;
        let mut v = l.values();
        let mut parts = vec![(0.0, 0.0, 0.0); l.k];
        for (j, i) in rows.enumerate() {
            let s = self.data.point(i);
            l.fill(s, self.tx(s), &mut v);
            let f = l.eval_terms(p, &v, &mut parts);
            if parts.iter().any(|&(_, _, q)| !(q > Q_FLOOR)) {
                return false;
            }
            r[j] = self.weight(i) * (f - self.data.y[i]);
        }
        true
    }
    fn jacobian(&self, p: &[f64], rows: Range<usize>, r: &mut [f64], jac: &mut [f64]) -> bool {
        let l = self.layout;
        let n = l.n_params();
        let (pt, nf, np) = (l.per_term(), l.n_factor(), l.num.len());
        let mut v = l.values();
        let mut parts = vec![(0.0, 0.0, 0.0); l.k];
        for (j, i) in rows.enumerate() {
            let s = self.data.point(i);
            l.fill(s, self.tx(s), &mut v);
            let f = l.eval_terms(p, &v, &mut parts);
            if parts.iter().any(|&(_, _, q)| !(q > Q_FLOOR)) {
                return false;
            }
            let w = self.weight(i);
            r[j] = w * (f - self.data.y[i]);
            let row = &mut jac[j * n..(j + 1) * n];
            for (k, &(g, pk, qk)) in parts.iter().enumerate() {
                let c = &p[k * pt..(k + 1) * pt];
                let jr = &mut row[k * pt..(k + 1) * pt];
                // ∂/∂u: T_a·P/Q; ∂/∂P: g·ψ/Q; ∂/∂Q-parameter: −g·P·∂Q/Q²
                let vk = pk / qk;
                for a in 0..nf {
                    jr[a] = w * v.g[a] * vk;
                }
                let gq = w * g / qk;
                for b in 0..np {
                    jr[nf + b] = gq * v.p[b];
                }
                let dq = -w * g * pk / (qk * qk);
                match &l.den {
                    Denominator::None => {}
                    Denominator::Free(_) => {
                        for (c, b) in v.q[1..].iter().enumerate() {
                            jr[nf + np + c] = dq * b;
                        }
                    }
                    Denominator::Positive(_) => {
                        // Q = B_0 + Σ (σ_c² + floor) B_c: ∂Q/∂σ_c = 2σ_c B_c
                        for (ci, b) in v.q[1..].iter().enumerate() {
                            jr[nf + np + ci] = dq * 2.0 * c[nf + np + ci] * b;
                        }
                    }
                }
            }
        }
        true
    }
}

/// The most terms a structured form may have (each is a full rational in the other variables).
pub const MAX_TERMS: u32 = 12;

/// Refuses a structured form the data or the fitter cannot determine, naming the cause and the
/// fix: a variable out of range, no terms or more than [`MAX_TERMS`], P's or Q's set using the
/// structure's variable, more low-rank terms than the separated polynomial has rank, and a
/// positive denominator over a set that is not a tensor product.
pub fn check_structure(
    d: usize,
    names: &[String],
    numerator: &ExponentSet,
    denominator: Option<&ExponentSet>,
    st: &Structure,
) -> Result<()> {
    let bad = |problem: String, fix: &str| FitError::BadStructure {
        problem,
        fix: fix.to_string(),
    };
    let x = st.variable();
    if d < 2 || x >= d {
        return Err(bad(
            format!("the structure's variable {x} is not one of the data's {d} variables (a structured form needs at least 2)"),
            "name one of the data's variables",
        ));
    }
    let name = names.get(x).cloned().unwrap_or_else(|| x.to_string());
    let k = st.terms();
    if k == 0 || k > MAX_TERMS {
        return Err(bad(
            format!("{k} terms"),
            &format!("use 1 to {MAX_TERMS} terms"),
        ));
    }
    for (what, s) in
        std::iter::once(("numerator", numerator)).chain(denominator.map(|q| ("denominator", q)))
    {
        s.check(d)?;
        if s.max_exponent_of(x) > 0 {
            return Err(bad(
                format!("the per-term {what} set has degree {} in '{name}', the structure's own variable", s.max_exponent_of(x)),
                "give the per-term sets in the other variables only (degree 0 in the structure's variable)",
            ));
        }
    }
    if let Structure::LowRank { degree, .. } = *st {
        super::basis::check_degree(degree)?;
        let rank = (degree as usize + 1).min(numerator.len());
        if k as usize > rank {
            return Err(bad(
                format!("{k} low-rank terms, but u_k of degree {degree} in '{name}' and P_k of {} coefficients separate into at most {rank} independent terms", numerator.len()),
                "use fewer terms or raise u_k's degree",
            ));
        }
    }
    if let Structure::SeparateDenominators { terms, .. } = *st {
        super::basis::check_degree(terms - 1)?;
    }
    if st.positive() {
        match denominator {
            None => {
                return Err(bad(
                    "a positive denominator was asked for, but the form has none".into(),
                    "give a denominator, or drop the '+'",
                ))
            }
            Some(q) if q.in_total.iter().any(|&b| b) && q.total < q.caps.iter().sum::<u32>() => {
                return Err(bad(
                    "a positive (Bernstein) denominator must have per-variable degrees, not a total degree".into(),
                    "write it as per-variable degrees, e.g. '+2,2'",
                ))
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// Fits a structured form ([`Form::Exponents`] with a [`Structure`]); the form is checked with
/// [`check_structure`] first.
pub fn fit_structured(
    data: &FitData,
    transforms: &[InputTransform],
    form: &Form,
    objective: Objective,
    opts: &StructuredOptions,
) -> Result<FitResult> {
    let start_time = Instant::now();
    let Form::Exponents {
        numerator,
        denominator,
        structure: Some(st),
    } = form
    else {
        return Err(FitError::BadStructure {
            problem: format!("{} is not a structured form", form.label()),
            fix: "fit it with fit_form".into(),
        });
    };
    let d = data.dim();
    check_structure(d, &data.names, numerator, denominator.as_ref(), st)?;
    let label = form.label_with(&data.names);
    check_lp_polish(&opts.lp_polish)?;
    check_max_mean(&opts.max_mean_polish)?;
    let prep = Prepared::new(data, transforms)?;
    let x = st.variable();
    let k = st.terms() as usize;
    let factor = match *st {
        Structure::SeparateDenominators {
            family: Family::Power,
            ..
        } => Factor::Power,
        Structure::LowRank { degree, .. } => Factor::Fitted(degree),
    };
    let num = ChebyshevBasis::from_exponents(d, numerator.exponents());
    let den = match denominator {
        None => Denominator::None,
        Some(q) if st.positive() => Denominator::Positive(q.caps.clone()),
        Some(q) => Denominator::Free(ChebyshevBasis::from_exponents(d, q.exponents())),
    };
    let layout = Layout {
        d,
        x,
        k,
        factor,
        num,
        den,
    };
    let n = layout.n_params();
    if prep.n_weighted() < n {
        return Err(FitError::TooFewPoints {
            form: label,
            coefficients: n,
            points: prep.n_weighted(),
        });
    }
    let explore_n = if opts.exploration_points == 0 {
        (300 * n).max(40_000)
    } else {
        opts.exploration_points.max(n)
    };
    let sub = prep.subsample(explore_n);
    let ex = sub.as_ref().unwrap_or(&prep);

    // 1. the least-squares polynomial (Q = 1): g fixed (t^a, or T_a for a low-rank start)
    let (lin_factor, lin_k) = match factor {
        Factor::Fitted(p) => (Factor::Chebyshev, p as usize + 1),
        f => (f, k),
    };
    let linear = Layout {
        factor: lin_factor,
        k: lin_k,
        den: Denominator::None,
        ..layout.clone()
    };
    let lin = opts.lm.solve(
        &Problem {
            layout: &linear,
            data: ex,
            extra: None,
        },
        vec![0.0; linear.n_params()],
    )?;
    let np = layout.num.len();
    let mut p0 = Vec::with_capacity(n);
    let q_start = match layout.den {
        // σ² + floor = 1: Q ≡ 1 (the Bernstein basis sums to 1)
        Denominator::Positive(_) => (1.0 - BERNSTEIN_FLOOR).sqrt(),
        _ => 0.0,
    };
    match factor {
        Factor::Fitted(p) => {
            // rank-K truncation of the coefficient matrix C (rows: T_a(s_x), columns: P's basis)
            let rows = p as usize + 1;
            let c = DMatrix::from_fn(rows, np, |a, b| lin.state.params[a * np + b]);
            let svd = c.svd(true, true);
            let (u, vt) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for Vᵀ"));
            let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
            order.sort_by(|&i, &j| svd.singular_values[j].total_cmp(&svd.singular_values[i]));
            for &i in order.iter().take(k) {
                let sv = svd.singular_values[i].sqrt();
                p0.extend((0..rows).map(|a| sv * u[(a, i)]));
                p0.extend((0..np).map(|b| sv * vt[(i, b)]));
                p0.extend(std::iter::repeat_n(q_start, layout.n_den()));
            }
        }
        _ => {
            for t in 0..k {
                p0.extend_from_slice(&lin.state.params[t * np..(t + 1) * np]);
                p0.extend(std::iter::repeat_n(q_start, layout.n_den()));
            }
        }
    }
    let mut starts = vec![StartReport {
        name: match factor {
            Factor::Fitted(_) => "truncated SVD of the least-squares polynomial".into(),
            _ => "least-squares polynomial, Q = 1".into(),
        },
        cost: Some(lin.state.cost),
        cost_all_points: None,
        termination: Some(lin.termination),
        iterations: lin.state.iterations,
        certified_steps: false,
        certified: true,
        note: None,
    }];

    // 2. joint Levenberg–Marquardt on the exploration set, then on all points
    let run = |data: &Prepared, extra: Option<&[f64]>, lm: &LevenbergMarquardt, p: Vec<f64>| {
        lm.solve(
            &Problem {
                layout: &layout,
                data,
                extra,
            },
            p,
        )
    };
    let mut rep = run(ex, None, &opts.lm, p0)?;
    starts.push(StartReport {
        name: "joint Levenberg–Marquardt".into(),
        cost: Some(rep.state.cost),
        cost_all_points: None,
        termination: Some(rep.termination),
        iterations: rep.state.iterations,
        certified_steps: false,
        certified: false,
        note: None,
    });
    if sub.is_some() && opts.refine_iterations > 0 {
        let lm = opts
            .lm
            .clone()
            .with_max_iterations(opts.refine_iterations)?;
        let refined = run(&prep, None, &lm, rep.state.params.clone())?;
        if refined.termination != TerminationReason::InfeasibleStart {
            rep = refined;
        }
    }
    let mut params = rep.state.params.clone();

    // 3. reweighting for the other objectives, the best iterate on all points kept (and for
    //    minimax a few iterates of the Lawson path, `robust::path_iterates`)
    let mut rounds = 0;
    let mut path = Vec::new();
    if objective != Objective::LeastSquares {
        let score = |p: &[f64], on: &Prepared| -> Option<f64> {
            let e = errors(&layout, on, p)?;
            Some(match objective {
                Objective::Minimax => e.iter().fold(0.0f64, |m, x| m.max(x.abs())),
                _ => e.iter().map(|x| x.abs()).sum::<f64>() / e.len().max(1) as f64,
            })
        };
        let mut best = (
            score(&params, &prep).unwrap_or(f64::INFINITY),
            params.clone(),
        );
        // (max, MAE) on all points, for the Lawson path's iterates
        let both = |p: &[f64]| -> Option<(f64, f64)> {
            let e = errors(&layout, &prep, p)?;
            let max = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            Some((
                max,
                e.iter().map(|x| x.abs()).sum::<f64>() / e.len().max(1) as f64,
            ))
        };
        let start = both(&params).unwrap_or((f64::INFINITY, f64::INFINITY));
        let mut iterates = Vec::new();
        let mut blended = Vec::new();
        let mut best_round = 0;
        let lm = opts
            .lm
            .clone()
            .with_max_iterations(opts.reweight_lm_iterations.max(1))?;
        // minimax: first a short branch from the same start with Lawson's weights blended
        // towards uniform, (1 − λ)·1 + λ·u for λ in LAWSON_BLEND (u normalised to a largest of
        // 1), whose iterates are candidates of the path only: it passes through fits of small
        // MAE cost that Lawson's own first round jumps over (`robust::reweight` does the same).
        // Its iterates are kept per band beside Lawson's own, not instead of them.
        if objective == Objective::Minimax {
            let mut u = vec![1.0; ex.len()];
            let unit = vec![1.0; ex.len()];
            let mut p = params.clone();
            for (round, &blend) in (1..).zip(&LAWSON_BLEND) {
                let Some(e) = errors(&layout, ex, &p) else {
                    break;
                };
                if !lawson_update(&mut u, &unit, &e) {
                    break;
                }
                let r = run(ex, Some(&blended_roots(&u, blend)), &lm, p.clone())?;
                if r.termination == TerminationReason::InfeasibleStart {
                    break;
                }
                p = r.state.params;
                if let Some((max, mae)) = both(&p) {
                    blended.push(Iterate {
                        round,
                        blend,
                        pnorm: None,
                        max_mean: None,
                        max,
                        mae,
                        params: p.clone(),
                    });
                }
            }
        }
        let mut u = vec![1.0; ex.len()];
        let mut p = params.clone();
        for _ in 0..opts.reweight_iterations {
            let Some(e) = errors(&layout, ex, &p) else {
                break;
            };
            match objective {
                Objective::Minimax => {
                    for (ui, e) in u.iter_mut().zip(&e) {
                        *ui *= e.abs();
                    }
                }
                _ => {
                    let mean = e.iter().map(|x| x.abs()).sum::<f64>() / e.len().max(1) as f64;
                    for (ui, e) in u.iter_mut().zip(&e) {
                        *ui = 1.0 / e.abs().max(1e-3 * mean).max(f64::MIN_POSITIVE);
                    }
                }
            }
            let total: f64 = u.iter().sum();
            if !(total > 0.0) {
                break;
            }
            let scale = u.len() as f64 / total;
            u.iter_mut().for_each(|x| *x = (*x * scale).max(1e-12));
            let extra: Vec<f64> = u.iter().map(|x| x.sqrt()).collect();
            let r = run(ex, Some(&extra), &lm, p.clone())?;
            if r.termination == TerminationReason::InfeasibleStart {
                break;
            }
            p = r.state.params;
            rounds += 1;
            if objective == Objective::Minimax {
                if let Some((max, mae)) = both(&p) {
                    iterates.push(Iterate {
                        round: rounds,
                        blend: 1.0,
                        pnorm: None,
                        max_mean: None,
                        max,
                        mae,
                        params: p.clone(),
                    });
                }
            }
            if let Some(sc) = score(&p, &prep) {
                if sc < best.0 {
                    best = (sc, p.clone());
                    best_round = rounds;
                }
            }
        }
        params = best.1;
        // Lawson's own iterates per band as without the branch, and the branch's beside them
        path = path_iterates(&iterates, start, best_round, &mut |_| true);
        path.extend(path_iterates(&blended, start, best_round, &mut |_| true));
        // the L_p polish from the least-squares fit (`robust::pnorm_branch`)
        if objective == Objective::Minimax && !opts.lp_polish.is_empty() {
            let from = rep.state.params.clone();
            if let Some(e) = errors(&layout, ex, &from) {
                let unit = vec![1.0; ex.len()];
                let mut solve = |pn: f64, warm: &[f64]| -> Result<Option<Solved>> {
                    let Some(e) = errors(&layout, ex, warm) else {
                        return Ok(None);
                    };
                    let scale = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    let inner = Problem {
                        layout: &layout,
                        data: ex,
                        extra: None,
                    };
                    let problem = PnormProblem {
                        inner: &inner,
                        p: pn,
                        scale,
                    };
                    let r = lm.solve(&problem, warm.to_vec())?;
                    if r.termination == TerminationReason::InfeasibleStart {
                        return Ok(None);
                    }
                    Ok(errors(&layout, ex, &r.state.params)
                        .map(|e| (r.state.params, e, Some(r.termination), r.state.iterations)))
                };
                let mut polished = pnorm_branch(&unit, (from, e), &opts.lp_polish, &mut solve)?;
                // max and MAE on all points, as the Lawson path's
                polished.retain_mut(|it| match both(&it.params) {
                    Some((max, mae)) => {
                        (it.max, it.mae) = (max, mae);
                        true
                    }
                    None => false,
                });
                path.extend(pnorm_path(&polished, start.1, &mut |_| true));
            }
        }
        // the max–mean polish (`robust::max_mean_branch`) of the minimax fit and of the L_p
        // polish's last iterate: the numerators P_k are jointly linear with the factors and
        // denominators held
        if objective == Objective::Minimax && !opts.max_mean_polish.is_empty() {
            let problem = Problem {
                layout: &layout,
                data: &prep,
                extra: None,
            };
            let (pt, nf, np) = (layout.per_term(), layout.n_factor(), layout.num.len());
            let linear: Vec<usize> = (0..layout.k)
                .flat_map(|t| t * pt + nf..t * pt + nf + np)
                .collect();
            let polished = max_mean_path(
                &problem,
                &linear,
                (&params, &path),
                &opts.max_mean_polish,
                &both,
                start.1,
                &mut |_| true,
            )?;
            path.extend(polished);
        }
    }

    // 4. the emitted form
    let approximant = to_approximant(&layout, data, transforms, &prep, &params);
    let solver = SolverReport {
        method: "levenberg-marquardt".into(),
        termination: Some(rep.termination),
        converged: rep.termination.converged(),
        iterations: rep.state.iterations,
        reweighting_iterations: rounds,
        lawson_path: None,
        condition: None,
        exploration_points: ex.len(),
        starts,
    };
    let mut fit = FitResult::assess(
        form.clone(),
        approximant,
        data,
        objective,
        Some(solver),
        &opts.certify,
    )?
    .with_path(&path, data, &opts.certify, &|p| {
        to_approximant(&layout, data, transforms, &prep, p)
    })?;
    fit.fit_seconds = start_time.elapsed().as_secs_f64();
    Ok(fit)
}

/// f − y at every point of `data` (None where a denominator is not positive).
fn errors(layout: &Layout, data: &Prepared, p: &[f64]) -> Option<Vec<f64>> {
    let problem = Problem {
        layout,
        data,
        extra: None,
    };
    let mut r = vec![0.0; data.len()];
    let ones = Prepared {
        w: vec![1.0; data.len()],
        ..data.clone()
    };
    let unweighted = Problem {
        data: &ones,
        ..problem
    };
    unweighted.residuals(p, 0..data.len(), &mut r).then_some(r)
}

/// Monomial coefficients in t of a tensor Bernstein polynomial on the box (row-major over the
/// per-variable degrees), listed in the order of `exps`.
fn bernstein_to_monomial(
    degrees: &[u32],
    bounds: &[(f64, f64)],
    coefficients: &[f64],
    exps: &[Vec<u32>],
) -> Vec<f64> {
    let mut c = coefficients.to_vec();
    let sizes: Vec<usize> = degrees.iter().map(|&m| m as usize + 1).collect();
    for (k, &m) in degrees.iter().enumerate() {
        if m == 0 {
            continue;
        }
        let n = sizes[k];
        let stride: usize = sizes[k + 1..].iter().product();
        let (lo, hi) = bounds[k];
        let (alpha, beta) = (1.0 / (hi - lo), -lo / (hi - lo));
        // B_i^m(u) = Σ_{j ≥ i} C(m, i) C(m − i, j − i) (−1)^{j − i} u^j, then u = α t + β
        let mut map = vec![vec![0.0; n]; n]; // map[l][i]: t^l coefficient of B_i
        for i in 0..n {
            for j in i..n {
                let sign = if (j - i) % 2 == 0 { 1.0 } else { -1.0 };
                let a = binomial(m, i as u32) * binomial(m - i as u32, (j - i) as u32) * sign;
                for l in 0..=j {
                    map[l][i] += a
                        * binomial(j as u32, l as u32)
                        * alpha.powi(l as i32)
                        * beta.powi((j - l) as i32);
                }
            }
        }
        let total = c.len();
        let mut out = vec![0.0; total];
        for start in (0..total).filter(|s| (s / stride).is_multiple_of(n)) {
            for l in 0..n {
                out[start + l * stride] = (0..n).map(|i| map[l][i] * c[start + i * stride]).sum();
            }
        }
        c = out;
    }
    exps.iter()
        .map(|e| {
            let mut idx = 0;
            for (k, &ek) in e.iter().enumerate() {
                idx = idx * sizes[k] + ek as usize;
            }
            c[idx]
        })
        .collect()
}

/// The fitted parameters as monomials in the transformed variables, each term's Q normalised
/// to constant term 1 where that is well conditioned.
fn to_approximant(
    layout: &Layout,
    data: &FitData,
    transforms: &[InputTransform],
    prep: &Prepared,
    p: &[f64],
) -> Approximant {
    let d = layout.d;
    let (pt, nf, np) = (layout.per_term(), layout.n_factor(), layout.num.len());
    let bounds: Vec<(f64, f64)> = prep.scales.iter().map(|s| (s.lo, s.hi)).collect();
    let max_exp = |exps: &[Vec<u32>]| exps.iter().flatten().copied().max().unwrap_or(0);
    let mut terms = Vec::with_capacity(layout.k);
    for k in 0..layout.k {
        let c = &p[k * pt..(k + 1) * pt];
        let factor = match layout.factor {
            Factor::Fitted(deg) => {
                let exps: Vec<Vec<u32>> = (0..=deg)
                    .map(|a| {
                        let mut e = vec![0; d];
                        e[layout.x] = a;
                        e
                    })
                    .collect();
                let coefficients = chebyshev_to_monomial(&exps, deg, &prep.scales, &c[..nf]);
                Some(Polynomial {
                    exponents: exps,
                    coefficients,
                })
            }
            _ => None,
        };
        let mut num = chebyshev_to_monomial(
            &layout.num.exps,
            max_exp(&layout.num.exps),
            &prep.scales,
            &c[nf..nf + np],
        );
        let mut num_exps = layout.num.exps.clone();
        if layout.factor == Factor::Power {
            // t_x^k·P_k(y): the exponents of x raised by k
            num_exps.iter_mut().for_each(|e| e[layout.x] += k as u32);
        }
        let denominator = match &layout.den {
            Denominator::None => None,
            Denominator::Free(b) => {
                let mut cheb = vec![1.0];
                cheb.extend_from_slice(&c[nf + np..]);
                Some((
                    b.exps.clone(),
                    chebyshev_to_monomial(&b.exps, max_exp(&b.exps), &prep.scales, &cheb),
                ))
            }
            Denominator::Positive(deg) => {
                let mut bern = vec![1.0];
                bern.extend(c[nf + np..].iter().map(|s| s * s + BERNSTEIN_FLOOR));
                let exps = ExponentSet::tensor(deg).exponents();
                let mono = bernstein_to_monomial(deg, &bounds, &bern, &exps);
                Some((exps, mono))
            }
        };
        let denominator = denominator.map(|(exps, mut q)| {
            let q0 = q[0];
            let qmax = q.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            if q0 > 0.0 && q0 >= NORMALISE_MIN_RATIO * qmax {
                q.iter_mut().for_each(|c| *c /= q0);
                q[0] = 1.0;
                num.iter_mut().for_each(|c| *c /= q0);
            }
            Polynomial {
                exponents: exps,
                coefficients: q,
            }
        });
        terms.push(Term {
            factor,
            numerator: Polynomial {
                exponents: num_exps,
                coefficients: num,
            },
            denominator,
        });
    }
    let mut rest = terms.into_iter();
    let first = rest.next().expect("at least one term");
    Approximant {
        variables: data.names.clone(),
        transforms: transforms.to_vec(),
        domain: data.domain.clone(),
        numerator: first.numerator,
        denominator: first.denominator,
        factor: first.factor,
        terms: rest.collect(),
    }
}

/// The least Bernstein coefficient of a positive denominator (the corner coefficient is 1):
/// Q ≥ this on the whole box, so no term is the quotient of two near-zero polynomials, whose
/// f32 evaluation would cancel.
pub const BERNSTEIN_FLOOR: f64 = 1e-2;

/// Q is divided by its constant term only if that is at least this fraction of its largest
/// monomial coefficient (else the division would magnify the others).
const NORMALISE_MIN_RATIO: f64 = 1e-3;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::result::LawsonPathIterate;

    /// The Lawson-path record of an iterate of a minimax fit's path.
    fn iterate(p: &FitResult) -> &LawsonPathIterate {
        p.solver.as_ref().unwrap().lawson_path.as_ref().unwrap()
    }
    use crate::fit::{fit_form, parse_form, FitOptions, PoleVerdict};

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

    fn names() -> Vec<String> {
        vec!["f0".into(), "r".into(), "mu".into()]
    }

    fn fit(data: &FitData, spec: &str) -> FitResult {
        let form = parse_form(spec, &data.names).unwrap();
        fit_form(
            data,
            &[InputTransform::Identity; 3],
            &form,
            Objective::LeastSquares,
            &FitOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn low_rank_recovers_a_separable_rational_and_counts_every_number() {
        // u_0 v_0 + u_1 v_1 with v_k rationals of degree 1/1 in (r, μ) and u_k of degree 2
        let f = |x: f64, r: f64, m: f64| {
            (1.0 + x * x) * (0.3 + 0.2 * r) / (1.0 + 0.5 * m)
                + (0.5 - x) * (0.1 + 0.4 * m) / (1.0 + 0.3 * r)
        };
        let data = grid3(8, f);
        let r = fit(&data, "lowrank:f0:2:2:1/1");
        // per term: u (3) + P (3) + Q (3 − 1)
        assert_eq!(r.n_coefficients, 2 * (3 + 3 + 2));
        assert_eq!(r.form.n_coefficients(3), r.n_coefficients);
        assert!(r.metrics.max_abs_error < 1e-8, "{:?}", r.metrics);
        assert!(r.is_usable(), "{:?}", r.poles);
        assert!(r.approximant.factor.is_some() && r.approximant.terms.len() == 1);
        let x = [0.37, 0.61, 0.23];
        assert!((r.eval(&x) - f(x[0], x[1], x[2])).abs() < 1e-8);
        // the fit file's JSON keeps the form and the value to the bit
        let back = FitResult::from_json(&r.to_json().unwrap()).unwrap();
        assert_eq!(back.form, r.form);
        assert_eq!(back.eval(&x).to_bits(), r.eval(&x).to_bits());
    }

    #[test]
    fn separate_denominators_recover_their_sum() {
        // P_0/Q_0 + f0·P_1/Q_1, each Q its own
        let f = |x: f64, r: f64, m: f64| {
            (0.4 + 0.1 * r) / (1.0 + 0.6 * m * r) + x * (0.2 - 0.1 * m) / (1.0 + 0.8 * r)
        };
        let data = grid3(8, f);
        let r = fit(&data, "sum:f0:power:2:1/+1");
        // per term: P (3) + positive Q of degree 1 in r and μ (4 − 1)
        assert_eq!(r.n_coefficients, 2 * (3 + 3));
        assert!(r.metrics.max_abs_error < 1e-8, "{:?}", r.metrics);
        assert!(
            matches!(r.poles, PoleVerdict::Certified { .. }),
            "{:?}",
            r.poles
        );
        // the second term's numerator is f0·P_1(r, μ)
        assert!(r.approximant.terms[0]
            .numerator
            .exponents
            .iter()
            .all(|e| e[0] == 1));
        let mut mean = 0.0;
        for i in 0..data.len() {
            mean += (r.approximant.eval(data.point(i)) - data.values[i]).abs();
        }
        assert!(mean / (data.len() as f64) < 1e-9);
    }

    #[test]
    fn positive_bernstein_denominators_are_positive_on_the_box() {
        // a function with a near-pole just outside the box: the positive form stays certified
        let f = |x: f64, r: f64, m: f64| (0.5 + 0.3 * x) / (1.05 - r * m);
        let data = grid3(7, f);
        let r = fit(&data, "lowrank:f0:1:1:2/+2");
        assert!(
            matches!(r.poles, PoleVerdict::Certified { .. }),
            "{:?}",
            r.poles
        );
        assert!(r.metrics.max_abs_error < 0.05, "{:?}", r.metrics);
        // the monomial form of Σ σ² B_i equals the Bernstein sum
        let deg = [0, 2, 3];
        let bounds = [(0.0, 1.0), (0.2, 0.9), (-1.0, 2.0)];
        let c: Vec<f64> = (0..12).map(|i| 0.1 + (i * 7 % 5) as f64).collect();
        let exps = ExponentSet::tensor(&deg).exponents();
        let mono = bernstein_to_monomial(&deg, &bounds, &c, &exps);
        let p = Polynomial {
            exponents: exps,
            coefficients: mono,
        };
        for t in [[0.3, 0.5, 1.7], [0.0, 0.2, -1.0], [1.0, 0.9, 2.0]] {
            let s: Vec<f64> = t
                .iter()
                .zip(&bounds)
                .map(|(&t, &(lo, hi))| 2.0 * (t - lo) / (hi - lo) - 1.0)
                .collect();
            let mut b = vec![0.0; 12];
            bernstein_tensor(&s, &deg, &mut b);
            let want: f64 = b.iter().zip(&c).map(|(b, c)| b * c).sum();
            assert!(
                (p.eval(&t) - want).abs() < 1e-12,
                "{} vs {want}",
                p.eval(&t)
            );
        }
    }

    /// The least-squares and the minimax fit of `form` in the identity variables.
    #[test]
    fn the_max_mean_polish_adds_exact_numerator_fits() {
        let f = |x: f64, r: f64, m: f64| (1.0 + x).sqrt() * (r * m + 0.1).ln().exp() / (1.2 + m);
        let data = grid3(9, f);
        let t = [InputTransform::Identity; 3];
        // a low-rank form (the structured fitter) and a split sum (the rational one)
        for spec in ["lowrank:f0:2:2:2/1", "split:f0:1:2/1"] {
            let form = parse_form(spec, &data.names).unwrap();
            let mut opts = FitOptions::default();
            opts.rational.lp_polish = vec![8.0];
            opts.structured.lp_polish = vec![8.0];
            opts.rational.max_mean_polish = vec![0.01, 64.0];
            opts.structured.max_mean_polish = vec![0.01, 64.0];
            let mm = fit_form(&data, &t, &form, Objective::Minimax, &opts).unwrap();
            let polished: Vec<&FitResult> = mm
                .path
                .iter()
                .filter(|p| iterate(p).max_mean.is_some())
                .collect();
            let which: Vec<(Option<f64>, Option<f64>)> = polished
                .iter()
                .map(|p| (iterate(p).pnorm, iterate(p).max_mean))
                .collect();
            // from the minimax fit, then from the L_p polish's last solve
            assert_eq!(
                which,
                [
                    (None, Some(0.01)),
                    (None, Some(64.0)),
                    (Some(8.0), Some(0.01)),
                    (Some(8.0), Some(64.0))
                ],
                "{spec}"
            );
            assert!(polished.iter().all(|p| p.is_usable()));
            // exact in the numerators: with the minimax fit's denominators the linear program's
            // max + λ·mean is at most the minimax fit's, so at λ = 0.01 its max error is at
            // most the minimax fit's + 0.01 × its MAE, and at λ = 64 its MAE at most the fit's
            let (mx, mae) = (mm.metrics.max_abs_error, mm.metrics.mae);
            let small = &polished[0].metrics;
            assert!(
                small.max_abs_error <= mx + 0.01 * mae + 1e-9,
                "{spec}: {small:?} vs {mx:e}"
            );
            assert!(polished[1].metrics.mae <= mae * (1.0 + 1e-9), "{spec}");
            assert!(polished[1].metrics.max_abs_error >= small.max_abs_error - 1e-9);
            // the fit file says what it is and loads back
            let it = iterate(polished[3]).clone();
            assert_eq!(it.label("-", ""), "p8-maxmean64");
            let json = polished[3].to_json().unwrap();
            assert!(
                json.contains("\"max_mean\": 64.0") && json.contains("max–mean polish"),
                "{json}"
            );
            let back = FitResult::from_json(&json).unwrap();
            assert_eq!(back.solver.unwrap().lawson_path, Some(it));
            // deterministic
            let again = fit_form(&data, &t, &form, Objective::Minimax, &opts).unwrap();
            assert_eq!(again.path, mm.path);
            // λ < 0 is refused, naming the setting
            let mut bad = FitOptions::default();
            bad.rational.max_mean_polish = vec![-1.0];
            bad.structured.max_mean_polish = vec![-1.0];
            let e = fit_form(&data, &t, &form, Objective::Minimax, &bad)
                .unwrap_err()
                .to_string();
            assert!(e.contains("max_mean_polish"), "{e}");
        }
    }

    fn least_squares_and_minimax(data: &FitData, form: &Form) -> (FitResult, FitResult) {
        let run = |o| {
            fit_form(
                data,
                &[InputTransform::Identity; 3],
                form,
                o,
                &FitOptions::default(),
            )
            .unwrap()
        };
        (run(Objective::LeastSquares), run(Objective::Minimax))
    }

    #[test]
    fn the_lp_polish_adds_one_fit_per_p() {
        let f = |x: f64, r: f64, m: f64| (1.0 + x).sqrt() * (r * m + 0.1).ln().exp() / (1.2 + m);
        let n = 9;
        let data = grid3(n, f);
        let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let lp_norm = |fit: &FitResult, p: f64| -> f64 {
            let mut s = 0.0;
            for &x in &ax {
                for &r in &ax {
                    for &m in &ax {
                        s += (fit.eval(&[x, r, m]) - f(x, r, m)).abs().powf(p);
                    }
                }
            }
            s
        };
        let t = [InputTransform::Identity; 3];
        // a low-rank form (the structured fitter) and a split sum (the rational one)
        for spec in ["lowrank:f0:2:2:2/1", "split:f0:1:2/1"] {
            let form = parse_form(spec, &data.names).unwrap();
            let mut opts = FitOptions::default();
            opts.rational.lp_polish = vec![4.0, 16.0];
            opts.structured.lp_polish = vec![4.0, 16.0];
            let ls = fit_form(&data, &t, &form, Objective::LeastSquares, &opts).unwrap();
            let mm = fit_form(&data, &t, &form, Objective::Minimax, &opts).unwrap();
            let polished: Vec<&FitResult> = mm
                .path
                .iter()
                .filter(|p| iterate(p).pnorm.is_some())
                .collect();
            let ps: Vec<Option<f64>> = polished.iter().map(|p| iterate(p).pnorm).collect();
            assert_eq!(ps, [Some(4.0), Some(16.0)], "{spec}");
            // Levenberg–Marquardt from the least-squares fit lowers Σ|e|⁴; p = 16 lowers the
            // max error below the least-squares fit's
            assert!(polished.iter().all(|p| p.is_usable()));
            assert!(
                lp_norm(polished[0], 4.0) <= lp_norm(&ls, 4.0) * (1.0 + 1e-9),
                "{spec}: {} vs {}",
                lp_norm(polished[0], 4.0),
                lp_norm(&ls, 4.0)
            );
            assert!(polished[1].metrics.max_abs_error < ls.metrics.max_abs_error);
            // the fit file says what it is and loads back
            let it = iterate(polished[1]).clone();
            assert_eq!(it.label("-", ""), "p16");
            let json = polished[1].to_json().unwrap();
            assert!(
                json.contains("\"pnorm\": 16.0") && json.contains("L_p polish"),
                "{json}"
            );
            let back = FitResult::from_json(&json).unwrap();
            assert_eq!(back.solver.unwrap().lawson_path, Some(it));
            // none by default
            let plain =
                fit_form(&data, &t, &form, Objective::Minimax, &FitOptions::default()).unwrap();
            assert!(plain.path.iter().all(|p| iterate(p).pnorm.is_none()));
            // p < 2 is refused, naming the setting
            let mut bad = FitOptions::default();
            bad.rational.lp_polish = vec![1.0];
            bad.structured.lp_polish = vec![1.0];
            let e = fit_form(&data, &t, &form, Objective::Minimax, &bad)
                .unwrap_err()
                .to_string();
            assert!(e.contains("lp_polish"), "{e}");
        }
    }

    #[test]
    fn minimax_lowers_the_max_error() {
        let f = |x: f64, r: f64, m: f64| (1.0 + x).sqrt() * (r * m + 0.1).ln().exp() / (1.2 + m);
        let data = grid3(9, f);
        let form = parse_form("lowrank:f0:2:2:2/1", &data.names).unwrap();
        let (ls, mm) = least_squares_and_minimax(&data, &form);
        assert!(
            mm.metrics.max_abs_error < ls.metrics.max_abs_error,
            "{:?} {:?}",
            mm.metrics,
            ls.metrics
        );
        assert!(mm.solver.as_ref().unwrap().reweighting_iterations > 0);
        // the Lawson path's kept iterates: each below the least-squares fit's max error with an
        // MAE inside the widest band, and the blended branch (λ < 1) among them
        let band = crate::fit::robust::PATH_MAE_BOUNDS[2];
        let blends: Vec<f64> = mm
            .path
            .iter()
            .map(|p| {
                assert!(p.metrics.max_abs_error < ls.metrics.max_abs_error);
                assert!(p.metrics.mae <= band * ls.metrics.mae * (1.0 + 1e-9));
                iterate(p).blend
            })
            .collect();
        assert!(blends.iter().all(|&b| b > 0.0 && b <= 1.0), "{blends:?}");
    }

    #[test]
    fn the_blended_branch_keeps_a_fit_of_least_squares_mae() {
        // a front that moves with x (as the leaving dielectric's critical angle moves with F0):
        // Lawson's own rounds trade MAE for max error beyond the path's bands; the branch with
        // weights blended towards uniform keeps a fit of lower max error and nearly the
        // least-squares MAE
        let f = |x: f64, r: f64, m: f64| {
            1.0 / (1.0 + (-(m - 0.4 - 0.3 * x) / (0.05 + 0.2 * r)).exp()) // logistic front
        };
        let data = grid3(9, f);
        let form = parse_form("lowrank:f0:2:2:3/2", &data.names).unwrap();
        let (ls, mm) = least_squares_and_minimax(&data, &form);
        let bands = crate::fit::robust::PATH_MAE_BOUNDS;
        assert!(
            mm.metrics.mae > bands[2] * ls.metrics.mae,
            "{:?}",
            mm.metrics
        );
        let blended = mm
            .path
            .iter()
            .find(|p| iterate(p).blend < 1.0)
            .expect("an iterate of the blended branch");
        assert!(blended.metrics.max_abs_error < 0.9 * ls.metrics.max_abs_error);
        assert!(blended.metrics.mae <= bands[0] * ls.metrics.mae);
        assert!(blended.is_usable());
    }

    #[test]
    fn bad_structures_are_refused_with_the_fix() {
        let n = names();
        let err = |spec: &str| parse_form(spec, &n).unwrap_err();
        let e = err("sum:f0:legendre:3:2/1");
        assert!(
            e.contains("unknown basis family 'legendre'") && e.contains("power"),
            "{e}"
        );
        let e = err("lowrank:f0:5:2:2/1");
        assert!(
            e.contains("at most 3 independent terms") && e.contains("fewer terms"),
            "{e}"
        );
        let e = err("lowrank:f0:0:2:2/1");
        assert!(e.contains("0 terms") && e.contains("1 to 12"), "{e}");
        let e = err("sum:f0:power:2:2/+1,1,1");
        assert!(e.contains("3 degrees for the positive denominator"), "{e}");
        let e = err("lowrank:g:2:2:2/1");
        assert!(e.contains("unknown variable 'g'"), "{e}");
        let e = err("sum:f0:power:2");
        assert!(e.contains("sum:<variable>:<family>:<K>:<n>/<m>"), "{e}");
        // a JSON form whose per-term set uses the structure's variable
        let json = r#"{"kind": "exponents", "numerator": {"total": 2, "caps": [2, 2, 2], "in_total": [true, true, true]}, "denominator": null, "structure": {"kind": "low_rank", "variable": 0, "terms": 1, "degree": 1, "positive": false}}"#;
        let e = err(json);
        assert!(
            e.contains("degree 2 in 'f0'") && e.contains("other variables only"),
            "{e}"
        );
        // more terms than values of the variable: 3 powers of f0 on 2 values
        let data = grid3(2, |x, r, m| x + r + m);
        let form = parse_form("sum:f0:power:3:1/0", &data.names).unwrap();
        let e = fit_form(
            &data,
            &[InputTransform::Identity; 3],
            &form,
            Objective::LeastSquares,
            &FitOptions::default(),
        )
        .unwrap_err();
        assert!(
            matches!(e, FitError::TooFewValues { distinct: 2, .. }),
            "{e}"
        );
    }
}
