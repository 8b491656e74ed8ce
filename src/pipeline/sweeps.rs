//! The reuse cache of degree sweeps: `fits/<model>/sweep-inputs.json` records what a sweep was
//! made from (the table's values, the sweep options, the furnace version) and the SHA-256 of
//! every file it wrote; a later run with the same inputs reuses those files instead of refitting.

use crate::bsdf::Model;
use crate::digest::{sha256_hex, values_sha256};
use crate::error::{Error, Result};
use crate::fit::check::{self, CheckSet};
use crate::fit::defaults::default_plan;
use crate::fit::job::{self, FitRecord, Stopwatch, SweepOutcome, SweepPlan, Timing};
use crate::fit::{source, Objective};
use crate::output;
use crate::progress::Observer;
use crate::report::model::fmt_e;
use crate::table::Tabulated;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What the fit step did for one model.
#[derive(Clone, Debug, Default)]
pub struct FitStep {
    /// The files of a previous sweep with the same inputs were kept.
    pub reused: bool,
    /// Each budget's best file, if the sweep has one.
    pub best: Vec<(usize, Option<BestSummary>)>,
    /// The table's off-grid check set (None for a model without one).
    pub check: Option<CheckSet>,
    /// Every file of the sweep, `sweep-inputs.json` last.
    pub files: Vec<PathBuf>,
    /// Fits not usable or skipped, if any.
    pub note: Option<String>,
    /// Wall and CPU seconds of the sweep (fits, their metrics, the best fits' stress tests and
    /// the files; None when reused): for the terminal only, never written under `fits/`.
    pub seconds: Option<(f64, Option<f64>)>,
}

/// The headline errors of a `best-<N>.json` (off-grid when measured, see [`FitRecord::headline`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BestSummary {
    pub n_coefficients: usize,
    pub max_abs_error: f64,
    pub mae: f64,
    /// Measured at the off-grid check points (else at the table nodes).
    pub off_grid: bool,
    /// The form, `rational of degree 4/4 [r² layer(μ; r, 1)] (minimax)`.
    pub label: String,
}

/// `best-20 max 1.16e-3 MAE 5.91e-4, best-40 none, …`: each budget's headline errors.
pub fn best_line(best: &[(usize, Option<BestSummary>)]) -> String {
    best.iter()
        .map(|(b, e)| {
            format!(
                "best-{b} {}",
                e.as_ref().map_or("none".into(), |s| format!(
                    "max {} MAE {}",
                    fmt_e(s.max_abs_error),
                    fmt_e(s.mae)
                ))
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The files `dir/best-<N>.json` of the budgets that have a best fit, in budget order.
pub fn best_paths(dir: &Path, best: &[(usize, Option<BestSummary>)]) -> Vec<PathBuf> {
    best.iter()
        .filter(|b| b.1.is_some())
        .map(|(b, _)| dir.join(format!("best-{b}.json")))
        .collect()
}

impl BestSummary {
    pub fn of(rec: &FitRecord) -> BestSummary {
        let (max_abs_error, mae) = rec.headline();
        let a = &rec.fit.approximant;
        BestSummary {
            n_coefficients: rec.fit.n_coefficients,
            max_abs_error,
            mae,
            off_grid: rec.off_grid.is_some(),
            label: format!(
                "{} [{}] {}",
                rec.fit.form.label(),
                a.transforms
                    .iter()
                    .map(|t| t.label(&a.variables))
                    .collect::<Vec<_>>()
                    .join(" "),
                job::objective_name(rec.fit.objective)
            ),
        }
    }
}

/// `fits/<model>/sweep-inputs.json`: what a sweep was made from, so that a re-run with the same
/// inputs reuses its files. Deterministic: no times, no absolute paths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepInputs {
    pub what: String,
    pub tool: String,
    pub tool_version: String,
    /// [`crate::fit::FITTER_VERSION`] of the fitter that wrote the files.
    #[serde(default)]
    pub fitter_version: u32,
    /// The table's cache stem as given to `furnace run` (relative to the working folder).
    pub table_stem: String,
    /// Cache key of the table's spec ([`TableSpec::content_hash`]).
    pub table_content_hash: String,
    /// SHA-256 of the table's values (little-endian f64, every output in turn).
    pub table_values_sha256: String,
    pub channel: String,
    /// The sweep options (degrees, transforms, objective, points, budgets).
    pub plan: SweepPlan,
    /// The off-grid check set the fits were measured on (count, layers, version).
    pub check_set: Option<String>,
    /// Every file the sweep wrote, with its SHA-256.
    pub files: Vec<FileHash>,
}

/// A file a sweep wrote, with its SHA-256.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileHash {
    pub file: String,
    pub sha256: String,
}

/// Name of the sweep-inputs file in each model's fit folder.
const SWEEP_INPUTS: &str = crate::report::inputs::SWEEP_INPUTS_FILE;

fn sweep_inputs(t: &Tabulated, plan: &SweepPlan, check: Option<&CheckSet>) -> SweepInputs {
    SweepInputs {
        what: "inputs of the sweep files in this folder, written by `furnace run` after them: a run whose table values and sweep options are the same reuses the files listed here (if their SHA-256 still match) instead of refitting; `furnace run --refit` refits".into(),
        tool: "furnace".into(),
        tool_version: crate::VERSION.into(),
        fitter_version: crate::fit::FITTER_VERSION,
        table_stem: t.stem.to_string_lossy().replace('\\', "/"),
        table_content_hash: t.table.spec.content_hash(),
        table_values_sha256: values_sha256(&t.table.values),
        channel: "E".into(),
        plan: plan.clone(),
        check_set: check.map(CheckSet::description),
        files: Vec::new(),
    }
}

/// The files of a previous sweep with the same inputs, if they are all intact.
fn reusable(dir: &Path, expected: &SweepInputs) -> Option<Vec<PathBuf>> {
    let text = std::fs::read_to_string(dir.join(SWEEP_INPUTS)).ok()?;
    let found: SweepInputs = serde_json::from_str(&text).ok()?;
    let same = SweepInputs {
        files: found.files.clone(),
        ..expected.clone()
    };
    if found != same {
        return None;
    }
    intact(dir, &found.files)
}

/// The paths of `files` under `dir` if each still has its SHA-256 and no other `best-*.json`
/// is there (a best file the step did not write would be a stale one).
fn intact(dir: &Path, files: &[FileHash]) -> Option<Vec<PathBuf>> {
    let mut paths = Vec::new();
    for f in files {
        let p = dir.join(&f.file);
        let bytes = std::fs::read(&p).ok()?;
        if sha256_hex(&bytes) != f.sha256 {
            return None;
        }
        paths.push(p);
    }
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        if n.starts_with("best-") && n.ends_with(".json") && !files.iter().any(|f| f.file == n) {
            return None;
        }
    }
    Some(paths)
}

/// Each file's name and SHA-256.
fn file_hashes(files: &[PathBuf]) -> Result<Vec<FileHash>> {
    files
        .iter()
        .map(|p| {
            let bytes = std::fs::read(p).map_err(|e| Error::io(p, e))?;
            Ok(FileHash {
                file: p
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                sha256: sha256_hex(&bytes),
            })
        })
        .collect()
}

/// The headline errors of each best file of a sweep folder.
fn best_errors(dir: &Path, budgets: &[usize]) -> Result<Vec<(usize, Option<BestSummary>)>> {
    budgets
        .iter()
        .map(|&b| {
            let p = dir.join(format!("best-{b}.json"));
            if !p.is_file() {
                return Ok((b, None));
            }
            let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
            let rec = FitRecord::from_json(&text).map_err(|e| {
                Error::file(
                    &p,
                    format!("not a fit file ({e}); delete it or run with --refit"),
                )
            })?;
            Ok((b, Some(BestSummary::of(&rec))))
        })
        .collect()
}

/// Where a sweep writes, and whether it may reuse a previous one.
#[derive(Clone, Copy, Debug)]
pub struct SweepPlace<'a> {
    /// The sweep's folder (`fits/<model>`).
    pub dir: &'a Path,
    /// Where `sweep-timing.json` goes (`data/timing/<model>`).
    pub timing: &'a Path,
    /// Highest degree (default: the paper's).
    pub max_degree: Option<u32>,
    /// Redo the sweep even when its inputs are unchanged.
    pub refit: bool,
}

/// The degree sweep of `t`'s table into `place.dir`, or the files of a previous sweep with the
/// same inputs (unless `place.refit`).
pub fn sweep_or_reuse(
    model: &dyn Model,
    t: &Tabulated,
    place: SweepPlace,
    progress: &dyn Observer,
) -> Result<FitStep> {
    let name = model.id().key();
    let input = source::from_table(&t.table, "E", Some(&t.stem))?;
    let plan = default_plan(
        &input.data,
        place.max_degree,
        None,
        Objective::LeastSquares,
        model.grazing_boundary_layer(),
    );
    plan.validate(&input.data)?;
    let check = check::get_or_compute(model, &t.table.spec, &t.stem)?;
    let dir = place.dir;
    let mut inputs = sweep_inputs(t, &plan, Some(&check));
    if !place.refit {
        if let Some(files) = reusable(dir, &inputs) {
            return Ok(FitStep {
                reused: true,
                best: best_errors(dir, &plan.budgets)?,
                check: Some(check),
                files,
                note: None,
                seconds: None,
            });
        }
    }
    let check_data = check.data()?;
    let check_on = check.description();
    let training = if plan.training_points > 0 {
        Some(check::training_get_or_compute(
            model,
            &t.table.spec,
            &t.stem,
            plan.training_points,
        )?)
    } else {
        None
    };
    let training_data = training.as_ref().map(CheckSet::data).transpose()?;
    let training_on = training.as_ref().map(CheckSet::training_description);
    let planned =
        (plan.polynomial_degrees.len() + plan.rational_degrees.len()) * plan.transform_sets.len();
    progress.begin(&format!("fit {name}"), planned as u64);
    let clock = Stopwatch::start();
    let mut done = 0;
    let outcome = job::sweep_fits_trained(
        &input,
        &plan,
        Some((&check_data, &check_on)),
        training_data.as_ref().zip(training_on.as_deref()),
        &mut |_line| {
            // one line per fit made or skipped; the minimax refits come on top of the planned ones
            done += 1;
            if done > planned {
                progress.extend(1);
            }
            progress.advance(1);
        },
    );
    progress.end();
    let mut outcome = outcome?;
    stress_checked_best(&mut outcome);
    let (files, _) = write_sweep_files(&outcome, dir, Some(place.timing), &clock)?;
    inputs.files = file_hashes(&files)?;
    let json = serde_json::to_string_pretty(&inputs)
        .map_err(|e| Error::file(dir.join(SWEEP_INPUTS), e.to_string()))?;
    // written last: it commits the sweep's files
    let key = dir.join(SWEEP_INPUTS);
    output::write(&key, format!("{json}\n").as_bytes())?;
    let mut files = files;
    files.push(key);
    let unusable = outcome.rows.iter().filter(|r| !r.usable).count();
    let note = (unusable > 0 || !outcome.skipped.is_empty())
        .then(|| format!("{unusable} fits not usable (pole or uncertified), {} skipped; listed in sweep.json, never chosen as best", outcome.skipped.len()));
    let best = plan
        .budgets
        .iter()
        .map(|&b| (b, outcome.best_record(b).map(BestSummary::of)))
        .collect();
    Ok(FitStep {
        reused: false,
        best,
        check: Some(check),
        files,
        note,
        seconds: Some((clock.wall_seconds(), clock.cpu_seconds())),
    })
}

/// Makes every best fit one whose f32 code passes the stress test that every emitted fit must
/// pass ([`crate::emit::stress_gate`], all evaluation forms, at the emit's number of points): a
/// best fit that fails it is counted as unusable and its budget chosen again, until each best
/// fit passes or none is left. So each `best-<N>.json` gets its emitted code.
pub fn stress_checked_best(outcome: &mut SweepOutcome) {
    let mut passed: Vec<usize> = Vec::new();
    let mut failed: Vec<usize> = Vec::new();
    loop {
        let mut untested: Vec<usize> = outcome
            .best
            .iter()
            .filter_map(|b| b.index)
            .filter(|i| !passed.contains(i) && !failed.contains(i))
            .collect();
        untested.sort_unstable();
        untested.dedup();
        if untested.is_empty() {
            return;
        }
        let mut newly_failed = false;
        for i in untested {
            match crate::emit::stress_gate(
                &outcome.records[i].fit,
                "albedo",
                crate::emit::generate::FormChoice::Auto,
                crate::emit::stress::DEFAULT_POINTS,
            ) {
                Ok(_) => passed.push(i),
                Err(_) => {
                    failed.push(i);
                    newly_failed = true;
                }
            }
        }
        if newly_failed {
            outcome.choose_best_excluding(&failed);
        }
    }
}

/// Writes `sweep.json`, `sweep.csv` and `best-<budget>.json` (removing a stale best file when a
/// budget has no usable fit), as `furnace fit --sweep` does, without printing; returns the paths
/// and the times.
/// The wall and CPU times go to `<timing>/sweep-timing.json` (git-ignored, under `data/`), the
/// sidecar `furnace fit` writes, so that the files under `fits/` are the same for the same inputs;
/// without a timing folder they are only returned.
pub fn write_sweep_files(
    outcome: &SweepOutcome,
    dir: &Path,
    timing: Option<&Path>,
    clock: &Stopwatch,
) -> Result<(Vec<PathBuf>, Timing)> {
    let mut written = Vec::new();
    let sweep_json = dir.join("sweep.json");
    let times = Timing::new(
        &sweep_json.display().to_string(),
        &outcome.source,
        &outcome.fitted_on,
        clock,
        outcome.fit_times(),
    );
    output::write(&sweep_json, outcome.to_json()?.as_bytes())?;
    written.push(sweep_json);
    let sweep_csv = dir.join("sweep.csv");
    output::write(&sweep_csv, outcome.to_csv().as_bytes())?;
    written.push(sweep_csv);
    for b in &outcome.best {
        let path = dir.join(format!("best-{}.json", b.budget));
        match outcome.best_record(b.budget) {
            Some(rec) => {
                output::write(&path, rec.to_json()?.as_bytes())?;
                written.push(path);
            }
            None if path.exists() => {
                std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?
            }
            None => {}
        }
    }
    if let Some(timing) = timing {
        output::write(
            &timing.join("sweep-timing.json"),
            times.to_json()?.as_bytes(),
        )?;
    }
    Ok((written, times))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::job::SweepPlan;

    fn inputs() -> SweepInputs {
        SweepInputs {
            what: "test".into(),
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            fitter_version: crate::fit::FITTER_VERSION,
            table_stem: "data/m/9x9".into(),
            table_content_hash: "abc".into(),
            table_values_sha256: "def".into(),
            channel: "E".into(),
            plan: SweepPlan {
                polynomial_degrees: vec![2],
                rational_degrees: vec![],
                rational_pairs: vec![],
                forms: vec![],
                transform_sets: vec![],
                objective: Objective::LeastSquares,
                max_fit_points: 0,
                fit_grading: vec![],
                training_points: 0,
                budgets: vec![20],
                minimax_refits: false,
                lp_polish: Vec::new(),
                max_mean_polish: Vec::new(),
            },
            check_set: None,
            files: Vec::new(),
        }
    }

    #[test]
    fn a_sweep_is_reused_only_with_the_same_fitter_and_intact_files() {
        let dir = std::env::temp_dir().join(format!("furnace-sweep-reuse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("best-20.json"), "{}").unwrap();
        let mut written = inputs();
        written.files = vec![FileHash {
            file: "best-20.json".into(),
            sha256: sha256_hex(b"{}"),
        }];
        std::fs::write(
            dir.join(SWEEP_INPUTS),
            serde_json::to_string(&written).unwrap(),
        )
        .unwrap();
        assert!(reusable(&dir, &inputs()).is_some());
        let newer_fitter = SweepInputs {
            fitter_version: crate::fit::FITTER_VERSION + 1,
            ..inputs()
        };
        assert!(reusable(&dir, &newer_fitter).is_none());
        std::fs::write(dir.join("best-20.json"), "{ }").unwrap();
        assert!(reusable(&dir, &inputs()).is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
