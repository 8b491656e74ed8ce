//! `furnace bench fit`: fit time against error, per form and degree, on `furnace run`'s tables.

use super::bench::{csv_to_stdout, machine_note, table_line, write_bench};
use super::fit::SolverArg;
use super::get_table;
use crate::bsdf;
use crate::error::{Error, Result};
use crate::fit::job::{self, default_sweep_points, FitRequest, FormKind, SweepPlan};
use crate::fit::{source, InputTransform, LsqMethod, Objective, RationalOptions};
use crate::quadrature::QuadratureSettings;
use crate::report::inputs::BenchPlot;
use crate::scene::{DEFAULT_RESOLUTION_2D, DEFAULT_RESOLUTION_3D};
use crate::table::TableSpec;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct BenchFitArgs {
    /// Models whose tables to fit (read from the cache, or computed).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "ggx-conductor,ggx-dielectric"
    )]
    pub models: Vec<String>,
    /// Nodes per axis of 2-D tables (default: `furnace run`'s, 1024).
    #[arg(long)]
    pub resolution_2d: Option<usize>,
    /// Nodes per axis of 3-D tables (default: `furnace run`'s, 128).
    #[arg(long)]
    pub resolution_3d: Option<usize>,
    /// Highest degree (default: the paper's sweep — 10 in 2-D; 7 for polynomials and 5 for
    /// rationals in 3-D).
    #[arg(long)]
    pub max_degree: Option<u32>,
    /// Folder of the table cache.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Least-squares solvers of the rational fits, each timed at every degree (polynomials are
    /// linear least squares and need none).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "lm,trust-region"
    )]
    pub solvers: Vec<SolverArg>,
    /// Also write the points as a benchmark CSV for the report, e.g. reports/bench/fit.csv
    /// (`-`: standard output).
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// Times least-squares fits in the identity variables at every degree of the paper's sweep, on
/// the points a sweep fits (an even subset of large tables), and measures each on every node.
pub fn bench_fit(args: &BenchFitArgs) -> Result<()> {
    super::bench::check_output(&args.output)?;
    if args.max_degree == Some(0) {
        return Err(Error::InvalidInput(
            "--max-degree 0 leaves no fit to time: the sweep's degrees start at 1; give --max-degree 1 or more".into(),
        ));
    }
    let csv_to_stdout = csv_to_stdout(&args.output);
    // MAE, not the max error: over the whole box every fit's max error sits at the
    // discontinuous corner r = μ = 0 (≈ 0.09 for the conductor at every degree)
    let mut plot = BenchPlot::new(
        "fit",
        "Fitting: wall time against error, per degree",
        "wall time of one fit, s",
        true,
        "MAE over every node of the table",
        true,
    );
    let resolution_arg =
        |flag: &str, v: Option<usize>| v.map_or(String::new(), |n| format!(" {flag} {n}"));
    let solvers: Vec<LsqMethod> = args.solvers.iter().map(|s| s.method()).collect();
    plot.notes.push(machine_note(&format!(
        "furnace bench fit --models {}{}{}{}{}",
        args.models.join(","),
        resolution_arg("--resolution-2d", args.resolution_2d),
        resolution_arg("--resolution-3d", args.resolution_3d),
        args.max_degree
            .map_or(String::new(), |d| format!(" --max-degree {d}")),
        if solvers == LsqMethod::ALL {
            String::new()
        } else {
            format!(
                " --solvers {}",
                solvers
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(",")
            )
        }
    )));
    plot.notes.push("Least squares in the identity variables, as the sweep's first transform set; fitted on at most 256² (2-D) or 32³ (3-D) even-subset nodes, measured on all. Rationals: one series per least-squares solver (lm: Levenberg–Marquardt, trust-region: argmin's dogleg trust region), each the whole multi-start strategy.".into());
    table_line(
        csv_to_stdout,
        format!(
            "{:<24} {:>12} {:<11} {:<13} {:>6} {:>5} {:>10} {:>10} {:>10} {:>6}  stopped by",
            "model", "table", "form", "solver", "degree", "n", "seconds", "MAE", "max", "steps"
        ),
    )?;
    for name in &args.models {
        let model = bsdf::find(name)?;
        let d = model.axes().len();
        let n = if d <= 2 {
            args.resolution_2d.unwrap_or(DEFAULT_RESOLUTION_2D)
        } else {
            args.resolution_3d.unwrap_or(DEFAULT_RESOLUTION_3D)
        };
        let spec = TableSpec::new(model.as_ref(), &vec![n; d], QuadratureSettings::default())
            .map_err(|e| {
                e.for_option(if d <= 2 {
                    "--resolution-2d"
                } else {
                    "--resolution-3d"
                })
            })?;
        let t = get_table(model.as_ref(), &spec, &args.data_dir, false)?;
        let input = source::from_table(&t.table, "E", Some(&t.stem))?;
        let plan = SweepPlan::paper(&input.data, args.max_degree, None, Objective::LeastSquares);
        let mut runs: Vec<(FormKind, Option<LsqMethod>, &Vec<u32>)> =
            vec![(FormKind::Polynomial, None, &plan.polynomial_degrees)];
        for &m in &solvers {
            runs.push((FormKind::Rational, Some(m), &plan.rational_degrees));
        }
        for (form, method, degrees) in runs {
            let rational = RationalOptions {
                method: method.unwrap_or_default(),
                ..RationalOptions::default()
            };
            // the default solver keeps the plot's series names of earlier benchmark files
            let series = match method {
                Some(m) if m != LsqMethod::LevenbergMarquardt => {
                    format!("{name} {} ({})", form.name(), m.name())
                }
                _ => format!("{name} {}", form.name()),
            };
            for &degree in degrees {
                let req = FitRequest {
                    form,
                    degree,
                    objective: Objective::LeastSquares,
                    transforms: vec![InputTransform::Identity; d],
                    max_fit_points: default_sweep_points(d),
                };
                let start = Instant::now();
                let rec = match job::fit_one_with(&input, &req, &rational) {
                    Ok(r) => r,
                    Err(e) => {
                        eprintln!("{name}: {} {degree}: {e}", form.name());
                        continue;
                    }
                };
                let secs = start.elapsed().as_secs_f64();
                let m = &rec.fit.metrics;
                let solver = rec.fit.solver.as_ref();
                table_line(csv_to_stdout, format!(
                    "{:<24} {:>12} {:<11} {:<13} {:>6} {:>5} {:>10.3} {:>10.2e} {:>10.2e} {:>6}  {}{}",
                    name,
                    spec.resolution_name(),
                    form.name(),
                    method.map_or("-", |m| m.name()),
                    degree,
                    rec.fit.n_coefficients,
                    secs,
                    m.mae,
                    m.max_abs_error,
                    solver.map_or(0, |s| s.iterations),
                    solver
                        .and_then(|s| s.termination)
                        .map_or("direct solve", |t| t.text()),
                    if rec.usable { "" } else { "  (not usable)" }
                ))?;
                if rec.usable && m.max_abs_error.is_finite() {
                    plot.push(
                        &series,
                        secs,
                        m.mae.max(1e-16),
                        &format!(
                            "degree {degree} ({} coefficients) max error {:.2e}",
                            rec.fit.n_coefficients, m.max_abs_error
                        ),
                    );
                }
            }
        }
    }
    if let Some(path) = &args.output {
        write_bench(&plot, path)?;
    }
    Ok(())
}
