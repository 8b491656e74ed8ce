//! `furnace report`: regenerate `reports/` (all models, or one with `--model`).

use super::Bars;
use crate::error::Result;
use crate::pipeline::CachedTables;
use crate::report::model::{fmt_e, ReportOptions, Reporter};
use crate::report::offgrid::LUT_TO_BEAT;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct ReportArgs {
    /// Regenerate only this model's section (then rebuild README.md from every section).
    #[arg(long)]
    pub model: Option<String>,
    /// Output folder.
    #[arg(long, default_value = "reports")]
    pub reports_dir: PathBuf,
    /// Folder of fit files, one subfolder per model.
    #[arg(long, default_value = "fits")]
    pub fits_dir: PathBuf,
    /// Folder of cached tables (missing ones are computed and cached).
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Folder of benchmark CSV files (one plot each), written only by the benchmark commands'
    /// `--output` (default: <reports-dir>/bench).
    #[arg(long)]
    pub bench_dir: Option<PathBuf>,
    /// The paper's published coefficients and tables (`coefficients/`, `tables/`); default:
    /// $FURNACE_PAPER_DATA, else data/paper. Missing: no paper comparison.
    #[arg(long)]
    pub paper_dir: Option<PathBuf>,
    /// Nodes per axis of the 2-D tables fits are measured against (default 65).
    #[arg(long)]
    pub resolution_2d: Option<usize>,
    /// Nodes per axis of the 3-D tables (default 17).
    #[arg(long)]
    pub resolution_3d: Option<usize>,
    /// Nodes per axis of the 2-D LUTs (default 32, as `furnace run` emits them; every k-th table
    /// node when (n−1) is a multiple of (m−1), else tabulated at that size).
    #[arg(long)]
    pub lut_2d: Option<usize>,
    /// Nodes per axis of the 3-D LUTs (default 32).
    #[arg(long)]
    pub lut_3d: Option<usize>,
    /// White furnace: at most this many table nodes per r and μ axis (default 33).
    #[arg(long)]
    pub furnace_nodes: Option<usize>,
    /// White furnace: F0 slices of 3-D tables (default 3: both ends and one between).
    #[arg(long)]
    pub furnace_f0_slices: Option<usize>,
    /// Table of the anisotropic conductor's section, nodes of r x aniso x mu x phi (default
    /// 16x8x16x8), or `none` to leave the section out; its fits are the ones `furnace run` wrote
    /// under `--fits-dir`.
    #[arg(long)]
    pub anisotropy: Option<String>,
}

pub(super) fn default_paper_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("FURNACE_PAPER_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| "data/paper".into());
    dir.join("coefficients").is_dir().then_some(dir)
}

pub fn report_cmd(args: &ReportArgs) -> Result<()> {
    // an unwritable report folder is refused before any table is computed or measured
    crate::output::check_dir_creatable(&args.reports_dir, "--reports-dir")?;
    if !args.fits_dir.is_dir() {
        return Err(crate::Error::file(
            &args.fits_dir,
            "no such folder; point --fits-dir at the folder of fit files, one subfolder per model (`furnace run` writes fits/)",
        ));
    }
    let mut options = ReportOptions::new(Path::new("."));
    options.reports_dir = args.reports_dir.clone();
    options.fits_dir = args.fits_dir.clone();
    options.bench_dir = args
        .bench_dir
        .clone()
        .unwrap_or_else(|| args.reports_dir.join("bench"));
    options.paper_dir = match &args.paper_dir {
        Some(d) => {
            if !d.join("coefficients").is_dir() {
                return Err(crate::Error::file(d, "no coefficients/ folder here; point --paper-dir at the paper repository's resources/ data"));
            }
            Some(d.clone())
        }
        None => default_paper_dir(),
    };
    let set = |v: Option<usize>, d: &mut usize| {
        if let Some(v) = v {
            *d = v;
        }
    };
    set(args.resolution_2d, &mut options.resolution_2d);
    set(args.resolution_3d, &mut options.resolution_3d);
    set(args.lut_2d, &mut options.lut_2d);
    set(args.lut_3d, &mut options.lut_3d);
    set(args.furnace_nodes, &mut options.furnace_nodes);
    set(args.furnace_f0_slices, &mut options.furnace_f0_slices);
    for (flag, v) in [
        ("--resolution-2d", options.resolution_2d),
        ("--resolution-3d", options.resolution_3d),
        ("--lut-2d", options.lut_2d),
        ("--lut-3d", options.lut_3d),
        ("--furnace-nodes", options.furnace_nodes),
        ("--furnace-f0-slices", options.furnace_f0_slices),
    ] {
        if v < 2 {
            return Err(crate::Error::InvalidInput(format!(
                "{flag} {v}: a grid needs at least 2 nodes per axis"
            )));
        }
    }
    match args.anisotropy.as_deref() {
        None => {}
        Some("none") => options.anisotropy = None,
        Some(text) => {
            let n = super::parse_resolution(
                "--anisotropy",
                Some(text),
                &crate::report::aniso::DEFAULT_RESOLUTION,
            )
            .map_err(|e| {
                crate::Error::InvalidInput(format!("{e}; or `none` to leave the section out"))
            })?;
            if n.iter().any(|&k| k < 2) {
                return Err(crate::Error::InvalidInput(format!(
                    "--anisotropy {text}: a grid needs at least 2 nodes per axis"
                )));
            }
            options.anisotropy = Some(n);
        }
    }
    let bars = Bars::default();
    let tables = CachedTables {
        data_dir: &args.data_dir,
        progress: &bars,
    };
    let progress = |m: &str| eprintln!("report: {m}");
    let reporter = Reporter::new(options, &tables, &progress);
    let models = match &args.model {
        Some(m) => Some(vec![crate::bsdf::lookup(m)?]),
        None => None,
    };
    let outcome = reporter.generate(models.as_deref())?;
    outln!(
        "{:<30} {:<22} {:>6} {:>10} {:>10}   furnace max |1 − E|: none / table / LUT {LUT_TO_BEAT} / fit",
        "model", "chosen fit", "coeffs", "MAE", "max err"
    )?;
    for s in &outcome.regenerated {
        let (form, n, mae, max) = match s.chosen.and_then(|k| s.fits.get(k)) {
            Some(f) => (
                f.form.clone(),
                f.n_coefficients.to_string(),
                fmt_e(f.measured.mae),
                fmt_e(f.measured.max_abs),
            ),
            None => ("no fit".into(), "-".into(), "-".into(), "-".into()),
        };
        let furnace: Vec<String> = s
            .furnace
            .iter()
            .map(|r| {
                let lut = format!("LUT {LUT_TO_BEAT}×");
                let v: Vec<String> = [
                    r.variants.iter().find(|v| v.name == "no compensation"),
                    r.variants
                        .iter()
                        .find(|v| v.name.starts_with("exact table")),
                    r.variants
                        .iter()
                        .find(|v| v.name.starts_with(&lut))
                        .or_else(|| r.variants.iter().find(|v| v.name.starts_with("LUT"))),
                    r.variants.iter().find(|v| v.name == "furnace fit"),
                ]
                .iter()
                .map(|v| {
                    v.and_then(|v| v.stats.as_ref())
                        .map_or("-".into(), |st| fmt_e(st.max_deviation))
                })
                .collect();
                format!("{}: {}", r.id, v.join(" / "))
            })
            .collect();
        outln!(
            "{:<30} {:<22} {:>6} {:>10} {:>10}   {}",
            s.model,
            form,
            n,
            mae,
            max,
            furnace.join("; ")
        )?;
    }
    outln!(
        "wrote {} ({} linked files)",
        outcome.readme.display(),
        outcome.linked.len()
    )?;
    Ok(())
}
