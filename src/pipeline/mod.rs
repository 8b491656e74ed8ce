//! The pipeline: tables → fits → emitted code and LUTs → report, for any [`Job`].
//!
//! A job ([`job`]) lists its tables and says how each stage runs; [`run`] runs any job through
//! the same four stages, reporting to one [`Observer`]:
//!
//! 1. **Tables** ([`crate::table::get_or_tabulate`], cached under `data/`): every table of the
//!    job over its ranges, and the small tables the LUTs and the report read.
//! 2. **Fits** ([`FitStage`]): the degree sweep of every table (`fits/<model>/sweep.{json,csv}`,
//!    `best-<N>.json`), reused rather than redone when its inputs are unchanged ([`sweeps`]);
//!    or one stress-tested rational per table ([`scene::fit_one`]).
//! 3. **Emit** ([`EmitStage`]): Rust, WGSL, GLSL, HLSL and C/C++ next to each fit and a LUT per
//!    table ([`crate::emit::file::emit_fit_file`], kept when unchanged: [`emits`]); or one file
//!    per language with only the helpers the job names ([`crate::emit::build_unit`]).
//! 4. **Report** ([`crate::report`]): `reports/`, one section per model.
//!
//! [`Job::default_set`] is `furnace run`'s job: the registry's default set
//! ([`crate::bsdf::default_set`], which [`crate::bsdf::register_in_default_set`] extends) and
//! [`PAPER_RADIANCE_MODELS`], swept, emitted per fit and reported. [`Job::scene`] is
//! `furnace run --scene`'s: a manifest's tables ([`crate::scene::plan`]), one fit each, one
//! file per language. A library user runs either, or a job of their own, without the command
//! line:
//!
//! ```no_run
//! use furnace::pipeline::{self, FitStage, Job};
//! use furnace::progress::Quiet;
//!
//! let mut job = Job::default_set(std::path::Path::new("out"));
//! job.only(&["ggx-conductor".to_string()])?;
//! job.set_resolution(65, 17);
//! job.fit = FitStage::Sweep { max_degree: Some(4) };
//! let outcome = pipeline::run(&job, &Quiet)?;
//! for row in &outcome.rows {
//!     println!("{}: {} files emitted", row.name, row.emitted.len());
//! }
//! # Ok::<(), furnace::Error>(())
//! ```
//!
//! Everything written under `fits/`, `reports/` and `data/lut/` is a function of the inputs
//! (no wall times, dates, absolute paths or thread counts), written through a temporary file
//! and a rename; wall times go to the observer only.

pub mod aniso;
pub mod emits;
pub mod job;
pub mod offgrid;
pub mod scene;
pub mod sweeps;

pub use job::{
    EmitStage, FitStage, Job, PlannedTable, PAPER_RADIANCE_MODELS, RUN_LUT_RESOLUTION,
    RUN_RESOLUTION_PAPER_RADIANCE,
};
pub use offgrid::{OffGridSummary, LUT_CHECK_RESOLUTIONS, LUT_TO_BEAT};
pub use scene::OneFit;
pub use sweeps::{sweep_or_reuse, BestSummary, FileHash, FitStep, SweepInputs, SweepPlace};

use crate::bsdf::{self, Model, ModelId};
use crate::emit::file::{emit_fit_file, EmitFileOptions};
use crate::emit::generate::FormChoice;
use crate::emit::{self, parse_langs, EmitOptions, EmittedFit, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::output;
use crate::progress::Observer;
use crate::quadrature::QuadratureSettings;
use crate::report::inputs::TableProvider;
use crate::report::model::{ModelSummary, ReportOptions, Reporter};
use crate::table::{get_or_tabulate, Table, TableSpec, Tabulated};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

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

/// What the fit stage made of one table.
// one value per table of a run: the variants' sizes do not matter
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, Default)]
pub enum Fitted {
    /// Nothing yet: the job stopped after the tables.
    #[default]
    None,
    /// The degree sweep ([`FitStage::Sweep`]).
    Sweep(FitStep),
    /// The one fit ([`FitStage::OnePerTable`]).
    One(OneFit),
}

/// What the pipeline did for one table.
#[derive(Clone, Debug)]
pub struct Row {
    pub id: ModelId,
    /// The cache name: folder under `data/`, `fits/` and `reports/`.
    pub name: String,
    /// The table's box, one (lo, hi) per axis.
    pub ranges: Vec<(f64, f64)>,
    pub resolution: String,
    /// What reads the table ([`PlannedTable::used_by`]).
    pub used_by: Vec<String>,
    pub cached: bool,
    pub table_seconds: f64,
    pub fit: Fitted,
    /// Files emitted next to the table's fits ([`EmitStage::EachFit`]; the files of
    /// [`EmitStage::OneFilePerLanguage`] are [`Outcome::written`]) and `off-grid.json`.
    pub emitted: Vec<PathBuf>,
    /// Files of the model's report section (0 without a report).
    pub report_files: usize,
    /// max |1 − E| of the BSDF compensated with the report's chosen fit.
    pub furnace: Option<f64>,
    /// The best fits and the 16/32/64-per-axis LUTs at the off-grid check points (sweeps of
    /// energy-form tables only).
    pub off_grid: Option<OffGridSummary>,
}

impl Row {
    /// The sweep of the table, if the job swept it.
    pub fn sweep(&self) -> Option<&FitStep> {
        match &self.fit {
            Fitted::Sweep(s) => Some(s),
            _ => None,
        }
    }

    /// The one fit of the table, if the job made one.
    pub fn one(&self) -> Option<&OneFit> {
        match &self.fit {
            Fitted::One(f) => Some(f),
            _ => None,
        }
    }

    /// The fit files to emit, in order: a sweep's best files, or the one fit's.
    fn fit_files(&self, fits_dir: &Path) -> Vec<PathBuf> {
        match &self.fit {
            Fitted::None => Vec::new(),
            Fitted::Sweep(s) => sweeps::best_paths(&fits_dir.join(&self.name), &s.best),
            Fitted::One(f) => vec![f.path.clone()],
        }
    }
}

/// What the pipeline did.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// One row per table, in the job's order.
    pub rows: Vec<Row>,
    /// The functions of [`EmitStage::OneFilePerLanguage`]'s files, one per table (empty for
    /// [`EmitStage::EachFit`]).
    pub functions: Vec<EmittedFit>,
    /// The files of [`EmitStage::OneFilePerLanguage`] (code and LUTs).
    pub written: Vec<PathBuf>,
    /// The anisotropic conductor's budget fits ([`Job::anisotropic_fits`]).
    pub anisotropic: Option<aniso::AnisoFits>,
    /// The code emitted next to them.
    pub anisotropic_emitted: Vec<PathBuf>,
}

/// Runs `job`; `progress` gets its log lines and progress (nothing of it reaches a file).
pub fn run(job: &Job, progress: &dyn Observer) -> Result<Outcome> {
    let models: Vec<Arc<dyn Model>> = job
        .tables
        .iter()
        .map(|t| bsdf::get(t.model))
        .collect::<Result<_>>()?;
    check_outputs(job)?;
    // a table that holds a degenerate slice is refused before anything is computed
    for (model, t) in models.iter().zip(&job.tables) {
        bsdf::check_no_degenerate_slice(model.as_ref(), &t.ranges, &|a, (lo, hi)| {
            format!("narrow the materials' {a} range in the manifest to leave the slice out (the model's default range is [{lo}, {hi}])")
        })?;
    }
    progress.line(job.human().trim_end());
    let (mut rows, tables) = tabulate(job, &models, progress)?;
    if job.tables_only {
        return Ok(Outcome {
            rows,
            functions: Vec::new(),
            written: Vec::new(),
            anisotropic: None,
            anisotropic_emitted: Vec::new(),
        });
    }
    let (sources, anisotropic) = fit(job, &models, &tables, &mut rows, progress)?;
    let mut anisotropic_emitted = Vec::new();
    let (functions, written) = match &job.emit {
        EmitStage::EachFit { lut_resolution } => {
            anisotropic_emitted = emit_each_fit(
                job,
                *lut_resolution,
                &mut rows,
                anisotropic.as_ref(),
                progress,
            )?;
            (Vec::new(), Vec::new())
        }
        EmitStage::OneFilePerLanguage {
            langs,
            helpers,
            lut_resolution,
            command,
        } => {
            let sources = match sources {
                Some(s) => s,
                None => best_sources(job, &rows, &tables)?,
            };
            emit_one_file_per_language(
                job,
                &sources,
                langs,
                helpers,
                *lut_resolution,
                command,
                progress,
            )?
        }
    };
    if let Some(options) = &job.report {
        report(job, options, &mut rows, progress)?;
    }
    Ok(Outcome {
        rows,
        functions,
        written,
        anisotropic,
        anisotropic_emitted,
    })
}

/// Every output folder of `job` is writable (checked before anything is computed).
fn check_outputs(job: &Job) -> Result<()> {
    output::check_writable_dir(&job.data_dir, "--data-dir")?;
    if job.tables_only {
        return Ok(());
    }
    output::check_writable_dir(&job.fits_dir, "--fits-dir")?;
    match &job.emit {
        // `furnace run` puts these LUTs under its data folder
        EmitStage::EachFit { .. } => output::check_writable_dir(&job.lut_dir, "--data-dir")?,
        EmitStage::OneFilePerLanguage { langs, .. } if langs.contains(&Lang::Lut) => {
            output::check_writable_dir(&job.lut_dir, "--lut-dir")?
        }
        EmitStage::OneFilePerLanguage { .. } => {}
    }
    if let Some(r) = &job.report {
        output::check_writable_dir(&r.reports_dir, "--reports-dir")?;
    }
    Ok(())
}

/// The table's spec at `resolution` nodes per axis over its box.
fn spec_of(
    model: &dyn Model,
    t: &PlannedTable,
    resolution: &[usize],
    job: &Job,
) -> Result<TableSpec> {
    TableSpec::with_ranges(model, resolution, &t.ranges, job.quadrature.clone())
}

/// Stage 1: every table of the job, then the small tables of the LUTs and the report (so that
/// later stages only read the cache).
fn tabulate(
    job: &Job,
    models: &[Arc<dyn Model>],
    progress: &dyn Observer,
) -> Result<(Vec<Row>, Vec<Tabulated>)> {
    let steps = job.stages();
    let stage = Instant::now();
    progress.line(&format!(
        "[1/{steps}] tables ({} models; cached under {})",
        models.len(),
        job.data_dir.display()
    ));
    let mut rows = Vec::new();
    let mut tables: Vec<Tabulated> = Vec::new();
    for (k, (model, planned)) in models.iter().zip(&job.tables).enumerate() {
        let spec = spec_of(model.as_ref(), planned, &planned.resolution, job)?;
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
            ranges: planned.ranges.clone(),
            resolution: spec.resolution_name(),
            used_by: planned.used_by.clone(),
            cached: t.cached,
            table_seconds: t.seconds,
            fit: Fitted::None,
            emitted: Vec::new(),
            report_files: 0,
            furnace: None,
            off_grid: None,
        });
        tables.push(t);
    }
    if !job.tables_only {
        let mut small: Vec<TableSpec> = Vec::new();
        for (model, planned) in models.iter().zip(&job.tables) {
            let dims = planned.ranges.len();
            if let (EmitStage::EachFit { lut_resolution }, false) =
                (&job.emit, model.id().is_radiance())
            {
                small.push(spec_of(
                    model.as_ref(),
                    planned,
                    &vec![*lut_resolution; dims],
                    job,
                )?);
            }
            if let Some(report) = &job.report {
                // the report measures on the model's default domain
                let mut sizes = vec![if dims <= 2 {
                    report.resolution_2d
                } else {
                    report.resolution_3d
                }];
                if !model.id().is_radiance() {
                    sizes.extend(&report.furnace_luts);
                }
                for n in sizes {
                    small.push(TableSpec::new(
                        model.as_ref(),
                        &vec![n; dims],
                        QuadratureSettings::default(),
                    )?);
                }
            }
        }
        let mut computed = 0;
        for spec in small {
            let model = bsdf::get(spec.model_id()?)?;
            if !get_or_tabulate(model.as_ref(), &spec, &job.data_dir, false, progress)?.cached {
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
    Ok((rows, tables))
}

/// Stage 2: the fits of every table and, for a sweep, the anisotropic conductor's budget fits
/// ([`Job::anisotropic_fits`]); for [`FitStage::OnePerTable`], the emitter's view of each fit.
fn fit(
    job: &Job,
    models: &[Arc<dyn Model>],
    tables: &[Tabulated],
    rows: &mut [Row],
    progress: &dyn Observer,
) -> Result<(Option<Vec<SourceFit>>, Option<aniso::AnisoFits>)> {
    let steps = job.stages();
    let stage = Instant::now();
    let mut sources = None;
    let mut anisotropic = None;
    match &job.fit {
        FitStage::Sweep { max_degree } => {
            progress.line(&format!(
                "[2/{steps}] fits (degree sweeps into {})",
                job.fits_dir.display()
            ));
            for ((model, t), row) in models.iter().zip(tables).zip(rows.iter_mut()) {
                let dir = job.fits_dir.join(&row.name);
                let timing = job.data_dir.join("timing").join(&row.name);
                let place = SweepPlace {
                    dir: &dir,
                    timing: &timing,
                    max_degree: *max_degree,
                    refit: job.refit || job.force,
                };
                let step = sweep_or_reuse(model.as_ref(), t, place, progress)?;
                log_sweep(&row.name, &step, progress);
                if let (Some(check), false) = (&step.check, row.id.is_radiance()) {
                    let luts = offgrid::lut_errors(model.as_ref(), check, &job.data_dir, progress)?;
                    let s = offgrid::summary(&row.name, check, &step.best, luts);
                    row.emitted.push(s.write(&dir)?);
                    for l in s.losses() {
                        progress.line(&format!("    warning: {l}"));
                    }
                    row.off_grid = Some(s);
                }
                row.fit = Fitted::Sweep(step);
            }
            if let Some(resolution) = &job.anisotropic_fits {
                let a = aniso::fits_or_reuse(job, resolution, progress)?;
                log_sweep(&a.name, &a.step, progress);
                anisotropic = Some(a);
            }
        }
        FitStage::OnePerTable {
            degrees,
            stress_points,
        } => {
            progress.line(&format!(
                "[2/{steps}] fits ({} per table into {})",
                crate::fit::Form::Rational {
                    numerator_degree: degrees.numerator_degree,
                    denominator_degree: degrees.denominator_degree
                }
                .label(),
                job.fits_dir.display()
            ));
            let mut all = Vec::new();
            for (t, row) in tables.iter().zip(rows.iter_mut()) {
                let (one, source) =
                    scene::fit_one(row.id, t, degrees, *stress_points, &job.fits_dir, progress)?;
                row.fit = Fitted::One(one);
                all.push(source);
            }
            sources = Some(all);
        }
    }
    progress.line(&format!("  fits: {:.1} s", stage.elapsed().as_secs_f64()));
    Ok((sources, anisotropic))
}

fn log_sweep(name: &str, step: &FitStep, progress: &dyn Observer) {
    progress.line(&format!(
        "  {:<38} {}: {}",
        name,
        if step.reused {
            "reused (same table values and options)"
        } else {
            "fitted"
        },
        sweeps::best_line(&step.best)
            + &match step.seconds {
                Some((wall, Some(cpu))) => format!("; {wall:.1} s wall, {cpu:.1} s CPU"),
                Some((wall, None)) => format!("; {wall:.1} s wall"),
                None => String::new(),
            }
    ));
    if let Some(n) = &step.note {
        progress.line(&format!("    {n}"));
    }
}

/// Stage 3 of [`EmitStage::EachFit`]: every fit file's code next to it, and a LUT per table
/// with its last fit; files of an emit with the same inputs are kept ([`emits`]). The
/// anisotropic fits get code only (a LUT of four axes is a table); their files are returned.
fn emit_each_fit(
    job: &Job,
    lut_resolution: usize,
    rows: &mut [Row],
    anisotropic: Option<&aniso::AnisoFits>,
    progress: &dyn Observer,
) -> Result<Vec<PathBuf>> {
    let steps = job.stages();
    let stage = Instant::now();
    progress.line(&format!(
        "[3/{steps}] emit (Rust, WGSL, GLSL, HLSL, C/C++ next to each best fit; LUTs under {})",
        job.lut_dir.display()
    ));
    let fits: Vec<Vec<PathBuf>> = rows
        .iter()
        .map(|r| {
            if r.id.is_radiance() {
                Vec::new()
            } else {
                r.fit_files(&job.fits_dir)
            }
        })
        .collect();
    let aniso_fits = anisotropic.map_or(Vec::new(), |a| a.best_files(&job.fits_dir));
    let total: usize = fits.iter().map(Vec::len).sum::<usize>() + aniso_fits.len();
    progress.begin("emit", total as u64);
    let mut kept = 0;
    const CODE: &str = "rust,wgsl,glsl,hlsl,cpp";
    for (row, files) in rows.iter_mut().zip(fits) {
        for (k, fit) in files.iter().enumerate() {
            progress.message(&format!("emit {}", row.name));
            // one LUT per model, compared with the largest-budget fit
            let lang = if k + 1 == files.len() { "all" } else { CODE };
            let written = emit_kept(
                job,
                &row.name,
                fit,
                lang,
                lut_resolution,
                &mut kept,
                progress,
            )?;
            row.emitted.extend(written);
            progress.advance(1);
        }
    }
    let mut aniso_emitted = Vec::new();
    if let Some(a) = anisotropic {
        for fit in &aniso_fits {
            progress.message(&format!("emit {}", a.name));
            aniso_emitted.extend(emit_kept(
                job,
                &a.name,
                fit,
                CODE,
                lut_resolution,
                &mut kept,
                progress,
            )?);
            progress.advance(1);
        }
    }
    progress.end();
    progress.line(&format!(
        "  emit: {} files in {:.1} s ({kept} of {total} fits kept: same inputs)",
        rows.iter().map(|r| r.emitted.len()).sum::<usize>() + aniso_emitted.len(),
        stage.elapsed().as_secs_f64()
    ));
    Ok(aniso_emitted)
}

/// The files emitted for `fit` of model folder `name` in `lang`, or those of an emit with the
/// same inputs (counted in `kept`); a fit that cannot be emitted is reported and skipped.
fn emit_kept(
    job: &Job,
    name: &str,
    fit: &Path,
    lang: &str,
    lut_resolution: usize,
    kept: &mut usize,
    progress: &dyn Observer,
) -> Result<Vec<PathBuf>> {
    let options = EmitFileOptions {
        langs: parse_langs(lang)?,
        lang_arg: lang.into(),
        form: FormChoice::Auto,
        suffix: String::new(),
        data_dir: job.data_dir.clone(),
        lut_dir: job.lut_dir.clone(),
        lut_resolution,
        force: false,
    };
    // the files of an emit with the same inputs are kept (emits::reusable)
    let cache = emits::cache_path(&job.data_dir, name, fit);
    let inputs = emits::emit_inputs(fit, &job.data_dir, lang, lut_resolution);
    let previous = if job.force || job.refit {
        None
    } else {
        inputs.as_ref().and_then(|i| emits::reusable(&cache, i))
    };
    let outcome = match previous {
        Some(p) => {
            *kept += 1;
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
    Ok(match outcome {
        Ok(written) => written,
        Err(e) => {
            progress.line(&format!("  {name}: {} not emitted: {e}", fit.display()));
            Vec::new()
        }
    })
}

/// The emitter's view of each table's largest-budget best fit (a swept job emitted as one file
/// per language).
fn best_sources(job: &Job, rows: &[Row], tables: &[Tabulated]) -> Result<Vec<SourceFit>> {
    rows.iter()
        .zip(tables)
        .map(|(row, t)| {
            let path = row.fit_files(&job.fits_dir).pop().ok_or_else(|| {
                Error::InvalidInput(format!(
                    "{}: the sweep has no usable best fit to emit; see {}",
                    row.name,
                    job.fits_dir.join(&row.name).join("sweep.csv").display()
                ))
            })?;
            SourceFit::new(&path, fitfile::read(&path)?, Some(t.table.clone()))
        })
        .collect()
}

/// Stage 3 of [`EmitStage::OneFilePerLanguage`]: one unit with every fit's function and the
/// helpers named, `<fits>/<job name>.<ext>` per language, and LUTs with [`Lang::Lut`].
fn emit_one_file_per_language(
    job: &Job,
    sources: &[SourceFit],
    langs: &[Lang],
    helpers: &[String],
    lut_resolution: usize,
    command: &str,
    progress: &dyn Observer,
) -> Result<(Vec<EmittedFit>, Vec<PathBuf>)> {
    let stage = Instant::now();
    progress.line(&format!(
        "[3/{}] emit ({} into {})",
        job.stages(),
        langs
            .iter()
            .map(|l| format!("{l:?}").to_lowercase())
            .collect::<Vec<_>>()
            .join(", "),
        job.fits_dir.display()
    ));
    let stress_points = match job.fit {
        FitStage::OnePerTable { stress_points, .. } => stress_points,
        FitStage::Sweep { .. } => 0,
    };
    let (mut unit, functions) = emit::build_unit(
        &job.name,
        &emit::guard_macro(&format!("scene {}", job.name)),
        sources,
        command,
        &EmitOptions {
            helpers: Some(helpers.to_vec()),
            stress_points: stress_points.max(emit::stress::DEFAULT_POINTS),
            ..EmitOptions::default()
        },
    )?;
    if langs.contains(&Lang::Lut) {
        for (src, e) in sources.iter().zip(&functions) {
            let lut = emit::lut_for_fit(
                src,
                &unit,
                &e.function,
                lut_resolution,
                &job.data_dir,
                job.force,
            )?;
            unit.luts.push(lut);
        }
    }
    let mut artifacts = Vec::new();
    for &lang in langs {
        artifacts.extend(emit::emitter(lang).produce(&unit)?);
    }
    let written = emit::write_artifacts(&artifacts, &job.fits_dir, &job.lut_dir)?;
    progress.line(&format!(
        "  emit: {} files in {:.1} s",
        written.len(),
        stage.elapsed().as_secs_f64()
    ));
    Ok((functions, written))
}

/// Stage 4: the report's sections of the job's energy-form models (the radiance-form tables
/// are reported beside them).
fn report(
    job: &Job,
    options: &ReportOptions,
    rows: &mut [Row],
    progress: &dyn Observer,
) -> Result<()> {
    let stage = Instant::now();
    progress.line(&format!(
        "[4/{}] report ({})",
        job.stages(),
        options.reports_dir.join("README.md").display()
    ));
    let selected: Vec<ModelId> = rows
        .iter()
        .map(|r| r.id)
        .filter(|m| !m.is_radiance())
        .collect();
    let provider = CachedTables {
        data_dir: &job.data_dir,
        progress,
    };
    progress.begin("report", selected.len() as u64);
    let message =
        |m: &str| progress.message(&format!("report {}", m.split(':').next().unwrap_or(m)));
    let reporter = Reporter::new(options.clone(), &provider, &message);
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
