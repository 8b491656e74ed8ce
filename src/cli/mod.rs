//! Command-line interface: clap arguments → checked configuration → one library call per
//! subcommand. Nothing here computes; it only parses, reports and writes.
//!
//! Everything printed on standard output goes through `out!` and `outln!`: a failed write
//! (a full disk, a closed pipe) is the I/O error on standard output, exit status 1, as for
//! `--output -`.

/// `print!` that returns the error of a failed write to standard output
/// ([`crate::output::write_stdout`]) instead of panicking.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::output::write_stdout(format!($($arg)*).as_bytes())
    };
}

/// `println!` that returns the error of a failed write to standard output, as `out!`.
macro_rules! outln {
    () => {
        $crate::output::write_stdout(b"\n")
    };
    ($($arg:tt)*) => {
        $crate::output::write_stdout(format!("{}\n", format_args!($($arg)*)).as_bytes())
    };
}

mod bench;
mod bench_eval;
mod bench_fit;
mod emit;
mod eval;
mod export;
mod fit;

pub use fit::{ComparePaperArgs, FitArgs, FormArg, ObjectiveArg};
mod report;
mod run;
mod scene;

pub use run::RunArgs;

use crate::bsdf::{self, Transmission};
use crate::error::{Error, Result};
use crate::progress::Observer;
use crate::quadrature::QuadratureSettings;
use crate::table::{self, io, TableSpec, Tabulated};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "furnace",
    version,
    about = "Directional-albedo tables, fits and emitters that make BSDFs pass the white furnace test"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// Parses the process's arguments (exiting with clap's message on a usage error), with
    /// negative numbers taken as option values: `--tolerance -1` reaches the check that says
    /// what the tolerance must be, instead of clap's "unexpected argument".
    pub fn parse_args() -> Cli {
        use clap::{CommandFactory, FromArgMatches};
        let matches = negative_values(Cli::command()).get_matches();
        Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
    }
}

/// Every option that takes a value accepts a negative number as one, in every subcommand.
fn negative_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(negative_values)
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// List the built-in models with their axes, ranges and a line on what they are.
    Models,
    /// Tabulate a model's directional albedo on a grid (cached under data/).
    Tabulate(TabulateArgs),
    /// Join the shards written by `tabulate --shard K/N` into the table (the same bytes as one run).
    Merge(MergeArgs),
    /// Evaluate E at arbitrary points: a model by direct quadrature (no interpolation), or a fit.
    Eval(EvalArgs),
    /// Fit a polynomial or rational approximation to a model's table or a user's table, or sweep degrees.
    Fit(FitArgs),
    /// Compare the paper's published coefficients with furnace's tables and fits.
    ComparePaper(ComparePaperArgs),
    /// Benchmarks that print run time against error (and, with --output, write the CSV files the
    /// report plots; nothing else writes them).
    Bench(BenchArgs),
    /// The whole pipeline on the built-in default set: tabulate (cached), fit (degree sweeps, reused
    /// when their table and options are unchanged), emit code and LUTs, and write reports/; with
    /// --scene, tabulate, fit and emit only what a scene's materials need.
    Run(RunArgs),
    /// Write Rust / WGSL / GLSL source (and LUTs) for fit files.
    Emit(emit::EmitArgs),
    /// Run a fit's emitted f32 operation sequence at ≥ 10⁶ points and edges against f64.
    Stress(emit::StressArgs),
    /// Error reports and the white furnace test: regenerate reports/ (or one model's section).
    Report(report::ReportArgs),
    /// Drop-in tables in another renderer's exact layout: Blender Cycles' shader.tables,
    /// Filament's DFG LUT, or any model as EXR + JSON.
    Export(export::ExportArgs),
}

#[derive(Args, Debug, Clone)]
pub struct QuadratureArgs {
    /// Gauss–Legendre points per panel and dimension.
    #[arg(long, default_value_t = crate::quadrature::DEFAULT_ORDER)]
    pub order: usize,
    /// Lower order of the per-cell error estimate |Q(order) − Q(companion)| (default ⌈3·order/4⌉).
    #[arg(long)]
    pub companion: Option<usize>,
    /// Per-cell tolerance on the error estimate; cells above it are refined at higher orders (×1.25 each).
    #[arg(long, default_value_t = QuadratureSettings::default().tolerance)]
    pub tolerance: f64,
    /// Highest order refinement may reach (default 8·order); cells still above tolerance are reported.
    #[arg(long)]
    pub max_order: Option<usize>,
    /// Transmission convention of dielectric models.
    #[arg(long, value_enum, default_value_t = TransmissionArg::Energy)]
    pub transmission: TransmissionArg,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransmissionArg {
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
        q.validate().map_err(|m| {
            Error::InvalidInput(format!(
                "{m} (check --order, --companion, --tolerance, --max-order)"
            ))
        })?;
        Ok(q)
    }

    /// The model `name` in the `--transmission` convention.
    fn model(&self, name: &str) -> Result<std::sync::Arc<dyn bsdf::Model>> {
        bsdf::find_variant(
            name,
            match self.transmission {
                TransmissionArg::Energy => Transmission::Energy,
                TransmissionArg::Radiance => Transmission::Radiance,
            },
        )
    }
}

#[derive(Args, Debug)]
pub struct TabulateArgs {
    /// Model name (see `furnace models`).
    #[arg(long)]
    pub model: String,
    /// Nodes per axis: one count for every axis (`1024`) or one per axis (`128x64x32`).
    /// Default: 1024 per axis in 2-D, 128 in 3-D (the paper's resolutions), 64x16x64x16 for the
    /// anisotropic conductor (see `furnace models`).
    #[arg(long)]
    pub resolution: Option<String>,
    /// Recompute even when a cached table with the same inputs exists.
    #[arg(long)]
    pub force: bool,
    /// Folder for tables.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Compute only slice K of N (0 ≤ K < N) and write it as a shard beside the table;
    /// `furnace merge` joins the N shards (see docs/quadrature.md, "Tables in shards").
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Model name, as given to `tabulate --shard`.
    #[arg(long)]
    pub model: String,
    /// Nodes per axis, as given to `tabulate --shard`.
    #[arg(long)]
    pub resolution: Option<String>,
    /// The N of `--shard K/N`: how many shards to join.
    #[arg(long)]
    pub shards: usize,
    /// Folder for tables (where the shards are).
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Model name (see `furnace models`): E by direct quadrature.
    #[arg(long, required_unless_present = "fit", conflicts_with = "fit")]
    pub model: Option<String>,
    /// A fit file (written by `furnace fit`, `run` or `run --scene`): E as the emitted code
    /// computes it — inputs clamped to the fit's domain, output to [0, 1] — in f64, after
    /// proving the fit pole-free as `emit` does.
    #[arg(long)]
    pub fit: Option<PathBuf>,
    /// With --fit: the raw f64 approximant P/Q, without the clamps (points must lie in the
    /// fit's domain).
    #[arg(long, requires = "fit")]
    pub raw: bool,
    /// CSV whose header names the model's axes or the fit's variables (any order), one point per row.
    #[arg(long)]
    pub input: PathBuf,
    /// CSV to write (`-`: standard output): the input columns, then E (and E_R, E_T) and the
    /// error estimate (a fit: its output only).
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
    /// CPU f32 ns/evaluation and error of emitted fits and of LUTs (16², 32², 64², 16³, 32³).
    Eval(bench_eval::BenchEvalArgs),
    /// Wall time and error of fits at every degree of the paper's sweep.
    Fit(bench_fit::BenchFitArgs),
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Models => out!("{}", models_listing()),
        Command::Tabulate(args) => tabulate_cmd(&args),
        Command::Merge(args) => merge_cmd(&args),
        Command::Eval(args) => eval::eval_cmd(&args),
        Command::Fit(args) => fit::fit_cmd(&args),
        Command::ComparePaper(args) => fit::compare_paper_cmd(&args),
        Command::Bench(args) => match args.what {
            BenchWhat::Tabulate(a) => bench::bench_tabulate(&a),
            BenchWhat::Eval(a) => bench_eval::bench_eval_cmd(&a),
            BenchWhat::Fit(a) => bench_fit::bench_fit(&a),
        },
        Command::Run(args) => run::run_cmd(&args),
        Command::Emit(args) => emit::emit_cmd(&args),
        Command::Stress(args) => emit::stress_cmd(&args),
        Command::Report(args) => report::report_cmd(&args),
        Command::Export(args) => export::export_cmd(&args),
    }
}

/// `furnace models`: one block per model.
pub fn models_listing() -> String {
    let mut s = String::new();
    for m in bsdf::listed() {
        s.push_str(&format!("{}\n    {}\n", m.id().name(), m.summary()));
        for a in m.axes() {
            s.push_str(&format!(
                "    {:<4} default [{}, {}], valid [{}, {}]: {}\n",
                a.name,
                a.default_range.0,
                a.default_range.1,
                a.valid_range.0,
                a.valid_range.1,
                a.description
            ));
        }
        let default: Vec<String> = m
            .default_resolution()
            .iter()
            .map(|n| n.to_string())
            .collect();
        s.push_str(&format!(
            "    outputs: {}; default resolution {}\n",
            m.outputs().join(", "),
            default.join("x")
        ));
    }
    s
}

/// Parses `1024` or `128x64x32`, given by `option` (`--resolution`, named in the errors), for a
/// model whose default resolution is `default` (one count per axis,
/// [`bsdf::Model::default_resolution`]).
pub fn parse_resolution(option: &str, text: Option<&str>, default: &[usize]) -> Result<Vec<usize>> {
    let dims = default.len();
    let Some(text) = text else {
        return Ok(default.to_vec());
    };
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let counts: Vec<usize> = parts
        .iter()
        .map(|p| {
            p.trim().parse::<usize>().map_err(|_| {
                Error::InvalidInput(format!(
                    "{option} '{text}': '{p}' is not a whole number; use e.g. 1024 or 128x128x128"
                ))
            })
        })
        .collect::<Result<_>>()?;
    match counts.len() {
        1 => Ok(vec![counts[0]; dims]),
        n if n == dims => Ok(counts),
        n => Err(Error::InvalidInput(format!(
            "{option} '{text}' gives {n} counts but the model has {dims} axes; give one count or {dims}"
        ))),
    }
}

/// A progress bar on stderr for `len` units (hidden when stderr is not a terminal).
pub fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg:28} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta}",
        )
        .expect("valid template"),
    );
    pb.set_message(what.to_string());
    pb
}

/// Progress bars on stderr for the library's long computations ([`Observer`]): one bar per
/// task (a task begun inside another gets its own until it ends), hidden when stderr is not a
/// terminal; log lines are printed above the bars.
#[derive(Default)]
pub struct Bars {
    bars: std::sync::Mutex<Vec<ProgressBar>>,
}

impl Bars {
    fn with(&self, f: impl FnOnce(&ProgressBar)) {
        let bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = bars.last() {
            f(b)
        }
    }
}

impl Observer for Bars {
    fn line(&self, text: &str) {
        let bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        match bars.last() {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }
    fn begin(&self, what: &str, total: u64) {
        let mut bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        bars.push(progress_bar(total, what));
    }
    fn extend(&self, n: u64) {
        self.with(|b| b.inc_length(n));
    }
    fn message(&self, what: &str) {
        self.with(|b| b.set_message(what.to_string()));
    }
    fn advance(&self, n: u64) {
        self.with(|b| b.inc(n));
    }
    fn end(&self) {
        let mut bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = bars.pop() {
            b.finish_and_clear();
        }
    }
}

/// Reads `spec` from the cache under `data_dir`, or computes (with a progress bar) and saves it.
pub fn get_table(
    model: &dyn bsdf::Model,
    spec: &TableSpec,
    data_dir: &Path,
    force: bool,
) -> Result<Tabulated> {
    table::get_or_tabulate(model, spec, data_dir, force, &Bars::default())
}

fn tabulate_cmd(args: &TabulateArgs) -> Result<()> {
    let settings = args.quadrature.settings()?;
    let model = args.quadrature.model(&args.model)?;
    let resolution = parse_resolution(
        "--resolution",
        args.resolution.as_deref(),
        &model.default_resolution(),
    )?;
    let spec = TableSpec::new(model.as_ref(), &resolution, settings)?;
    if let Some(text) = &args.shard {
        let id = table::shard::ShardId::parse(text)?;
        let stem = io::table_stem(&args.data_dir, model.as_ref(), &spec);
        let start = Instant::now();
        let pb = progress_bar(
            spec.cells() as u64 / id.count as u64,
            &format!("{} {} shard {text}", spec.model, spec.resolution_name()),
        );
        let json = table::shard::tabulate_shard(model.as_ref(), &spec, id, &stem, &|n| pb.inc(n))?;
        pb.finish_and_clear();
        eprintln!(
            "{} {} shard {}/{}: computed in {:.2} s\n    {} (+ .bin)",
            spec.model,
            spec.resolution_name(),
            id.index,
            id.count,
            start.elapsed().as_secs_f64(),
            json.display()
        );
        return Ok(());
    }
    let t = get_table(model.as_ref(), &spec, &args.data_dir, args.force)?;
    report_table(&t);
    Ok(())
}

fn merge_cmd(args: &MergeArgs) -> Result<()> {
    let settings = args.quadrature.settings()?;
    let model = args.quadrature.model(&args.model)?;
    let resolution = parse_resolution(
        "--resolution",
        args.resolution.as_deref(),
        &model.default_resolution(),
    )?;
    let spec = TableSpec::new(model.as_ref(), &resolution, settings)?;
    let stem = io::table_stem(&args.data_dir, model.as_ref(), &spec);
    let start = Instant::now();
    let table = table::shard::merge(model.as_ref(), &spec, args.shards, &stem)?;
    io::save(&table, &stem)?;
    report_table(&Tabulated {
        table,
        stem,
        cached: false,
        seconds: start.elapsed().as_secs_f64(),
    });
    Ok(())
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
