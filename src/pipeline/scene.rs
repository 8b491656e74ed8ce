//! What a scene adds to the pipeline: its options ([`RunOptions`], made into a job by
//! [`super::Job::scene`]) and the one fit per table of [`super::FitStage::OnePerTable`]
//! ([`fit_table`], [`fit_one`]). The scene runs through [`super::run`] like any job:
//!
//! ```no_run
//! use furnace::pipeline::{self, scene::RunOptions, Job};
//! use furnace::progress::Quiet;
//! use furnace::scene::Manifest;
//! # fn options() -> RunOptions { unimplemented!() }
//! let manifest = Manifest::read(std::path::Path::new("scene.json"))?;
//! let outcome = pipeline::run(&Job::scene(&manifest, &options())?, &Quiet)?;
//! println!("{} files", outcome.written.len());
//! # Ok::<(), furnace::Error>(())
//! ```

use std::path::{Path, PathBuf};

use crate::emit::generate::albedo_function_name;
use crate::emit::stress::StressReport;
use crate::emit::{self, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::fit::job::FitRecord;
use crate::fit::source::FittedOn;
use crate::fit::{fit_rational, FitData, FitResult, InputTransform, Objective, RationalOptions};
use crate::progress::Observer;
use crate::quadrature::QuadratureSettings;
use crate::scene::FitSettings;
use crate::table::{Table, Tabulated};

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

/// The one fit of a table ([`super::FitStage::OnePerTable`]).
#[derive(Clone, Debug)]
pub struct OneFit {
    /// The fit file written (`<fits>/<model>.json`).
    pub path: PathBuf,
    pub fit: FitResult,
    /// The denominator margin of the fit (one of [`DENOMINATOR_MARGINS`]).
    pub margin: f64,
    pub stress: Option<StressReport>,
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

/// Fits table `t` of `model` with a rational of `degrees` ([`fit_table`], stress-tested at
/// `stress_points` but at least the emit's own number of points, so that what passes here is
/// emitted; 0 skips the test), writes the fit file `<dir>/<model>.json` and returns it with the
/// emitter's view of it.
pub fn fit_one(
    model: crate::bsdf::ModelId,
    t: &Tabulated,
    degrees: &FitSettings,
    stress_points: usize,
    dir: &Path,
    progress: &dyn Observer,
) -> Result<(OneFit, SourceFit)> {
    let points = match stress_points {
        0 => 0,
        n => n.max(emit::stress::DEFAULT_POINTS),
    };
    let stable = fit_table(&t.table, degrees, &model.name(), points)?;
    for (m, why) in &stable.rejected {
        progress.line(&format!(
            "  {model}: denominator margin {m} rejected: {why}"
        ));
    }
    let fit = stable.fit;
    progress.line(&format!(
        "  {model}: {} (denominator margin {}) MAE {:.2e}, max {:.2e}{}",
        fit.form.label(),
        stable.margin,
        fit.metrics.mae,
        fit.metrics.max_abs_error,
        stable.stress.as_ref().map_or(String::new(), |r| format!(
            "; f32 stress passed at {} points",
            r.random_points + r.edge_points
        ))
    ));
    let input = crate::fit::source::from_table(&t.table, "E", Some(&t.stem))?;
    let file = FitRecord::new(
        fit.clone(),
        &input,
        FittedOn {
            points: input.data.len(),
            selection: "all points".into(),
        },
    );
    let path = dir.join(format!("{}.json", model.key()));
    crate::output::write(&path, file.to_json()?.as_bytes())?;
    let source = SourceFit::new(&path, file, Some(t.table.clone()))?;
    Ok((
        OneFit {
            path,
            fit,
            margin: stable.margin,
            stress: stable.stress,
        },
        source,
    ))
}
