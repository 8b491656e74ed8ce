//! GLSL (4.50 core, and any version with `float` functions): `float name(float x, …)` inside an
//! include guard, to `#include` or paste after the `#version` line. The file has no `#version`
//! and no `main`, so it can be included as it is.

use super::ir::{float_literal, Function};
use super::source::{render, Operand, Syntax};
use super::{Artifact, Emitter, Unit};

/// The GLSL emitter.
#[derive(Clone, Copy, Debug, Default)]
pub struct Glsl;

impl Syntax for Glsl {
    fn literal(&self, x: f32) -> String {
        float_literal(x)
    }
    fn min(&self, a: Operand, b: Operand) -> String {
        format!("min({}, {})", a.text, b.text)
    }
    fn max(&self, a: Operand, b: Operand) -> String {
        format!("max({}, {})", a.text, b.text)
    }
    fn sqrt(&self, a: Operand) -> String {
        format!("sqrt({})", a.text)
    }
    fn select_ge(&self, a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String {
        format!(
            "{} >= {} ? {} : {}",
            a.wrapped(),
            b.wrapped(),
            then.wrapped(),
            otherwise.wrapped()
        )
    }
    fn prologue(&self, unit: &Unit) -> Vec<String> {
        vec![
            format!("#ifndef {}", unit.guard),
            format!("#define {}", unit.guard),
            String::new(),
        ]
    }
    fn epilogue(&self, unit: &Unit) -> Vec<String> {
        vec![format!("#endif // {}", unit.guard)]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        let mut v: Vec<String> = f
            .doc
            .iter()
            .map(|l| format!("// {l}").trim_end().to_string())
            .collect();
        let params = f
            .params
            .iter()
            .map(|p| format!("float {p}"))
            .collect::<Vec<_>>()
            .join(", ");
        v.push(format!("float {}({params}) {{", f.name));
        v
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("float {name} = {value};")
    }
    fn result(&self, value: &str) -> String {
        format!("return {value};")
    }
}

impl Emitter for Glsl {
    fn lang(&self) -> &'static str {
        "glsl"
    }
    fn produce(&self, unit: &Unit) -> crate::Result<Vec<Artifact>> {
        Ok(vec![Artifact::code(
            format!("{}.glsl", unit.stem),
            render(unit, self),
        )])
    }
}
