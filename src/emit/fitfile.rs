//! Fit files: `fits/<model>/<form>.json`, a [`FitResult`] wrapped with what an emitter needs to
//! trust it — the tool and version that wrote it, the model, the output and (for fits of furnace
//! tables) the table's spec, so LUTs and benchmarks can recompute the same table at any size.
//!
//! ```json
//! { "tool": "furnace", "tool_version": "0.1.0", "model": "ggx-conductor", "output": "E",
//!   "table": { "stem": "data/ggx-conductor/1024x1024", "content_hash": "…", "spec": { … } },
//!   "fit": { "form": …, "approximant": …, "metrics": …, "poles": …, … } }
//! ```
//!
//! [`load`] refuses a file from another furnace version, a file missing any of these fields, and
//! a fit whose denominator is not proved pole-free *now* (the verdict in the file is recomputed,
//! not trusted); each error names the file and the fix.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::fit::{CertifyOptions, FitResult, PoleVerdict};
use crate::table::TableSpec;

/// Where a fit's data came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableRef {
    /// The cached table's path without extension (see `table::io::table_stem`).
    pub stem: PathBuf,
    /// Its content hash (the cache key).
    pub content_hash: String,
    /// Everything that determines its values.
    pub spec: TableSpec,
}

/// A fit file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitFile {
    pub tool: String,
    pub tool_version: String,
    /// Model name (see `furnace models`), or a name of the form `paper-<model>` for coefficients
    /// that did not come from a furnace table.
    pub model: String,
    /// The table output that was fitted (`E`, `E_R`, `E_T`).
    pub output: String,
    /// The table fitted, if it was a furnace table.
    pub table: Option<TableRef>,
    pub fit: FitResult,
}

/// Fields every fit file must have, in the order they are checked.
const REQUIRED: [&str; 5] = ["tool", "tool_version", "model", "output", "fit"];

impl FitFile {
    /// Wraps a fit written by this version of furnace.
    pub fn new(model: &str, output: &str, table: Option<TableRef>, fit: FitResult) -> FitFile {
        FitFile {
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            model: model.into(),
            output: output.into(),
            table,
            fit,
        }
    }

    /// Pretty JSON with a trailing newline (deterministic: the fit's own JSON is).
    pub fn to_json(&self) -> Result<String> {
        let s = serde_json::to_string_pretty(self)
            .map_err(|e| Error::InvalidInput(format!("fit file does not serialise: {e}")))?;
        Ok(format!("{s}\n"))
    }

    /// SHA-256 (hex) of the fit's canonical JSON ([`FitResult::to_json`]): identifies the
    /// coefficients an emitted file was generated from.
    pub fn fit_hash(&self) -> Result<String> {
        let json = self.fit.to_json()?;
        Ok(Sha256::digest(json.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect())
    }

    /// Parses and checks a fit file's text (`path` only names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<FitFile> {
        let value: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| Error::file(path, format!("not valid JSON ({e}); fit files are written by `furnace run --scene` or the fitting commands")))?;
        let obj = value
            .as_object()
            .ok_or_else(|| Error::file(path, "a fit file is a JSON object; this is not one"))?;
        if obj.contains_key("source") && obj.contains_key("fit") && !obj.contains_key("model") {
            return FitFile::from_fit_record(value, path);
        }
        for field in REQUIRED {
            if !obj.contains_key(field) {
                let hint = if obj.contains_key("approximant") {
                    " — this looks like a bare fit result; fit files wrap it as {tool, tool_version, model, output, table, fit}: re-create it with this furnace"
                } else {
                    "; re-create the fit with this furnace"
                };
                return Err(Error::file(path, format!("missing field '{field}'{hint}")));
            }
        }
        if obj["tool"] != "furnace" {
            return Err(Error::file(
                path,
                format!(
                    "written by '{}', not furnace; only furnace fit files can be emitted",
                    obj["tool"]
                ),
            ));
        }
        let version = obj["tool_version"].as_str().unwrap_or("?");
        if version != crate::VERSION {
            return Err(Error::file(
                path,
                format!(
                    "written by furnace {version}, but this is furnace {}; fit files are tied to the version that checked them — re-run the fit with this version (or emit with furnace {version})",
                    crate::VERSION
                ),
            ));
        }
        let file: FitFile = serde_json::from_value(value).map_err(|e| {
            Error::file(
                path,
                format!(
                    "invalid fit file: {e}; re-create it with furnace {}",
                    crate::VERSION
                ),
            )
        })?;
        file.fit
            .approximant
            .validate()
            .map_err(|e| Error::file(path, format!("invalid approximant: {e}")))?;
        if file.fit.approximant.variables.is_empty() {
            return Err(Error::file(path, "the approximant has no variables"));
        }
        Ok(file)
    }

    /// A fit record written by `furnace fit` ([`crate::fit::job::FitRecord`]): its model and
    /// channel come from the record's source; a record that says it is unusable is refused.
    fn from_fit_record(value: serde_json::Value, path: &Path) -> Result<FitFile> {
        let record: crate::fit::job::FitRecord = serde_json::from_value(value).map_err(|e| {
            Error::file(
                path,
                format!(
                    "invalid fit record: {e}; re-create it with furnace {}",
                    crate::VERSION
                ),
            )
        })?;
        if record.tool != "furnace" {
            return Err(Error::file(
                path,
                format!("written by '{}', not furnace", record.tool),
            ));
        }
        if record.tool_version != crate::VERSION {
            return Err(Error::file(
                path,
                format!(
                    "written by furnace {}, but this is furnace {}; re-run the fit with this version",
                    record.tool_version,
                    crate::VERSION
                ),
            ));
        }
        if !record.usable {
            return Err(Error::file(
                path,
                format!(
                    "the fit is not usable: {}; refit (e.g. another degree or --domain)",
                    record.verdict
                ),
            ));
        }
        let model = record
            .source
            .model
            .clone()
            .unwrap_or_else(|| "table".into());
        let file = FitFile::new(&model, &record.source.channel, None, record.fit);
        file.fit
            .approximant
            .validate()
            .map_err(|e| Error::file(path, format!("invalid approximant: {e}")))?;
        Ok(file)
    }

    /// Reads and checks a fit file.
    pub fn read(path: &Path) -> Result<FitFile> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        FitFile::parse(&text, path)
    }

    /// Re-proves that the denominator has no zero on the domain (the file's verdict is not
    /// trusted) and that the fit was finite at every data point; returns the proved lower bound
    /// of |Q| (None for a polynomial).
    pub fn certify(&self, path: &Path) -> Result<Option<f64>> {
        if self.fit.metrics.non_finite > 0 {
            return Err(Error::file(
                path,
                format!("the fit is not finite at {} of its data points; refit it (lower degree or a polynomial) — it cannot be emitted", self.fit.metrics.non_finite),
            ));
        }
        match self.fit.approximant.certify_poles(&CertifyOptions::default()) {
            PoleVerdict::NoDenominator => Ok(None),
            PoleVerdict::Certified { min_lower_bound, .. } => Ok(Some(min_lower_bound)),
            PoleVerdict::PoleFound { at } => Err(Error::file(
                path,
                format!(
                    "uncertified denominator: Q changes sign near {} = {:?}, so the fit has a pole inside its domain; refit it (e.g. a lower denominator degree or a polynomial) — emitted code would divide by zero there",
                    self.fit.approximant.variables.join(", "),
                    at
                ),
            )),
            PoleVerdict::Undecided { reason, .. } => Err(Error::file(
                path,
                format!("uncertified denominator: no proof that Q ≠ 0 on the domain ({reason}); refit it with a denominator bounded away from zero — it cannot be emitted"),
            )),
        }
    }
}

/// Loads a fit file and requires a certified denominator: what `furnace emit` accepts.
pub fn load(path: &Path) -> Result<(FitFile, Option<f64>)> {
    let f = FitFile::read(path)?;
    let q_min = f.certify(path)?;
    Ok((f, q_min))
}
