//! `furnace bench fit`: fit time against error, per form and degree, on `furnace run`'s tables.

use super::bench::{machine_note, write_bench};
use super::{get_table, RUN_RESOLUTION_2D, RUN_RESOLUTION_3D};
use crate::bsdf;
use crate::error::Result;
use crate::fit::job::{self, default_sweep_points, FitRequest, FormKind, SweepPlan};
use crate::fit::{source, InputTransform, Objective};
use crate::quadrature::QuadratureSettings;
use crate::report::inputs::BenchPlot;
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
    /// Nodes per axis of 3-D tables (default: `furnace run`'s, 64).
    #[arg(long)]
    pub resolution_3d: Option<usize>,
    /// Highest degree (default: the paper's sweep — 10 in 2-D; 7 for polynomials and 5 for
    /// rationals in 3-D).
    #[arg(long)]
    pub max_degree: Option<u32>,
    /// Folder of the table cache.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Also write the points as a benchmark CSV for the report, e.g. reports/bench/fit.csv.
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// Times least-squares fits in the identity variables at every degree of the paper's sweep, on
/// the points a sweep fits (an even subset of large tables), and measures each on every node.
pub fn bench_fit(args: &BenchFitArgs) -> Result<()> {
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
    plot.notes.push(machine_note(&format!(
        "furnace bench fit --models {}{}{}{}",
        args.models.join(","),
        resolution_arg("--resolution-2d", args.resolution_2d),
        resolution_arg("--resolution-3d", args.resolution_3d),
        args.max_degree
            .map_or(String::new(), |d| format!(" --max-degree {d}"))
    )));
    plot.notes.push("Least squares in the identity variables, as the sweep's first transform set; fitted on at most 256² (2-D) or 32³ (3-D) even-subset nodes, measured on all.".into());
    println!(
        "{:<24} {:>12} {:<11} {:>6} {:>5} {:>10} {:>10} {:>10}",
        "model", "table", "form", "degree", "n", "seconds", "MAE", "max"
    );
    for name in &args.models {
        let model = bsdf::find(name)?;
        let d = model.axes().len();
        let n = if d <= 2 {
            args.resolution_2d.unwrap_or(RUN_RESOLUTION_2D)
        } else {
            args.resolution_3d.unwrap_or(RUN_RESOLUTION_3D)
        };
        let spec = TableSpec::new(model.as_ref(), &vec![n; d], QuadratureSettings::default())?;
        let t = get_table(model.as_ref(), &spec, &args.data_dir, false)?;
        let input = source::from_table(&t.table, "E", Some(&t.stem))?;
        let plan = SweepPlan::paper(&input.data, args.max_degree, None, Objective::LeastSquares);
        for (form, degrees) in [
            (FormKind::Polynomial, &plan.polynomial_degrees),
            (FormKind::Rational, &plan.rational_degrees),
        ] {
            for &degree in degrees {
                let req = FitRequest {
                    form,
                    degree,
                    objective: Objective::LeastSquares,
                    transforms: vec![InputTransform::Identity; d],
                    max_fit_points: default_sweep_points(d),
                };
                let start = Instant::now();
                let rec = match job::fit_one(&input, &req) {
                    Ok(r) => r,
                    Err(e) => {
                        eprintln!("{name}: {} {degree}: {e}", form.name());
                        continue;
                    }
                };
                let secs = start.elapsed().as_secs_f64();
                let m = &rec.fit.metrics;
                println!(
                    "{:<24} {:>12} {:<11} {:>6} {:>5} {:>10.3} {:>10.2e} {:>10.2e}{}",
                    name,
                    spec.resolution_name(),
                    form.name(),
                    degree,
                    rec.fit.n_coefficients,
                    secs,
                    m.mae,
                    m.max_abs_error,
                    if rec.usable { "" } else { "  (not usable)" }
                );
                if rec.usable && m.max_abs_error.is_finite() {
                    plot.push(
                        &format!("{name} {}", form.name()),
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
