//! The scene job: a manifest's plan ([`crate::scene::plan`]) through the pipeline's stages —
//! the tables from the cache ([`crate::table::get_or_tabulate`]), one stress-tested rational fit
//! per table ([`fit_table`], in place of the default set's degree sweep), and one emitted file per
//! language with only the functions and helpers the scene's materials use.
//!
//! ```no_run
//! use furnace::pipeline::scene::{self, RunOptions};
//! use furnace::scene::Manifest;
//! # fn options() -> RunOptions { unimplemented!() }
//! let manifest = Manifest::read(std::path::Path::new("scene.json"))?;
//! let outcome = scene::run(&manifest, &options(), &|line| eprintln!("{line}"))?;
//! println!("{} files", outcome.written.len());
//! # Ok::<(), furnace::Error>(())
//! ```

use std::path::PathBuf;

use crate::bsdf;
use crate::emit::generate::albedo_function_name;
use crate::emit::stress::StressReport;
use crate::emit::{self, build_unit, EmitOptions, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::fit::job::FitRecord;
use crate::fit::source::FittedOn;
use crate::fit::{fit_rational, FitData, FitResult, InputTransform, Objective, RationalOptions};
use crate::quadrature::QuadratureSettings;
use crate::scene::{plan, FitSettings, Manifest, Plan, TableNeed};
use crate::table::{Table, TableSpec};

/// Where and how to run a scene.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub data_dir: PathBuf,
    /// Outputs go to `<fits_dir>/<scene name>/`.
    pub fits_dir: PathBuf,
    pub lut_dir: PathBuf,
    pub force: bool,
    pub quadrature: QuadratureSettings,
    pub langs: Vec<Lang>,
    pub lut_resolution: usize,
    /// Random points of the f32 stress test of each fit (0 skips it).
    pub stress_points: usize,
    /// The command line that regenerates the output, quoted in the emitted headers.
    pub command: String,
}

/// One fitted table of a scene run.
#[derive(Clone, Debug)]
pub struct FittedTable {
    pub need: TableNeed,
    pub table_cached: bool,
    pub fit_path: PathBuf,
    pub fit: FitResult,
    pub stress: Option<StressReport>,
}

/// What a scene run did.
#[derive(Clone, Debug)]
pub struct SceneOutcome {
    pub plan: Plan,
    pub fitted: Vec<FittedTable>,
    pub emitted: Vec<emit::EmittedFit>,
    pub written: Vec<PathBuf>,
}

/// Denominator margins tried in turn (see `RationalOptions::denominator_margin`): the fitter's
/// default first (most accurate), then larger ones, which keep Q further from zero. A rational
/// whose Q nearly vanishes somewhere amplifies f32 rounding by 1/Q there: the 12³ leaving-
/// dielectric fit of `tests/fixtures` has Q down to 8e-4 and an f32 error of 2.2e-5 at
/// margin 1e-3, but 2.5e-6 at margin 1e-2 for 0.4% more MAE.
pub const DENOMINATOR_MARGINS: [f64; 5] = [1e-3, 1e-2, 3e-2, 1e-1, 3e-1];

/// A fit of a table that is certified pole-free and, if `stress_points` > 0, passed the f32
/// stress test.
#[derive(Clone, Debug)]
pub struct StableFit {
    pub fit: FitResult,
    pub margin: f64,
    pub stress: Option<StressReport>,
    /// Margins tried before, with why they were rejected.
    pub rejected: Vec<(f64, String)>,
}

/// Fits output `E` of a table with a rational of the given degrees (identity transforms, the
/// paper's form) over the table's own domain; tries [`DENOMINATOR_MARGINS`] in turn until the fit
/// is certified and passes the f32 stress test at `stress_points` random points (0: certified
/// is enough).
pub fn fit_table(
    table: &Table,
    settings: &FitSettings,
    model: &str,
    stress_points: usize,
) -> Result<StableFit> {
    let names: Vec<String> = table.spec.axes.iter().map(|a| a.name.clone()).collect();
    let axes: Vec<Vec<f64>> = table.spec.axes.iter().map(|a| a.nodes()).collect();
    let data = FitData::from_grid(names, &axes, table.output(0).to_vec())?;
    let d = axes.len();
    let mut rejected = Vec::new();
    for margin in DENOMINATOR_MARGINS {
        let opts = RationalOptions {
            denominator_margin: margin,
            ..RationalOptions::default()
        };
        let fit = match fit_rational(
            &data,
            &vec![InputTransform::Identity; d],
            settings.numerator_degree,
            settings.denominator_degree,
            Objective::LeastSquares,
            &opts,
        ) {
            Ok(f) => f,
            Err(e) => {
                rejected.push((margin, e.to_string()));
                continue;
            }
        };
        if !fit.is_usable() {
            rejected.push((margin, format!("not certified pole-free ({:?})", fit.poles)));
            continue;
        }
        if stress_points == 0 {
            return Ok(StableFit {
                fit,
                margin,
                stress: None,
                rejected,
            });
        }
        // the gate every emitted fit passes (all evaluation forms are tried)
        match emit::stress_gate(
            &fit,
            &albedo_function_name(model, "E"),
            emit::generate::FormChoice::Auto,
            stress_points,
        ) {
            Ok((_, _, report)) => {
                return Ok(StableFit {
                    fit,
                    margin,
                    stress: Some(report),
                    rejected,
                })
            }
            Err(why) => rejected.push((margin, why)),
        }
    }
    Err(Error::InvalidInput(format!(
        "no {} fit of {} is both pole-free and stable in f32 (denominator margins tried: {}); lower fit.numerator_degree / fit.denominator_degree in the manifest or narrow the material ranges",
        crate::fit::Form::Rational { numerator_degree: settings.numerator_degree, denominator_degree: settings.denominator_degree }.label(),
        table.spec.model,
        rejected.iter().map(|(m, why)| format!("{m}: {why}")).collect::<Vec<_>>().join(" | ")
    )))
}

/// Runs a scene: plan, tabulate (cached) and fit only what it needs, stress-test the fits in
/// f32, and emit one file per language with only the needed functions.
pub fn run(manifest: &Manifest, opts: &RunOptions, log: &dyn Fn(&str)) -> Result<SceneOutcome> {
    let plan = plan(manifest)?;
    log(&plan.human());
    let out_dir = opts.fits_dir.join(&plan.scene);
    let mut fitted = Vec::new();
    let mut sources = Vec::new();
    for need in &plan.tables {
        let model = bsdf::get(need.model)?;
        bsdf::check_no_degenerate_slice(model.as_ref(), &need.ranges, &|a, (lo, hi)| {
            format!("narrow the materials' {a} range in the manifest to leave the slice out (the model's default range is [{lo}, {hi}])")
        })?;
        let spec = TableSpec::with_ranges(
            model.as_ref(),
            &need.resolution,
            &need.ranges,
            opts.quadrature.clone(),
        )?;
        log(&format!(
            "  {} {}: tabulating {} cells (or reading them from the cache) …",
            need.model,
            spec.resolution_name(),
            spec.cells()
        ));
        let crate::table::Tabulated {
            table,
            stem,
            cached,
            ..
        } = crate::table::get_or_tabulate(
            model.as_ref(),
            &spec,
            &opts.data_dir,
            opts.force,
            &crate::progress::Quiet,
        )?;
        log(&format!(
            "  {} {}: table {}",
            need.model,
            spec.resolution_name(),
            if cached {
                "read from cache"
            } else {
                "computed"
            }
        ));
        // the emit gate's own number of points, so what passes here is emitted
        let points = match opts.stress_points {
            0 => 0,
            n => n.max(emit::stress::DEFAULT_POINTS),
        };
        let stable = fit_table(&table, &plan.fit, &need.model.name(), points)?;
        for (m, why) in &stable.rejected {
            log(&format!(
                "  {}: denominator margin {m} rejected: {why}",
                need.model
            ));
        }
        let fit = stable.fit;
        log(&format!(
            "  {}: {} (denominator margin {}) MAE {:.2e}, max {:.2e}{}",
            need.model,
            fit.form.label(),
            stable.margin,
            fit.metrics.mae,
            fit.metrics.max_abs_error,
            stable.stress.as_ref().map_or(String::new(), |r| format!(
                "; f32 stress passed at {} points",
                r.random_points + r.edge_points
            ))
        ));
        let stress_report = stable.stress;
        let input = crate::fit::source::from_table(&table, "E", Some(&stem))?;
        let file = FitRecord::new(
            fit.clone(),
            &input,
            FittedOn {
                points: input.data.len(),
                selection: "all points".into(),
            },
        );
        let fit_path = out_dir.join(format!("{}.json", need.model.key()));
        crate::output::write(&fit_path, file.to_json()?.as_bytes())?;
        sources.push(SourceFit::new(&fit_path, file, Some(table.clone()))?);
        fitted.push(FittedTable {
            need: need.clone(),
            table_cached: cached,
            fit_path,
            fit,
            stress: stress_report,
        });
    }
    let keep = plan.helper_names();
    let (mut unit, emitted) = build_unit(
        &plan.scene,
        &emit::guard_macro(&format!("scene {}", plan.scene)),
        &sources,
        &opts.command,
        &EmitOptions {
            helpers: Some(keep),
            stress_points: opts.stress_points.max(emit::stress::DEFAULT_POINTS),
            ..EmitOptions::default()
        },
    )?;
    if opts.langs.contains(&Lang::Lut) {
        for (src, e) in sources.iter().zip(&emitted) {
            let lut = emit::lut_for_fit(
                src,
                &unit,
                &e.function,
                opts.lut_resolution,
                &opts.data_dir,
                opts.force,
            )?;
            unit.luts.push(lut);
        }
    }
    let mut artifacts = Vec::new();
    for &lang in &opts.langs {
        artifacts.extend(emit::emitter(lang).produce(&unit)?);
    }
    let written = emit::write_artifacts(&artifacts, &out_dir, &opts.lut_dir)?;
    Ok(SceneOutcome {
        plan,
        fitted,
        emitted,
        written,
    })
}
