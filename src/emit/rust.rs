//! Rust: `pub fn name(x: f32, …) -> f32`, meant to be `include!`d as it is. Every literal is
//! suffixed `_f32`, so no expression can fall back to f64, and Rust never contracts `a * b + c`
//! into an FMA: on a CPU the emitted code performs exactly the roundings of
//! [`super::ir::Arith::Ieee`].

use super::ir::{float_literal, Function};
use super::source::{render, Operand, Syntax};
use super::{Artifact, Emitter, Unit};

/// The Rust emitter.
#[derive(Clone, Copy, Debug, Default)]
pub struct Rust;

impl Syntax for Rust {
    fn literal(&self, x: f32) -> String {
        format!("{}_f32", float_literal(x))
    }
    fn min(&self, a: Operand, b: Operand) -> String {
        format!("{}.min({})", a.wrapped(), b.text)
    }
    fn max(&self, a: Operand, b: Operand) -> String {
        format!("{}.max({})", a.wrapped(), b.text)
    }
    fn sqrt(&self, a: Operand) -> String {
        format!("{}.sqrt()", a.wrapped())
    }
    fn select_ge(&self, a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String {
        format!(
            "if {} >= {} {{ {} }} else {{ {} }}",
            a.text, b.text, then.text, otherwise.text
        )
    }
    fn prologue(&self, _unit: &Unit) -> Vec<String> {
        vec![]
    }
    fn epilogue(&self, _unit: &Unit) -> Vec<String> {
        vec![]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        let mut v: Vec<String> = f
            .doc
            .iter()
            .map(|l| format!("/// {l}").trim_end().to_string())
            .collect();
        v.push("#[inline]".into());
        v.push("#[rustfmt::skip]".into());
        v.push("#[allow(clippy::excessive_precision, clippy::approx_constant, clippy::manual_clamp, clippy::unreadable_literal, unused_variables)]".into());
        let params = f
            .params
            .iter()
            .map(|p| format!("{p}: f32"))
            .collect::<Vec<_>>()
            .join(", ");
        v.push(format!("pub fn {}({params}) -> f32 {{", f.name));
        v
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("let {name} = {value};")
    }
    fn result(&self, value: &str) -> String {
        value.to_string()
    }
}

impl Emitter for Rust {
    fn lang(&self) -> &'static str {
        "rust"
    }
    fn produce(&self, unit: &Unit) -> crate::Result<Vec<Artifact>> {
        Ok(vec![Artifact::code(
            format!("{}.rs", unit.stem),
            render(unit, self),
        )])
    }
}
