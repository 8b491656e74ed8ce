//! Exports: furnace's albedos in the exact layouts other renderers already read.
//!
//! * [`cycles`]: Blender Cycles' `shader.tables` — the eight GGX arrays (`table_ggx_E`,
//!   `table_ggx_Eavg`, the entering and leaving glass tables and their averages, the two
//!   generalised-Schlick tables) with Cycles' names, sizes, node placement, f32 parametrisation,
//!   edge conventions, saturation and 6-decimal print; optionally spliced into Cycles' own file.
//! * [`filament`]: the split-sum DFG table of Filament (and the sizes Godot and three.js use),
//!   in Filament's texel placement and GL row order, as RG16F or RG32F, as Filament's `dfg.inc`,
//!   C++ or JavaScript source, or raw little-endian binary with a JSON header beside it.
//! * [`generic`]: any model on any grid, as furnace's own table files (EXR, exact f64, JSON).
//!
//! Every value is furnace's quadrature at the peer's nodes, refined to the tolerance (1e-7 by
//! default); every export states in its header the tool and version, the exact definition of
//! each table, and its largest per-cell error estimate. Everything is computed in memory before
//! anything is written; [`write`] refuses to replace a file furnace did not write.

pub mod cycles;
pub mod filament;
pub mod generic;

use crate::bsdf::{self, Model, ModelId};
use crate::error::{Error, Result};
use crate::quadrature::QuadratureSettings;
use crate::table::{self, io, GridAxis, Table, TableSpec};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The line every text export starts its header with, and [`write`] looks for before replacing
/// an existing file.
pub const MARKER: &str = "Written by furnace export";

/// How far into an existing file [`write`] looks for [`MARKER`].
const MARKER_WINDOW: usize = 4096;

/// One table an export holds, as its header reports it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TableReport {
    /// The peer's name for it (`table_ggx_E`, `DFG`).
    pub name: String,
    /// What each value is, exactly.
    pub definition: String,
    pub cells: usize,
    /// Largest per-cell quadrature error estimate.
    pub max_error_estimate: f64,
    /// Cells whose estimate stayed above the tolerance.
    pub unconverged: usize,
    /// Wall time to compute (or read from the cache), in seconds.
    pub seconds: f64,
}

/// A file to write: where, and its bytes.
#[derive(Clone, Debug)]
pub struct OutputFile {
    pub path: PathBuf,
    pub bytes: Vec<u8>,
}

/// The result of an export, in memory.
#[derive(Clone, Debug)]
pub enum Files {
    /// Files whose bytes are ready.
    Bytes(Vec<OutputFile>),
    /// A furnace table to save at a stem, with its definition ([`io::save_described`]).
    Table(Box<Table>, PathBuf, String),
}

/// An export: its files and the tables in it.
#[derive(Clone, Debug)]
pub struct Export {
    pub files: Files,
    pub tables: Vec<TableReport>,
    /// May the output replace this file even though furnace did not write it (the Cycles file
    /// an export is spliced into)?
    pub replaceable: Option<PathBuf>,
}

impl Export {
    /// The paths the export writes.
    pub fn paths(&self) -> Vec<PathBuf> {
        match &self.files {
            Files::Bytes(f) => f.iter().map(|f| f.path.clone()).collect(),
            Files::Table(_, stem, _) => io::files(stem).to_vec(),
        }
    }

    /// The largest error estimate of any table in it.
    pub fn max_error_estimate(&self) -> f64 {
        self.tables
            .iter()
            .map(|t| t.max_error_estimate)
            .fold(0.0, f64::max)
    }
}

/// Where tables are computed: the quadrature settings and the cache folder (none: compute).
#[derive(Clone, Debug)]
pub struct Compute {
    pub quadrature: QuadratureSettings,
    pub data_dir: Option<PathBuf>,
}

impl Compute {
    /// `model` tabulated on `axes`: from the table cache ([`table::get_or_tabulate`], which
    /// saves what it computes) when there is one, else computed.
    pub fn table(&self, model: ModelId, axes: Vec<GridAxis>) -> Result<(Table, f64)> {
        let model = bsdf::get(model)?;
        let spec = TableSpec::with_axes(model.as_ref(), axes, self.quadrature.clone())?;
        match &self.data_dir {
            Some(dir) => {
                let t = table::get_or_tabulate(
                    model.as_ref(),
                    &spec,
                    dir,
                    false,
                    &crate::progress::Quiet,
                )?;
                Ok((t.table, t.seconds))
            }
            None => {
                let start = Instant::now();
                let t = table::tabulate(model.as_ref(), &spec, &|_| {})?;
                Ok((t, start.elapsed().as_secs_f64()))
            }
        }
    }
}

/// The report of `table` under `name`.
pub fn report(name: &str, definition: String, table: &Table, seconds: f64) -> TableReport {
    TableReport {
        name: name.into(),
        definition,
        cells: table.cells(),
        max_error_estimate: table.summary.max_error_estimate,
        unconverged: table.summary.unconverged_cells,
        seconds,
    }
}

/// The model's one-line summary, as a definition.
pub fn model_definition(model: &dyn Model) -> String {
    format!("furnace model {}: {}", model.id().key(), model.summary())
}

/// Whether an existing file at `path` may be replaced: a file whose header carries
/// [`MARKER`], a binary export whose JSON header (`<path>.json`) says furnace wrote exactly
/// these bytes, a furnace table file, or `allowed`.
fn written_by_furnace(path: &Path, allowed: Option<&Path>) -> Result<bool> {
    if let Some(a) = allowed {
        if same_file(path, a) {
            return Ok(true);
        }
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let head = &bytes[..bytes.len().min(MARKER_WINDOW)];
    if String::from_utf8_lossy(head).contains(MARKER) {
        return Ok(true);
    }
    if let Some(header) = read_json(&sidecar_path(path)) {
        let sha: String = Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        if header.get("tool").and_then(|t| t.as_str()) == Some("furnace")
            && header.get("sha256").and_then(|t| t.as_str()) == Some(sha.as_str())
        {
            return Ok(true);
        }
    }
    // a furnace table: its JSON sidecar (the file itself, or beside an .exr / .f64)
    let json = if path.extension().is_some_and(|e| e == "json") {
        path.to_path_buf()
    } else {
        path.with_extension("json")
    };
    Ok(read_json(&json).is_some_and(|j| {
        j.get("tool").and_then(|t| t.as_str()) == Some("furnace") && j.get("content_hash").is_some()
    }))
}

fn read_json(path: &Path) -> Option<serde_json::Value> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// `<path>.json`: the JSON header of a binary export.
pub fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Refuses, before anything is computed or written, every target that is a folder, or an
/// existing regular file furnace did not write (`replaceable` excepted).
pub fn check_paths(paths: &[PathBuf], replaceable: Option<&Path>) -> Result<()> {
    for path in paths {
        let Ok(meta) = std::fs::metadata(path) else {
            continue; // nothing there (or a dangling link, whose target is created)
        };
        if meta.is_dir() {
            return Err(Error::file(path, "is a folder; give --output a file name"));
        }
        if meta.is_file() && !written_by_furnace(path, replaceable)? {
            return Err(Error::file(
                path,
                "exists and was not written by furnace export; remove it or choose another --output",
            ));
        }
    }
    Ok(())
}

/// [`check_paths`] for the files of `export`.
pub fn check_targets(export: &Export) -> Result<()> {
    check_paths(&export.paths(), export.replaceable.as_deref())
}

/// Writes an export: checks every target first ([`check_targets`]), then each file through
/// [`crate::output::write`] (a temporary file renamed over the target, devices and FIFOs in
/// place, links followed and kept), so that no file is ever half written and nothing is written
/// when a target is refused.
pub fn write(export: &Export) -> Result<()> {
    check_targets(export)?;
    match &export.files {
        Files::Bytes(files) => {
            for f in files {
                crate::output::write(&f.path, &f.bytes)?;
            }
            Ok(())
        }
        Files::Table(table, stem, definition) => {
            io::save_described(table, stem, Some(definition)).map(|_| ())
        }
    }
}

/// The comment block of a text export: the marker line, then `lines`, each prefixed.
pub fn header_lines(prefix: &str, command: &str, lines: &[String]) -> String {
    let mut s = format!("{prefix}{MARKER} {} ({command}).\n", crate::VERSION);
    for l in lines {
        if l.is_empty() {
            s.push_str(prefix.trim_end());
            s.push('\n');
        } else {
            s.push_str(prefix);
            s.push_str(l);
            s.push('\n');
        }
    }
    s
}

/// `v` formatted for a header: `4.1e-8`.
pub fn fmt_error(v: f64) -> String {
    format!("{v:.1e}")
}
