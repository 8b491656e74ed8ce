//! Blender Cycles' GGX albedo tables (`intern/cycles/scene/shader.tables`), computed by
//! furnace's quadrature in Cycles' exact layout.
//!
//! Cycles fills them with `cycles_precompute` (`intern/cycles/app/cycles_precompute.cpp`): for
//! cell (x, y, z) of an nx × ny × nz table it averages 2²⁰–2²⁶ Sobol samples of its own BSDF
//! sampler at rough = clamp(x/(nx−1), 1e-4, 1), μ = clamp(y/(ny−1), 1e-4, 1) (or μ uniform in
//! (0, 1) for the averages, whose sample is 2μE) and z = clamp(z/(nz−1), 1e-4, 0.99), all in f32,
//! with IOR = ior_from_F0(z⁴) (f32, F0 clamped to 0.99 inside) for the glass tables and exponent
//! 5(1 − z)/z for the generalised-Schlick one; stores saturate(mean) at index
//! z·nx·ny + y·nx + x; and prints each value with `std::to_string` (6 decimals) and an `f`.
//!
//! furnace evaluates the same definitions at the same f32 node values, with these edge
//! conventions of Cycles' renderer (`bsdf_microfacet.h`), which its tables inherit:
//!
//! * α = rough² in f32, and where α_x·α_y ≤ 2e-10 (`roughness_is_almost_specular`, here
//!   rough = 1e-4) the BSDF is a smooth interface: the node is r = 0, furnace's smooth-surface
//!   value (E = 1 for the conductor and, in energy form, for glass; s(μ) itself for the
//!   generalised-Schlick factor);
//! * at z = 1e-4 the IOR rounds to 1.0 in f32 and Cycles treats |η − 1| < 1e-4 as no interface
//!   (a specular pass-through): E = 1 and E_avg = 1 there; the dielectric s of that slice is 0
//!   (F = F0 = 0), as furnace's model gives.
//!
//! The glass tables use furnace's convention, which is today's Cycles sampler's: a refracted
//! direction on the wrong side of the macro-surface carries no energy. Cycles' shipped
//! `table_ggx_glass_inv_E` and `_inv_Eavg` were made by a 2023 sampler that kept those rays;
//! see docs/exporting.md for the difference.

use super::{
    fmt_error, header_lines, model_definition, report, Compute, Export, Files, OutputFile,
    TableReport,
};
use crate::bsdf::{self, Family, ModelId, Side};
use crate::error::{Error, Result};
use crate::math::SmithForm;
use crate::table::{GridAxis, Table};
use std::path::{Path, PathBuf};

/// `roughness_is_almost_specular`: α_x·α_y at or below this is a smooth surface (Cycles).
pub const SPECULAR_ALPHA2: f32 = 2e-10;
/// Cycles' clamps of the rough and μ axes.
pub const MIN_COORD: f32 = 1e-4;
/// Cycles' upper clamp of the z axis.
pub const MAX_Z: f32 = 0.99;

/// Which of Cycles' arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CyclesTable {
    GgxE,
    GgxEavg,
    GlassE,
    GlassEavg,
    GlassInvE,
    GlassInvEavg,
    GenSchlickIorS,
    GenSchlickS,
}

impl CyclesTable {
    /// Every array, in the order of Cycles' file.
    pub const ALL: [CyclesTable; 8] = [
        CyclesTable::GgxE,
        CyclesTable::GgxEavg,
        CyclesTable::GlassE,
        CyclesTable::GlassEavg,
        CyclesTable::GlassInvE,
        CyclesTable::GlassInvEavg,
        CyclesTable::GenSchlickIorS,
        CyclesTable::GenSchlickS,
    ];

    /// The array's name in `shader.tables`.
    pub fn name(self) -> &'static str {
        match self {
            CyclesTable::GgxE => "table_ggx_E",
            CyclesTable::GgxEavg => "table_ggx_Eavg",
            CyclesTable::GlassE => "table_ggx_glass_E",
            CyclesTable::GlassEavg => "table_ggx_glass_Eavg",
            CyclesTable::GlassInvE => "table_ggx_glass_inv_E",
            CyclesTable::GlassInvEavg => "table_ggx_glass_inv_Eavg",
            CyclesTable::GenSchlickIorS => "table_ggx_gen_schlick_ior_s",
            CyclesTable::GenSchlickS => "table_ggx_gen_schlick_s",
        }
    }

    /// (nx, ny, nz): rough, μ, z counts as `cycles_precompute` declares them (ny = 1: an average
    /// over μ).
    pub fn dims(self) -> (usize, usize, usize) {
        match self {
            CyclesTable::GgxE => (32, 32, 1),
            CyclesTable::GgxEavg => (32, 1, 1),
            CyclesTable::GlassE | CyclesTable::GlassInvE => (16, 16, 16),
            CyclesTable::GlassEavg | CyclesTable::GlassInvEavg => (16, 1, 16),
            CyclesTable::GenSchlickIorS | CyclesTable::GenSchlickS => (16, 16, 16),
        }
    }

    /// Values in the array.
    pub fn values_len(self) -> usize {
        let (x, y, z) = self.dims();
        x * y * z
    }

    /// The furnace model whose first output the array holds.
    pub fn model(self) -> ModelId {
        let hc = SmithForm::HeightCorrelated;
        match self {
            CyclesTable::GgxE => ModelId::ggx_conductor(hc),
            CyclesTable::GgxEavg => ModelId::ggx_conductor(hc).averaged(),
            CyclesTable::GlassE => ModelId::ggx_dielectric(Side::Entering, hc),
            CyclesTable::GlassEavg => ModelId::ggx_dielectric(Side::Entering, hc).averaged(),
            CyclesTable::GlassInvE => ModelId::ggx_dielectric(Side::Leaving, hc),
            CyclesTable::GlassInvEavg => ModelId::ggx_dielectric(Side::Leaving, hc).averaged(),
            CyclesTable::GenSchlickIorS => ModelId::new(Family::GGX_GEN_SCHLICK_IOR),
            CyclesTable::GenSchlickS => ModelId::new(Family::GGX_GEN_SCHLICK),
        }
    }

    /// Whether the first axis is the IOR (glass and ior_s tables).
    fn ior_axis(self) -> bool {
        !matches!(
            self,
            CyclesTable::GgxE | CyclesTable::GgxEavg | CyclesTable::GenSchlickS
        )
    }

    /// What a value of the array is, in words, for the header.
    fn definition(self) -> String {
        let model = bsdf::get(self.model()).expect("built-in model");
        let what = model_definition(model.as_ref());
        let (nx, ny, nz) = self.dims();
        let mut s = format!("{what}. Index ");
        s.push_str(&match (ny, nz) {
            (1, 1) => "x".into(),
            (_, 1) => format!("y·{nx} + x"),
            (1, _) => format!("z·{nx} + x"),
            _ => format!("z·{} + y·{nx} + x", nx * ny),
        });
        s.push_str(&format!(
            "; rough = clamp(x/{}, 1e-4, 1), α = rough² in f32 (a smooth surface, r = 0, where α² ≤ 2e-10)",
            nx - 1
        ));
        if ny > 1 {
            s.push_str(&format!("; μ = clamp(y/{}, 1e-4, 1)", ny - 1));
        } else {
            s.push_str("; averaged over μ ∈ [0, 1]");
        }
        if nz > 1 {
            let z = format!("z = clamp(z/{}, 1e-4, 0.99) in f32", nz - 1);
            s.push_str(&if self.ior_axis() {
                format!("; {z}, IOR = ior_from_F0(z⁴) in f32, F0 = ((IOR − 1)/(IOR + 1))²")
            } else {
                format!("; {z}, exponent p = 5(1 − z)/z")
            });
        }
        if self.no_interface_value().is_some() {
            s.push_str("; 1 where the IOR is 1.0 in f32 (Cycles: no interface)");
        }
        s
    }

    /// The value Cycles stores where its f32 IOR is 1 (|η − 1| < 1e-4: no interface).
    fn no_interface_value(self) -> Option<f64> {
        match self {
            CyclesTable::GlassE
            | CyclesTable::GlassEavg
            | CyclesTable::GlassInvE
            | CyclesTable::GlassInvEavg => Some(1.0),
            _ => None,
        }
    }
}

/// Cycles' node `clamp(i/(n − 1), lo, hi)` in f32.
pub fn node(i: usize, n: usize, lo: f32, hi: f32) -> f32 {
    (i as f32 / (n - 1) as f32).clamp(lo, hi)
}

/// furnace's r for Cycles' `rough`: √α of α = rough² in f32, or 0 where Cycles' renderer treats
/// the surface as smooth.
pub fn r_of_rough(rough: f32) -> f64 {
    let alpha = rough * rough;
    if alpha * alpha <= SPECULAR_ALPHA2 {
        0.0
    } else {
        (alpha as f64).sqrt()
    }
}

/// Cycles' `ior_from_F0(z⁴)` in f32.
pub fn ior_of_z(z: f32) -> f32 {
    let f0 = (z * z) * (z * z);
    let s = f0.clamp(0.0, 0.99).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// furnace's f0 for an IOR (so that furnace's η = (1 + √F0)/(1 − √F0) is that IOR).
pub fn f0_of_ior(ior: f32) -> f64 {
    let eta = ior as f64;
    let q = (eta - 1.0) / (eta + 1.0);
    q * q
}

/// The axes of a furnace table holding `which` (in furnace's axis order: [q,] r[, mu]).
pub fn axes(which: CyclesTable) -> Result<Vec<GridAxis>> {
    let (nx, ny, nz) = which.dims();
    let mut axes = Vec::new();
    if nz > 1 {
        let zs: Vec<f32> = (0..nz).map(|k| node(k, nz, MIN_COORD, MAX_Z)).collect();
        if which.ior_axis() {
            let f0: Vec<f64> = zs.iter().map(|&z| f0_of_ior(ior_of_z(z))).collect();
            axes.push(GridAxis::explicit("f0", f0)?);
        } else {
            axes.push(GridAxis::explicit(
                "z",
                zs.iter().map(|&z| z as f64).collect(),
            )?);
        }
    }
    let r: Vec<f64> = (0..nx)
        .map(|i| r_of_rough(node(i, nx, MIN_COORD, 1.0)))
        .collect();
    axes.push(GridAxis::explicit("r", r)?);
    if ny > 1 {
        let mu: Vec<f64> = (0..ny)
            .map(|j| node(j, ny, MIN_COORD, 1.0) as f64)
            .collect();
        axes.push(GridAxis::explicit("mu", mu)?);
    }
    Ok(axes)
}

/// The array's values in Cycles' order (saturated, f64), from furnace's table of it.
pub fn values(which: CyclesTable, table: &Table) -> Vec<f64> {
    let (nx, ny, nz) = which.dims();
    let e = table.output(0);
    let no_interface = which.no_interface_value();
    let mut out = Vec::with_capacity(which.values_len());
    for z in 0..nz {
        let ior_is_one =
            nz > 1 && which.ior_axis() && ior_of_z(node(z, nz, MIN_COORD, MAX_Z)) == 1.0;
        for y in 0..ny {
            for x in 0..nx {
                // furnace's row-major order: [z,] r, [mu]
                let idx = (z * nx + x) * ny + y;
                let v = match no_interface {
                    Some(v) if ior_is_one => v,
                    _ => e[idx],
                };
                out.push(v.clamp(0.0, 1.0)); // saturatef
            }
        }
    }
    out
}

/// One array as Cycles prints it (`cycles_precompute`: `std::to_string` of the f32, `f`,
/// rows of nx, a blank line between slices of a 3-D table).
pub fn format_array(which: CyclesTable, values: &[f64]) -> String {
    let (nx, ny, nz) = which.dims();
    let mut s = format!(
        "static const float {}[{}] = {{\n",
        which.name(),
        which.values_len()
    );
    for z in 0..nz {
        for y in 0..ny {
            s.push_str("  ");
            for x in 0..nx {
                let v = values[(z * ny + y) * nx + x] as f32;
                s.push_str(&format!("{:.6}", v as f64)); // std::to_string(float): "%f"
                if x + 1 < nx {
                    s.push_str("f, ");
                } else if y + 1 < ny || z + 1 < nz {
                    s.push_str("f,");
                } else {
                    s.push('f');
                }
            }
            s.push('\n');
        }
        if ny > 1 && z + 1 < nz {
            s.push('\n');
        }
    }
    s.push_str("};\n");
    s
}

/// One array: which, its values in Cycles' order, its report.
pub type Array = (CyclesTable, Vec<f64>, TableReport);

/// The arrays of a Cycles export, each with its values and report.
pub struct CyclesArrays {
    pub arrays: Vec<Array>,
}

/// Computes the eight arrays.
pub fn compute_arrays(compute: &Compute) -> Result<CyclesArrays> {
    let mut arrays = Vec::new();
    for which in CyclesTable::ALL {
        let (table, seconds) = compute.table(which.model(), axes(which)?)?;
        let v = values(which, &table);
        let r = report(which.name(), which.definition(), &table, seconds);
        arrays.push((which, v, r));
    }
    Ok(CyclesArrays { arrays })
}

const COMMAND: &str = "furnace export --format cycles";

fn array_comment(r: &TableReport) -> String {
    let mut s = String::from("/* ");
    s.push_str(&format!(
        "{}: {} Max quadrature error estimate {} over {} cells{}. */\n",
        r.name,
        r.definition,
        fmt_error(r.max_error_estimate),
        r.cells,
        if r.unconverged > 0 {
            format!(", {} above the tolerance", r.unconverged)
        } else {
            String::new()
        }
    ));
    s
}

fn file_header(arrays: &CyclesArrays, spliced: bool, tolerance: f64) -> String {
    let max = arrays
        .arrays
        .iter()
        .map(|a| a.2.max_error_estimate)
        .fold(0.0, f64::max);
    let mut lines = vec![
        "Blender Cycles' GGX albedo tables (the arrays of intern/cycles/scene/shader.tables of the"
            .to_string(),
        "same names and sizes), computed by deterministic quadrature at Cycles' own f32 nodes and"
            .into(),
        "edge conventions, not by Monte Carlo. Glass tables: energy-form transmission, and a"
            .into(),
        "refracted direction on the wrong side of the macro-surface carries no energy (as in"
            .into(),
        "Cycles' current sampler).".into(),
        format!(
            "Max quadrature error estimate over all arrays: {} (per-cell tolerance {}).",
            fmt_error(max),
            fmt_error(tolerance)
        ),
    ];
    if !spliced {
        lines.push("Cycles' shader.tables also defines table_sheen_ltc and table_thin_film_cmf, which this".into());
        lines.push(
            "file does not: splice it into Cycles' own file with --splice instead to replace it."
                .into(),
        );
    }
    let mut s = String::from("/*\n");
    s.push_str(&header_lines(" * ", COMMAND, &lines));
    s.push_str(" */\n");
    s
}

/// A complete file holding the eight arrays.
pub fn standalone(arrays: &CyclesArrays, tolerance: f64) -> String {
    let mut s = file_header(arrays, false, tolerance);
    s.push_str("\nCCL_NAMESPACE_BEGIN\n\n");
    for (which, v, r) in &arrays.arrays {
        s.push_str(&array_comment(r));
        s.push_str(&format_array(*which, v));
        s.push('\n');
    }
    s.push_str("CCL_NAMESPACE_END\n");
    s
}

/// Cycles' `shader.tables` (`base`) with its eight GGX arrays replaced, everything else kept
/// byte for byte; the header goes before the first replaced array.
pub fn splice(
    base: &str,
    base_path: &Path,
    arrays: &CyclesArrays,
    tolerance: f64,
) -> Result<String> {
    let mut out = String::with_capacity(base.len());
    let mut rest = base;
    let mut first = true;
    // arrays in the order they appear in `base`
    let mut found: Vec<(usize, &Array)> = Vec::new();
    for a in &arrays.arrays {
        let decl = format!(
            "static const float {}[{}] = {{",
            a.0.name(),
            a.0.values_len()
        );
        let Some(at) = base.find(&decl) else {
            let other = format!("static const float {}[", a.0.name());
            let why = if base.contains(&other) {
                format!(
                    "declares {} with another size than {}",
                    a.0.name(),
                    a.0.values_len()
                )
            } else {
                format!("has no array {}", a.0.name())
            };
            return Err(Error::file(
                base_path,
                format!("{why}: not a Cycles shader.tables this export can replace arrays in"),
            ));
        };
        found.push((at, a));
    }
    found.sort_by_key(|f| f.0);
    let mut offset = 0;
    for (at, (which, v, r)) in found {
        let local = at - offset;
        let end = rest[local..].find("};").ok_or_else(|| {
            Error::file(
                base_path,
                format!("array {} is not closed by '}};'", which.name()),
            )
        })? + local
            + 2;
        out.push_str(&rest[..local]);
        if first {
            out.push_str(&file_header(arrays, true, tolerance));
            first = false;
        }
        out.push_str(&array_comment(r));
        let mut array = format_array(*which, v);
        array.pop(); // the newline after "};" is the base's
        out.push_str(&array);
        rest = &rest[end..];
        offset = at + (end - local);
    }
    out.push_str(rest);
    Ok(out)
}

/// The Cycles export to `output` (spliced into `splice_base` if given).
pub fn export(compute: &Compute, output: &Path, splice_base: Option<&Path>) -> Result<Export> {
    let base = splice_base
        .map(|p| std::fs::read_to_string(p).map_err(|e| Error::io(p, e)))
        .transpose()?;
    if let (Some(b), Some(p)) = (&base, splice_base) {
        // refuse a wrong file before computing anything
        for which in CyclesTable::ALL {
            if !b.contains(&format!(
                "static const float {}[{}] = {{",
                which.name(),
                which.values_len()
            )) {
                return Err(Error::file(
                    p,
                    format!(
                        "has no array {}[{}]: not a Cycles shader.tables this export can replace arrays in",
                        which.name(),
                        which.values_len()
                    ),
                ));
            }
        }
    }
    super::check_paths(&[output.to_path_buf()], splice_base)?;
    let arrays = compute_arrays(compute)?;
    let tolerance = compute.quadrature.tolerance;
    let text = match (&base, splice_base) {
        (Some(b), Some(p)) => splice(b, p, &arrays, tolerance)?,
        _ => standalone(&arrays, tolerance),
    };
    Ok(Export {
        files: Files::Bytes(vec![OutputFile {
            path: output.to_path_buf(),
            bytes: text.into_bytes(),
        }]),
        tables: arrays.arrays.into_iter().map(|a| a.2).collect(),
        replaceable: splice_base.map(PathBuf::from),
    })
}

/// Parses every `static const float NAME[N] = { … };` array of a Cycles tables file (values
/// with or without the `f` suffix), in file order: for comparing with Cycles' shipped data.
pub fn parse_arrays(text: &str) -> Vec<(String, Vec<f64>)> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("static const float ") {
        rest = &rest[at + "static const float ".len()..];
        let Some(open) = rest.find('[') else { break };
        let name = rest[..open].trim().to_string();
        let Some(brace) = rest.find('{') else { break };
        let Some(close) = rest.find("};") else { break };
        let body = &rest[brace + 1..close];
        let values = body
            .split(|c: char| c == ',' || c.is_whitespace() || c == '{' || c == '}')
            .filter(|t| !t.is_empty())
            .filter_map(|t| t.trim_end_matches('f').parse::<f64>().ok())
            .collect();
        out.push((name, values));
        rest = &rest[close + 2..];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_follow_cycles_f32_conventions() {
        assert_eq!(node(0, 32, MIN_COORD, 1.0), 1e-4);
        assert_eq!(node(31, 32, MIN_COORD, 1.0), 1.0);
        assert_eq!(node(15, 16, MIN_COORD, MAX_Z), 0.99);
        assert_eq!(r_of_rough(1e-4), 0.0, "α² = 1e-16 is smooth in Cycles");
        assert!((r_of_rough(1.0 / 31.0) - 1.0 / 31.0).abs() < 1e-8);
        assert_eq!(
            ior_of_z(1e-4),
            1.0,
            "the IOR of z = 1e-4 rounds to 1 in f32"
        );
        let ior = ior_of_z(node(8, 16, MIN_COORD, MAX_Z));
        let eta = crate::math::eta_from_f0(f0_of_ior(ior));
        assert!((eta - ior as f64).abs() < 1e-13);
    }

    #[test]
    fn arrays_print_like_cycles_precompute() {
        let which = CyclesTable::GgxEavg;
        let v: Vec<f64> = (0..32).map(|i| 1.0 - i as f64 / 64.0).collect();
        let s = format_array(which, &v);
        assert!(s.starts_with("static const float table_ggx_Eavg[32] = {\n  1.000000f, 0.984375f,"));
        assert!(s.ends_with(", 0.515625f\n};\n"), "{s}");
        // a tie at the 7th decimal rounds to even, as printf does
        let w = vec![0.5078125; 32];
        assert!(format_array(which, &w).contains("0.507812f"));
        let parsed = parse_arrays(&s);
        assert_eq!(parsed[0].0, "table_ggx_Eavg");
        assert_eq!(parsed[0].1, v);
    }
}
