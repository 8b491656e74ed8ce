//! `furnace run`: the arguments → a [`Job`] (the built-in default set, or a scene with
//! `--scene`) → [`crate::pipeline::run`] with progress bars → a summary table.

use super::scene::SceneArgs;
use super::Bars;
use crate::error::Result;
use crate::pipeline::{self, FitStage, Job, Row};
use crate::report::model::fmt_e;
use clap::Args;
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
    /// table values with the same options (after a change to the fitting code), and emit every
    /// fit again.
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
    /// `ggx-dielectric-inv-separable-radiance`; `ggx-conductor-aniso` for the anisotropic
    /// conductor's budget fits).
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

/// The default set's job `args` ask for.
fn default_job(args: &RunArgs) -> Result<Job> {
    let mut job = Job::default_set(Path::new("."));
    job.data_dir = args.data_dir.clone();
    job.fits_dir = args.scene.fits_dir.clone();
    job.lut_dir = args.data_dir.join("lut");
    job.force = args.force;
    job.refit = args.refit;
    job.tables_only = args.tables_only;
    let three_d = args
        .resolution_3d
        .unwrap_or(crate::scene::DEFAULT_RESOLUTION_3D);
    let two_d = args
        .resolution_2d
        .unwrap_or(crate::scene::DEFAULT_RESOLUTION_2D);
    job.set_resolution(two_d, three_d);
    job.fit = FitStage::Sweep {
        max_degree: args.max_degree,
    };
    if !args.models.is_empty() {
        job.only(&args.models)?;
    }
    if let Some(report) = &mut job.report {
        report.reports_dir = args.reports_dir.clone();
        report.fits_dir = args.scene.fits_dir.clone();
        report.bench_dir = args.reports_dir.join("bench");
        report.paper_dir = super::report::default_paper_dir();
    }
    if args.quick_report {
        job.quick_report();
    }
    if args.no_report {
        job.report = None;
    }
    Ok(job)
}

/// `furnace run`: the default set, or the scene of `--scene`.
pub fn run_cmd(args: &RunArgs) -> Result<()> {
    let start = Instant::now();
    let job = match &args.scene.scene {
        Some(path) => super::scene::scene_job(&args.scene, path, &args.data_dir, args.force)?,
        None => default_job(args)?,
    };
    let outcome = pipeline::run(&job, &Bars::default())?;
    match &args.scene.scene {
        Some(_) => super::scene::print_summary(&outcome, start),
        None => print_summary(&outcome, args, start),
    }
}

fn print_summary(outcome: &pipeline::Outcome, args: &RunArgs, start: Instant) -> Result<()> {
    let rows = &outcome.rows;
    let mut budgets: Vec<usize> = rows
        .iter()
        .filter_map(Row::sweep)
        .flat_map(|s| s.best.iter().map(|b| b.0))
        .collect();
    budgets.sort_unstable();
    budgets.dedup();
    outln!()?;
    let mut head = format!(
        "{:<38} {:>12} {:>7} {:>9} {:>7}",
        "model", "table", "cached", "table s", "fits"
    );
    for b in &budgets {
        head.push_str(&format!(" {:>9}", format!("best-{b}")));
    }
    head.push_str(&format!(
        " {:>9} {:>13} {:>6}",
        format!("LUT-{}", pipeline::LUT_TO_BEAT),
        "furnace |1−E|",
        "files"
    ));
    outln!("{head}")?;
    let mut files = 0;
    let mut losses = Vec::new();
    for r in rows {
        let sweep = r.sweep();
        let best = |b: usize| {
            sweep
                .and_then(|s| s.best.iter().find(|x| x.0 == b))
                .and_then(|x| x.1.as_ref())
                .map_or("–".to_string(), |s| fmt_e(s.max_abs_error))
        };
        let fits = match sweep {
            None => "–",
            Some(s) if s.reused => "reused",
            Some(_) => "fitted",
        };
        let n = sweep.map_or(0, |s| s.files.len())
            + r.emitted.len()
            + r.report_files
            + if r.cached { 0 } else { 3 };
        files += n;
        let mut line = format!(
            "{:<38} {:>12} {:>7} {:>9.1} {:>7}",
            r.name,
            r.resolution,
            if r.cached { "yes" } else { "no" },
            r.table_seconds,
            fits,
        );
        for &b in &budgets {
            line.push_str(&format!(" {:>9}", best(b)));
        }
        let lut = r
            .off_grid
            .as_ref()
            .and_then(|o| o.luts.iter().find(|l| l.per_axis == pipeline::LUT_TO_BEAT))
            .map_or("–".to_string(), |l| fmt_e(l.errors.max_abs_error));
        line.push_str(&format!(
            " {:>9} {:>13} {:>6}",
            lut,
            r.furnace.map_or("–".to_string(), fmt_e),
            n
        ));
        outln!("{line}")?;
        if let Some(o) = &r.off_grid {
            losses.extend(o.losses());
        }
    }
    if let Some(a) = &outcome.anisotropic {
        let n = a.step.files.len() + outcome.anisotropic_emitted.len();
        files += n;
        outln!(
            "{:<38} 4-D fits {}: {}; {n} files",
            a.name,
            if a.step.reused { "reused" } else { "fitted" },
            pipeline::sweeps::best_line(&a.step.best)
        )?;
    }
    outln!(
        "best-N, LUT-{}: max |E − exact| at the off-grid check points of each table (fits/<model>/off-grid.json; at the table nodes for a table without check points); furnace: max |1 − E| of the BSDF compensated with the report's chosen fit (reports/README.md)",
        pipeline::LUT_TO_BEAT
    )?;
    if losses.is_empty() {
        if rows.iter().any(|r| r.off_grid.is_some()) {
            outln!(
                "every best fit beats the {}-per-axis LUT on max error and MAE",
                pipeline::LUT_TO_BEAT
            )?;
        }
    } else {
        outln!(
            "WARNING: {} best fits lose to the {}-per-axis LUT (a renderer would rather use the LUT):",
            losses.len(),
            pipeline::LUT_TO_BEAT
        )?;
        for l in &losses {
            outln!("  {l}")?;
        }
    }
    outln!(
        "{files} files written or confirmed under {}, {}, {} and {}; total {:.1} s",
        args.data_dir.display(),
        args.scene.fits_dir.display(),
        args.data_dir.join("lut").display(),
        args.reports_dir.display(),
        start.elapsed().as_secs_f64()
    )
}
