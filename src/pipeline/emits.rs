//! The reuse cache of emitted fits: `<data-dir>/emit-inputs/<model>/<fit>.json` records what
//! one fit file's emitted code and LUT were made from (the fit file's bytes, its table's
//! sidecar, the languages, the LUT size, the furnace version and the SHA-256 of the running
//! executable, since the emitters and the stress test are code) and the SHA-256 of every file
//! written, or the reason the fit was not emitted. A later run with the same inputs keeps those
//! files (if they are intact) instead of emitting, stress-testing and measuring the fit again.
//! The cache lives under the git-ignored data folder: a fresh clone emits everything once.

use crate::digest::sha256_hex;
use crate::error::Result;
use crate::fit::file as fitfile;
use crate::output;
use crate::table::io;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use super::sweeps::FileHash;

/// What one fit file's emitted files were made from, and what came of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EmitInputs {
    pub what: String,
    pub tool_version: String,
    /// SHA-256 of the executable that emitted (the emitters, the stress test and the f32
    /// interpreter are its code).
    pub executable_sha256: String,
    pub fit_file: FileHash,
    /// SHA-256 of the sidecar of the fit's table in the cache (it holds the values' SHA-256),
    /// if the table is there.
    pub table_sidecar_sha256: Option<String>,
    pub langs: String,
    pub lut_resolution: usize,
    /// The files written (paths as given to the emitter), or why the fit was not emitted.
    pub outcome: EmitOutcome,
}

/// The result of emitting one fit file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EmitOutcome {
    Written(Vec<FileHash>),
    NotEmitted(String),
}

/// SHA-256 of the running executable (computed once), or "unknown" if it cannot be read, in
/// which case nothing is reused.
fn executable_sha256() -> &'static str {
    static HASH: OnceLock<String> = OnceLock::new();
    HASH.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map(|b| sha256_hex(&b))
            .unwrap_or_else(|_| "unknown".into())
    })
}

/// The cache file of the fit file `fit` of model folder `model`.
pub fn cache_path(data_dir: &Path, model: &str, fit: &Path) -> PathBuf {
    let name = fit
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    data_dir.join("emit-inputs").join(model).join(name)
}

/// The inputs of emitting `fit` with `langs` and LUTs of `lut_resolution` per axis (the
/// outcome left empty), or None if the fit file cannot be read (the emitter then says why).
pub fn emit_inputs(
    fit: &Path,
    data_dir: &Path,
    langs: &str,
    lut_resolution: usize,
) -> Option<EmitInputs> {
    let bytes = std::fs::read(fit).ok()?;
    let record = fitfile::read(fit).ok()?;
    let table_sidecar_sha256 = record.table.as_ref().and_then(|t| {
        let sidecar = |stem: &Path| std::fs::read(io::with_ext(stem, "json")).ok();
        let text = sidecar(&t.stem).or_else(|| {
            let model = t.spec.model_id().and_then(crate::bsdf::get).ok()?;
            sidecar(&io::table_stem(data_dir, model.as_ref(), &t.spec))
        })?;
        Some(sha256_hex(&text))
    });
    Some(EmitInputs {
        what: "inputs of the files `furnace run` emitted for this fit file: a run with the same inputs keeps those files (if their SHA-256 still match) instead of emitting again".into(),
        tool_version: crate::VERSION.into(),
        executable_sha256: executable_sha256().into(),
        fit_file: FileHash {
            file: fit.to_string_lossy().replace('\\', "/"),
            sha256: sha256_hex(&bytes),
        },
        table_sidecar_sha256,
        langs: langs.into(),
        lut_resolution,
        outcome: EmitOutcome::NotEmitted(String::new()),
    })
}

/// The outcome of a previous emit with the same inputs, if its files are all intact.
pub fn reusable(
    path: &Path,
    expected: &EmitInputs,
) -> Option<std::result::Result<Vec<PathBuf>, String>> {
    if expected.executable_sha256 == "unknown" {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let found: EmitInputs = serde_json::from_str(&text).ok()?;
    let same = EmitInputs {
        outcome: found.outcome.clone(),
        ..expected.clone()
    };
    if found != same {
        return None;
    }
    match found.outcome {
        EmitOutcome::NotEmitted(why) => Some(Err(why)),
        EmitOutcome::Written(files) => {
            let mut out = Vec::new();
            for f in &files {
                let p = PathBuf::from(&f.file);
                if sha256_hex(&std::fs::read(&p).ok()?) != f.sha256 {
                    return None;
                }
                out.push(p);
            }
            Some(Ok(out))
        }
    }
}

/// Records `inputs` with the outcome of emitting (the files written, hashed now, or why not).
pub fn record(
    path: &Path,
    mut inputs: EmitInputs,
    outcome: std::result::Result<&[PathBuf], String>,
) -> Result<()> {
    inputs.outcome = match outcome {
        Ok(files) => EmitOutcome::Written(
            files
                .iter()
                .map(|p| {
                    Ok(FileHash {
                        file: p.to_string_lossy().replace('\\', "/"),
                        sha256: sha256_hex(
                            &std::fs::read(p).map_err(|e| crate::error::Error::io(p, e))?,
                        ),
                    })
                })
                .collect::<Result<_>>()?,
        ),
        Err(why) => EmitOutcome::NotEmitted(why),
    };
    let json = serde_json::to_string_pretty(&inputs)
        .map_err(|e| crate::error::Error::file(path, e.to_string()))?;
    output::write(path, format!("{json}\n").as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(dir: &Path) -> EmitInputs {
        let fit = dir.join("best-20.json");
        std::fs::write(&fit, b"not a fit file").unwrap();
        EmitInputs {
            what: "test".into(),
            tool_version: crate::VERSION.into(),
            executable_sha256: executable_sha256().into(),
            fit_file: FileHash {
                file: fit.to_string_lossy().into_owned(),
                sha256: sha256_hex(b"not a fit file"),
            },
            table_sidecar_sha256: None,
            langs: "all".into(),
            lut_resolution: 32,
            outcome: EmitOutcome::NotEmitted(String::new()),
        }
    }

    #[test]
    fn a_record_is_reused_only_while_inputs_and_files_are_unchanged() {
        let dir = std::env::temp_dir().join(format!("furnace-emits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("best-20.rs");
        std::fs::write(&out, b"fn f() {}").unwrap();
        let cache = dir.join("cache").join("best-20.json");
        let i = inputs(&dir);
        assert!(reusable(&cache, &i).is_none(), "nothing recorded yet");
        record(&cache, i.clone(), Ok(std::slice::from_ref(&out))).unwrap();
        assert_eq!(reusable(&cache, &i), Some(Ok(vec![out.clone()])));
        // other languages, another LUT size: emitted again
        let mut j = i.clone();
        j.langs = "rust".into();
        assert!(reusable(&cache, &j).is_none());
        j = i.clone();
        j.lut_resolution = 16;
        assert!(reusable(&cache, &j).is_none());
        // a written file that changed: emitted again
        std::fs::write(&out, b"fn g() {}").unwrap();
        assert!(reusable(&cache, &i).is_none());
        // a recorded refusal is replayed
        record(&cache, i.clone(), Err("not proved pole-free".into())).unwrap();
        assert_eq!(
            reusable(&cache, &i),
            Some(Err("not proved pole-free".into()))
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
