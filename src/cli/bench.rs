//! `furnace bench tabulate`: run time against error of full-size tables.
//!
//! For each quadrature order the whole table is computed exactly as `furnace tabulate` does
//! (every cell at order n and n/2 for its error estimate) but without refinement, and the same
//! fixed-order rule is evaluated at the reference points to measure its true error.

use crate::bsdf::{self, albedo, Model};
use crate::error::{Error, Result};
use crate::quadrature::{QuadratureSettings, RuleCache};
use crate::table::{self, TableSpec};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args, Debug)]
pub struct BenchTabulateArgs {
    /// Quadrature orders to measure.
    #[arg(long, value_delimiter = ',', default_value = "6,8,12,16,24")]
    pub orders: Vec<usize>,
    /// Models to measure.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "ggx-conductor,ggx-dielectric,ggx-dielectric-inv,ggx-glossy"
    )]
    pub models: Vec<String>,
    /// Smaller tables (256² and 32³) for a quick look.
    #[arg(long)]
    pub quick: bool,
    /// Folder with the reference albedos (ref2d.csv, ref3d.csv).
    #[arg(long, default_value = "data/reference")]
    pub reference_dir: PathBuf,
    /// Also write the rows as a benchmark CSV (wall time against error at the reference points)
    /// for the report, e.g. reports/bench/tabulate.csv (`-`: standard output).
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// "2 CPUs, load average 3.10 at the start" — the conditions a wall time was measured under.
pub fn machine_note(command: &str) -> String {
    let cpus = std::thread::available_parallelism().map_or(0, |n| n.get());
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string));
    format!(
        "Measured by `{command}` on {cpus} CPUs{} (wall times; other work on the machine slows them).",
        load.map_or(String::new(), |l| format!(", load average {l} at the start"))
    )
}

/// A line of a benchmark's table: on standard output, or on standard error when the CSV goes
/// to standard output (`--output -`).
pub fn table_line(csv_to_stdout: bool, line: String) -> Result<()> {
    if csv_to_stdout {
        eprintln!("{line}");
        Ok(())
    } else {
        outln!("{line}")
    }
}

/// Refuses, before the benchmark runs, an `--output` that cannot be written.
pub fn check_output(output: &Option<PathBuf>) -> Result<()> {
    match output {
        Some(p) => crate::output::Target::from_arg(p).check("--output"),
        None => Ok(()),
    }
}

/// Whether `--output` is standard output.
pub fn csv_to_stdout(output: &Option<PathBuf>) -> bool {
    output.as_deref().is_some_and(|p| p.as_os_str() == "-")
}

/// Writes a benchmark plot's CSV to `path` (`-`: standard output) and says where.
pub fn write_bench(plot: &crate::report::inputs::BenchPlot, path: &Path) -> Result<()> {
    let target = crate::output::Target::from_arg(path);
    target.write(plot.to_csv().as_bytes())?;
    eprintln!(
        "wrote {} ({} points); `furnace report` plots it",
        target.describe(),
        plot.rows.len()
    );
    Ok(())
}

/// Reads a model's coordinates from a reference row.
type PointOf = fn(&[f64]) -> Vec<f64>;
/// Reads a model's expected E from a reference row.
type ValueOf = fn(&[f64]) -> f64;

/// Reference points and expected E for a model, from the reference files (data/reference).
pub fn reference_points(model: &str, dir: &Path) -> Result<Vec<(Vec<f64>, f64)>> {
    let (file, point, value): (&str, PointOf, ValueOf) = match model {
        "ggx-conductor" => ("ref2d.csv", |r| vec![r[0], r[1]], |r| r[2]),
        "ggx-conductor-separable" => ("ref2d.csv", |r| vec![r[0], r[1]], |r| r[3]),
        "ggx-dielectric" => ("ref3d.csv", |r| vec![r[0], r[2], r[3]], |r| r[5] + r[6]),
        "ggx-dielectric-inv" => ("ref3d.csv", |r| vec![r[0], r[2], r[3]], |r| r[7] + r[8]),
        "ggx-glossy" => ("ref3d.csv", |r| vec![r[0], r[2], r[3]], |r| r[5] / r[4]),
        _ => return Ok(vec![]),
    };
    let path = dir.join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let row: Vec<f64> = line
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| Error::file(&path, format!("row {}: not a number", i + 1)))?;
        out.push((point(&row), value(&row)));
    }
    Ok(out)
}

fn reference_error(
    model: &dyn Model,
    refs: &[(Vec<f64>, f64)],
    settings: &QuadratureSettings,
) -> Option<f64> {
    if refs.is_empty() {
        return None;
    }
    let cache = RuleCache::new(settings);
    Some(
        refs.iter()
            .map(|(x, e)| (albedo(model, x, settings, &cache).value[0] - e).abs())
            .fold(0.0, f64::max),
    )
}

pub fn bench_tabulate(args: &BenchTabulateArgs) -> Result<()> {
    check_output(&args.output)?;
    let csv_to_stdout = csv_to_stdout(&args.output);
    let mut plot = crate::report::inputs::BenchPlot::new(
        "tabulate",
        "Tabulation: wall time against quadrature error",
        "wall time of the whole table, s",
        true,
        "max |E − reference| at the reference points",
        true,
    );
    plot.notes.push(machine_note(&format!(
        "furnace bench tabulate --orders {} --models {}{}",
        args.orders
            .iter()
            .map(|o| o.to_string())
            .collect::<Vec<_>>()
            .join(","),
        args.models.join(","),
        if args.quick { " --quick" } else { "" }
    )));
    plot.notes.push("Each point is one table at a fixed Gauss–Legendre order without refinement (\"default\": the default settings, with refinement to 1e-7).".into());
    table_line(
        csv_to_stdout,
        format!(
            "{:<22} {:>12} {:>6} {:>9} {:>9} {:>13} {:>13}",
            "model", "table", "order", "wall s", "µs/cell", "max |ΔE| ref", "max est."
        ),
    )?;
    for name in &args.models {
        let model = bsdf::find(name)?;
        let dims = model.axes().len();
        let n = match (dims, args.quick) {
            (2, false) => 1024,
            (2, true) => 256,
            (_, false) => 128,
            (_, true) => 32,
        };
        let refs = reference_points(name, &args.reference_dir).unwrap_or_else(|e| {
            eprintln!("note: no reference for {name} ({e}); the reference column stays empty");
            vec![]
        });
        let mut rows: Vec<(String, QuadratureSettings)> = args
            .orders
            .iter()
            .map(|&o| {
                (
                    o.to_string(),
                    QuadratureSettings {
                        tolerance: f64::MAX,
                        max_order: o,
                        ..QuadratureSettings::with_order(o)
                    },
                )
            })
            .collect();
        rows.push(("default".into(), QuadratureSettings::default()));
        for (label, settings) in rows {
            let spec = TableSpec::new(model.as_ref(), &vec![n; dims], settings.clone())?;
            let start = Instant::now();
            let t = table::tabulate(model.as_ref(), &spec, &|_| {})?;
            let wall = start.elapsed().as_secs_f64();
            let err = reference_error(model.as_ref(), &refs, &settings);
            if let Some(e) = err {
                // an exact zero cannot go on a log axis: the reference's own rounding is ~1e-16
                // the default settings (order 12, refined) are not on the fixed-order curve
                let series = if label == "default" {
                    format!("{name} {} default settings", spec.resolution_name())
                } else {
                    format!("{name} {} fixed order", spec.resolution_name())
                };
                plot.push(
                    &series,
                    wall,
                    e.max(1e-16),
                    &if label == "default" {
                        "order 12 refined to 1e-7".to_string()
                    } else {
                        format!("order {label}")
                    },
                );
            }
            table_line(
                csv_to_stdout,
                format!(
                    "{:<22} {:>12} {:>6} {:>9.2} {:>9.2} {:>13} {:>13.2e}",
                    name,
                    spec.resolution_name(),
                    label,
                    wall,
                    wall * 1e6 / spec.cells() as f64,
                    err.map(|e| format!("{e:.2e}"))
                        .unwrap_or_else(|| "-".into()),
                    t.summary.max_error_estimate
                ),
            )?;
        }
    }
    if let Some(path) = &args.output {
        if plot.rows.is_empty() {
            return Err(Error::InvalidInput(
                "no reference points for these models: nothing to write to --output".into(),
            ));
        }
        write_bench(&plot, path)?;
    }
    Ok(())
}
