//! GLSL (4.50 core and GLSL ES 3.00 alike): `highp float name(highp float x, …)` inside an
//! include guard, to `#include` or paste after the `#version` line. The file has no `#version`
//! and no `main`, so it can be included as it is. Every declaration is `highp`: an ES fragment
//! shader has no default float precision, and under `mediump` (fp16) the 2⁻¹⁰⁰ literal of the
//! grazing-layer transform underflows and the conductor gives 0/0 at r = μ = 0. RGB values are
//! `vec3`. The text is validated by naga before it is returned ([`super::validate`]).

use super::ir::{float_literal, Function};
use super::source::{c_style_open, c_style_select_ge, render, xyz_component, Operand, Syntax};
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
        c_style_select_ge(a, b, then, otherwise)
    }
    fn component(&self, vector: &str, i: u8) -> String {
        xyz_component(vector, i)
    }
    fn vec3(&self, x: String, y: String, z: String) -> String {
        format!("vec3({x}, {y}, {z})")
    }
    fn prologue(&self, unit: &Unit) -> Vec<String> {
        vec![
            "// GLSL 4.50 or GLSL ES 3.00 (every declaration highp). Include after #version (glslangValidator".into(),
            "// needs #extension GL_GOOGLE_include_directive : require for #include) or paste.".into(),
            String::new(),
            format!("#ifndef {}", unit.guard),
            format!("#define {}", unit.guard),
            String::new(),
        ]
    }
    fn epilogue(&self, unit: &Unit) -> Vec<String> {
        vec![format!("#endif // {}", unit.guard)]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        c_style_open(f, "", "highp float", "highp vec3")
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("highp float {name} = {value};")
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
        let text = render(unit, self)?;
        super::validate::glsl(&text)?;
        Ok(vec![Artifact::code(format!("{}.glsl", unit.stem), text)])
    }
}
