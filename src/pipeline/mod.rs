//! The pipeline: tables → fits → emitted code and LUTs → report, for a set of models.
//!
//! 1. **Tables** ([`crate::table::get_or_tabulate`], cached under `data/`): every model of the
//!    job at [`Job::resolution_2d`]² (2-D) or [`Job::resolution_3d`]³ — radiance-form
//!    models at [`Job::resolution_radiance`]³ — and the small tables the LUTs and the report
//!    read.
//! 2. **Fits**: the degree sweep of every table (`fits/<model>/sweep.{json,csv}`, `best-20.json`,
//!    `best-40.json`), reused rather than redone when its inputs are unchanged ([`sweeps`]).
//! 3. **Emit** ([`crate::emit::file::emit_fit_file`]): Rust, WGSL, GLSL, HLSL and C/C++ next to each best
//!    fit, and a [`RUN_LUT_RESOLUTION`]-per-axis LUT under `data/lut/<model>/` (not for the
//!    radiance-form tables, which only serve the comparison with the paper).
//! 4. **Report** ([`crate::report`]): `reports/`, one section per model.
//!
//! [`Job::default_set`] is the default set (`furnace run`): the registry's
//! ([`crate::bsdf::default_set`], which [`crate::bsdf::register_in_default_set`] extends) and
//! [`PAPER_RADIANCE_MODELS`]. A library user runs it, or the same job on models of their own,
//! without the command line:
//!
//! ```no_run
//! use furnace::pipeline::{self, Job};
//! use furnace::progress::Quiet;
//!
//! let mut job = Job::default_set(std::path::Path::new("out"));
//! job.only(&["ggx-conductor".to_string()])?;
//! let outcome = pipeline::run(&job, &Quiet)?;
//! println!("{} files", outcome.rows[0].emitted.len());
//! # Ok::<(), furnace::Error>(())
//! ```
//!
//! A scene manifest ([`crate::scene`]) is planned into the tables its materials need and run by
//! [`scene::run`] through the same table cache and emitters, with one stress-tested rational fit
//! per table instead of a sweep.
//!
//! Everything written under `fits/`, `reports/` and `data/lut/` is a function of the inputs
//! (no wall times, dates, absolute paths or thread counts), written through a temporary file
//! and a rename; wall times go to the observer only.

pub mod emits;
pub mod offgrid;
pub mod scene;
pub mod sweeps;

pub use offgrid::{OffGridSummary, LUT_CHECK_RESOLUTIONS, LUT_TO_BEAT};
pub use sweeps::{sweep_or_reuse, BestSummary, FileHash, FitStep, SweepInputs};

use crate::bsdf::{self, Model, ModelId, Side, Transmission};
use crate::emit::file::{emit_fit_file, EmitFileOptions};
use crate::emit::generate::FormChoice;
use crate::emit::parse_langs;
use crate::error::{Error, Result};
use crate::math::SmithForm;
use crate::output;
use crate::progress::Observer;
use crate::quadrature::QuadratureSettings;
use crate::report::inputs::TableProvider;
use crate::report::model::{fmt_e, ModelSummary, ReportOptions, Reporter};
use crate::scene::{DEFAULT_RESOLUTION_2D, DEFAULT_RESOLUTION_3D};
use crate::table::{get_or_tabulate, Table, TableSpec, Tabulated};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// 3-D resolution of the radiance-form tables, which exist only to set furnace's fit beside the
/// paper's published one: 32³ is what a sweep fits on anyway (`job::default_sweep_points`).
pub const RUN_RESOLUTION_PAPER_RADIANCE: usize = 32;

/// Nodes per axis of the LUTs `furnace run` emits.
pub const RUN_LUT_RESOLUTION: usize = 32;

/// Models also tabulated and fitted with radiance-form transmission (×1/η² entering, ×η²
/// leaving): the paper's two dielectric tables are in that form, and its published fits are
/// compared with furnace's on the same convention.
pub const PAPER_RADIANCE_MODELS: &[ModelId] = &[
    ModelId::ggx_dielectric(Side::Entering, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
    ModelId::ggx_dielectric(Side::Leaving, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
];

/// What a run of the pipeline does and where it reads and writes.
#[derive(Clone, Debug)]
pub struct Job {
    /// The models, in order (registered ones: [`crate::bsdf::register`] adds a user's).
    pub models: Vec<ModelId>,
    /// Table cache (`data`); LUTs go to `<data_dir>/lut`, sweep timings to `<data_dir>/timing`.
    pub data_dir: PathBuf,
    /// Fits and emitted code, one folder per model (`fits`).
    pub fits_dir: PathBuf,
    /// Recompute tables even when cached (implies [`Job::refit`]).
    pub force: bool,
    /// Redo every sweep even when its inputs are unchanged.
    pub refit: bool,
    /// Stop after the tables.
    pub tables_only: bool,
    /// Skip the report.
    pub no_report: bool,
    /// Nodes per axis of 2-D tables, 3-D tables and 3-D radiance-form tables.
    pub resolution_2d: usize,
    pub resolution_3d: usize,
    pub resolution_radiance: usize,
    /// Highest degree of the sweeps (default: the paper's).
    pub max_degree: Option<u32>,
    /// The report's folders and grids.
    pub report: ReportOptions,
}

impl Job {
    /// The default set ([`crate::bsdf::default_set`], then [`PAPER_RADIANCE_MODELS`]) at full
    /// size, reading and writing `data/`, `fits/` and `reports/` under `root` (the paper's data from `root/data/paper` when it is there).
    pub fn default_set(root: &Path) -> Job {
        let mut report = ReportOptions::new(root);
        let paper = root.join("data").join("paper");
        report.paper_dir = paper.join("coefficients").is_dir().then_some(paper);
        Job {
            models: bsdf::default_set()
                .into_iter()
                .chain(PAPER_RADIANCE_MODELS.iter().copied())
                .collect(),
            data_dir: root.join("data"),
            fits_dir: root.join("fits"),
            force: false,
            refit: false,
            tables_only: false,
            no_report: false,
            resolution_2d: DEFAULT_RESOLUTION_2D,
            resolution_3d: DEFAULT_RESOLUTION_3D,
            resolution_radiance: RUN_RESOLUTION_PAPER_RADIANCE,
            max_degree: None,
            report,
        }
    }

    /// Keeps only the models named (by their cache names, `ggx-dielectric-separable-radiance`);
    /// refused for a name not in the job.
    pub fn only(&mut self, names: &[String]) -> Result<()> {
        for m in names {
            if !self.models.iter().any(|id| &id.key() == m) {
                let known: Vec<String> = self.models.iter().map(|id| id.key()).collect();
                return Err(Error::InvalidInput(format!(
                    "--models: '{m}' is not in the default set; choose from {}",
                    known.join(", ")
                )));
            }
        }
        self.models.retain(|id| names.contains(&id.key()));
        Ok(())
    }

    /// The report on tiny grids (9² / 5³ tables, 3- and 5-per-axis LUTs, 2 sphere columns): for
    /// tests and trials.
    pub fn quick_report(&mut self) {
        let o = &mut self.report;
        o.resolution_2d = 9;
        o.resolution_3d = 5;
        o.lut_2d = 5;
        o.lut_3d = 3;
        o.furnace_luts = vec![3];
        o.furnace_nodes = 9;
        o.furnace_f0_slices = 2;
        o.sphere_roughness = vec![0.3, 1.0];
        o.anisotropy = Some(crate::report::aniso::QUICK_RESOLUTION.to_vec());
    }

    /// The number of stages the job runs (1 tables only, 3 without the report, else 4).
    pub fn stages(&self) -> usize {
        if self.tables_only {
            1
        } else if self.no_report {
            3
        } else {
            4
        }
    }

    fn resolution(&self, model: &dyn Model) -> Vec<usize> {
        let dims = model.axes().len();
        let n = match (dims, model.id().is_radiance()) {
            (2, _) => self.resolution_2d,
            (_, false) => self.resolution_3d,
            (_, true) => self.resolution_radiance,
        };
        vec![n; dims]
    }
}

/// Tables from the cache under `data_dir`, tabulated (reporting to `progress`) when missing:
/// the report's [`TableProvider`].
pub struct CachedTables<'a> {
    pub data_dir: &'a Path,
    pub progress: &'a dyn Observer,
}

impl TableProvider for CachedTables<'_> {
    fn table(&self, model: &dyn Model, resolution: &[usize]) -> Result<Table> {
        let spec = TableSpec::new(model, resolution, QuadratureSettings::default())?;
        Ok(get_or_tabulate(model, &spec, self.data_dir, false, self.progress)?.table)
    }
}

/// What the pipeline did for one model.
#[derive(Clone, Debug)]
pub struct Row {
    pub id: ModelId,
    /// The cache name: folder under `data/`, `fits/` and `reports/`.
    pub name: String,
    pub resolution: String,
    pub cached: bool,
    pub table_seconds: f64,
    pub fit: FitStep,
    pub emitted: Vec<PathBuf>,
    /// Files of the model's report section (0 without a report).
    pub report_files: usize,
    /// max |1 − E| of the BSDF compensated with the report's chosen fit.
    pub furnace: Option<f64>,
    /// The best fits and the 16/32/64-per-axis LUTs at the off-grid check points (not for the
    /// radiance-form tables).
    pub off_grid: Option<OffGridSummary>,
}

/// What the pipeline did.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// One row per model, in the job's order.
    pub rows: Vec<Row>,
}

/// Runs the pipeline; `progress` gets its log lines and progress (nothing of it reaches a file).
pub fn run(job: &Job, progress: &dyn Observer) -> Result<Outcome> {
    let models: Vec<Arc<dyn Model>> = job
        .models
        .iter()
        .map(|&id| bsdf::get(id))
        .collect::<Result<_>>()?;
    // every output folder is writable before anything is computed
    output::check_writable_dir(&job.data_dir, "--data-dir")?;
    if !job.tables_only {
        output::check_writable_dir(&job.fits_dir, "--fits-dir")?;
        output::check_writable_dir(&job.data_dir.join("lut"), "--data-dir")?;
        if !job.no_report {
            output::check_writable_dir(&job.report.reports_dir, "--reports-dir")?;
        }
    }
    let steps = job.stages();

    // 1. tables
    let stage = Instant::now();
    progress.line(&format!(
        "[1/{steps}] tables ({} models; cached under {})",
        models.len(),
        job.data_dir.display()
    ));
    let mut rows = Vec::new();
    let mut tables: Vec<Tabulated> = Vec::new();
    for (k, model) in models.iter().enumerate() {
        let spec = TableSpec::new(
            model.as_ref(),
            &job.resolution(model.as_ref()),
            QuadratureSettings::default(),
        )?;
        let t = get_or_tabulate(model.as_ref(), &spec, &job.data_dir, job.force, progress)?;
        let name = model.id().key();
        progress.line(&format!(
            "  {:>2}/{} {:<38} {:>12} {} in {:.1} s; max error estimate {:.1e}{}",
            k + 1,
            models.len(),
            name,
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
        ));
        rows.push(Row {
            id: model.id(),
            name,
            resolution: spec.resolution_name(),
            cached: t.cached,
            table_seconds: t.seconds,
            fit: FitStep::default(),
            emitted: Vec::new(),
            report_files: 0,
            furnace: None,
            off_grid: None,
        });
        tables.push(t);
    }
    if !job.tables_only {
        // the small tables of the LUTs and the report, so that later steps only read the cache
        let mut small: Vec<(&dyn Model, usize)> = Vec::new();
        for model in &models {
            if !model.id().is_radiance() {
                small.push((model.as_ref(), RUN_LUT_RESOLUTION));
            }
            if !job.no_report {
                let dims = model.axes().len();
                small.push((
                    model.as_ref(),
                    if dims <= 2 {
                        job.report.resolution_2d
                    } else {
                        job.report.resolution_3d
                    },
                ));
                if !model.id().is_radiance() {
                    for &n in &job.report.furnace_luts {
                        small.push((model.as_ref(), n));
                    }
                }
            }
        }
        let mut computed = 0;
        for (model, n) in small {
            let spec = TableSpec::new(
                model,
                &vec![n; model.axes().len()],
                QuadratureSettings::default(),
            )?;
            if !get_or_tabulate(model, &spec, &job.data_dir, false, progress)?.cached {
                computed += 1;
            }
        }
        if computed > 0 {
            progress.line(&format!(
                "  computed {computed} small tables for the LUTs and the report"
            ));
        }
    }
    progress.line(&format!("  tables: {:.1} s", stage.elapsed().as_secs_f64()));
    if job.tables_only {
        return Ok(Outcome { rows });
    }

    // 2. fits
    let stage = Instant::now();
    progress.line(&format!(
        "[2/{steps}] fits (degree sweeps into {})",
        job.fits_dir.display()
    ));
    for ((model, t), row) in models.iter().zip(&tables).zip(rows.iter_mut()) {
        row.fit = sweep_or_reuse(model.as_ref(), &row.name, t, job, progress)?;
        let best: Vec<String> = row
            .fit
            .best
            .iter()
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
            .collect();
        progress.line(&format!(
            "  {:<38} {}: {}",
            row.name,
            if row.fit.reused {
                "reused (same table values and options)"
            } else {
                "fitted"
            },
            best.join(", ")
        ));
        if let Some(n) = &row.fit.note {
            progress.line(&format!("    {n}"));
        }
        if let (Some(check), false) = (&row.fit.check, row.id.is_radiance()) {
            let luts = offgrid::lut_errors(model.as_ref(), check, &job.data_dir, progress)?;
            let s = offgrid::summary(&row.name, check, &row.fit.best, luts);
            row.emitted.push(s.write(&job.fits_dir.join(&row.name))?);
            for l in s.losses() {
                progress.line(&format!("    warning: {l}"));
            }
            row.off_grid = Some(s);
        }
    }
    progress.line(&format!("  fits: {:.1} s", stage.elapsed().as_secs_f64()));

    // 3. emit
    let stage = Instant::now();
    let lut_dir = job.data_dir.join("lut");
    progress.line(&format!(
        "[3/{steps}] emit (Rust, WGSL, GLSL, HLSL, C/C++ next to each best fit; LUTs under {})",
        lut_dir.display()
    ));
    let total: usize = rows
        .iter()
        .filter(|r| !r.id.is_radiance())
        .map(|r| r.fit.best.iter().filter(|b| b.1.is_some()).count())
        .sum();
    progress.begin("emit", total as u64);
    let mut kept = 0;
    for row in rows.iter_mut().filter(|r| !r.id.is_radiance()) {
        let dir = job.fits_dir.join(&row.name);
        let best: Vec<PathBuf> = row
            .fit
            .best
            .iter()
            .filter(|b| b.1.is_some())
            .map(|(b, _)| dir.join(format!("best-{b}.json")))
            .collect();
        for (k, fit) in best.iter().enumerate() {
            progress.message(&format!("emit {}", row.name));
            // one LUT per model, compared with the largest-budget fit
            let lang = if k + 1 == best.len() {
                "all"
            } else {
                "rust,wgsl,glsl,hlsl,cpp"
            };
            let options = EmitFileOptions {
                langs: parse_langs(lang)?,
                lang_arg: lang.into(),
                form: FormChoice::Auto,
                suffix: String::new(),
                data_dir: job.data_dir.clone(),
                lut_dir: lut_dir.clone(),
                lut_resolution: RUN_LUT_RESOLUTION,
                force: false,
            };
            // the files of an emit with the same inputs are kept (emits::reusable)
            let cache = emits::cache_path(&job.data_dir, &row.name, fit);
            let inputs = emits::emit_inputs(fit, &job.data_dir, lang, RUN_LUT_RESOLUTION);
            let previous = if job.force || job.refit {
                None
            } else {
                inputs.as_ref().and_then(|i| emits::reusable(&cache, i))
            };
            let outcome = match previous {
                Some(p) => {
                    kept += 1;
                    p
                }
                None => {
                    let outcome = match emit_fit_file(fit, &options, None, &mut |_| {}) {
                        Ok(written) => Ok(written),
                        // a file that cannot be written stops the run; a fit that cannot be
                        // emitted (e.g. not proved pole-free) is reported and skipped
                        Err(e @ Error::Io { .. }) => {
                            progress.end();
                            return Err(e);
                        }
                        Err(e) => Err(e.to_string()),
                    };
                    if let Some(i) = inputs {
                        emits::record(&cache, i, outcome.as_deref().map_err(Clone::clone))?;
                    }
                    outcome
                }
            };
            match outcome {
                Ok(written) => row.emitted.extend(written),
                Err(e) => progress.line(&format!(
                    "  {}: {} not emitted: {e}",
                    row.name,
                    fit.display()
                )),
            }
            progress.advance(1);
        }
    }
    progress.end();
    progress.line(&format!(
        "  emit: {} files in {:.1} s ({kept} of {total} fits kept: same inputs)",
        rows.iter().map(|r| r.emitted.len()).sum::<usize>(),
        stage.elapsed().as_secs_f64()
    ));

    // 4. report
    if !job.no_report {
        let stage = Instant::now();
        progress.line(&format!(
            "[4/{steps}] report ({})",
            job.report.reports_dir.join("README.md").display()
        ));
        // the radiance-form tables are reported beside their energy-form models
        let selected: Vec<ModelId> = job
            .models
            .iter()
            .filter(|m| !m.is_radiance())
            .copied()
            .collect();
        let provider = CachedTables {
            data_dir: &job.data_dir,
            progress,
        };
        progress.begin("report", selected.len() as u64);
        let message =
            |m: &str| progress.message(&format!("report {}", m.split(':').next().unwrap_or(m)));
        let reporter = Reporter::new(job.report.clone(), &provider, &message);
        let outcome =
            reporter.generate_each(Some(&selected), !job.force, &mut |_, _| progress.advance(1));
        progress.end();
        let outcome = outcome?;
        for row in rows.iter_mut() {
            row.furnace = furnace_of(row.id, &outcome.regenerated);
            if let Some(s) = outcome.regenerated.iter().find(|s| s.model == row.name) {
                row.report_files = s.files.len() + 2;
            }
        }
        progress.line(&format!(
            "  report: {} sections ({} regenerated, {} unchanged inputs: kept), {} linked files in {:.1} s",
            outcome.regenerated.len(),
            outcome.regenerated.len() - outcome.reused.len(),
            outcome.reused.len(),
            outcome.linked.len(),
            stage.elapsed().as_secs_f64()
        ));
    }
    Ok(Outcome { rows })
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
