//! Command-line interface: clap arguments → checked configuration → one library call per
//! subcommand. Nothing here computes; it only parses, reports and writes.

mod bench;
mod eval;
mod report;

use crate::bsdf::{self, ModelOptions};
use crate::error::{Error, Result};
use crate::quadrature::QuadratureSettings;
use crate::table::{self, io, Table, TableSpec};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(name = "furnace", version, about = "Directional-albedo tables, fits and emitters that make BSDFs pass the white furnace test")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// List the built-in models with their axes, ranges and a line on what they are.
    Models,
    /// Tabulate a model's directional albedo on a grid (cached under data/).
    Tabulate(TabulateArgs),
    /// Evaluate E at arbitrary points by direct quadrature (no interpolation).
    Eval(EvalArgs),
    /// Benchmarks that print run time against error.
    Bench(BenchArgs),
    /// The main job on the built-in default set: tabulate (cached) every default model.
    Run(RunArgs),
    /// Error reports and the white furnace test: regenerate reports/ (or one model's section).
    Report(report::ReportArgs),
}

#[derive(Args, Debug, Clone)]
pub struct QuadratureArgs {
    /// Gauss–Legendre points per panel and dimension.
    #[arg(long, default_value_t = crate::quadrature::DEFAULT_ORDER)]
    pub order: usize,
    /// Lower order of the per-cell error estimate |Q(order) − Q(companion)| (default ⌈3·order/4⌉).
    #[arg(long)]
    pub companion: Option<usize>,
    /// Per-cell tolerance on the error estimate; cells above it are refined at doubled orders.
    #[arg(long, default_value_t = QuadratureSettings::default().tolerance)]
    pub tolerance: f64,
    /// Highest order refinement may reach (default 8·order); cells still above tolerance are reported.
    #[arg(long)]
    pub max_order: Option<usize>,
    /// Transmission convention of dielectric models.
    #[arg(long, value_enum, default_value_t = Transmission::Energy)]
    pub transmission: Transmission,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transmission {
    /// E_T without the 1/η² radiance factor: E_R + E_T → 1 as α → 0 (the default).
    Energy,
    /// E_T in radiance form (×1/η² entering, ×η² leaving), as the paper's repository tabulates.
    Radiance,
}

impl QuadratureArgs {
    fn settings(&self) -> Result<QuadratureSettings> {
        let mut q = QuadratureSettings::with_order(self.order);
        if let Some(c) = self.companion {
            q.companion = c;
        }
        if let Some(m) = self.max_order {
            q.max_order = m;
        }
        q.tolerance = self.tolerance;
        q.validate().map_err(|m| Error::InvalidInput(format!("{m} (check --order, --companion, --tolerance, --max-order)")))?;
        Ok(q)
    }

    fn model_options(&self) -> ModelOptions {
        ModelOptions { radiance_transmission: self.transmission == Transmission::Radiance }
    }
}

#[derive(Args, Debug)]
pub struct TabulateArgs {
    /// Model name (see `furnace models`).
    #[arg(long)]
    pub model: String,
    /// Nodes per axis: one count for every axis (`1024`) or one per axis (`128x64x32`).
    /// Default: 1024 per axis in 2-D, 128 in 3-D (the paper's resolutions).
    #[arg(long)]
    pub resolution: Option<String>,
    /// Recompute even when a cached table with the same inputs exists.
    #[arg(long)]
    pub force: bool,
    /// Folder for tables.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Model name (see `furnace models`).
    #[arg(long)]
    pub model: String,
    /// CSV whose header names the model's axes (any order), one point per row.
    #[arg(long)]
    pub input: PathBuf,
    /// CSV to write: the input columns, then E (and E_R, E_T) and the error estimate.
    #[arg(long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(Subcommand, Debug)]
pub enum BenchWhat {
    /// Wall time and error of full-size tables at several quadrature orders.
    Tabulate(bench::BenchTabulateArgs),
}

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Folder for tables.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Recompute tables even when cached.
    #[arg(long)]
    pub force: bool,
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Models => {
            print!("{}", models_listing());
            Ok(())
        }
        Command::Tabulate(args) => tabulate_cmd(&args).map(|_| ()),
        Command::Eval(args) => eval::eval_cmd(&args),
        Command::Bench(args) => match args.what {
            BenchWhat::Tabulate(a) => bench::bench_tabulate(&a),
        },
        Command::Run(args) => run_default(&args),
        Command::Report(args) => report::report_cmd(&args),
    }
}

/// `furnace models`: one block per model.
pub fn models_listing() -> String {
    let mut s = String::new();
    for m in bsdf::registry() {
        s.push_str(&format!("{}\n    {}\n", m.name(), m.summary()));
        for a in m.axes() {
            s.push_str(&format!(
                "    {:<4} default [{}, {}], valid [{}, {}]: {}\n",
                a.name, a.default_range.0, a.default_range.1, a.valid_range.0, a.valid_range.1, a.description
            ));
        }
        s.push_str(&format!("    outputs: {}\n", m.outputs().join(", ")));
    }
    s
}

/// Parses `1024` or `128x64x32` for a model with `dims` axes.
pub fn parse_resolution(text: Option<&str>, dims: usize) -> Result<Vec<usize>> {
    let Some(text) = text else {
        return Ok(vec![if dims <= 2 { 1024 } else { 128 }; dims]);
    };
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let counts: Vec<usize> = parts
        .iter()
        .map(|p| {
            p.trim().parse::<usize>().map_err(|_| {
                Error::InvalidInput(format!("--resolution '{text}': '{p}' is not a whole number; use e.g. 1024 or 128x128x128"))
            })
        })
        .collect::<Result<_>>()?;
    match counts.len() {
        1 => Ok(vec![counts[0]; dims]),
        n if n == dims => Ok(counts),
        n => Err(Error::InvalidInput(format!(
            "--resolution '{text}' gives {n} counts but the model has {dims} axes; give one count or {dims}"
        ))),
    }
}

/// A progress bar on stderr for `len` units (hidden when stderr is not a terminal).
pub fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{msg:28} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta}")
            .expect("valid template"),
    );
    pb.set_message(what.to_string());
    pb
}

/// Result of getting a table: computed or read from the cache.
pub struct Tabulated {
    pub table: Table,
    pub stem: PathBuf,
    pub cached: bool,
    pub seconds: f64,
}

/// Reads `spec` from the cache under `data_dir`, or computes and saves it.
pub fn get_table(model: &dyn bsdf::Model, spec: &TableSpec, data_dir: &Path, force: bool) -> Result<Tabulated> {
    let stem = io::table_stem(data_dir, model, spec);
    let start = Instant::now();
    if !force {
        if let Some(table) = io::load_cached(spec, &stem)? {
            return Ok(Tabulated { table, stem, cached: true, seconds: start.elapsed().as_secs_f64() });
        }
    }
    let pb = progress_bar(spec.cells() as u64, &format!("{} {}", spec.model, spec.resolution_name()));
    let table = table::tabulate(model, spec, &|n| pb.inc(n))?;
    pb.finish_and_clear();
    io::save(&table, &stem)?;
    Ok(Tabulated { table, stem, cached: false, seconds: start.elapsed().as_secs_f64() })
}

fn tabulate_cmd(args: &TabulateArgs) -> Result<Tabulated> {
    let settings = args.quadrature.settings()?;
    let model = bsdf::find(&args.model, args.quadrature.model_options())?;
    let resolution = parse_resolution(args.resolution.as_deref(), model.axes().len())?;
    let spec = TableSpec::new(model.as_ref(), &resolution, settings)?;
    let t = get_table(model.as_ref(), &spec, &args.data_dir, args.force)?;
    report_table(&t);
    Ok(t)
}

fn report_table(t: &Tabulated) {
    let s = &t.table.summary;
    let [exr, _, json] = io::files(&t.stem);
    eprintln!(
        "{} {}: {} in {:.2} s; max error estimate {:.2e}; {} cells refined (max order {}); {} unconverged",
        t.table.spec.model,
        t.table.spec.resolution_name(),
        if t.cached { "read from cache" } else { "computed" },
        t.seconds,
        s.max_error_estimate,
        s.refined_cells,
        s.max_order_used,
        s.unconverged_cells
    );
    eprintln!("    {} (+ .f64, sidecar {})", exr.display(), json.display());
    if s.unconverged_cells > 0 {
        eprintln!(
            "    warning: {} cells did not reach the tolerance {:.1e} by order {}; they are listed in the sidecar (first at {:?})",
            s.unconverged_cells,
            t.table.spec.quadrature.tolerance,
            t.table.spec.quadrature.max_order,
            s.unconverged.first().map(|u| &u.0)
        );
    }
}

/// The built-in default set of the main command.
pub const DEFAULT_MODELS: &[&str] = &[
    "ggx-conductor",
    "ggx-conductor-separable",
    "ggx-glossy",
    "ggx-glossy-separable",
    "ggx-dielectric",
    "ggx-dielectric-separable",
    "ggx-dielectric-inv",
    "ggx-dielectric-inv-separable",
];

fn run_default(args: &RunArgs) -> Result<()> {
    let start = Instant::now();
    let mut rows = Vec::new();
    for name in DEFAULT_MODELS {
        let model = bsdf::find(name, ModelOptions::default())?;
        let resolution = parse_resolution(None, model.axes().len())?;
        let spec = TableSpec::new(model.as_ref(), &resolution, QuadratureSettings::default())?;
        let t = get_table(model.as_ref(), &spec, &args.data_dir, args.force)?;
        report_table(&t);
        rows.push(t);
    }
    println!("{:<30} {:>12} {:>8} {:>10} {:>12}", "model", "resolution", "cached", "seconds", "max err est");
    for t in &rows {
        println!(
            "{:<30} {:>12} {:>8} {:>10.2} {:>12.2e}",
            t.table.spec.model,
            t.table.spec.resolution_name(),
            if t.cached { "yes" } else { "no" },
            t.seconds,
            t.table.summary.max_error_estimate
        );
    }
    println!("total {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}
