//! Emitted shaders are validated before they are returned, so a shader naga rejects is never
//! written: WGSL through naga's WGSL front end, GLSL (an include file) as the body of a
//! `#version 450` fragment shader through its GLSL front end, each then through naga's
//! validator with every check on. (The tests also compile the GLSL with glslangValidator, as
//! GLSL 4.50 to SPIR-V checked by spirv-val and as GLSL ES 3.00.)

use crate::error::{Error, Result};

fn validate(module: &naga::Module) -> std::result::Result<(), String> {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(module)
    .map(|_| ())
    .map_err(|e| format!("{:?}", e.into_inner()))
}

fn refused(lang: &str, why: String) -> Error {
    Error::InvalidInput(format!(
        "the generated {lang} does not pass naga ({why}); nothing was written (a generator bug; please report it)"
    ))
}

/// Parses and validates WGSL source.
pub fn wgsl(src: &str) -> Result<()> {
    let module =
        naga::front::wgsl::parse_str(src).map_err(|e| refused("WGSL", e.emit_to_string(src)))?;
    validate(&module).map_err(|e| refused("WGSL", e))
}

/// Parses and validates a GLSL include (no `#version`, no `main`) inside a fragment shader.
/// naga's GLSL front end does not take precision qualifiers on parameters (which GLSL ES needs
/// and desktop GLSL ignores), and its module has no precision, so `highp` is removed for it.
pub fn glsl(src: &str) -> Result<()> {
    let src = src.replace("highp ", "");
    let full = format!("#version 450\n{src}\nvoid main() {{}}\n");
    let module = naga::front::glsl::Frontend::default()
        .parse(
            &naga::front::glsl::Options::from(naga::ShaderStage::Fragment),
            &full,
        )
        .map_err(|e| refused("GLSL", e.emit_to_string(&full)))?;
    validate(&module).map_err(|e| refused("GLSL", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_validators_refuse_broken_shaders() {
        wgsl("fn f(x: f32) -> f32 { return x * 2.0; }").unwrap();
        glsl("highp float f(highp float x) { return x * 2.0; }").unwrap();
        let e = wgsl("fn f(x: f32) -> f32 { return x + y; }")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("does not pass naga") && e.contains("nothing was written"),
            "{e}"
        );
        assert!(glsl("float f(float x) { return x + undefined_name; }").is_err());
        // parses, but the validator refuses it: a function returning a value on no path
        assert!(wgsl("fn f(x: f32) -> f32 { if x > 0.0 { return x; } }").is_err());
    }
}
