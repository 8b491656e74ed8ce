//! The digest of everything a section reads, and whether a written section can be reused.

use super::data::subsample_lut;
use super::{Dependency, ModelSummary, ReportOptions, Reporter};
use crate::bsdf::{self, ModelId};
use crate::digest::{sha256_hex, values_sha256};
use crate::error::{Error, Result};
use crate::report::inputs::paper_link;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The revision of what a section computes from its inputs, part of their digest: raised when
/// the same inputs give other numbers (2: furnace's fits evaluated as their emitted code, E
/// clamped to [0, 1]; 3: the fits of radiance-form tables, never emitted, measured as fitted),
/// so that no section written by an earlier revision is reused.
pub const REPORT_REVISION: u32 = 3;

impl Reporter<'_> {
    /// SHA-256 of everything a section computed from `deps` reads: the report options, the
    /// furnace version, and per model its report table's and LUT's values, every file under its
    /// fits folder, and the paper's files for it.
    pub fn inputs_digest(&self, deps: &[Dependency]) -> Result<String> {
        let o = &self.options;
        let mut text = format!(
            "furnace {} report {}\nresolution {} {} lut {} {} furnace luts {:?} nodes {} f0 slices {} spheres {:?} f0 {} paper {}\n",
            crate::VERSION,
            REPORT_REVISION,
            o.resolution_2d,
            o.resolution_3d,
            o.lut_2d,
            o.lut_3d,
            o.furnace_luts,
            o.furnace_nodes,
            o.furnace_f0_slices,
            o.sphere_roughness,
            o.sphere_f0,
            o.paper_dir.is_some()
        );
        for d in deps {
            let id = d.id()?;
            let model = bsdf::get(id)?;
            let dims = model.axes().len();
            let table = self
                .tables
                .table(model.as_ref(), &self.options.resolution(dims))
                .map_err(|e| e.for_option(ReportOptions::resolution_option(dims)))?;
            let _ = writeln!(
                text,
                "model {} table {} {}",
                model.id().key(),
                table.spec.resolution_name(),
                values_sha256(&table.values)
            );
            if subsample_lut(&table, self.options.lut(dims)).is_none() {
                let lut = self
                    .tables
                    .table(model.as_ref(), &vec![self.options.lut(dims); dims])
                    .map_err(|e| e.for_option(ReportOptions::lut_option(dims)))?;
                let _ = writeln!(text, "lut {}", values_sha256(&lut.values));
            }
            for &n in &self.options.furnace_luts {
                if n != self.options.lut(dims) {
                    let lut = self.tables.table(model.as_ref(), &vec![n; dims])?;
                    let _ = writeln!(text, "lut {n} {}", values_sha256(&lut.values));
                }
            }
            let dir = self.options.fits_dir.join(model.id().key());
            for (rel, sha) in files_digest(&dir)? {
                let _ = writeln!(text, "fit {rel} {sha}");
            }
            if let (Some(paper), Some(link)) = (&self.options.paper_dir, paper_link(id)) {
                if link.model == id {
                    for sub in ["coefficients", "tables"] {
                        let p = paper.join(sub).join(format!("{}.csv", link.stem));
                        let sha = std::fs::read(&p)
                            .map(|b| sha256_hex(&b))
                            .unwrap_or_else(|_| "missing".into());
                        let _ = writeln!(text, "paper {sub} {sha}");
                    }
                }
            }
        }
        Ok(sha256_hex(text.as_bytes()))
    }

    /// The summary of `reports/<name>/` if it was made from the same inputs as now and its
    /// files are intact (their SHA-256 as recorded), so that it need not be regenerated.
    pub fn reusable_section(&self, id: ModelId) -> Result<Option<ModelSummary>> {
        let name = id.key();
        let path = self.model_dir(&name).join("summary.json");
        let Ok(text) = std::fs::read_to_string(&path) else {
            return Ok(None);
        };
        let Ok(summary) = serde_json::from_str::<ModelSummary>(&text) else {
            return Ok(None);
        };
        if summary.model != name || summary.dependencies.is_empty() || summary.outputs.is_empty() {
            return Ok(None);
        }
        for f in &summary.outputs {
            match std::fs::read(self.options.reports_dir.join(&f.file)) {
                Ok(bytes) if sha256_hex(&bytes) == f.sha256 => {}
                _ => return Ok(None),
            }
        }
        if self.inputs_digest(&summary.dependencies)? != summary.inputs_sha256 {
            return Ok(None);
        }
        Ok(Some(summary))
    }
}

/// (path relative to `dir`, SHA-256) of every file under `dir`, recursively, sorted; none if
/// `dir` does not exist.
fn files_digest(dir: &Path) -> Result<Vec<(String, String)>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, String)>) -> Result<()> {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return Ok(());
        };
        let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        for p in paths {
            if p.is_dir() {
                walk(root, &p, out)?;
            } else if p.extension().is_some_and(|e| e == "json") {
                let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
                out.push((
                    p.strip_prefix(root)
                        .unwrap_or(&p)
                        .to_string_lossy()
                        .replace('\\', "/"),
                    sha256_hex(&bytes),
                ));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    Ok(out)
}
