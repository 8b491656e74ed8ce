//! `furnace report`: regenerate `reports/` (all models, or one with `--model`).

use super::get_table;
use crate::bsdf::Model;
use crate::error::Result;
use crate::quadrature::QuadratureSettings;
use crate::report::inputs::TableProvider;
use crate::report::model::{fmt_e, ReportOptions, Reporter};
use crate::table::{Table, TableSpec};
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
    /// Folder of benchmark CSV files (one plot each).
    #[arg(long, default_value = "bench")]
    pub bench_dir: PathBuf,
    /// The paper's published coefficients and tables (`coefficients/`, `tables/`); default:
    /// $FURNACE_PAPER_DATA, else ../shared/paper-repo-data. Missing: no paper comparison.
    #[arg(long)]
    pub paper_dir: Option<PathBuf>,
    /// Nodes per axis of the 2-D tables fits are measured against.
    #[arg(long, default_value_t = 65)]
    pub resolution_2d: usize,
    /// Nodes per axis of the 3-D tables.
    #[arg(long, default_value_t = 17)]
    pub resolution_3d: usize,
    /// Nodes per axis of the 2-D LUTs (every k-th table node when (n−1) is a multiple of (m−1)).
    #[arg(long, default_value_t = 33)]
    pub lut_2d: usize,
    /// Nodes per axis of the 3-D LUTs.
    #[arg(long, default_value_t = 9)]
    pub lut_3d: usize,
    /// White furnace: at most this many table nodes per r and μ axis.
    #[arg(long, default_value_t = 33)]
    pub furnace_nodes: usize,
    /// White furnace: F0 slices of 3-D tables.
    #[arg(long, default_value_t = 3)]
    pub furnace_f0_slices: usize,
}

/// Tables from the cache under `data_dir`, computed (with progress) when missing.
struct CachedTables<'a> {
    data_dir: &'a Path,
}

impl TableProvider for CachedTables<'_> {
    fn table(&self, model: &dyn Model, resolution: &[usize]) -> Result<Table> {
        let spec = TableSpec::new(model, resolution, QuadratureSettings::default())?;
        Ok(get_table(model, &spec, self.data_dir, false)?.table)
    }
}

fn default_paper_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("FURNACE_PAPER_DATA").map(PathBuf::from).unwrap_or_else(|| "../shared/paper-repo-data".into());
    dir.join("coefficients").is_dir().then_some(dir)
}

pub fn report_cmd(args: &ReportArgs) -> Result<()> {
    let mut options = ReportOptions::new(Path::new("."));
    options.reports_dir = args.reports_dir.clone();
    options.fits_dir = args.fits_dir.clone();
    options.bench_dir = args.bench_dir.clone();
    options.paper_dir = match &args.paper_dir {
        Some(d) => {
            if !d.join("coefficients").is_dir() {
                return Err(crate::Error::file(d, "no coefficients/ folder here; point --paper-dir at the paper repository's resources/ data"));
            }
            Some(d.clone())
        }
        None => default_paper_dir(),
    };
    options.resolution_2d = args.resolution_2d;
    options.resolution_3d = args.resolution_3d;
    options.lut_2d = args.lut_2d;
    options.lut_3d = args.lut_3d;
    options.furnace_nodes = args.furnace_nodes;
    options.furnace_f0_slices = args.furnace_f0_slices;
    for (flag, v) in [("--resolution-2d", args.resolution_2d), ("--resolution-3d", args.resolution_3d), ("--lut-2d", args.lut_2d), ("--lut-3d", args.lut_3d), ("--furnace-nodes", args.furnace_nodes)] {
        if v < 2 {
            return Err(crate::Error::InvalidInput(format!("{flag} {v}: a grid needs at least 2 nodes per axis")));
        }
    }
    let tables = CachedTables { data_dir: &args.data_dir };
    let progress = |m: &str| eprintln!("report: {m}");
    let reporter = Reporter::new(options, &tables, &progress);
    let models = args.model.as_ref().map(|m| vec![m.clone()]);
    let outcome = reporter.generate(models.as_deref())?;
    println!("{:<30} {:<22} {:>6} {:>10} {:>10}   furnace max |1 − E|: none / table / LUT / fit", "model", "chosen fit", "coeffs", "MAE", "max err");
    for s in &outcome.regenerated {
        let (form, n, mae, max) = match s.chosen.and_then(|k| s.fits.get(k)) {
            Some(f) => (f.form.clone(), f.n_coefficients.to_string(), fmt_e(f.measured.mae), fmt_e(f.measured.max_abs)),
            None => ("no fit".into(), "-".into(), "-".into(), "-".into()),
        };
        let furnace: Vec<String> = s
            .furnace
            .iter()
            .map(|r| {
                let v: Vec<String> = r.variants.iter().take(4).map(|v| v.stats.as_ref().map_or("-".into(), |st| fmt_e(st.max_deviation))).collect();
                format!("{}: {}", r.id, v.join(" / "))
            })
            .collect();
        println!("{:<30} {:<22} {:>6} {:>10} {:>10}   {}", s.model, form, n, mae, max, furnace.join("; "));
    }
    println!("wrote {} ({} linked files)", outcome.readme.display(), outcome.linked.len());
    Ok(())
}
