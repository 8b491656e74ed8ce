//! WGSL: `fn name(x: f32, …) -> f32`, plain functions to paste or concatenate into a shader
//! module (WGSL has no include). Literals are abstract floats whose decimal denotes an f32
//! exactly (see [`float_literal`]), so conversion to f32 is exact. RGB values are `vec3<f32>`.
//! The text is validated by naga before it is returned ([`super::validate`]).

use super::ir::{float_literal, Function};
use super::source::{render, Operand, Syntax};
use super::{Artifact, Emitter, Unit};

/// The WGSL emitter.
#[derive(Clone, Copy, Debug, Default)]
pub struct Wgsl;

impl Syntax for Wgsl {
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
        // WGSL select(f, t, cond) returns t when cond holds
        format!(
            "select({}, {}, {} >= {})",
            otherwise.text, then.text, a.text, b.text
        )
    }
    fn component(&self, vector: &str, i: u8) -> String {
        format!("{vector}.{}", ["x", "y", "z"][i as usize])
    }
    fn vec3(&self, x: String, y: String, z: String) -> String {
        format!("vec3<f32>({x}, {y}, {z})")
    }
    fn prologue(&self, _unit: &Unit) -> Vec<String> {
        vec![
            "// Paste or concatenate into a WGSL module (WGSL has no include).".into(),
            String::new(),
        ]
    }
    fn epilogue(&self, _unit: &Unit) -> Vec<String> {
        vec![]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        let mut v: Vec<String> = f
            .doc
            .iter()
            .map(|l| format!("// {l}").trim_end().to_string())
            .collect();
        let ty = |vector: bool| if vector { "vec3<f32>" } else { "f32" };
        let params = f
            .params
            .iter()
            .map(|p| format!("{p}: {}", ty(f.is_vector_param(p))))
            .collect::<Vec<_>>()
            .join(", ");
        v.push(format!(
            "fn {}({params}) -> {} {{",
            f.name,
            ty(f.returns_vector())
        ));
        v
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("let {name} = {value};")
    }
    fn result(&self, value: &str) -> String {
        format!("return {value};")
    }
}

impl Emitter for Wgsl {
    fn lang(&self) -> &'static str {
        "wgsl"
    }
    fn produce(&self, unit: &Unit) -> crate::Result<Vec<Artifact>> {
        let text = render(unit, self)?;
        super::validate::wgsl(&text)?;
        Ok(vec![Artifact::code(format!("{}.wgsl", unit.stem), text)])
    }
}
