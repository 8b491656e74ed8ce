//! Fit files: the one format of every fit furnace writes (`furnace fit`, the sweeps of
//! `furnace run`, a scene's fits) and reads (`emit`, `eval --fit`, `stress`, `bench eval`): a
//! [`FitRecord`] as pretty JSON. The layout is documented in `docs/fitting.md` ("Fit files").
//!
//! [`read`] parses a file and checks that it is one furnace can trust: written by this furnace
//! version, every field present, a valid approximant with distinct variables, and — when it
//! names a model or a table — variables, output and domain that agree with them. [`load`] also
//! proves again that the fit has no pole on its domain and was finite at every data point (the
//! verdict stored in the file is recomputed, not trusted): what `emit`, `eval --fit` and
//! `stress` accept. Every error names the file and the fix.

use std::path::Path;

use super::job::FitRecord;
use super::{CertifyOptions, PoleVerdict};
use crate::bsdf;
use crate::error::{Error, Result};

pub use super::source::TableRef;

/// Top-level fields every fit file has, in the order they are checked.
const REQUIRED: [&str; 9] = [
    "tool",
    "tool_version",
    "usable",
    "verdict",
    "warnings",
    "source",
    "fitted_on",
    "metrics_on",
    "fit",
];

/// Reads and checks a fit file (not its poles: see [`load`]).
pub fn read(path: &Path) -> Result<FitRecord> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text, path)
}

/// Parses and checks a fit file's text; `path` only names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<FitRecord> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        Error::file(path, format!("not valid JSON ({e}); fit files are written by `furnace fit`, `furnace run` and `furnace run --scene`"))
    })?;
    let obj = value
        .as_object()
        .ok_or_else(|| Error::file(path, "a fit file is a JSON object; this is not one"))?;
    if obj.contains_key("approximant") && !obj.contains_key("fit") {
        return Err(Error::file(path, "this looks like a bare fit result (FitResult::to_json); fit files wrap it with its provenance (see docs/fitting.md, \"Fit files\"): write it with `furnace fit`"));
    }
    for field in REQUIRED {
        if !obj.contains_key(field) {
            return Err(Error::file(
                path,
                format!(
                    "not a furnace fit file: the field '{field}' is missing (the layout is in docs/fitting.md, \"Fit files\"); write fit files with `furnace fit` (furnace {})",
                    crate::VERSION
                ),
            ));
        }
    }
    if obj["tool"] != "furnace" {
        return Err(Error::file(
            path,
            format!(
                "written by {}, not furnace; only furnace fit files can be read",
                obj["tool"]
            ),
        ));
    }
    let version = obj["tool_version"].as_str().unwrap_or("?");
    if version != crate::VERSION {
        return Err(Error::file(
            path,
            format!(
                "written by furnace {version}, but this is furnace {}; fit files are tied to the version that checked them — re-run the fit with this version (or use furnace {version})",
                crate::VERSION
            ),
        ));
    }
    let record: FitRecord = serde_json::from_value(value).map_err(|e| {
        Error::file(
            path,
            format!(
                "invalid fit file: {e}; re-create it with furnace {}",
                crate::VERSION
            ),
        )
    })?;
    check(&record).map_err(|m| Error::file(path, m))?;
    Ok(record)
}

/// A fit file that passed [`load`]: checked, and its denominator proved pole-free now.
#[derive(Clone, Debug)]
pub struct Checked {
    pub record: FitRecord,
    /// The proved lower bound of |Q| on the domain (None for a polynomial).
    pub q_min: Option<f64>,
}

/// Reads a fit file and proves it usable: what `emit`, `eval --fit` and `stress` accept.
pub fn load(path: &Path) -> Result<Checked> {
    let record = read(path)?;
    let q_min = certify(&record, path)?;
    Ok(Checked { record, q_min })
}

/// Two variable names the emitted code could not tell apart: the same text, or the same once
/// letters are lowered and other characters mapped to `_` (`F0` and `f0`).
fn same_identifier(a: &str, b: &str) -> bool {
    let norm = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_lowercase()
                } else {
                    '_'
                }
            })
            .collect()
    };
    norm(a) == norm(b)
}

/// The consistency of a record with itself, its table and its model; the message says what
/// disagrees and how to fix it.
pub fn check(record: &FitRecord) -> std::result::Result<(), String> {
    let a = &record.fit.approximant;
    a.validate()
        .map_err(|e| format!("invalid approximant: {e}"))?;
    if a.variables.is_empty() {
        return Err("the approximant has no variables".into());
    }
    for (i, v) in a.variables.iter().enumerate() {
        if let Some(w) = a.variables[..i].iter().find(|w| same_identifier(w, v)) {
            let how = if w == v {
                format!("'{v}' appears twice")
            } else {
                format!("'{w}' and '{v}' name the same argument")
            };
            return Err(format!(
                "duplicate variables: {how} in [{}]; every variable of a fit must be distinct — re-create the fit",
                a.variables.join(", ")
            ));
        }
    }
    let output = &record.source.channel;
    if let Some(t) = &record.table {
        if record.source.model.as_deref() != Some(t.spec.model.as_str()) {
            return Err(format!(
                "model mismatch: source.model is {} but the fitted table is of {}; re-create the fit",
                record.source.model.as_deref().unwrap_or("(none)"),
                t.spec.model
            ));
        }
        let axes: Vec<&str> = t.spec.axes.iter().map(|x| x.name.as_str()).collect();
        if !names_match(&a.variables, &axes) {
            return Err(format!(
                "variables/table mismatch: the fit's variables are [{}] but its table's axes are [{}]; re-create the fit",
                a.variables.join(", "),
                axes.join(", ")
            ));
        }
        if !t.spec.outputs.iter().any(|o| o == output) {
            return Err(format!(
                "the fitted output '{output}' is not an output of its table ({}); re-create the fit",
                t.spec.outputs.join(", ")
            ));
        }
        for ((v, &(lo, hi)), ax) in a.variables.iter().zip(&a.domain).zip(&t.spec.axes) {
            if lo < ax.lo || hi > ax.hi {
                return Err(format!(
                    "the fit's domain of {v}, [{lo}, {hi}], reaches outside its table's [{}, {}]; re-create the fit",
                    ax.lo, ax.hi
                ));
            }
        }
    }
    if let Some(name) = &record.source.model {
        let model = bsdf::find(name).map_err(|e| {
            format!("{e}; a fit of a furnace model names one of them in source.model, a fit of a user's table none — fix the field or re-create the fit")
        })?;
        check_model(record, model.as_ref())?;
    }
    Ok(())
}

/// The fit's variables are the model's axes in order, its output one of the model's and its
/// domain inside the model's valid ranges.
pub fn check_model(record: &FitRecord, model: &dyn bsdf::Model) -> std::result::Result<(), String> {
    let a = &record.fit.approximant;
    let axes = model.axes();
    let names: Vec<&str> = axes.iter().map(|x| x.name.as_str()).collect();
    if !names_match(&a.variables, &names) {
        let unknown: Vec<&String> = a
            .variables
            .iter()
            .filter(|v| !names.iter().any(|n| same_identifier(n, v)))
            .collect();
        let detail = if unknown.is_empty() {
            String::new()
        } else {
            format!(
                " ({} not an axis of {})",
                unknown
                    .iter()
                    .map(|v| format!("'{v}'"))
                    .collect::<Vec<_>>()
                    .join(", "),
                model.id().name()
            )
        };
        return Err(format!(
            "model/variables mismatch: {} has the axes [{}] but the fit's variables are [{}]{detail}; a fit of {} must use its axes in this order — re-create the fit",
            model.id().name(),
            names.join(", "),
            a.variables.join(", "),
            model.id().name()
        ));
    }
    let output = &record.source.channel;
    if !model.outputs().contains(&output.as_str()) {
        return Err(format!(
            "model/output mismatch: {} has the outputs {} but the fit is of '{output}'; re-create the fit",
            model.id().name(),
            model.outputs().join(", ")
        ));
    }
    for ((v, &(lo, hi)), ax) in a.variables.iter().zip(&a.domain).zip(&axes) {
        let (vlo, vhi) = ax.valid_range;
        if lo < vlo || hi > vhi {
            return Err(format!(
                "the fit's domain of {v}, [{lo}, {hi}], reaches outside the valid range [{vlo}, {vhi}] of {}; re-create the fit",
                model.id().name()
            ));
        }
    }
    Ok(())
}

fn names_match(variables: &[String], axes: &[&str]) -> bool {
    variables.len() == axes.len()
        && variables
            .iter()
            .zip(axes)
            .all(|(v, a)| same_identifier(v, a))
}

/// Proves again that the fit has no pole on its domain and was finite at every data point; the
/// proved lower bound of |Q| (None for a polynomial).
pub fn certify(record: &FitRecord, path: &Path) -> Result<Option<f64>> {
    let fit = &record.fit;
    if fit.metrics.non_finite > 0 {
        return Err(Error::file(
            path,
            format!("the fit is not finite at {} of its data points; refit it (a lower degree or a polynomial) — it cannot be used", fit.metrics.non_finite),
        ));
    }
    match fit.approximant.certify_poles(&CertifyOptions::default()) {
        PoleVerdict::NoDenominator => Ok(None),
        PoleVerdict::Certified { min_lower_bound, .. } => Ok(Some(min_lower_bound)),
        PoleVerdict::PoleFound { at } => Err(Error::file(
            path,
            format!(
                "uncertified denominator: Q changes sign near {} = {:?}, so the fit has a pole inside its domain; refit it (e.g. a lower denominator degree or a polynomial) — its values there are meaningless",
                fit.approximant.variables.join(", "),
                at
            ),
        )),
        PoleVerdict::Undecided { reason, .. } => Err(Error::file(
            path,
            format!("uncertified denominator: no proof that Q ≠ 0 on the domain ({reason}); refit it with a denominator bounded away from zero"),
        )),
    }
}

/// SHA-256 (hex) of the fit's canonical JSON ([`super::FitResult::to_json`]): identifies the
/// coefficients an emitted file was generated from.
pub fn fit_hash(record: &FitRecord) -> Result<String> {
    let json = record.fit.to_json()?;
    Ok(crate::digest::sha256_hex(json.as_bytes()))
}

/// The name a fit's emitted functions start with: its model, or for a user's table the table
/// file's name (`my_measurements.csv` → `my_measurements`), or `table` if it has none.
pub fn subject_name(record: &FitRecord) -> String {
    if let Some(m) = &record.source.model {
        return m.clone();
    }
    record
        .source
        .path
        .as_deref()
        .map(Path::new)
        .and_then(Path::file_stem)
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "table".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers_that_collide() {
        assert!(same_identifier("F0", "f0"));
        assert!(same_identifier("r", "r"));
        assert!(same_identifier("mu-o", "mu_o"));
        assert!(!same_identifier("mu", "r"));
    }
}
