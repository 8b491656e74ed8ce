//! HLSL (Shader Model 5 and 6; DXC, FXC and glslang's HLSL front end alike): `float name(float
//! x, …)` inside an include guard, to `#include` in a shader or paste. Every literal carries the
//! `f` suffix, so no expression is promoted to `double` or left a DXC "literal float" (which DXC
//! folds in 64 bits); its decimal denotes the f32 exactly ([`float_literal`]). `float` is 32-bit in
//! every shader model; nothing is `min16float`. RGB values are `float3`. The tests compile it with
//! glslangValidator's HLSL front end to SPIR-V and check that with spirv-val.

use super::ir::{float_literal, Function};
use super::source::{
    c_style_open, c_style_select_ge, guard_with_suffix, render, xyz_component, Operand, Syntax,
};
use super::{Artifact, Emitter, Unit};

/// The HLSL emitter.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hlsl;

/// The include guard of `unit` in HLSL: its GLSL guard with `_HLSL` for `_GLSL`.
pub fn guard(unit: &Unit) -> String {
    guard_with_suffix(unit, "_HLSL")
}

impl Syntax for Hlsl {
    fn literal(&self, x: f32) -> String {
        format!("{}f", float_literal(x))
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
        format!("float3({x}, {y}, {z})")
    }
    fn prologue(&self, unit: &Unit) -> Vec<String> {
        let guard = guard(unit);
        vec![
            "// HLSL (Shader Model 5 or 6; float is 32-bit). #include it in a shader or paste it."
                .into(),
            String::new(),
            format!("#ifndef {guard}"),
            format!("#define {guard}"),
            String::new(),
        ]
    }
    fn epilogue(&self, unit: &Unit) -> Vec<String> {
        vec![format!("#endif // {}", guard(unit))]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        c_style_open(f, "", "float", "float3")
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("float {name} = {value};")
    }
    fn result(&self, value: &str) -> String {
        format!("return {value};")
    }
}

impl Emitter for Hlsl {
    fn lang(&self) -> &'static str {
        "hlsl"
    }
    fn produce(&self, unit: &Unit) -> crate::Result<Vec<Artifact>> {
        Ok(vec![Artifact::code(
            format!("{}.hlsl", unit.stem),
            render(unit, self)?,
        )])
    }
}
