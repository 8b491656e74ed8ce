//! `furnace bench eval`: a thin wrapper over [`crate::emit::bench`].

use std::path::PathBuf;

use clap::Args;

use crate::emit::bench::{bench_eval, render, BenchOptions};
use crate::error::Result;
use crate::fit::file as fitfile;

#[derive(Args, Debug)]
pub struct BenchEvalArgs {
    /// Fit files to time and measure (e.g. fits/ggx-conductor/rational-3.json).
    #[arg(long, required = true)]
    pub fit: Vec<PathBuf>,
    /// Folder of the table cache (reference tables and LUT tables are cached there).
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Nodes per axis of the accurate reference table of 2-D fits.
    #[arg(long, default_value_t = BenchOptions::default().reference_2d)]
    pub reference_2d: usize,
    /// Nodes per axis of the accurate reference table of 3-D fits.
    #[arg(long, default_value_t = BenchOptions::default().reference_3d)]
    pub reference_3d: usize,
    /// Random points per timing pass.
    #[arg(long, default_value_t = BenchOptions::default().points)]
    pub points: usize,
    /// Timing passes (the best is reported).
    #[arg(long, default_value_t = BenchOptions::default().passes)]
    pub passes: usize,
    /// Keep the generated timing crate and print where it is.
    #[arg(long)]
    pub keep: bool,
    /// Also write the rows as a benchmark CSV (ns per call against max error) for the report,
    /// e.g. reports/bench/eval.csv (`-`: standard output).
    #[arg(long)]
    pub output: Option<PathBuf>,
}

pub fn bench_eval_cmd(args: &BenchEvalArgs) -> Result<()> {
    super::bench::check_output(&args.output)?;
    let fits = args
        .fit
        .iter()
        .map(|p| fitfile::read(p).map(|f| (p.clone(), f)))
        .collect::<Result<Vec<_>>>()?;
    let opts = BenchOptions {
        data_dir: args.data_dir.clone(),
        reference_2d: args.reference_2d,
        reference_3d: args.reference_3d,
        points: args.points,
        passes: args.passes,
        keep: args.keep,
        ..BenchOptions::default()
    };
    let rows = bench_eval(&fits, &opts, &|l| eprintln!("{l}"))?;
    super::bench::table_line(
        super::bench::csv_to_stdout(&args.output),
        render(&rows).trim_end().to_string(),
    )?;
    if let Some(path) = &args.output {
        let mut plot = crate::report::inputs::BenchPlot::new(
            "eval",
            "Evaluation: cost against error, fits and LUTs (f32, CPU)",
            "ns per evaluation (one call through a function pointer)",
            true,
            "max |ΔE| against an accurate table",
            true,
        );
        let files: Vec<String> = args.fit.iter().map(|p| p.display().to_string()).collect();
        plot.notes.push(super::bench::machine_note(&format!(
            "furnace bench eval --fit {}",
            files.join(" --fit ")
        )));
        let mut refs: Vec<&str> = rows.iter().map(|r| r.reference.as_str()).collect();
        refs.dedup();
        plot.notes.push(format!(
            "Errors at every node of {}; times: best of {} passes over {} random points.",
            refs.join(", "),
            args.passes,
            args.points
        ));
        plot.notes.push("Fits: the evaluation form furnace emits for each (the other forms are in the terminal output); LUTs: f32 values, multilinear in f32.".into());
        for r in &rows {
            let lut = r.what.contains("LUT");
            // fits: only the emitted form; LUTs: once per model (they are timed again for each fit)
            if !lut && !r.what.contains("(emitted)") {
                continue;
            }
            let series = format!("{} {}", r.model, if lut { "LUTs" } else { "fits" });
            let label = format!("{} ({} B)", r.what.replace(", f32", ""), r.bytes);
            if lut
                && plot
                    .rows
                    .iter()
                    .zip(&plot.labels)
                    .any(|(row, l)| row.0 == series && *l == label)
            {
                continue;
            }
            plot.push(&series, r.ns_call, r.max_error.max(1e-16), &label);
        }
        super::bench::write_bench(&plot, path)?;
    }
    Ok(())
}
