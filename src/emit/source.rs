//! Printing a [`Unit`]'s program as source text: one walk over the shared tree, with the
//! language differences (literal syntax, min/max/sqrt, select, declarations, vectors) behind
//! [`Syntax`]. Operands are parenthesised by [`needs_parens`], so every language groups — and
//! therefore rounds — exactly as the tree says. The text is ASCII ([`super::ascii`]).

use super::ir::{needs_parens, precedence, Expr, Function};
use super::Unit;

/// An operand already printed, and whether it can be used as a method receiver / postfix
/// operand without parentheses.
pub struct Operand {
    pub text: String,
    pub atomic: bool,
}

impl Operand {
    /// The text, parenthesised unless atomic.
    pub fn wrapped(&self) -> String {
        if self.atomic {
            self.text.clone()
        } else {
            format!("({})", self.text)
        }
    }
}

/// What differs between languages.
pub trait Syntax {
    fn literal(&self, x: f32) -> String;
    fn min(&self, a: Operand, b: Operand) -> String;
    fn max(&self, a: Operand, b: Operand) -> String;
    fn sqrt(&self, a: Operand) -> String;
    /// `a >= b ? then : otherwise` in the language's form.
    fn select_ge(&self, a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String;
    /// Component `i` (0, 1, 2) of a vector parameter.
    fn component(&self, vector: &str, i: u8) -> String;
    /// A three-component vector value.
    fn vec3(&self, x: String, y: String, z: String) -> String;
    /// Lines before the first function (after the header comment), e.g. an include guard.
    fn prologue(&self, unit: &Unit) -> Vec<String>;
    /// Lines after the last function.
    fn epilogue(&self, unit: &Unit) -> Vec<String>;
    /// The doc-comment lines and signature of a function, ending with `{`.
    fn open_function(&self, f: &Function) -> Vec<String>;
    fn let_stmt(&self, name: &str, value: &str) -> String;
    /// The last line of a body.
    fn result(&self, value: &str) -> String;
}

/// The `//` doc lines and `<ret> <name>(<type> <param>, …) {` signature of the C-family
/// languages (GLSL, HLSL, C/C++), whose declarations differ only in the scalar and vector type
/// names and an optional qualifier before the return type.
pub fn c_style_open(f: &Function, qualifier: &str, scalar: &str, vector: &str) -> Vec<String> {
    let mut v: Vec<String> = f
        .doc
        .iter()
        .map(|l| format!("// {l}").trim_end().to_string())
        .collect();
    let ty = |is_vector: bool| if is_vector { vector } else { scalar };
    let params = f
        .params
        .iter()
        .map(|p| format!("{} {p}", ty(f.is_vector_param(p))))
        .collect::<Vec<_>>()
        .join(", ");
    v.push(format!(
        "{qualifier}{} {}({params}) {{",
        ty(f.returns_vector()),
        f.name
    ));
    v
}

/// `a >= b ? then : otherwise`, the C-family conditional (GLSL, HLSL, C/C++).
pub fn c_style_select_ge(a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String {
    format!(
        "{} >= {} ? {} : {}",
        a.wrapped(),
        b.wrapped(),
        then.wrapped(),
        otherwise.wrapped()
    )
}

/// Component `i` of a vector as `.x`, `.y`, `.z` (GLSL, HLSL, C/C++).
pub fn xyz_component(vector: &str, i: u8) -> String {
    format!("{vector}.{}", ["x", "y", "z"][i as usize])
}

/// `unit`'s include guard with the language's suffix in place of GLSL's `_GLSL`.
pub fn guard_with_suffix(unit: &Unit, suffix: &str) -> String {
    format!(
        "{}{suffix}",
        unit.guard.strip_suffix("_GLSL").unwrap_or(&unit.guard)
    )
}

/// An expression as text.
pub fn expr(e: &Expr, s: &dyn Syntax) -> String {
    let operand = |child: &Expr, parent: u8, right: bool| -> String {
        let t = expr(child, s);
        if needs_parens(child, parent, right) {
            format!("({t})")
        } else {
            t
        }
    };
    let atom = |child: &Expr| -> Operand {
        let atomic =
            precedence(child) == 3 && !matches!(child, Expr::Lit(l) if l.value.is_sign_negative());
        Operand {
            text: expr(child, s),
            atomic,
        }
    };
    match e {
        Expr::Lit(l) => s.literal(l.value),
        Expr::Var(n) => n.clone(),
        Expr::Add(a, b) => format!("{} + {}", operand(a, 1, false), operand(b, 1, true)),
        Expr::Sub(a, b) => format!("{} - {}", operand(a, 1, false), operand(b, 1, true)),
        Expr::Mul(a, b) => format!("{} * {}", operand(a, 2, false), operand(b, 2, true)),
        Expr::Div(a, b) => format!("{} / {}", operand(a, 2, false), operand(b, 2, true)),
        Expr::Min(a, b) => s.min(atom(a), atom(b)),
        Expr::Max(a, b) => s.max(atom(a), atom(b)),
        Expr::Sqrt(a) => s.sqrt(atom(a)),
        Expr::Call(name, args) => format!(
            "{name}({})",
            args.iter()
                .map(|a| expr(a, s))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Expr::SelectGe {
            a,
            b,
            then,
            otherwise,
        } => s.select_ge(atom(a), atom(b), atom(then), atom(otherwise)),
        Expr::Component(v, i) => s.component(v, *i),
        Expr::Vec3(v) => s.vec3(expr(&v[0], s), expr(&v[1], s), expr(&v[2], s)),
    }
}

/// The whole file: header comment, prologue, functions, epilogue; `\n` line ends, one trailing
/// newline, ASCII only.
pub fn render(unit: &Unit, s: &dyn Syntax) -> crate::Result<String> {
    let mut lines: Vec<String> = unit
        .header
        .iter()
        .map(|l| {
            if l.is_empty() {
                "//".to_string()
            } else {
                format!("// {l}")
            }
        })
        .collect();
    lines.push(String::new());
    lines.extend(s.prologue(unit));
    for f in &unit.program.functions {
        lines.extend(s.open_function(f));
        for st in &f.body {
            if let Some(c) = &st.comment {
                lines.push(format!("    // {c}"));
            }
            lines.push(format!("    {}", s.let_stmt(&st.name, &expr(&st.value, s))));
        }
        lines.push(format!("    {}", s.result(&expr(&f.result, s))));
        lines.push("}".into());
        lines.push(String::new());
    }
    lines.extend(s.epilogue(unit));
    while lines.last().is_some_and(|l| l.is_empty()) {
        lines.pop();
    }
    let mut out = lines.join("\n");
    out.push('\n');
    super::ascii::to_ascii(&out)
}
