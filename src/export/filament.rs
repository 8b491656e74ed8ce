//! Filament's split-sum DFG table (and the same table at the sizes Godot and three.js use).
//!
//! Filament's `cmgen --ibl-dfg-multiscatter` (`libs/ibl/src/CubemapIBL.cpp`, `DFG` and
//! `DFV_Multiscatter`) fills an n × n image whose row y holds perceptual roughness
//! r = saturate((n − y + 0.5)/n) (α = r²) and whose column x holds μ = saturate((x + 0.5)/n),
//! with the two channels of its multiple-scattering form:
//!
//! * DFG1 = ∫ Fc f cos = B, Fc = (1 − ωo·h)⁵ (the f90 part of the split sum);
//! * DFG2 = ∫ f cos = A + B, the white conductor's albedo (its reciprocal is Filament's energy
//!   compensation 1 + F0(1/DFG2 − 1));
//!
//! so that E = mix(DFG1, DFG2, F0) = F0·A + B, with Filament's visibility — the height-correlated
//! Smith term. `cmgen` writes the rows bottom-up ("GL order": memory row j is image row n − 1 − j,
//! r = min(1, (j + 1.5)/n)) as half floats, two per texel; Filament's `DFG.cpp` uploads them as
//! an RG16F texture sampled at (μ, r). furnace writes the same texels from its `ggx-split-sum`
//! model, as RG16F (each value rounded f64 → f32 → f16, as `cmgen` does from its float image) or
//! RG32F, in one of four encodings:
//!
//! * `inc`: Filament's `dfg.inc` (comment lines, then `0x….,` half-float words, four texels a
//!   line) — RG16F only, as Filament declares `const uint16_t DFG_LUT[]` around it;
//! * `cpp`: a C++ header declaring `DFG_LUT_SIZE` and `DFG_LUT` (`uint16_t` or `float`);
//! * `js`: an ES module exporting `DFG_LUT_SIZE` and `DFG_LUT` (`Uint16Array` or
//!   `Float32Array`), ready for a three.js `DataTexture(…, RGFormat, HalfFloatType | FloatType)`;
//! * `bin`: the raw little-endian texels, with the header as JSON in `<file>.json`.

use super::{
    fmt_error, header_lines, model_definition, report, sidecar_path, Compute, Export, Files,
    OutputFile, TableReport,
};
use crate::bsdf::{self, Family, ModelId};
use crate::error::{Error, Result};
use crate::math::SmithForm;
use crate::table::GridAxis;
use sha2::{Digest, Sha256};
use std::path::Path;

/// The sizes furnace writes: powers of two (Filament's DFG_LUT_SIZE is one: 128; Godot and
/// three.js use 16–64).
pub const SIZES: std::ops::RangeInclusive<usize> = 4..=1024;

/// Precision of the texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// RG16F (IEEE half).
    F16,
    /// RG32F.
    F32,
}

/// How the texels are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Inc,
    Cpp,
    Js,
    Bin,
}

impl Encoding {
    /// The encoding an output file name implies.
    pub fn from_path(path: &Path) -> Option<Encoding> {
        match path.extension()?.to_str()? {
            "inc" => Some(Encoding::Inc),
            "h" | "hpp" | "hh" | "c" | "cc" | "cpp" => Some(Encoding::Cpp),
            "js" | "mjs" => Some(Encoding::Js),
            "bin" | "raw" => Some(Encoding::Bin),
            _ => None,
        }
    }
}

/// The split-sum model Filament's table comes from.
pub fn model() -> ModelId {
    ModelId::new(Family::GGX_SPLIT_SUM).with_smith(SmithForm::HeightCorrelated)
}

/// Refuses a size Filament's table cannot have.
pub fn check_size(size: usize) -> Result<()> {
    if !SIZES.contains(&size) || !size.is_power_of_two() {
        return Err(Error::InvalidInput(format!(
            "--size {size}: Filament's DFG table is a square texture whose side is a power of two from {} to {} (Filament ships 128; Godot and three.js use 16, 32 or 64)",
            SIZES.start(),
            SIZES.end()
        )));
    }
    Ok(())
}

/// The r of memory row j (GL order) and the μ of column x, as `cmgen` computes them.
pub fn row_r(j: usize, n: usize) -> f64 {
    let y = (n - 1 - j) as f64; // image row
    let h = n as f64;
    ((h - y + 0.5) / h).clamp(0.0, 1.0)
}

pub fn column_mu(x: usize, n: usize) -> f64 {
    ((x as f64 + 0.5) / n as f64).clamp(0.0, 1.0)
}

/// IEEE binary16 nearest to `v` (round to nearest, ties to even), as a bit pattern.
pub fn f16_bits(v: f32) -> u16 {
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xff) as i32;
    let mant = bits & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if mant != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00; // overflow: infinity
    }
    if e <= 0 {
        if e < -10 {
            return sign; // underflow to zero
        }
        let m = mant | 0x80_0000; // subnormal half
        let shift = (14 - e) as u32;
        let half = m >> shift;
        let rem = m & ((1 << shift) - 1);
        let mid = 1 << (shift - 1);
        let round = rem > mid || (rem == mid && half & 1 == 1);
        return sign | (half + round as u32) as u16;
    }
    let half = ((e as u32) << 10) | (mant >> 13);
    let rem = mant & 0x1fff;
    let round = rem > 0x1000 || (rem == 0x1000 && half & 1 == 1);
    sign | (half + round as u32) as u16 // a carry rounds up into the exponent, as it should
}

/// The value of a binary16 bit pattern.
pub fn f16_value(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let e = ((h >> 10) & 0x1f) as i32;
    let m = (h & 0x3ff) as f64;
    match e {
        0 => sign * m * 2f64.powi(-24),
        0x1f => {
            if m == 0.0 {
                sign * f64::INFINITY
            } else {
                f64::NAN
            }
        }
        _ => sign * (1.0 + m / 1024.0) * 2f64.powi(e - 15),
    }
}

/// The texels (DFG1, DFG2) in memory order, as f64.
pub struct Dfg {
    pub size: usize,
    pub texels: Vec<[f64; 2]>,
    pub report: TableReport,
}

/// Computes the n × n table.
pub fn compute(compute: &Compute, size: usize) -> Result<Dfg> {
    check_size(size)?;
    // furnace's grid: r increasing = memory rows in order; μ increasing = columns
    let r: Vec<f64> = (0..size).map(|j| row_r(j, size)).collect();
    let mu: Vec<f64> = (0..size).map(|x| column_mu(x, size)).collect();
    let axes = vec![GridAxis::explicit("r", r)?, GridAxis::explicit("mu", mu)?];
    let (table, seconds) = compute.table(model(), axes)?;
    let (a, b) = (table.output(0), table.output(1));
    let texels = (0..size * size).map(|k| [b[k], a[k] + b[k]]).collect();
    let m = bsdf::get(model())?;
    let definition = format!(
        "{}. Texel (x, j), j the row in memory (GL order, bottom-up): DFG1 = B, DFG2 = A + B at μ = (x + 0.5)/{size} and perceptual roughness r = min(1, (j + 1.5)/{size}), α = r² (cmgen's placement); E = mix(DFG1, DFG2, F0) = F0·A + B",
        model_definition(m.as_ref())
    );
    Ok(Dfg {
        size,
        texels,
        report: report("DFG", definition, &table, seconds),
    })
}

/// The texel values as written: f32, or f16 via f32.
fn words(dfg: &Dfg, precision: Precision) -> Vec<u32> {
    dfg.texels
        .iter()
        .flat_map(|t| t.iter())
        .map(|&v| match precision {
            Precision::F32 => (v as f32).to_bits(),
            Precision::F16 => f16_bits(v as f32) as u32,
        })
        .collect()
}

fn header(dfg: &Dfg, precision: Precision, prefix: &str) -> String {
    let lines = vec![
        format!(
            "DFG LUT stored as an {} texture, in GL order ({} × {} texels, two values each).",
            match precision {
                Precision::F16 => "RG16F",
                Precision::F32 => "RG32F",
            },
            dfg.size,
            dfg.size
        ),
        dfg.report.definition.clone(),
        format!(
            "Max quadrature error estimate {} over {} texels{}.",
            fmt_error(dfg.report.max_error_estimate),
            dfg.report.cells,
            match precision {
                Precision::F16 => "; rounding to half adds up to 2⁻¹¹ relative",
                Precision::F32 => "",
            }
        ),
    ];
    header_lines(
        prefix,
        &format!("furnace export --format filament --size {}", dfg.size),
        &lines,
    )
}

fn literal(word: u32, precision: Precision) -> String {
    match precision {
        Precision::F16 => format!("0x{word:04x}"),
        Precision::F32 => {
            let v = f32::from_bits(word);
            format!("{v:e}")
        }
    }
}

/// The files of the export to `output`.
pub fn files(
    dfg: &Dfg,
    precision: Precision,
    encoding: Encoding,
    output: &Path,
) -> Result<Vec<OutputFile>> {
    let w = words(dfg, precision);
    let file = |bytes: Vec<u8>| OutputFile {
        path: output.to_path_buf(),
        bytes,
    };
    Ok(match encoding {
        Encoding::Inc => {
            check_encoding(precision, encoding)?;
            // cmgen: a line break and four spaces before every fourth texel, "0x…, " per value
            let mut s = header(dfg, precision, "// ");
            for (k, pair) in w.chunks(2).enumerate() {
                if k % 4 == 0 {
                    s.push_str("\n    ");
                }
                for &v in pair {
                    s.push_str(&format!("0x{v:04x}, "));
                }
            }
            s.push_str("\n\n");
            vec![file(s.into_bytes())]
        }
        Encoding::Cpp | Encoding::Js => {
            let cpp = encoding == Encoding::Cpp;
            let mut s = header(dfg, precision, "// ");
            let n = dfg.size;
            if cpp {
                let ty = match precision {
                    Precision::F16 => "uint16_t",
                    Precision::F32 => "float",
                };
                s.push_str("#pragma once\n#include <cstdint>\n\n");
                s.push_str(&format!("constexpr unsigned DFG_LUT_SIZE = {n};\n"));
                s.push_str(&format!("const {ty} DFG_LUT[{}] = {{", 2 * n * n));
            } else {
                let ty = match precision {
                    Precision::F16 => "Uint16Array",
                    Precision::F32 => "Float32Array",
                };
                s.push_str(&format!("export const DFG_LUT_SIZE = {n};\n"));
                s.push_str(&format!("export const DFG_LUT = new {ty}(["));
            }
            for (k, &v) in w.iter().enumerate() {
                if k % 8 == 0 {
                    s.push_str("\n    ");
                }
                s.push_str(&literal(v, precision));
                if precision == Precision::F32 && cpp {
                    s.push('f');
                }
                s.push_str(if k + 1 < w.len() { ", " } else { "" });
            }
            s.push_str(if cpp { "\n};\n" } else { "\n]);\n" });
            vec![file(s.into_bytes())]
        }
        Encoding::Bin => {
            let bytes: Vec<u8> = match precision {
                Precision::F16 => w.iter().flat_map(|&v| (v as u16).to_le_bytes()).collect(),
                Precision::F32 => w.iter().flat_map(|&v| v.to_le_bytes()).collect(),
            };
            let sha: String = Sha256::digest(&bytes)
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            let json = serde_json::json!({
                "tool": "furnace",
                "tool_version": crate::VERSION,
                "written_by": super::MARKER,
                "format": "filament-dfg",
                "texture_format": match precision { Precision::F16 => "RG16F", Precision::F32 => "RG32F" },
                "size": dfg.size,
                "layout": "row-major, rows in GL order (bottom-up: memory row j holds r = min(1, (j + 1.5)/size)), columns μ = (x + 0.5)/size, two little-endian values per texel: DFG1 = B, DFG2 = A + B",
                "definition": dfg.report.definition,
                "max_error_estimate": dfg.report.max_error_estimate,
                "tolerance_unconverged_cells": dfg.report.unconverged,
                "sha256": sha,
            });
            let text = serde_json::to_string_pretty(&json).expect("json") + "\n";
            vec![
                file(bytes),
                OutputFile {
                    path: sidecar_path(output),
                    bytes: text.into_bytes(),
                },
            ]
        }
    })
}

/// Refuses an encoding that cannot hold the precision.
pub fn check_encoding(precision: Precision, encoding: Encoding) -> Result<()> {
    if encoding == Encoding::Inc && precision == Precision::F32 {
        return Err(Error::InvalidInput(
            "Filament's dfg.inc holds RG16F words (it is included in `const uint16_t DFG_LUT[]`); use --precision f16, or --encoding cpp, js or bin for RG32F".into(),
        ));
    }
    Ok(())
}

/// The Filament export of side `size` to `output`.
pub fn export(
    compute_with: &Compute,
    size: usize,
    precision: Precision,
    encoding: Encoding,
    output: &Path,
) -> Result<Export> {
    check_size(size)?;
    check_encoding(precision, encoding)?;
    let mut paths = vec![output.to_path_buf()];
    if encoding == Encoding::Bin {
        paths.push(sidecar_path(output));
    }
    super::check_paths(&paths, None)?;
    let dfg = compute(compute_with, size)?;
    Ok(Export {
        files: Files::Bytes(files(&dfg, precision, encoding, output)?),
        tables: vec![dfg.report],
        replaceable: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_round_to_nearest_even() {
        for (v, h) in [
            (0.0f32, 0x0000u16),
            (1.0, 0x3c00),
            (0.5, 0x3800),
            (65504.0, 0x7bff),
            (2f32.powi(-24), 0x0001),
            (1.0 + 2f32.powi(-11), 0x3c00), // a tie rounds to even
            (1.0 + 3.0 * 2f32.powi(-11), 0x3c02),
            (0.999_999, 0x3c00),
        ] {
            assert_eq!(f16_bits(v), h, "{v}");
        }
        for h in [0x0001u16, 0x03ff, 0x0400, 0x3555, 0x3bff, 0x3c00] {
            assert_eq!(f16_bits(f16_value(h) as f32), h);
        }
    }

    #[test]
    fn texel_placement_is_cmgens() {
        // memory row 0 is the image's bottom row y = n − 1: r = 1.5/n; the top row clamps to 1
        assert_eq!(row_r(0, 16), 1.5 / 16.0);
        assert_eq!(row_r(15, 16), 1.0);
        assert_eq!(row_r(14, 16), 15.5 / 16.0);
        assert_eq!(column_mu(0, 128), 0.5 / 128.0);
        assert!(check_size(128).is_ok() && check_size(48).is_err() && check_size(2048).is_err());
    }
}
