//! `furnace run --scene scene.json`: the scene options of the `run` command, the scene's
//! [`Job`] and its summary table.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use crate::emit::parse_langs;
use crate::error::Result;
use crate::pipeline::scene::RunOptions;
use crate::pipeline::{Job, Outcome};
use crate::quadrature::QuadratureSettings;
use crate::scene::Manifest;

#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Scene manifest: tabulate, fit and emit only what its materials need (see
    /// docs/scenes.md). Without it, `run` tabulates the default model set.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Folder for the scene's fits and emitted code (`<fits-dir>/<scene name>/`).
    #[arg(long, default_value = "fits")]
    pub fits_dir: PathBuf,
    /// Output formats for the scene: rust, wgsl, glsl, hlsl, cpp, lut, all (or a comma-separated
    /// list).
    #[arg(long, default_value = "rust,wgsl,glsl")]
    pub lang: String,
    /// Folder for LUTs (with `--lang lut` or `all`).
    #[arg(long, default_value = "data/lut")]
    pub lut_dir: PathBuf,
    /// Nodes per axis of LUTs.
    #[arg(long, default_value_t = 32)]
    pub lut_resolution: usize,
    /// Random points (at least 10⁶, besides the edges) of the f32 stress test each fit must pass
    /// before anything is emitted; a fit that fails it is refitted with a larger denominator
    /// margin.
    #[arg(long, default_value_t = crate::emit::stress::DEFAULT_POINTS)]
    pub stress_points: usize,
}

/// The job of the scene manifest at `path`, with the options of `args`.
pub fn scene_job(args: &SceneArgs, path: &Path, data_dir: &Path, force: bool) -> Result<Job> {
    crate::emit::check_stress_points(args.stress_points)?;
    let manifest = Manifest::read(path)?;
    let opts = RunOptions {
        data_dir: data_dir.to_path_buf(),
        fits_dir: args.fits_dir.clone(),
        lut_dir: args.lut_dir.clone(),
        force,
        quadrature: QuadratureSettings::default(),
        langs: parse_langs(&args.lang)?,
        lut_resolution: args.lut_resolution,
        stress_points: args.stress_points,
        command: format!(
            "furnace run --scene {} --lang {}",
            path.display(),
            args.lang
        ),
    };
    Job::scene(&manifest, &opts)
}

/// The table of a scene's fits and the files written.
pub fn print_summary(out: &Outcome, start: Instant) -> Result<()> {
    outln!(
        "{:<30} {:>12} {:>8} {:>10} {:>10} {:>10} {:>12}",
        "model",
        "table",
        "cached",
        "fit MAE",
        "fit max",
        "f32 max Δ",
        "stress"
    )?;
    for (r, e) in out.rows.iter().zip(&out.functions) {
        let Some(f) = r.one() else { continue };
        outln!(
            "{:<30} {:>12} {:>8} {:>10.2e} {:>10.2e} {:>10.1e} {:>12}",
            r.id,
            r.resolution,
            if r.cached { "yes" } else { "no" },
            f.fit.metrics.mae,
            f.fit.metrics.max_abs_error,
            e.form.chosen().max_diff(),
            f.stress
                .as_ref()
                .map_or("skipped".to_string(), |s| if s.passed() {
                    format!("pass ({})", s.random_points)
                } else {
                    "FAIL".into()
                })
        )?;
    }
    for w in &out.written {
        outln!("wrote {}", w.display())?;
    }
    outln!("total {:.1} s", start.elapsed().as_secs_f64())
}
