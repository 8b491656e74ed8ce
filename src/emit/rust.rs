//! Rust: `pub fn name(x: f32, …) -> f32`, meant to be `include!`d as it is. Every literal is
//! suffixed `_f32`, so no expression can fall back to f64, and Rust never contracts `a * b + c`
//! into an FMA: on a CPU the emitted code performs exactly the roundings of
//! [`super::ir::Arith::Ieee`]. RGB values are `[f32; 3]`.
//!
//! The code needs nothing but `core` (min, max and arithmetic) except for square roots, which
//! `core` lacks: a function that takes one declares `sqrtf` inside its body — `f32::sqrt` with
//! std, `libm::sqrtf` when the including crate has a `libm` feature (for `#![no_std]`, e.g.
//! rust-gpu or embedded targets). Both are correctly rounded, so the results are the same bits.

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
        format!("sqrtf({})", a.text)
    }
    fn select_ge(&self, a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String {
        format!(
            "if {} >= {} {{ {} }} else {{ {} }}",
            a.text, b.text, then.text, otherwise.text
        )
    }
    fn component(&self, vector: &str, i: u8) -> String {
        format!("{vector}[{i}]")
    }
    fn vec3(&self, x: String, y: String, z: String) -> String {
        format!("[{x}, {y}, {z}]")
    }
    fn prologue(&self, unit: &Unit) -> Vec<String> {
        if unit.program.functions.iter().any(Function::uses_sqrt) {
            vec![
                "// Needs only `core`, but for square roots: with std they are f32::sqrt; under #![no_std],".into(),
                "// give the including crate a `libm` feature that enables a libm dependency (same bits).".into(),
                String::new(),
            ]
        } else {
            vec![
                "// Needs only `core`: usable under #![no_std].".into(),
                String::new(),
            ]
        }
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
        v.push("#[allow(clippy::excessive_precision, clippy::approx_constant, clippy::manual_clamp, clippy::unreadable_literal, unused_variables, unexpected_cfgs)]".into());
        let ty = |vector: bool| if vector { "[f32; 3]" } else { "f32" };
        let params = f
            .params
            .iter()
            .map(|p| format!("{p}: {}", ty(f.is_vector_param(p))))
            .collect::<Vec<_>>()
            .join(", ");
        v.push(format!(
            "pub fn {}({params}) -> {} {{",
            f.name,
            ty(f.returns_vector())
        ));
        if f.uses_sqrt() {
            v.extend([
                "    #[cfg(feature = \"libm\")]".to_string(),
                "    use libm::sqrtf;".into(),
                "    #[cfg(not(feature = \"libm\"))]".into(),
                "    fn sqrtf(x: f32) -> f32 { x.sqrt() }".into(),
            ]);
        }
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
            render(unit, self)?,
        )])
    }
}
