//! The language-neutral program every emitter prints and every f32 check executes.
//!
//! A [`Program`] is a list of pure scalar functions; each is a sequence of `let` bindings and a
//! result, built from +, −, ×, ÷, min, max, sqrt, calls and a two-way select. The printers
//! (`rust.rs`, `wgsl.rs`, `glsl.rs`) print the *same tree* with parentheses wherever the
//! language's left-to-right associativity would otherwise regroup it, so the three languages
//! perform the same roundings in the same order. [`Compiled`] flattens the tree into registers
//! and evaluates it in f32 exactly as the emitted Rust does (every operation rounded once), with
//! multiply–adds fused (as GPU compilers may contract them), or with the division and square
//! root errors GPUs are allowed (WGSL/Vulkan: 2.5 ulp for x/y, sqrt inherited from
//! 1/inverseSqrt), and propagates a first-order rounding-error bound alongside (Higham 2002,
//! "Accuracy and Stability of Numerical Algorithms", §3.1: fl(a op b) = (a op b)(1 + δ), |δ| ≤ u).

use std::collections::HashMap;

/// A literal: the f32 the code contains and the f64 value it stands for (their difference is
/// the representation error, counted in the error bound).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lit {
    pub value: f32,
    pub exact: f64,
}

impl Lit {
    /// The f32 nearest to `x`.
    pub fn nearest(x: f64) -> Lit {
        Lit {
            value: x as f32,
            exact: x,
        }
    }
    /// An f32 that is exactly the value meant (a clamp bound, 1, 2, …).
    pub fn exact(x: f32) -> Lit {
        Lit {
            value: x,
            exact: x as f64,
        }
    }
}

/// An expression tree.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Lit(Lit),
    /// A parameter or an earlier `let`.
    Var(String),
    Add(Box<Expr>, Box<Expr>),
    Sub(Box<Expr>, Box<Expr>),
    Mul(Box<Expr>, Box<Expr>),
    Div(Box<Expr>, Box<Expr>),
    Min(Box<Expr>, Box<Expr>),
    Max(Box<Expr>, Box<Expr>),
    Sqrt(Box<Expr>),
    /// A call of an earlier function of the same program.
    Call(String, Vec<Expr>),
    /// `if a >= b { then } else { otherwise }`.
    SelectGe {
        a: Box<Expr>,
        b: Box<Expr>,
        then: Box<Expr>,
        otherwise: Box<Expr>,
    },
    /// Component 0, 1 or 2 of a three-component parameter (an RGB colour): a parameter used
    /// only this way is printed as a vector (`[f32; 3]`, `vec3<f32>`, `vec3`).
    Component(String, u8),
    /// A three-component value; only as a function's result, which then returns a vector.
    Vec3(Box<[Expr; 3]>),
}

/// Shorthand constructors, so generator code reads like the formula.
pub mod build {
    use super::{Expr, Lit};
    pub fn lit(x: f64) -> Expr {
        Expr::Lit(Lit::nearest(x))
    }
    pub fn var(name: &str) -> Expr {
        Expr::Var(name.to_string())
    }
    pub fn add(a: Expr, b: Expr) -> Expr {
        Expr::Add(Box::new(a), Box::new(b))
    }
    pub fn sub(a: Expr, b: Expr) -> Expr {
        Expr::Sub(Box::new(a), Box::new(b))
    }
    pub fn mul(a: Expr, b: Expr) -> Expr {
        Expr::Mul(Box::new(a), Box::new(b))
    }
    pub fn div(a: Expr, b: Expr) -> Expr {
        Expr::Div(Box::new(a), Box::new(b))
    }
    pub fn min(a: Expr, b: Expr) -> Expr {
        Expr::Min(Box::new(a), Box::new(b))
    }
    pub fn max(a: Expr, b: Expr) -> Expr {
        Expr::Max(Box::new(a), Box::new(b))
    }
    pub fn sqrt(a: Expr) -> Expr {
        Expr::Sqrt(Box::new(a))
    }
    pub fn call(name: &str, args: Vec<Expr>) -> Expr {
        Expr::Call(name.to_string(), args)
    }
    pub fn select_ge(a: Expr, b: Expr, then: Expr, otherwise: Expr) -> Expr {
        Expr::SelectGe {
            a: Box::new(a),
            b: Box::new(b),
            then: Box::new(then),
            otherwise: Box::new(otherwise),
        }
    }
    /// `max(min(x, hi), lo)`: clamp that maps +∞ to hi and −∞ to lo.
    pub fn clamp(x: Expr, lo: Expr, hi: Expr) -> Expr {
        max(min(x, hi), lo)
    }
    pub fn component(vector: &str, i: u8) -> Expr {
        Expr::Component(vector.to_string(), i)
    }
    pub fn vec3(x: Expr, y: Expr, z: Expr) -> Expr {
        Expr::Vec3(Box::new([x, y, z]))
    }
}

/// `let name = value;` with an optional comment line above it.
#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    pub name: String,
    pub value: Expr,
    pub comment: Option<String>,
}

/// A pure function of f32 parameters returning one f32.
#[derive(Clone, Debug, PartialEq)]
pub struct Function {
    pub name: String,
    /// Documentation lines (printed as doc comments).
    pub doc: Vec<String>,
    pub params: Vec<String>,
    pub body: Vec<Stmt>,
    pub result: Expr,
}

/// Functions in dependency order (a function calls only earlier ones).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    pub functions: Vec<Function>,
}

impl Program {
    pub fn function(&self, name: &str) -> Option<&Function> {
        self.functions.iter().find(|f| f.name == name)
    }
}

impl Expr {
    /// Calls `visit` on this node and every node below it.
    pub fn walk(&self, visit: &mut dyn FnMut(&Expr)) {
        visit(self);
        match self {
            Expr::Lit(_) | Expr::Var(_) | Expr::Component(..) => {}
            Expr::Add(a, b)
            | Expr::Sub(a, b)
            | Expr::Mul(a, b)
            | Expr::Div(a, b)
            | Expr::Min(a, b)
            | Expr::Max(a, b) => {
                a.walk(visit);
                b.walk(visit);
            }
            Expr::Sqrt(a) => a.walk(visit),
            Expr::Call(_, args) => args.iter().for_each(|a| a.walk(visit)),
            Expr::SelectGe {
                a,
                b,
                then,
                otherwise,
            } => {
                for e in [a, b, then, otherwise] {
                    e.walk(visit);
                }
            }
            Expr::Vec3(v) => v.iter().for_each(|e| e.walk(visit)),
        }
    }
}

impl Function {
    /// Every expression of the body and the result, in order.
    pub fn exprs(&self) -> impl Iterator<Item = &Expr> {
        self.body.iter().map(|s| &s.value).chain([&self.result])
    }

    /// Whether parameter `p` is a three-component vector (used through [`Expr::Component`]).
    pub fn is_vector_param(&self, p: &str) -> bool {
        let mut found = false;
        for e in self.exprs() {
            e.walk(&mut |n| {
                if matches!(n, Expr::Component(v, _) if v == p) {
                    found = true;
                }
            });
        }
        found
    }

    /// Whether the function returns a three-component vector.
    pub fn returns_vector(&self) -> bool {
        matches!(self.result, Expr::Vec3(_))
    }

    /// Whether any expression takes a square root.
    pub fn uses_sqrt(&self) -> bool {
        let mut found = false;
        for e in self.exprs() {
            e.walk(&mut |n| found |= matches!(n, Expr::Sqrt(_)));
        }
        found
    }
}

/// Precedence of a node when printed infix (higher binds tighter); atoms are 3, a select
/// (`if`/`?:`) is 0.
pub fn precedence(e: &Expr) -> u8 {
    match e {
        Expr::SelectGe { .. } => 0,
        Expr::Add(..) | Expr::Sub(..) => 1,
        Expr::Mul(..) | Expr::Div(..) => 2,
        _ => 3,
    }
}

/// Whether an operand must be parenthesised to keep the tree's grouping, for left-associative
/// infix operators: a lower-precedence child always, a same-precedence child on the right
/// always (floating-point + and × are not associative), and a negative literal on the right.
pub fn needs_parens(child: &Expr, parent_prec: u8, right: bool) -> bool {
    let p = precedence(child);
    p < parent_prec
        || (right && p == parent_prec)
        || (right && matches!(child, Expr::Lit(l) if l.value.is_sign_negative()))
}

/// The shortest decimal that denotes exactly `x` whether a compiler parses it straight to f32 or
/// to f64 first and then rounds to f32 (glslang and WGSL abstract floats do the latter); falls back
/// to the shortest f64 decimal of `x`, which is exact in both paths. Always has a `.` or an
/// exponent, so it is a float literal in Rust, WGSL and GLSL.
pub fn float_literal(x: f32) -> String {
    assert!(
        x.is_finite(),
        "emitted literals are finite (checked when the program is built)"
    );
    let short = format!("{x:?}"); // Rust's shortest round-trip form, e.g. 0.1, 1.0, 1e-7
    let candidate = if round_trips(&short, x) {
        short
    } else {
        format!("{:?}", x as f64)
    };
    debug_assert!(
        round_trips(&candidate, x),
        "{candidate} does not round-trip {x:e}"
    );
    if candidate.contains(['.', 'e', 'E']) {
        candidate
    } else {
        format!("{candidate}.0")
    }
}

fn round_trips(s: &str, x: f32) -> bool {
    let direct = s.parse::<f32>().ok();
    let via_f64 = s.parse::<f64>().ok().map(|v| v as f32);
    direct.map(f32::to_bits) == Some(x.to_bits()) && via_f64.map(f32::to_bits) == Some(x.to_bits())
}

/// How the f32 evaluation rounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arith {
    /// Every operation rounded once to nearest, nothing fused: what the emitted Rust does.
    Ieee,
    /// Every `a·b ± c` contracted to one fused multiply–add (GLSL and WGSL compilers may do so).
    Fused,
    /// Fused, and each division and square root off by up to the error GPUs are allowed
    /// ([`GPU_DIV_ULPS`], [`GPU_SQRT_ULPS`]), in a pseudo-random direction seeded per point.
    Gpu { seed: u64 },
}

/// Error of x/y a GPU may have: 2.5 ulp (WGSL spec §"Floating Point Accuracy"; Vulkan spec,
/// "Precision and Operation of SPIR-V Instructions"). The simulation moves the result by whole
/// ulps, so it uses 2.
pub const GPU_DIV_ULPS: u32 = 2;
/// Error of sqrt a GPU may have: inherited from 1/inverseSqrt(x) (inverseSqrt 2 ulp, then a
/// 2.5-ulp division), i.e. up to about 4.5 ulp; the simulation uses 4 whole ulps.
pub const GPU_SQRT_ULPS: u32 = 4;
/// Points [`Compiled::eval_block`] evaluates at once.
pub const BLOCK: usize = 64;
/// Relative error bound per operation for the running bound: u = 2⁻²⁴ for +, −, × (correctly
/// rounded everywhere), and the GPU allowances for ÷ (2.5 ulp ≤ 5u) and sqrt (4.5 ulp ≤ 9u),
/// so the bound covers CPUs and GPUs alike.
const U: f64 = 1.0 / (1u64 << 24) as f64;
const DIV_REL: f64 = 5.0 * U;
const SQRT_REL: f64 = 9.0 * U;

/// One register of a flattened function: operands are earlier registers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Node {
    Lit(Lit),
    Param(usize),
    Add(usize, usize),
    Sub(usize, usize),
    Mul(usize, usize),
    Div(usize, usize),
    Min(usize, usize),
    Max(usize, usize),
    Sqrt(usize),
    SelectGe(usize, usize, usize, usize),
}

/// A function of a [`Program`] flattened into registers, calls inlined. Evaluation is the
/// emitted operation sequence, operation for operation.
#[derive(Clone, Debug)]
pub struct Compiled {
    nodes: Vec<Node>,
    n_params: usize,
    /// The result's registers: one, or three for a vector result.
    results: Vec<usize>,
    /// Register of each named `let` of the top function.
    lets: HashMap<String, usize>,
}

/// Errors of flattening: a program refers to something it does not define.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IrError {
    #[error("function '{0}' is not defined in the program (a generator bug; please report it)")]
    UnknownFunction(String),
    #[error("variable '{name}' is not defined in function '{function}' (a generator bug; please report it)")]
    UnknownVariable { function: String, name: String },
    #[error("call of '{function}' with {got} arguments, expected {expected} (a generator bug; please report it)")]
    Arity {
        function: String,
        expected: usize,
        got: usize,
    },
    #[error("function '{function}' uses a vector where a scalar is needed (a generator bug; please report it)")]
    Vector { function: String },
}

impl Compiled {
    /// Flattens function `name` of `program`. A vector parameter takes three consecutive
    /// scalar arguments; a vector result gives three results.
    pub fn new(program: &Program, name: &str) -> Result<Compiled, IrError> {
        let f = program
            .function(name)
            .ok_or_else(|| IrError::UnknownFunction(name.into()))?;
        let widths: Vec<usize> = f
            .params
            .iter()
            .map(|p| if f.is_vector_param(p) { 3 } else { 1 })
            .collect();
        let n_params: usize = widths.iter().sum();
        let mut nodes: Vec<Node> = (0..n_params).map(Node::Param).collect();
        let mut env = HashMap::new();
        let mut k = 0;
        for (p, &w) in f.params.iter().zip(&widths) {
            if w == 3 {
                for i in 0..3 {
                    env.insert(component_key(p, i), k + i);
                }
            } else {
                env.insert(p.clone(), k);
            }
            k += w;
        }
        let mut lets = HashMap::new();
        let results = inline_body(program, f, &f.body, env, &mut nodes, Some(&mut lets))?;
        Ok(Compiled {
            nodes,
            n_params,
            results,
            lets,
        })
    }

    /// The part of scalar function `name` after its `let`s `inputs`, as a function of them:
    /// parameter k is the value of `inputs[k]` (e.g. the transformed variables of an albedo
    /// function, whose polynomial part this then is). Fails if that part uses any other earlier
    /// `let` or a parameter of the function.
    pub fn after_lets(
        program: &Program,
        name: &str,
        inputs: &[String],
    ) -> Result<Compiled, IrError> {
        let f = program
            .function(name)
            .ok_or_else(|| IrError::UnknownFunction(name.into()))?;
        let mut start = 0;
        for input in inputs {
            let at = f
                .body
                .iter()
                .position(|s| s.name == *input)
                .ok_or_else(|| IrError::UnknownVariable {
                    function: f.name.clone(),
                    name: input.clone(),
                })?;
            start = start.max(at + 1);
        }
        let mut nodes: Vec<Node> = (0..inputs.len()).map(Node::Param).collect();
        let env: HashMap<String, usize> = inputs.iter().cloned().zip(0..).collect();
        let mut lets = HashMap::new();
        let results = inline_body(
            program,
            f,
            &f.body[start..],
            env,
            &mut nodes,
            Some(&mut lets),
        )?;
        Ok(Compiled {
            nodes,
            n_params: inputs.len(),
            results,
            lets,
        })
    }

    pub fn n_params(&self) -> usize {
        self.n_params
    }

    /// Register of the top function's `let name`, if any.
    pub fn register(&self, name: &str) -> Option<usize> {
        self.lets.get(name).copied()
    }

    /// Number of registers (a rough operation count).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub(crate) fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The registers of the result (one, or three for a vector).
    pub fn results(&self) -> &[usize] {
        &self.results
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Evaluates in f32 into `regs` (resized to [`Compiled::len`]); returns the result.
    pub fn eval_f32(&self, x: &[f32], arith: Arith, regs: &mut Vec<f32>) -> f32 {
        assert_eq!(x.len(), self.n_params, "one argument per parameter");
        regs.clear();
        regs.resize(self.nodes.len(), 0.0);
        let mut rng = match arith {
            Arith::Gpu { seed } => seed | 1,
            _ => 0,
        };
        let fused = !matches!(arith, Arith::Ieee);
        for (i, node) in self.nodes.iter().enumerate() {
            let v = match *node {
                Node::Lit(l) => l.value,
                Node::Param(k) => x[k],
                Node::Add(a, b) => self.add_f32(regs, a, b, false, fused),
                Node::Sub(a, b) => self.add_f32(regs, a, b, true, fused),
                Node::Mul(a, b) => regs[a] * regs[b],
                Node::Div(a, b) => {
                    let q = regs[a] / regs[b];
                    if matches!(arith, Arith::Gpu { .. }) {
                        perturb(q, GPU_DIV_ULPS, &mut rng)
                    } else {
                        q
                    }
                }
                Node::Min(a, b) => regs[a].min(regs[b]),
                Node::Max(a, b) => regs[a].max(regs[b]),
                Node::Sqrt(a) => {
                    let s = regs[a].sqrt();
                    if matches!(arith, Arith::Gpu { .. }) && s > 0.0 {
                        perturb(s, GPU_SQRT_ULPS, &mut rng)
                    } else {
                        s
                    }
                }
                Node::SelectGe(a, b, t, e) => {
                    if regs[a] >= regs[b] {
                        regs[t]
                    } else {
                        regs[e]
                    }
                }
            };
            regs[i] = v;
        }
        regs[self.results[0]]
    }

    /// [`Compiled::eval_f32`] on a block of up to [`BLOCK`] points at once, bit for bit the same:
    /// `xs` holds the points row-major (`n_params` values each); in the GPU model point j's
    /// error directions come from `seeds[j]`, as `Arith::Gpu { seed: seeds[j] }` would give.
    /// Register r of point j is `regs[r * BLOCK + j]` afterwards. One pass over the registers
    /// serves the whole block, so the dispatch on each operation is paid once per block.
    pub fn eval_block(&self, xs: &[f32], arith: Arith, seeds: &[u64], regs: &mut Vec<f32>) {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            unsafe fn wide(
                c: &Compiled,
                xs: &[f32],
                arith: Arith,
                seeds: &[u64],
                regs: &mut Vec<f32>,
            ) {
                c.eval_block_impl(xs, arith, seeds, regs)
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has AVX2 and FMA (checked just above). Every operation is
                // IEEE-rounded the same way with or without them (a fused multiply–add rounds
                // once either way), so the bits do not depend on the path.
                return unsafe { wide(self, xs, arith, seeds, regs) };
            }
        }
        self.eval_block_impl(xs, arith, seeds, regs)
    }

    /// The body of [`Compiled::eval_block`], compiled once per instruction set.
    #[inline(always)]
    fn eval_block_impl(&self, xs: &[f32], arith: Arith, seeds: &[u64], regs: &mut Vec<f32>) {
        let d = self.n_params;
        let n = xs.len().checked_div(d).unwrap_or(0);
        assert!(
            n <= BLOCK && xs.len() == n * d,
            "at most BLOCK whole points"
        );
        // every register of points 0..n is written before it is read: no need to clear
        if regs.len() != self.nodes.len() * BLOCK {
            regs.clear();
            regs.resize(self.nodes.len() * BLOCK, 0.0);
        }
        let gpu = matches!(arith, Arith::Gpu { .. });
        let mut rng = [0u64; BLOCK];
        if gpu {
            for (r, s) in rng.iter_mut().zip(seeds) {
                *r = s | 1;
            }
        }
        let fused = !matches!(arith, Arith::Ieee);
        for (i, node) in self.nodes.iter().enumerate() {
            let (done, rest) = regs.split_at_mut(i * BLOCK);
            let out = &mut rest[..n];
            let r = |k: usize| &done[k * BLOCK..k * BLOCK + n];
            match *node {
                Node::Lit(l) => out.fill(l.value),
                Node::Param(k) => {
                    for (j, o) in out.iter_mut().enumerate() {
                        *o = xs[j * d + k];
                    }
                }
                Node::Add(a, b) | Node::Sub(a, b) => {
                    let neg = matches!(node, Node::Sub(..));
                    let (ra, rb) = (r(a), r(b));
                    match (fused, self.nodes[a], self.nodes[b]) {
                        (true, Node::Mul(x, y), _) => {
                            let (rx, ry) = (r(x), r(y));
                            for j in 0..n {
                                let c = if neg { -rb[j] } else { rb[j] };
                                out[j] = rx[j].mul_add(ry[j], c);
                            }
                        }
                        (true, _, Node::Mul(x, y)) => {
                            let (rx, ry) = (r(x), r(y));
                            for j in 0..n {
                                out[j] = if neg {
                                    (-rx[j]).mul_add(ry[j], ra[j])
                                } else {
                                    rx[j].mul_add(ry[j], ra[j])
                                };
                            }
                        }
                        _ if neg => {
                            for j in 0..n {
                                out[j] = ra[j] - rb[j];
                            }
                        }
                        _ => {
                            for j in 0..n {
                                out[j] = ra[j] + rb[j];
                            }
                        }
                    }
                }
                Node::Mul(a, b) => {
                    let (ra, rb) = (r(a), r(b));
                    for j in 0..n {
                        out[j] = ra[j] * rb[j];
                    }
                }
                Node::Div(a, b) => {
                    let (ra, rb) = (r(a), r(b));
                    for j in 0..n {
                        let q = ra[j] / rb[j];
                        out[j] = if gpu {
                            perturb(q, GPU_DIV_ULPS, &mut rng[j])
                        } else {
                            q
                        };
                    }
                }
                Node::Min(a, b) => {
                    let (ra, rb) = (r(a), r(b));
                    for j in 0..n {
                        out[j] = ra[j].min(rb[j]);
                    }
                }
                Node::Max(a, b) => {
                    let (ra, rb) = (r(a), r(b));
                    for j in 0..n {
                        out[j] = ra[j].max(rb[j]);
                    }
                }
                Node::Sqrt(a) => {
                    let ra = r(a);
                    for j in 0..n {
                        let s = ra[j].sqrt();
                        out[j] = if gpu && s > 0.0 {
                            perturb(s, GPU_SQRT_ULPS, &mut rng[j])
                        } else {
                            s
                        };
                    }
                }
                Node::SelectGe(a, b, t, e) => {
                    let (ra, rb, rt, re) = (r(a), r(b), r(t), r(e));
                    for j in 0..n {
                        out[j] = if ra[j] >= rb[j] { rt[j] } else { re[j] };
                    }
                }
            }
        }
    }

    /// [`Compiled::eval_f32`] of the first result at many points, [`BLOCK`] at a time through
    /// [`Compiled::eval_block`] (bit for bit the same as point by point): `xs` holds the points
    /// row-major (`n_params` values each), `out[j]` receives point j's value. In the GPU model
    /// every point uses the one seed, as `eval_f32` with that `arith` would.
    pub fn eval_f32_points(&self, xs: &[f32], arith: Arith, out: &mut [f32], regs: &mut Vec<f32>) {
        let d = self.n_params;
        assert_eq!(xs.len(), out.len() * d, "one point per output");
        if d == 0 {
            let v = self.eval_f32(&[], arith, regs);
            out.fill(v);
            return;
        }
        let seed = match arith {
            Arith::Gpu { seed } => seed,
            _ => 0,
        };
        let seeds = [seed; BLOCK];
        let r = self.results[0];
        for (block, o) in xs.chunks(BLOCK * d).zip(out.chunks_mut(BLOCK)) {
            self.eval_block(block, arith, &seeds[..o.len()], regs);
            o.copy_from_slice(&regs[r * BLOCK..r * BLOCK + o.len()]);
        }
    }

    /// a ± b, fused with a product operand when `fused` (the product on the left first, as a
    /// contraction of `a*b + c` would pick).
    #[inline]
    fn add_f32(&self, regs: &[f32], a: usize, b: usize, negate_b: bool, fused: bool) -> f32 {
        if fused {
            if let Node::Mul(x, y) = self.nodes[a] {
                let c = if negate_b { -regs[b] } else { regs[b] };
                return regs[x].mul_add(regs[y], c);
            }
            if let Node::Mul(x, y) = self.nodes[b] {
                let (x, y) = (regs[x], regs[y]);
                return if negate_b {
                    (-x).mul_add(y, regs[a])
                } else {
                    x.mul_add(y, regs[a])
                };
            }
        }
        if negate_b {
            regs[a] - regs[b]
        } else {
            regs[a] + regs[b]
        }
    }

    /// Evaluates with exact-coefficient f64 arithmetic and a first-order bound on the f32
    /// evaluation's error (any of the [`Arith`] modes) per register; returns (value, bound) of the
    /// result and fills `regs`.
    pub fn eval_bound(&self, x: &[f32], regs: &mut Vec<(f64, f64)>) -> (f64, f64) {
        regs.clear();
        regs.resize(self.nodes.len(), (0.0, 0.0));
        for (i, node) in self.nodes.iter().enumerate() {
            let r = match *node {
                Node::Lit(l) => (l.exact, (l.value as f64 - l.exact).abs()),
                Node::Param(k) => (x[k] as f64, 0.0),
                Node::Add(a, b) | Node::Sub(a, b) => {
                    let ((va, ea), (vb, eb)) = (regs[a], regs[b]);
                    let v = if matches!(node, Node::Add(..)) {
                        va + vb
                    } else {
                        va - vb
                    };
                    (v, ea + eb + U * (v.abs() + ea + eb))
                }
                Node::Mul(a, b) => {
                    let ((va, ea), (vb, eb)) = (regs[a], regs[b]);
                    let e = va.abs() * eb + vb.abs() * ea + ea * eb;
                    (va * vb, e + U * ((va * vb).abs() + e))
                }
                Node::Div(a, b) => {
                    let ((va, ea), (vb, eb)) = (regs[a], regs[b]);
                    let v = va / vb;
                    let e = if eb < vb.abs() {
                        (ea + v.abs() * eb) / (vb.abs() - eb)
                    } else {
                        f64::INFINITY
                    };
                    (v, e + DIV_REL * (v.abs() + e))
                }
                Node::Min(a, b) => {
                    let ((va, ea), (vb, eb)) = (regs[a], regs[b]);
                    (va.min(vb), ea.max(eb))
                }
                Node::Max(a, b) => {
                    let ((va, ea), (vb, eb)) = (regs[a], regs[b]);
                    (va.max(vb), ea.max(eb))
                }
                Node::Sqrt(a) => {
                    let (va, ea) = regs[a];
                    let v = va.max(0.0).sqrt();
                    // |√â − √a| ≤ ε/(√a + √(a−ε)) when a > ε, and ≤ √ε always
                    let e = if va > 2.0 * ea {
                        ea / (v + (va - ea).sqrt())
                    } else {
                        ea.sqrt()
                    };
                    (v, e + SQRT_REL * (v + e))
                }
                Node::SelectGe(a, b, t, e) => {
                    if regs[a].0 >= regs[b].0 {
                        regs[t]
                    } else {
                        regs[e]
                    }
                }
            };
            regs[i] = r;
        }
        regs[self.results[0]]
    }
}

/// Moves `v` by k ∈ {−ulps, …, ulps} whole ulps, k from a SplitMix64 step of `state`.
fn perturb(v: f32, ulps: u32, state: &mut u64) -> f32 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    let k = (z % (2 * ulps as u64 + 1)) as i64 - ulps as i64;
    let mut out = v;
    for _ in 0..k.unsigned_abs() {
        out = if k > 0 {
            out.next_up()
        } else {
            out.next_down()
        };
    }
    out
}

fn component_key(vector: &str, i: usize) -> String {
    format!("{vector}.{i}")
}

/// Lowers `body` and the result of `f` with the bindings `env`; returns the result's registers.
fn inline_body(
    program: &Program,
    f: &Function,
    body: &[Stmt],
    mut env: HashMap<String, usize>,
    nodes: &mut Vec<Node>,
    mut lets_out: Option<&mut HashMap<String, usize>>,
) -> Result<Vec<usize>, IrError> {
    for s in body {
        let r = lower(program, f, &s.value, &env, nodes)?;
        env.insert(s.name.clone(), r);
        if let Some(l) = lets_out.as_deref_mut() {
            l.insert(s.name.clone(), r);
        }
    }
    match &f.result {
        Expr::Vec3(v) => v
            .iter()
            .map(|e| lower(program, f, e, &env, nodes))
            .collect(),
        e => Ok(vec![lower(program, f, e, &env, nodes)?]),
    }
}

/// A call: the callee must take and return scalars.
fn inline(
    program: &Program,
    f: &Function,
    args: &[usize],
    nodes: &mut Vec<Node>,
) -> Result<usize, IrError> {
    if args.len() != f.params.len() {
        return Err(IrError::Arity {
            function: f.name.clone(),
            expected: f.params.len(),
            got: args.len(),
        });
    }
    if f.returns_vector() || f.params.iter().any(|p| f.is_vector_param(p)) {
        return Err(IrError::Vector {
            function: f.name.clone(),
        });
    }
    let env: HashMap<String, usize> = f.params.iter().cloned().zip(args.iter().copied()).collect();
    Ok(inline_body(program, f, &f.body, env, nodes, None)?[0])
}

fn lower(
    program: &Program,
    f: &Function,
    e: &Expr,
    env: &HashMap<String, usize>,
    nodes: &mut Vec<Node>,
) -> Result<usize, IrError> {
    let bin = |a: &Expr,
               b: &Expr,
               nodes: &mut Vec<Node>,
               mk: fn(usize, usize) -> Node|
     -> Result<usize, IrError> {
        let ra = lower(program, f, a, env, nodes)?;
        let rb = lower(program, f, b, env, nodes)?;
        nodes.push(mk(ra, rb));
        Ok(nodes.len() - 1)
    };
    match e {
        Expr::Lit(l) => {
            nodes.push(Node::Lit(*l));
            Ok(nodes.len() - 1)
        }
        Expr::Var(name) => env
            .get(name)
            .copied()
            .ok_or_else(|| IrError::UnknownVariable {
                function: f.name.clone(),
                name: name.clone(),
            }),
        Expr::Add(a, b) => bin(a, b, nodes, Node::Add),
        Expr::Sub(a, b) => bin(a, b, nodes, Node::Sub),
        Expr::Mul(a, b) => bin(a, b, nodes, Node::Mul),
        Expr::Div(a, b) => bin(a, b, nodes, Node::Div),
        Expr::Min(a, b) => bin(a, b, nodes, Node::Min),
        Expr::Max(a, b) => bin(a, b, nodes, Node::Max),
        Expr::Sqrt(a) => {
            let r = lower(program, f, a, env, nodes)?;
            nodes.push(Node::Sqrt(r));
            Ok(nodes.len() - 1)
        }
        Expr::Call(name, call_args) => {
            let g = program
                .function(name)
                .ok_or_else(|| IrError::UnknownFunction(name.clone()))?;
            let regs = call_args
                .iter()
                .map(|a| lower(program, f, a, env, nodes))
                .collect::<Result<Vec<_>, _>>()?;
            inline(program, g, &regs, nodes)
        }
        Expr::Component(v, i) => {
            env.get(&component_key(v, *i as usize))
                .copied()
                .ok_or_else(|| IrError::UnknownVariable {
                    function: f.name.clone(),
                    name: format!("{v}[{i}]"),
                })
        }
        Expr::Vec3(_) => Err(IrError::Vector {
            function: f.name.clone(),
        }),
        Expr::SelectGe {
            a,
            b,
            then,
            otherwise,
        } => {
            let ra = lower(program, f, a, env, nodes)?;
            let rb = lower(program, f, b, env, nodes)?;
            let rt = lower(program, f, then, env, nodes)?;
            let re = lower(program, f, otherwise, env, nodes)?;
            nodes.push(Node::SelectGe(ra, rb, rt, re));
            Ok(nodes.len() - 1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::build::*;
    use super::*;

    #[test]
    fn literals_round_trip_both_ways_and_look_like_floats() {
        let mut state = 0x1234_5678u64;
        let mut xs = vec![
            0.0f32,
            -0.0,
            1.0,
            2.0,
            0.1,
            -400.04813,
            1e-7,
            3.4028235e38,
            1.0e-45,
            16777216.0,
            0.0125,
        ];
        for _ in 0..20_000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = f32::from_bits((state >> 32) as u32);
            if x.is_finite() {
                xs.push(x);
            }
        }
        for x in xs {
            let s = float_literal(x);
            assert!(s.contains(['.', 'e']), "{s}");
            assert_eq!(s.parse::<f32>().unwrap().to_bits(), x.to_bits(), "{s}");
            assert_eq!(
                (s.parse::<f64>().unwrap() as f32).to_bits(),
                x.to_bits(),
                "{s}"
            );
        }
        assert_eq!(float_literal(1.0), "1.0");
        assert_eq!(float_literal(0.1), "0.1");
    }

    fn program(result: Expr) -> Program {
        Program {
            functions: vec![Function {
                name: "f".into(),
                doc: vec![],
                params: vec!["x".into(), "y".into()],
                body: vec![Stmt {
                    name: "t".into(),
                    value: mul(var("x"), var("y")),
                    comment: None,
                }],
                result,
            }],
        }
    }

    #[test]
    fn ieee_and_fused_differ_exactly_where_a_contraction_rounds_once() {
        // x·y − 1 with x = y = 1 + 2⁻¹²: x·y = 1 + 2⁻¹¹ + 2⁻²⁴ rounds (ties to even) to 1 + 2⁻¹¹
        let p = program(sub(var("t"), lit(1.0)));
        let c = Compiled::new(&p, "f").unwrap();
        let x = 1.0 + 2f32.powi(-12);
        let mut regs = Vec::new();
        let ieee = c.eval_f32(&[x, x], Arith::Ieee, &mut regs);
        let fused = c.eval_f32(&[x, x], Arith::Fused, &mut regs);
        assert_eq!(ieee, 2f32.powi(-11));
        assert_eq!(fused, 2f32.powi(-11) + 2f32.powi(-24));
        let (v, bound) = c.eval_bound(&[x, x], &mut Vec::new());
        assert!((v - fused as f64).abs() < 1e-15);
        assert!(
            (ieee as f64 - v).abs() <= bound,
            "bound {bound} must cover the IEEE rounding"
        );
    }

    #[test]
    fn the_bound_covers_cancellation_and_gpu_division() {
        // (x − 0.9999)·1e4 / y: catastrophic cancellation amplified, then a division
        let p = program(div(mul(sub(var("x"), lit(0.9999)), lit(1e4)), var("y")));
        let c = Compiled::new(&p, "f").unwrap();
        let mut regs = Vec::new();
        let mut bregs = Vec::new();
        let mut worst = 0.0f64;
        for i in 0..2000 {
            let x = 0.999 + i as f32 * 1e-6;
            let y = 0.3 + i as f32 * 1e-4;
            let (v, b) = c.eval_bound(&[x, y], &mut bregs);
            for arith in [Arith::Ieee, Arith::Fused, Arith::Gpu { seed: i }] {
                let got = c.eval_f32(&[x, y], arith, &mut regs) as f64;
                assert!((got - v).abs() <= b, "{arith:?} at {x}: {got} vs {v} ± {b}");
                worst = worst.max((got - v).abs() / b);
            }
        }
        assert!(worst > 0.05, "the bound should not be vacuous: {worst}");
    }

    #[test]
    fn block_evaluation_is_bit_identical() {
        let p = program(div(
            add(mul(var("t"), lit(0.3)), sqrt(var("x"))),
            sub(var("y"), lit(2.5)),
        ));
        let c = Compiled::new(&p, "f").unwrap();
        let xs: Vec<f32> = (0..2 * 50).map(|i| 0.37 * i as f32 - 3.1).collect();
        let seeds: Vec<u64> = (0..50).map(|j| 1000 + j).collect();
        let (mut one, mut block) = (Vec::new(), Vec::new());
        for arith in [Arith::Ieee, Arith::Fused, Arith::Gpu { seed: 0 }] {
            c.eval_block(&xs, arith, &seeds, &mut block);
            for j in 0..50 {
                let a = match arith {
                    Arith::Gpu { .. } => Arith::Gpu { seed: seeds[j] },
                    a => a,
                };
                let want = c.eval_f32(&xs[2 * j..2 * j + 2], a, &mut one);
                let got = block[c.results()[0] * BLOCK + j];
                assert_eq!(got.to_bits(), want.to_bits(), "{arith:?} point {j}");
            }
        }
    }

    #[test]
    fn many_points_match_one_at_a_time() {
        let p = program(div(
            add(mul(var("t"), lit(0.3)), sqrt(var("x"))),
            sub(var("y"), lit(2.5)),
        ));
        let c = Compiled::new(&p, "f").unwrap();
        let n = 2 * BLOCK + 13;
        let xs: Vec<f32> = (0..2 * n).map(|i| 0.21 * i as f32 - 7.3).collect();
        let (mut one, mut many) = (Vec::new(), Vec::new());
        for arith in [Arith::Ieee, Arith::Fused, Arith::Gpu { seed: 77 }] {
            let mut out = vec![f32::NAN; n];
            c.eval_f32_points(&xs, arith, &mut out, &mut many);
            for (j, got) in out.iter().enumerate() {
                let want = c.eval_f32(&xs[2 * j..2 * j + 2], arith, &mut one);
                assert_eq!(got.to_bits(), want.to_bits(), "{arith:?} point {j}");
            }
        }
    }

    #[test]
    fn calls_inline_and_select_picks_a_branch() {
        let mut p = program(mul(var("t"), lit(2.0)));
        p.functions.push(Function {
            name: "g".into(),
            doc: vec![],
            params: vec!["a".into()],
            body: vec![],
            result: select_ge(
                var("a"),
                lit(0.0),
                call("f", vec![var("a"), lit(3.0)]),
                call("f", vec![sub(lit(0.0), var("a")), lit(1.0)]),
            ),
        });
        let c = Compiled::new(&p, "g").unwrap();
        let mut regs = Vec::new();
        assert_eq!(c.eval_f32(&[2.0], Arith::Ieee, &mut regs), 12.0);
        assert_eq!(c.eval_f32(&[-2.0], Arith::Ieee, &mut regs), 4.0);
        assert!(matches!(
            Compiled::new(&p, "nope"),
            Err(IrError::UnknownFunction(_))
        ));
    }
}
