//! LUTs for renderers that prefer textures: a table at a small resolution (e.g. 32² or 32³) as
//! an EXR image, raw little-endian f32 and f16 arrays, and a JSON description, so a LUT and a
//! fit of equal memory can be compared.
//!
//! The values are the model's albedo *at the LUT's nodes*, computed by quadrature at that
//! resolution (not filtered from a finer table): a multilinear LUT interpolates them exactly.
//! Node i of an axis with n nodes over [lo, hi] sits at x_i = lo + (hi − lo)·i/(n − 1); a GPU
//! sampler with linear filtering and clamp-to-edge must therefore be addressed at
//! u = (0.5 + (n − 1)(x − lo)/(hi − lo))/n, which the JSON repeats.

use crate::digest::sha256_hex;
use exr::prelude::f16;
use rayon::prelude::*;
use serde::Serialize;

use super::{Artifact, Emitter, Place, Unit};
use crate::error::{Error, Result};
use crate::table::{GridAxis, Table};

/// Most nodes a LUT may have (a 256³ f32 LUT is 64 MiB — far beyond "small"); refused before
/// anything is computed.
pub const MAX_LUT_CELLS: usize = 1 << 24;

/// A LUT: one output of a table at its nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct Lut {
    pub model: String,
    pub output: String,
    pub axes: Vec<GridAxis>,
    /// Exact values, row-major, last axis fastest.
    pub values: Vec<f64>,
    /// Content hash of the table the values come from.
    pub table_hash: String,
    /// Largest per-cell quadrature error estimate of that table.
    pub max_error_estimate: f64,
    /// File path without extension, relative to the LUT folder (`ggx-conductor/32x32`).
    pub stem: String,
    /// Measured comparison with a finer table and a fit, if available.
    pub comparison: Option<LutComparison>,
}

/// How a LUT compares with a fit at a finer table's nodes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LutComparison {
    pub reference: String,
    pub points: usize,
    pub lut_f32_mae: f64,
    pub lut_f32_max: f64,
    pub lut_f16_mae: f64,
    pub lut_f16_max: f64,
    pub fit_function: Option<String>,
    pub fit_bytes: Option<usize>,
    pub fit_f32_mae: Option<f64>,
    pub fit_f32_max: Option<f64>,
}

impl Lut {
    /// Output `output` of `table`, stored under `stem`.
    pub fn from_table(table: &Table, output: &str, stem: String) -> Result<Lut> {
        let o = table.output_index(output).ok_or_else(|| {
            Error::InvalidInput(format!(
                "table of {} has no output '{output}'; it has {}",
                table.spec.model,
                table.spec.outputs.join(", ")
            ))
        })?;
        if table.cells() > MAX_LUT_CELLS {
            return Err(Error::InvalidInput(format!(
                "a LUT of {} cells is over the limit of {MAX_LUT_CELLS}; choose a smaller --lut-resolution",
                table.cells()
            )));
        }
        Ok(Lut {
            model: table.spec.model.clone(),
            output: output.into(),
            axes: table.spec.axes.clone(),
            values: table.output(o).to_vec(),
            table_hash: table.spec.content_hash(),
            max_error_estimate: table.summary.max_error_estimate,
            stem,
            comparison: None,
        })
    }

    pub fn cells(&self) -> usize {
        self.values.len()
    }

    pub fn values_f32(&self) -> Vec<f32> {
        self.values.iter().map(|&v| v as f32).collect()
    }

    pub fn values_f16(&self) -> Vec<f16> {
        self.values.iter().map(|&v| f16::from_f64(v)).collect()
    }

    /// A sampler over the f32 values.
    pub fn sampler_f32(&self) -> Sampler {
        Sampler::new(&self.axes, self.values_f32())
    }

    /// A sampler over the f16 values (widened to f32, as a texture unit does).
    pub fn sampler_f16(&self) -> Sampler {
        Sampler::new(
            &self.axes,
            self.values_f16().iter().map(|h| h.to_f32()).collect(),
        )
    }
}

/// Multilinear interpolation in f32 of node values, inputs clamped to the grid — what a texture
/// unit with linear filtering and clamp-to-edge does, except that GPUs quantise the weights
/// (often to 8 fractional bits), which this does not.
#[derive(Clone, Debug)]
pub struct Sampler {
    /// Per axis: lo, (n − 1)/(hi − lo), n.
    axes: Vec<(f32, f32, usize)>,
    strides: Vec<usize>,
    pub data: Vec<f32>,
}

impl Sampler {
    pub fn new(axes: &[GridAxis], data: Vec<f32>) -> Sampler {
        let d = axes.len();
        let mut strides = vec![1; d];
        for k in (0..d.saturating_sub(1)).rev() {
            strides[k] = strides[k + 1] * axes[k + 1].n;
        }
        let axes = axes
            .iter()
            .map(|a| (a.lo as f32, ((a.n - 1) as f64 / (a.hi - a.lo)) as f32, a.n))
            .collect();
        Sampler {
            axes,
            strides,
            data,
        }
    }

    /// The interpolated value at `x` (one coordinate per axis).
    #[inline]
    pub fn sample(&self, x: &[f32]) -> f32 {
        let d = self.axes.len();
        let mut base = 0usize;
        let mut frac = [0.0f32; crate::fit::data::MAX_DIM];
        for k in 0..d {
            let (lo, scale, n) = self.axes[k];
            let u = ((x[k] - lo) * scale).max(0.0).min((n - 1) as f32);
            let i = (u as usize).min(n - 2);
            frac[k] = u - i as f32;
            base += i * self.strides[k];
        }
        // blend the 2^d corners axis by axis: lerp(a, b, f) = a + f·(b − a)
        let mut corners = [0.0f32; 8];
        for (c, v) in corners.iter_mut().enumerate().take(1 << d) {
            let mut idx = base;
            for k in 0..d {
                if c >> (d - 1 - k) & 1 == 1 {
                    idx += self.strides[k];
                }
            }
            *v = self.data[idx];
        }
        let mut len = 1 << d;
        for f in &frac[..d] {
            len /= 2;
            for c in 0..len {
                let (a, b) = (corners[c], corners[c + len]);
                corners[c] = a + f * (b - a);
            }
        }
        corners[0]
    }
}

/// Table nodes per work item of [`compare`].
const COMPARE_CHUNK: usize = 1 << 14;

/// Errors of the LUT (f32 and f16 values, multilinear in f32) and of the emitted f32 fit
/// (`function`, flattened as `compiled`, of `n_coefficients` coefficients) at every node of
/// `reference` (a finer table of the same model and domain).
pub fn compare(
    lut: &Lut,
    reference: &Table,
    function: &str,
    compiled: &super::ir::Compiled,
    n_coefficients: usize,
) -> Result<LutComparison> {
    let o = reference.output_index(&lut.output).ok_or_else(|| {
        Error::InvalidInput(format!("reference table has no output '{}'", lut.output))
    })?;
    let d = lut.axes.len();
    if reference.spec.axes.len() != d {
        return Err(Error::InvalidInput(
            "the reference table and the LUT have different axes".into(),
        ));
    }
    let (s32, s16) = (lut.sampler_f32(), lut.sampler_f16());
    let values = reference.output(o);
    // fixed chunks, each summed in order and the chunks combined in order: the same bits for
    // any number of threads
    let chunks: Vec<([crate::math::CompensatedSum; 3], [f64; 3])> = values
        .par_chunks(COMPARE_CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut sums = [crate::math::CompensatedSum::default(); 3];
            let mut maxes = [0.0f64; 3];
            let mut x = vec![0.0; d];
            let mut x32 = vec![0.0f32; d * chunk.len()];
            for i in 0..chunk.len() {
                reference.spec.point(c * COMPARE_CHUNK + i, &mut x);
                for k in 0..d {
                    x32[i * d + k] = x[k] as f32;
                }
            }
            let mut fit32 = vec![0.0f32; chunk.len()];
            compiled.eval_f32_points(&x32, super::ir::Arith::Ieee, &mut fit32, &mut Vec::new());
            for (i, &y) in chunk.iter().enumerate() {
                let p = &x32[i * d..(i + 1) * d];
                let errs = [
                    (s32.sample(p) as f64 - y).abs(),
                    (s16.sample(p) as f64 - y).abs(),
                    (fit32[i] as f64 - y).abs(),
                ];
                for k in 0..3 {
                    sums[k].add(errs[k]);
                    maxes[k] = maxes[k].max(errs[k]);
                }
            }
            (sums, maxes)
        })
        .collect();
    let mut sums = [crate::math::CompensatedSum::default(); 3];
    let mut maxes = [0.0f64; 3];
    for (s, m) in &chunks {
        for k in 0..3 {
            sums[k].add(s[k].value());
            maxes[k] = maxes[k].max(m[k]);
        }
    }
    let n = values.len().max(1) as f64;
    Ok(LutComparison {
        reference: format!(
            "{} {} table",
            reference.spec.model,
            reference.spec.resolution_name()
        ),
        points: values.len(),
        lut_f32_mae: sums[0].value() / n,
        lut_f32_max: maxes[0],
        lut_f16_mae: sums[1].value() / n,
        lut_f16_max: maxes[1],
        fit_function: Some(function.to_string()),
        fit_bytes: Some(4 * n_coefficients),
        fit_f32_mae: Some(sums[2].value() / n),
        fit_f32_max: Some(maxes[2]),
    })
}

#[derive(Serialize)]
struct FileEntry {
    file: String,
    sample_type: &'static str,
    bytes: usize,
    sha256: String,
}

#[derive(Serialize)]
struct Description<'a> {
    tool: &'static str,
    tool_version: &'static str,
    model: &'a str,
    output: &'a str,
    axes: &'a [GridAxis],
    cells: usize,
    layout: &'static str,
    texture_coordinates: &'static str,
    values: &'static str,
    table_content_hash: &'a str,
    table_max_error_estimate: f64,
    f16_max_rounding_error: f64,
    files: Vec<FileEntry>,
    comparison: &'a Option<LutComparison>,
}

const LAYOUT: &str = "row-major, last axis fastest: cell (i0, …, i_last) at ((i0·n1 + i1)·n2 + …)·n_last + i_last; \
.f32 / .f16: little-endian IEEE binary32 / binary16, no header; EXR: one image n_last wide and (product of the other counts) tall, one channel named after the output";
const TEXCOORDS: &str = "node i of an axis with n nodes over [lo, hi] is at x_i = lo + (hi − lo)·i/(n − 1); \
for a texture with linear filtering and clamp-to-edge, sample at u = (0.5 + (n − 1)·(x − lo)/(hi − lo))/n";
const VALUES: &str = "the model's albedo at the nodes by quadrature at this resolution (not filtered from a finer table)";

fn exr_bytes(lut: &Lut) -> Result<Vec<u8>> {
    use exr::prelude::*;
    let width = lut.axes.last().map_or(1, |a| a.n);
    let height = lut.cells() / width;
    let channel = AnyChannel::new(lut.output.as_str(), FlatSamples::F32(lut.values_f32()));
    let mut attributes = LayerAttributes::named(lut.model.as_str());
    attributes.comments = Some(Text::from(
        format!(
            "furnace {}: {} of {} over {}",
            crate::VERSION,
            lut.output,
            lut.model,
            lut.axes
                .iter()
                .map(|a| format!("{} [{}, {}] x{}", a.name, a.lo, a.hi, a.n))
                .collect::<Vec<_>>()
                .join(", ")
        )
        .as_str(),
    ));
    let layer = Layer::new(
        (width, height),
        attributes,
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let mut buf = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut buf)
        .map_err(|e| {
            crate::Error::InvalidInput(format!("cannot encode the EXR of {}: {e}", lut.stem))
        })?;
    Ok(buf.into_inner())
}

/// The LUT emitter: four files per LUT of the unit.
#[derive(Clone, Copy, Debug, Default)]
pub struct LutEmitter;

impl Emitter for LutEmitter {
    fn lang(&self) -> &'static str {
        "lut"
    }

    fn produce(&self, unit: &Unit) -> Result<Vec<Artifact>> {
        if unit.luts.is_empty() {
            return Err(Error::InvalidInput(
                "no LUT to write: the fit has no table reference and its model is unknown, so there is nothing to tabulate".into(),
            ));
        }
        let mut out = Vec::new();
        for lut in &unit.luts {
            if let Some(bad) = lut.values.iter().find(|v| !v.is_finite()) {
                return Err(Error::InvalidInput(format!(
                    "LUT {} holds a non-finite value {bad}; refusing to write it",
                    lut.stem
                )));
            }
            let f32_bytes: Vec<u8> = lut
                .values_f32()
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect();
            let f16_bytes: Vec<u8> = lut
                .values_f16()
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect();
            let exr = exr_bytes(lut)?;
            let name = |ext: &str| format!("{}.{ext}", lut.stem);
            let base = |ext: &str| {
                std::path::Path::new(&name(ext))
                    .file_name()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            };
            let f16_err = lut
                .values
                .iter()
                .map(|&v| (f16::from_f64(v).to_f64() - v).abs())
                .fold(0.0, f64::max);
            let desc = Description {
                tool: "furnace",
                tool_version: crate::VERSION,
                model: &lut.model,
                output: &lut.output,
                axes: &lut.axes,
                cells: lut.cells(),
                layout: LAYOUT,
                texture_coordinates: TEXCOORDS,
                values: VALUES,
                table_content_hash: &lut.table_hash,
                table_max_error_estimate: lut.max_error_estimate,
                f16_max_rounding_error: f16_err,
                files: vec![
                    FileEntry {
                        file: base("exr"),
                        sample_type: "f32",
                        bytes: exr.len(),
                        sha256: sha256_hex(&exr),
                    },
                    FileEntry {
                        file: base("f32"),
                        sample_type: "f32",
                        bytes: f32_bytes.len(),
                        sha256: sha256_hex(&f32_bytes),
                    },
                    FileEntry {
                        file: base("f16"),
                        sample_type: "f16",
                        bytes: f16_bytes.len(),
                        sha256: sha256_hex(&f16_bytes),
                    },
                ],
                comparison: &lut.comparison,
            };
            let json = serde_json::to_string_pretty(&desc)
                .map_err(|e| Error::InvalidInput(format!("LUT description: {e}")))?;
            out.push(Artifact {
                file_name: name("exr"),
                bytes: exr,
                place: Place::Lut,
            });
            out.push(Artifact {
                file_name: name("f32"),
                bytes: f32_bytes,
                place: Place::Lut,
            });
            out.push(Artifact {
                file_name: name("f16"),
                bytes: f16_bytes,
                place: Place::Lut,
            });
            // the description last: it commits the other three
            out.push(Artifact {
                file_name: name("json"),
                bytes: format!("{json}\n").into_bytes(),
                place: Place::Lut,
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multilinear_sampling_reproduces_nodes_and_linear_functions() {
        let axes = vec![
            GridAxis::new("f0", 0.0, 0.5, 3),
            GridAxis::new("r", 0.0, 1.0, 4),
            GridAxis::new("mu", 0.0, 1.0, 5),
        ];
        let f = |x: &[f64]| 0.25 + 0.5 * x[0] - 0.125 * x[1] + 0.25 * x[2];
        let mut values = Vec::new();
        for i in 0..3 {
            for j in 0..4 {
                for k in 0..5 {
                    values.push(f(&[axes[0].node(i), axes[1].node(j), axes[2].node(k)]) as f32);
                }
            }
        }
        let s = Sampler::new(&axes, values);
        for x in [
            [0.0f32, 0.0, 0.0],
            [0.5, 1.0, 1.0],
            [0.1, 0.37, 0.81],
            [0.33, 0.99, 0.01],
        ] {
            let want = f(&[x[0] as f64, x[1] as f64, x[2] as f64]);
            assert!((s.sample(&x) as f64 - want).abs() < 1e-6, "{x:?}");
        }
        // clamped outside
        assert!((s.sample(&[-1.0, 2.0, 0.5]) as f64 - f(&[0.0, 1.0, 0.5])).abs() < 1e-6);
    }
}
