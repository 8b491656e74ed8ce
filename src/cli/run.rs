//! `furnace run` without a scene: the whole pipeline on the built-in default set.
//!
//! 1. **Tables** (cached under `data/`): every model of [`DEFAULT_MODELS`] at the paper's
//!    [`DEFAULT_RESOLUTION_2D`]² (2-D) or [`DEFAULT_RESOLUTION_3D`]³, the paper's radiance-form dielectrics ([`PAPER_RADIANCE_MODELS`],
//!    at [`RUN_RESOLUTION_PAPER_RADIANCE`]³), and the small tables the report and the LUTs read.
//! 2. **Fits**: the degree sweep of every table (`fits/<model>/sweep.{json,csv}`, `best-20.json`,
//!    `best-40.json`). A sweep is reused, not redone, when `fits/<model>/sweep-inputs.json` says
//!    it was made from a table with the same values (SHA-256) with the same sweep options and
//!    furnace version, and the files it lists still have the SHA-256 it recorded.
//! 3. **Emit**: Rust, WGSL and GLSL next to each best fit, and a 32-per-axis LUT under
//!    `data/lut/<model>/` (not for the radiance-form tables, which only serve the comparison).
//! 4. **Report**: `reports/` (see [`crate::report`]).
//!
//! Everything written under `fits/`, `reports/` and `data/lut/` is a function of the inputs
//! (no wall times, dates, absolute paths or thread counts), written through a temporary file
//! and a rename; wall times go to the terminal only.

use super::emit::{emit_files, EmitArgs, FormArg as EmitFormArg};
use super::report::CachedTables;
use super::scene::SceneArgs;
use super::{get_table, progress_bar, Tabulated};
use crate::bsdf::{self, Model, ModelId, Side, Transmission};
use crate::emit::parse_langs;
use crate::error::{Error, Result};
use crate::fit::job::{self, FitRecord, Stopwatch, SweepPlan};
use crate::fit::{source, Objective};
use crate::math::SmithForm;
use crate::output;
use crate::quadrature::QuadratureSettings;
use crate::report::model::{fmt_e, ModelSummary, ReportOptions, Reporter, REPORT_MODELS};
use crate::scene::{DEFAULT_RESOLUTION_2D, DEFAULT_RESOLUTION_3D};
use crate::table::{Table, TableSpec};
use clap::Args;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Folder for tables.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Recompute tables even when cached (implies --refit).
    #[arg(long)]
    pub force: bool,
    /// Redo every sweep even when fits/<model>/sweep-inputs.json shows it was made from the same
    /// table values with the same options (after a change to the fitting code).
    #[arg(long)]
    pub refit: bool,
    /// Only tabulate (skip fits, emitted code and the report).
    #[arg(long)]
    pub tables_only: bool,
    /// Skip the report.
    #[arg(long)]
    pub no_report: bool,
    /// Folder for the report (`furnace report`'s `--reports-dir`).
    #[arg(long, default_value = "reports")]
    pub reports_dir: PathBuf,
    /// Only these models of the default set, comma-separated (their cache names: the paper's
    /// radiance-form dielectrics are `ggx-dielectric-separable-radiance` and
    /// `ggx-dielectric-inv-separable-radiance`).
    #[arg(long, value_delimiter = ',')]
    pub models: Vec<String>,
    /// Development: nodes per axis of the 2-D tables instead of 1024.
    #[arg(long, hide = true)]
    pub resolution_2d: Option<usize>,
    /// Development: nodes per axis of the 3-D tables instead of 128 (and 32 for the radiance pair).
    #[arg(long, hide = true)]
    pub resolution_3d: Option<usize>,
    /// Development: highest degree of the sweeps.
    #[arg(long, hide = true)]
    pub max_degree: Option<u32>,
    /// Development: the report on tiny grids (9² / 5³ tables, 2 sphere columns).
    #[arg(long, hide = true)]
    pub quick_report: bool,
    /// (`--fits-dir`, shared with scenes, is the folder for fits and emitted code.)
    #[command(flatten)]
    pub scene: SceneArgs,
}

/// 3-D resolution of the radiance-form tables, which exist only to set furnace's fit beside the
/// paper's published one: 32³ is what a sweep fits on anyway (`job::default_sweep_points`).
pub const RUN_RESOLUTION_PAPER_RADIANCE: usize = 32;

/// Nodes per axis of the LUTs `furnace run` emits.
pub const RUN_LUT_RESOLUTION: usize = 32;

/// The built-in default set of `furnace run`: the paper's models in both Smith forms and
/// the rough-diffuse models — the set the report covers.
pub const DEFAULT_MODELS: &[ModelId] = REPORT_MODELS;

/// Models also tabulated and fitted with radiance-form transmission (×1/η² entering, ×η²
/// leaving): the paper's two dielectric tables are in that form, and its published fits are
/// compared with furnace's on the same convention.
pub const PAPER_RADIANCE_MODELS: &[ModelId] = &[
    ModelId::ggx_dielectric(Side::Entering, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
    ModelId::ggx_dielectric(Side::Leaving, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
];

/// One table of `furnace run` and what became of it.
struct Job {
    model: std::sync::Arc<dyn Model>,
    /// The cache name (`ggx-dielectric-separable-radiance`): folder under data/, fits/.
    name: String,
    resolution: Vec<usize>,
}

impl Job {
    /// A radiance-form table (for the paper comparison only: fitted and reported, not emitted).
    fn radiance(&self) -> bool {
        self.model.id().is_radiance()
    }
}

/// What the fit step did for one model.
#[derive(Default)]
struct FitStep {
    reused: bool,
    /// (budget, max error on the whole table) of each best file.
    best: Vec<(usize, Option<f64>)>,
    files: Vec<PathBuf>,
    note: Option<String>,
}

/// One row of the final summary.
struct Row {
    id: ModelId,
    name: String,
    resolution: String,
    cached: bool,
    table_seconds: f64,
    fit: FitStep,
    emitted: Vec<PathBuf>,
    report_files: usize,
    furnace: Option<f64>,
}

fn default_jobs(args: &RunArgs) -> Result<Vec<Job>> {
    let r2 = args.resolution_2d.unwrap_or(DEFAULT_RESOLUTION_2D);
    let r3 = args.resolution_3d.unwrap_or(DEFAULT_RESOLUTION_3D);
    let r3_radiance = args
        .resolution_3d
        .map_or(RUN_RESOLUTION_PAPER_RADIANCE, |n| {
            n.min(RUN_RESOLUTION_PAPER_RADIANCE)
        });
    let mut jobs = Vec::new();
    for &id in DEFAULT_MODELS.iter().chain(PAPER_RADIANCE_MODELS) {
        let model = bsdf::get(id)?;
        let dims = model.axes().len();
        let n = match (dims, id.is_radiance()) {
            (2, _) => r2,
            (_, false) => r3,
            (_, true) => r3_radiance,
        };
        jobs.push(Job {
            name: model.id().key(),
            resolution: vec![n; dims],
            model,
        });
    }
    if !args.models.is_empty() {
        for m in &args.models {
            if !jobs.iter().any(|j| &j.name == m) {
                let known: Vec<&str> = jobs.iter().map(|j| j.name.as_str()).collect();
                return Err(Error::InvalidInput(format!(
                    "--models: '{m}' is not in the default set; choose from {}",
                    known.join(", ")
                )));
            }
        }
        jobs.retain(|j| args.models.contains(&j.name));
    }
    Ok(jobs)
}

fn report_options(args: &RunArgs) -> ReportOptions {
    let mut o = ReportOptions::new(Path::new("."));
    o.reports_dir = args.reports_dir.clone();
    o.fits_dir = args.scene.fits_dir.clone();
    o.bench_dir = args.reports_dir.join("bench");
    o.paper_dir = super::report::default_paper_dir();
    if args.quick_report {
        o.resolution_2d = 9;
        o.resolution_3d = 5;
        o.lut_2d = 5;
        o.lut_3d = 3;
        o.furnace_nodes = 9;
        o.furnace_f0_slices = 2;
        o.sphere_roughness = vec![0.3, 1.0];
    }
    o
}

/// `furnace run` on the default set.
pub fn run_default(args: &RunArgs) -> Result<()> {
    let start = Instant::now();
    let jobs = default_jobs(args)?;
    // every output folder is writable before anything is computed
    output::check_writable_dir(&args.data_dir, "--data-dir")?;
    if !args.tables_only {
        output::check_writable_dir(&args.scene.fits_dir, "--fits-dir")?;
        output::check_writable_dir(&args.data_dir.join("lut"), "--data-dir")?;
        if !args.no_report {
            output::check_writable_dir(&args.reports_dir, "--reports-dir")?;
        }
    }
    let steps = if args.tables_only {
        1
    } else if args.no_report {
        3
    } else {
        4
    };

    // 1. tables
    let stage = Instant::now();
    eprintln!(
        "[1/{steps}] tables ({} models; cached under {})",
        jobs.len(),
        args.data_dir.display()
    );
    let mut rows = Vec::new();
    let mut tables = Vec::new();
    for (k, job) in jobs.iter().enumerate() {
        let spec = TableSpec::new(
            job.model.as_ref(),
            &job.resolution,
            QuadratureSettings::default(),
        )?;
        let t = get_table(job.model.as_ref(), &spec, &args.data_dir, args.force)?;
        eprintln!(
            "  {:>2}/{} {:<38} {:>12} {} in {:.1} s; max error estimate {:.1e}{}",
            k + 1,
            jobs.len(),
            job.name,
            spec.resolution_name(),
            if t.cached {
                "read from cache"
            } else {
                "computed"
            },
            t.seconds,
            t.table.summary.max_error_estimate,
            if t.table.summary.unconverged_cells > 0 {
                format!(
                    ", {} cells unconverged (listed in the sidecar)",
                    t.table.summary.unconverged_cells
                )
            } else {
                String::new()
            }
        );
        rows.push(Row {
            id: job.model.id(),
            name: job.name.clone(),
            resolution: spec.resolution_name(),
            cached: t.cached,
            table_seconds: t.seconds,
            fit: FitStep::default(),
            emitted: Vec::new(),
            report_files: 0,
            furnace: None,
        });
        tables.push(t);
    }
    if !args.tables_only {
        // the small tables of the LUTs and the report, so that later steps only read the cache
        let options = report_options(args);
        let mut small: Vec<(&dyn Model, usize)> = Vec::new();
        for job in &jobs {
            if !job.radiance() {
                small.push((job.model.as_ref(), RUN_LUT_RESOLUTION));
            }
            if !args.no_report {
                let dims = job.model.axes().len();
                small.push((
                    job.model.as_ref(),
                    if dims <= 2 {
                        options.resolution_2d
                    } else {
                        options.resolution_3d
                    },
                ));
            }
        }
        let mut computed = 0;
        for (model, n) in small {
            let spec = TableSpec::new(
                model,
                &vec![n; model.axes().len()],
                QuadratureSettings::default(),
            )?;
            let t = get_table(model, &spec, &args.data_dir, false)?;
            if !t.cached {
                computed += 1;
            }
        }
        if computed > 0 {
            eprintln!("  computed {computed} small tables for the LUTs and the report");
        }
    }
    eprintln!("  tables: {:.1} s", stage.elapsed().as_secs_f64());
    if args.tables_only {
        print_summary(&rows, args, start);
        return Ok(());
    }

    // 2. fits
    let stage = Instant::now();
    eprintln!(
        "[2/{steps}] fits (degree sweeps into {})",
        args.scene.fits_dir.display()
    );
    for ((job, t), row) in jobs.iter().zip(&tables).zip(rows.iter_mut()) {
        row.fit = sweep_or_reuse(job, t, args)?;
        let best: Vec<String> = row
            .fit
            .best
            .iter()
            .map(|(b, e)| format!("best-{b} max {}", e.map_or("none".into(), fmt_e)))
            .collect();
        eprintln!(
            "  {:<38} {}: {}",
            job.name,
            if row.fit.reused {
                "reused (same table values and options)"
            } else {
                "fitted"
            },
            best.join(", ")
        );
        if let Some(n) = &row.fit.note {
            eprintln!("    {n}");
        }
    }
    eprintln!("  fits: {:.1} s", stage.elapsed().as_secs_f64());

    // 3. emit
    let stage = Instant::now();
    eprintln!(
        "[3/{steps}] emit (Rust, WGSL, GLSL next to each best fit; LUTs under {})",
        args.data_dir.join("lut").display()
    );
    let total: usize = jobs
        .iter()
        .zip(&rows)
        .filter(|(j, _)| !j.radiance())
        .map(|(_, r)| r.fit.best.iter().filter(|b| b.1.is_some()).count())
        .sum();
    let pb = progress_bar(total as u64, "emit");
    for (job, row) in jobs
        .iter()
        .zip(rows.iter_mut())
        .filter(|(j, _)| !j.radiance())
    {
        let dir = args.scene.fits_dir.join(&job.name);
        let best: Vec<PathBuf> = row
            .fit
            .best
            .iter()
            .filter(|b| b.1.is_some())
            .map(|(b, _)| dir.join(format!("best-{b}.json")))
            .collect();
        for (k, fit) in best.iter().enumerate() {
            pb.set_message(format!("emit {}", job.name));
            // one LUT per model, compared with the largest-budget fit
            let lang = if k + 1 == best.len() {
                "all"
            } else {
                "rust,wgsl,glsl"
            };
            let emit_args = EmitArgs {
                fit: vec![fit.clone()],
                lang: lang.into(),
                form: EmitFormArg::Auto,
                suffix: String::new(),
                output: None,
                data_dir: args.data_dir.clone(),
                lut_dir: args.data_dir.join("lut"),
                lut_resolution: RUN_LUT_RESOLUTION,
                force: false,
            };
            let langs = parse_langs(lang)?;
            match emit_files(fit, &langs, &emit_args, None, &mut |_| {}) {
                Ok(written) => row.emitted.extend(written),
                // a file that cannot be written stops the run; a fit that cannot be emitted
                // (e.g. not proved pole-free) is reported and skipped
                Err(e @ Error::Io { .. }) => {
                    pb.finish_and_clear();
                    return Err(e);
                }
                Err(e) => {
                    pb.suspend(|| eprintln!("  {}: {} not emitted: {e}", job.name, fit.display()))
                }
            }
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    eprintln!(
        "  emit: {} files in {:.1} s",
        rows.iter().map(|r| r.emitted.len()).sum::<usize>(),
        stage.elapsed().as_secs_f64()
    );

    // 4. report
    if !args.no_report {
        let stage = Instant::now();
        eprintln!(
            "[4/{steps}] report ({})",
            args.reports_dir.join("README.md").display()
        );
        let selected: Vec<ModelId> = REPORT_MODELS
            .iter()
            .filter(|m| jobs.iter().any(|j| j.model.id() == **m))
            .copied()
            .collect();
        let provider = CachedTables {
            data_dir: &args.data_dir,
        };
        let pb = progress_bar(selected.len() as u64, "report");
        let pb_ref = &pb;
        let progress =
            |m: &str| pb_ref.set_message(format!("report {}", m.split(':').next().unwrap_or(m)));
        let reporter = Reporter::new(report_options(args), &provider, &progress);
        let outcome =
            reporter.generate_each(Some(&selected), !args.force, &mut |_, _| pb_ref.inc(1))?;
        pb.finish_and_clear();
        for row in rows.iter_mut() {
            row.furnace = furnace_of(row.id, &outcome.regenerated);
            if let Some(s) = outcome.regenerated.iter().find(|s| s.model == row.name) {
                row.report_files = s.files.len() + 2;
            }
        }
        eprintln!(
            "  report: {} sections ({} regenerated, {} unchanged inputs: kept), {} linked files in {:.1} s",
            outcome.regenerated.len(),
            outcome.regenerated.len() - outcome.reused.len(),
            outcome.reused.len(),
            outcome.linked.len(),
            stage.elapsed().as_secs_f64()
        );
    }
    print_summary(&rows, args, start);
    Ok(())
}

/// max |1 − E| of the BSDF compensated with furnace's chosen fit: the model's first furnace
/// material, or for a radiance-form table the paper comparison of its energy-form model.
fn furnace_of(id: ModelId, sections: &[ModelSummary]) -> Option<f64> {
    let name = id.key();
    if id.is_radiance() {
        return sections
            .iter()
            .find(|s| s.model == id.energy_form().key())
            .and_then(|s| s.paper.as_ref())
            .and_then(|p| p.furnace_fit_furnace);
    }
    let s = sections.iter().find(|s| s.model == name)?;
    s.furnace
        .first()?
        .variants
        .iter()
        .find(|v| v.name == "furnace fit")?
        .stats
        .as_ref()
        .map(|st| st.max_deviation)
}

fn print_summary(rows: &[Row], args: &RunArgs, start: Instant) {
    println!();
    println!(
        "{:<38} {:>12} {:>7} {:>9} {:>7} {:>11} {:>11} {:>13} {:>6}",
        "model",
        "table",
        "cached",
        "table s",
        "fits",
        "best-20 max",
        "best-40 max",
        "furnace |1−E|",
        "files"
    );
    let mut files = 0;
    for r in rows {
        let best = |b: usize| {
            r.fit
                .best
                .iter()
                .find(|x| x.0 == b)
                .and_then(|x| x.1)
                .map_or("–".to_string(), fmt_e)
        };
        let fits = if args.tables_only {
            "–"
        } else if r.fit.reused {
            "reused"
        } else {
            "fitted"
        };
        let n = r.fit.files.len() + r.emitted.len() + r.report_files + if r.cached { 0 } else { 3 };
        files += n;
        println!(
            "{:<38} {:>12} {:>7} {:>9.1} {:>7} {:>11} {:>11} {:>13} {:>6}",
            r.name,
            r.resolution,
            if r.cached { "yes" } else { "no" },
            r.table_seconds,
            fits,
            best(20),
            best(40),
            r.furnace.map_or("–".to_string(), fmt_e),
            n
        );
    }
    println!(
        "best-N max: largest |fit − table| over every node of the table; furnace: max |1 − E| of the BSDF compensated with the report's chosen fit (reports/README.md)"
    );
    println!(
        "{files} files written or confirmed under {}, {}, {} and {}; total {:.1} s",
        args.data_dir.display(),
        args.scene.fits_dir.display(),
        args.data_dir.join("lut").display(),
        args.reports_dir.display(),
        start.elapsed().as_secs_f64()
    );
}

/// `fits/<model>/sweep-inputs.json`: what a sweep was made from, so that a re-run with the same
/// inputs reuses its files. Deterministic: no times, no absolute paths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepInputs {
    pub what: String,
    pub tool: String,
    pub tool_version: String,
    /// The table's cache stem as given to `furnace run` (relative to the working folder).
    pub table_stem: String,
    /// Cache key of the table's spec ([`TableSpec::content_hash`]).
    pub table_content_hash: String,
    /// SHA-256 of the table's values (little-endian f64, every output in turn).
    pub table_values_sha256: String,
    pub channel: String,
    /// The sweep options (degrees, transforms, objective, points, budgets), as Rust debug text.
    pub plan: String,
    /// Every file the sweep wrote, with its SHA-256.
    pub files: Vec<FileHash>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileHash {
    pub file: String,
    pub sha256: String,
}

/// Name of the sweep-inputs file in each model's fit folder.
const SWEEP_INPUTS: &str = crate::report::inputs::SWEEP_INPUTS_FILE;

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// SHA-256 of a table's values.
pub fn values_sha256(table: &Table) -> String {
    let mut h = Sha256::new();
    for v in &table.values {
        h.update(v.to_le_bytes());
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn sweep_inputs(t: &Tabulated, plan: &SweepPlan) -> SweepInputs {
    SweepInputs {
        what: "inputs of the sweep files in this folder, written by `furnace run` after them: a run whose table values and sweep options are the same reuses the files listed here (if their SHA-256 still match) instead of refitting; `furnace run --refit` refits".into(),
        tool: "furnace".into(),
        tool_version: crate::VERSION.into(),
        table_stem: t.stem.to_string_lossy().replace('\\', "/"),
        table_content_hash: t.table.spec.content_hash(),
        table_values_sha256: values_sha256(&t.table),
        channel: "E".into(),
        plan: format!("{plan:?}"),
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
    let mut files = Vec::new();
    for f in &found.files {
        let p = dir.join(&f.file);
        let bytes = std::fs::read(&p).ok()?;
        if sha256_hex(&bytes) != f.sha256 {
            return None;
        }
        files.push(p);
    }
    // a best file the sweep did not write must not be there (it would be a stale one)
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        if n.starts_with("best-")
            && n.ends_with(".json")
            && !found.files.iter().any(|f| f.file == n)
        {
            return None;
        }
    }
    Some(files)
}

/// Max error (whole table) of each best file of a sweep folder.
fn best_errors(dir: &Path, budgets: &[usize]) -> Result<Vec<(usize, Option<f64>)>> {
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
            Ok((b, Some(rec.fit.metrics.max_abs_error)))
        })
        .collect()
}

fn sweep_or_reuse(job: &Job, t: &Tabulated, args: &RunArgs) -> Result<FitStep> {
    let input = source::from_table(&t.table, "E", Some(&t.stem))?;
    let mut plan = SweepPlan::paper(&input.data, args.max_degree, None, Objective::LeastSquares);
    if !job.model.grazing_boundary_layer() {
        plan = plan.without_boundary_layer(None);
    }
    let dir = args.scene.fits_dir.join(&job.name);
    let mut inputs = sweep_inputs(t, &plan);
    if !args.refit && !args.force {
        if let Some(files) = reusable(&dir, &inputs) {
            return Ok(FitStep {
                reused: true,
                best: best_errors(&dir, &plan.budgets)?,
                files,
                note: None,
            });
        }
    }
    let planned =
        (plan.polynomial_degrees.len() + plan.rational_degrees.len()) * plan.transform_sets.len();
    let pb = progress_bar(planned as u64, &format!("fit {}", job.name));
    let clock = Stopwatch::start();
    let outcome = job::sweep_fits(&input, &plan, &mut |_line| {
        // one line per fit made or skipped; the minimax refits come on top of the planned ones
        if pb.position() >= pb.length().unwrap_or(0) {
            pb.inc_length(1);
        }
        pb.inc(1);
    });
    pb.finish_and_clear();
    let outcome = outcome?;
    let (files, _) = super::fit::write_sweep_files(
        &outcome,
        &dir,
        Some(&args.data_dir.join("timing").join(&job.name)),
        &clock,
    )?;
    inputs.files = files
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
        .collect::<Result<_>>()?;
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
        .map(|&b| {
            (
                b,
                outcome.best_record(b).map(|r| r.fit.metrics.max_abs_error),
            )
        })
        .collect();
    Ok(FitStep {
        reused: false,
        best,
        files,
        note,
    })
}
