//! C and C++ (C99 or later, C++11 or later, CUDA): a header of `static inline float name(float
//! x, …)`, `__host__ __device__` under nvcc, inside an include guard. Literals carry the `f`
//! suffix (decimals that denote the f32 exactly, [`float_literal`]), min/max/sqrt are `fminf`,
//! `fmaxf`, `sqrtf` of `<math.h>` (host and device functions in CUDA), and every `let` is a
//! `const float`, so each operation is one f32 operation in the tree's order.
//!
//! Compiled with floating-point contraction off (GCC/Clang `-ffp-contract=off`; GCC contracts
//! `a * b + c` into an FMA by default in C++ and GNU C modes wherever the target has one, e.g.
//! with `-march=native` on x86-64) and with `FLT_EVAL_METHOD == 0` (SSE on x86-64, AArch64;
//! not 32-bit x87, which keeps excess precision), the results are the emitted Rust's bit for
//! bit: the operations are IEEE-754 correctly rounded, `sqrtf` included. Compilers that contract
//! (nvcc's default `--fmad=true`) perform [`super::ir::Arith::Fused`], which the stated bound
//! covers. `-ffast-math` reassociates and voids both. RGB values are `furnace_rgb`, a struct of
//! three floats defined once however many headers are included.

use super::ir::{float_literal, Function};
use super::source::{
    c_style_open, c_style_select_ge, guard_with_suffix, render, xyz_component, Operand, Syntax,
};
use super::{Artifact, Emitter, Unit};

/// The C/C++ emitter.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cpp;

/// The include guard of `unit` in C: its GLSL guard with `_H` for `_GLSL`.
pub fn guard(unit: &Unit) -> String {
    guard_with_suffix(unit, "_H")
}

impl Syntax for Cpp {
    fn literal(&self, x: f32) -> String {
        format!("{}f", float_literal(x))
    }
    fn min(&self, a: Operand, b: Operand) -> String {
        format!("fminf({}, {})", a.text, b.text)
    }
    fn max(&self, a: Operand, b: Operand) -> String {
        format!("fmaxf({}, {})", a.text, b.text)
    }
    fn sqrt(&self, a: Operand) -> String {
        format!("sqrtf({})", a.text)
    }
    fn select_ge(&self, a: Operand, b: Operand, then: Operand, otherwise: Operand) -> String {
        c_style_select_ge(a, b, then, otherwise)
    }
    fn component(&self, vector: &str, i: u8) -> String {
        xyz_component(vector, i)
    }
    fn vec3(&self, x: String, y: String, z: String) -> String {
        format!("furnace_rgb_make({x}, {y}, {z})")
    }
    fn prologue(&self, unit: &Unit) -> Vec<String> {
        let guard = guard(unit);
        let mut v = vec![
            "// C99 / C++11 / CUDA header: include it as it is. Bit-identical to the emitted Rust when".into(),
            "// compiled without FMA contraction (GCC/Clang: -ffp-contract=off) on a target with".into(),
            "// FLT_EVAL_METHOD == 0 (x86-64 SSE, AArch64); contracting compilers (nvcc by default)".into(),
            "// stay within each function's stated bound. Not with -ffast-math.".into(),
            String::new(),
            format!("#ifndef {guard}"),
            format!("#define {guard}"),
            String::new(),
            "#include <math.h>".into(),
            String::new(),
            "#ifndef FURNACE_FN".into(),
            "#if defined(__CUDACC__)".into(),
            "#define FURNACE_FN static inline __host__ __device__".into(),
            "#else".into(),
            "#define FURNACE_FN static inline".into(),
            "#endif".into(),
            "#endif".into(),
            String::new(),
        ];
        let vectors = unit
            .program
            .functions
            .iter()
            .any(|f| f.returns_vector() || f.params.iter().any(|p| f.is_vector_param(p)));
        if vectors {
            v.extend([
                "#ifndef FURNACE_RGB_DEFINED".to_string(),
                "#define FURNACE_RGB_DEFINED".into(),
                "// An RGB value (x, y, z = red, green, blue).".into(),
                "typedef struct furnace_rgb { float x, y, z; } furnace_rgb;".into(),
                "FURNACE_FN furnace_rgb furnace_rgb_make(float x, float y, float z) {".into(),
                "    furnace_rgb v;".into(),
                "    v.x = x;".into(),
                "    v.y = y;".into(),
                "    v.z = z;".into(),
                "    return v;".into(),
                "}".into(),
                "#endif".into(),
                String::new(),
            ]);
        }
        v
    }
    fn epilogue(&self, unit: &Unit) -> Vec<String> {
        vec![format!("#endif // {}", guard(unit))]
    }
    fn open_function(&self, f: &Function) -> Vec<String> {
        c_style_open(f, "FURNACE_FN ", "float", "furnace_rgb")
    }
    fn let_stmt(&self, name: &str, value: &str) -> String {
        format!("const float {name} = {value};")
    }
    fn result(&self, value: &str) -> String {
        format!("return {value};")
    }
}

impl Emitter for Cpp {
    fn lang(&self) -> &'static str {
        "cpp"
    }
    fn produce(&self, unit: &Unit) -> crate::Result<Vec<Artifact>> {
        Ok(vec![Artifact::code(
            format!("{}.h", unit.stem),
            render(unit, self)?,
        )])
    }
}
