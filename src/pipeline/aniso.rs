//! The anisotropic conductor's budget fits of `furnace run`: `fits/<model>/best-<N>.json` for
//! each budget of [`crate::fit::aniso::BUDGETS`], fitted by [`crate::fit::aniso::budget_fits`]
//! for the job's table of the model, measured at every node of that table (the fit file's
//! source) and at the table's off-grid check set, and written with `fit-inputs.json` last; a run
//! with the same inputs keeps the files (if they are intact) instead of refitting.

use super::sweeps::{best_errors, best_paths, file_hashes, intact, BestSummary, FileHash};
use super::Job;
use crate::bsdf::{self, ModelId};
use crate::digest::values_sha256;
use crate::error::{Error, Result};
use crate::fit::aniso::{budget_fits, fit_grid, BUDGETS, FIT_VARIABLES, RATIONAL_DEGREES};
use crate::fit::check;
use crate::fit::job::FitRecord;
use crate::fit::metrics::measure;
use crate::fit::source::{self, FittedOn};
use crate::output;
use crate::progress::Observer;
use crate::table::{get_or_tabulate, TableSpec};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// Name of the inputs file in the model's fit folder.
pub const FIT_INPUTS: &str = "fit-inputs.json";

/// The model fitted: the height-correlated anisotropic conductor of the report's section.
pub fn model() -> ModelId {
    crate::material::anisotropic::albedo_model(crate::report::aniso::SMITH)
}

/// `fits/<model>/fit-inputs.json`: what the budget fits were made from. Deterministic: no
/// times, no absolute paths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AnisoFitInputs {
    pub what: String,
    pub tool_version: String,
    /// [`crate::fit::FITTER_VERSION`] of the fitter that wrote the files.
    pub fitter_version: u32,
    /// Cache key of the table's spec ([`TableSpec::content_hash`]).
    pub table_content_hash: String,
    /// SHA-256 of the table's values.
    pub table_values_sha256: String,
    pub budgets: Vec<usize>,
    pub rational_degrees: (u32, u32),
    pub variables: String,
    /// Points per variable of the grid the fits are fitted on.
    pub fit_grid: [usize; 4],
    /// The off-grid check set the fits were measured on.
    pub check_set: String,
    /// Every file written, with its SHA-256.
    pub files: Vec<FileHash>,
}

/// What the step did.
#[derive(Clone, Debug)]
pub struct AnisoFits {
    /// The model's fit folder name.
    pub name: String,
    /// The files of a previous run with the same inputs were kept.
    pub reused: bool,
    /// Each budget's best file, if there is one.
    pub best: Vec<(usize, Option<BestSummary>)>,
    /// Every file, `fit-inputs.json` last.
    pub files: Vec<PathBuf>,
    /// Wall seconds of fitting (None when reused): for the terminal only.
    pub seconds: Option<f64>,
}

impl AnisoFits {
    /// The best files, in budget order (what the emit stage emits).
    pub fn best_files(&self, fits_dir: &std::path::Path) -> Vec<PathBuf> {
        best_paths(&fits_dir.join(&self.name), &self.best)
    }
}

/// The budget fits of [`model`] on its table of `resolution` nodes per axis (tabulated into the
/// job's data folder if missing), or the files of a previous run with the same inputs (unless
/// the job refits).
pub fn fits_or_reuse(
    job: &Job,
    resolution: &[usize],
    progress: &dyn Observer,
) -> Result<AnisoFits> {
    let id = model();
    let name = id.key();
    let model = bsdf::get(id)?;
    let spec = TableSpec::new(model.as_ref(), resolution, job.quadrature.clone())?;
    let t = get_or_tabulate(model.as_ref(), &spec, &job.data_dir, job.force, progress)?;
    let check = check::get_or_compute(model.as_ref(), &t.table.spec, &t.stem)?;
    let dir = job.fits_dir.join(&name);
    let mut inputs = AnisoFitInputs {
        what: "inputs of the best fits in this folder, written by `furnace run` after them: a run whose table values and fit options are the same keeps the files listed here (if their SHA-256 still match) instead of refitting; `furnace run --refit` refits".into(),
        tool_version: crate::VERSION.into(),
        fitter_version: crate::fit::FITTER_VERSION,
        table_content_hash: t.table.spec.content_hash(),
        table_values_sha256: values_sha256(&t.table.values),
        budgets: BUDGETS.to_vec(),
        rational_degrees: RATIONAL_DEGREES,
        variables: FIT_VARIABLES.into(),
        fit_grid: fit_grid(resolution),
        check_set: check.description(),
        files: Vec::new(),
    };
    let key = dir.join(FIT_INPUTS);
    if !(job.refit || job.force) {
        let found = std::fs::read_to_string(&key)
            .ok()
            .and_then(|text| serde_json::from_str::<AnisoFitInputs>(&text).ok());
        if let Some(found) = found {
            let same = AnisoFitInputs {
                files: found.files.clone(),
                ..inputs.clone()
            };
            if found == same {
                if let Some(mut files) = intact(&dir, &found.files) {
                    files.push(key);
                    return Ok(AnisoFits {
                        best: best_errors(&dir, &BUDGETS)?,
                        name,
                        reused: true,
                        files,
                        seconds: None,
                    });
                }
            }
        }
    }
    let start = Instant::now();
    let fitted = budget_fits(model.as_ref(), &t.table)?.ok_or_else(|| {
        Error::InvalidInput(format!("{name}: its axes have no layer variable to fit in"))
    })?;
    let input = source::from_table(&t.table, "E", Some(&t.stem))?;
    let check_data = check.data()?;
    let check_on = check.description();
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut files = Vec::new();
    for budget in BUDGETS {
        let path = dir.join(format!("best-{budget}.json"));
        let Some(b) = fitted.fits.iter().find(|f| f.budget == budget) else {
            // no certified fit under this budget: no stale file either
            if path.exists() {
                std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            }
            continue;
        };
        let mut fit = b.fit.clone();
        fit.metrics = measure(&fit.approximant, &input.data);
        let on = FittedOn {
            points: fitted.points,
            selection: fitted.selection(),
        };
        let record = FitRecord::new(fit, &input, on).with_off_grid(Some((&check_data, &check_on)));
        output::write(&path, record.to_json()?.as_bytes())?;
        files.push(path);
    }
    inputs.files = file_hashes(&files)?;
    let json =
        serde_json::to_string_pretty(&inputs).map_err(|e| Error::file(&key, e.to_string()))?;
    // written last: it commits the fit files
    output::write(&key, format!("{json}\n").as_bytes())?;
    files.push(key);
    Ok(AnisoFits {
        best: best_errors(&dir, &BUDGETS)?,
        name,
        reused: false,
        files,
        seconds: Some(start.elapsed().as_secs_f64()),
    })
}
