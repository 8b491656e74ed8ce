//! `furnace fit` (one fit or a degree sweep of a model's or a user's table) and
//! `furnace compare-paper`. Parsing, reporting and writing only; the work is in
//! [`crate::fit::job`], [`crate::fit::source`] and [`crate::fit::compare`].

use super::{get_table, parse_resolution, QuadratureArgs};
use crate::bsdf;
use crate::error::{Error, Result};
use crate::fit::check::{self, CheckSet};
use crate::fit::compare::{
    compare_model, paper_box, same_form_request, CompareReport, PaperPair, PAPER_PAIRS,
};
use crate::fit::defaults::default_plan;
use crate::fit::job::{
    self, FitRecord, FitRequest, FitTime, FormKind, Stopwatch, SweepOutcome, Timing,
};
use crate::fit::source::{self, FitInput, FittedOn, UserTableOptions};
use crate::fit::{LsqMethod, Objective, RationalOptions};
use crate::output;
use crate::output::Target;
use crate::pipeline::sweeps::{stress_checked_best, write_sweep_files};
use crate::quadrature::QuadratureSettings;
use crate::table::TableSpec;
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormArg {
    Rational,
    Polynomial,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectiveArg {
    /// Least squares (sum of squared errors).
    Lsq,
    /// Mean absolute error (iteratively reweighted least squares).
    Mae,
    /// Maximum absolute error (Lawson reweighting).
    Minimax,
}

/// The least-squares solver of a rational fit.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverArg {
    /// Levenberg–Marquardt (furnace's, under argmin's executor; the default of every fit).
    Lm,
    /// argmin's trust-region method with the dogleg step, on the same Gauss–Newton model.
    TrustRegion,
}

impl SolverArg {
    pub fn method(self) -> LsqMethod {
        match self {
            SolverArg::Lm => LsqMethod::LevenbergMarquardt,
            SolverArg::TrustRegion => LsqMethod::TrustRegion,
        }
    }
}

#[derive(Args, Debug)]
pub struct FitArgs {
    /// Model whose table to fit (computed, or read from the cache under --data-dir).
    #[arg(long, required_unless_present = "table", conflicts_with = "table")]
    pub model: Option<String>,
    /// A table to fit instead of a model's: a furnace table stem or its .json sidecar, a .csv
    /// (header: the variables and E; scattered points allowed), an .exr, or a .json grid.
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Functional form (n/n rational, or polynomial).
    #[arg(long, value_enum, required_unless_present_any = ["sweep", "spec"], conflicts_with = "spec")]
    pub form: Option<FormArg>,
    /// Total degree (of numerator and denominator for a rational).
    #[arg(long, required_unless_present_any = ["sweep", "spec"], conflicts_with_all = ["sweep", "spec"])]
    pub degree: Option<u32>,
    /// Any form instead of --form/--degree: `rational:4/3`, `split:f0:4:5/4` (degree 4 in f0
    /// times total degree 5 in the others over a shared denominator of degree 4 without f0),
    /// `tensor:1,1/1,0` (per-variable degrees), `tensor:1,5@r:0/1,0` (of the numerator's
    /// monomials without r only those of total degree ≤ 0: c + r·(b₀ + … + b₅μ⁵) over
    /// 1 + q r), `sum:f0:power:3:3/+1` (Σ_a t_f0^a·P_a/Q_a, each
    /// term its own denominator; `+`: positive Bernstein denominators), `lowrank:f0:3:3:4/2`
    /// (Σ_k u_k(f0)·P_k/Q_k, 3 terms, u_k of degree 3), or a form's JSON (docs/fitting.md,
    /// "Structured forms").
    #[arg(long, conflicts_with = "sweep")]
    pub spec: Option<String>,
    /// Sweep degrees like the paper's Fig. 3 (2D: 1–10, 3D: polynomials 1–7, rationals 1–5)
    /// over several input transforms; writes sweep.{json,csv} and best-N.json for every
    /// budget N (20, 40, 80 and 160 coefficients, and 8 in 2-D).
    #[arg(long)]
    pub sweep: bool,
    /// Highest degree of a sweep (caps or extends the paper's range).
    #[arg(long, requires = "sweep")]
    pub max_degree: Option<u32>,
    /// What the fit minimises.
    #[arg(long, value_enum, default_value_t = ObjectiveArg::Lsq)]
    pub objective: ObjectiveArg,
    /// Least-squares solver of a single rational fit; with trust-region the fit file's name
    /// ends in `-trust-region.json`.
    #[arg(long, value_enum, default_value_t = SolverArg::Lm, conflicts_with = "sweep")]
    pub solver: SolverArg,
    /// Input transforms, e.g. `mu=sqrt,f0=sqrt` (identity, sqrt, one_minus, square, clamp:lo:hi,
    /// layer:<variable>:<k>, root:<n>:lo:hi[:<b>], glayer:…, slayer:…, critical:lo:hi, sin2,
    /// player:…, pratio:…; an unknown name prints every syntax; docs/fitting.md). With --sweep:
    /// one more transform set to try.
    #[arg(long)]
    pub transform: Option<String>,
    /// Table nodes per axis, `256` or `128x64x32` (default 1024² in 2D, 128³ in 3D).
    #[arg(long, conflicts_with = "table")]
    pub resolution: Option<String>,
    /// Most points the solver sees; larger tables are fitted on an even subset of their nodes
    /// (random subset for scattered points) and measured on all of them. 0 = all. Default: all
    /// for one fit; 256² (2D) or 32³ (3D) for a sweep.
    #[arg(long)]
    pub fit_points: Option<usize>,
    /// Output to fit: E, or E_R / E_T of dielectrics; the value column / channel of a user table.
    #[arg(long, default_value = "E")]
    pub channel: String,
    /// Axes of an .exr without sidecar (`r=0:1,mu=0:1`, `f0=0:1:32,r=0:1,mu=0:1`), or the domain
    /// of CSV points (default: their bounding box).
    #[arg(long, requires = "table")]
    pub axes: Option<String>,
    /// Fit and measure only on a sub-box of the table, e.g. `r=0.035:1,mu=0.02:1` (where the
    /// paper's tables start, away from the discontinuous corner r = μ = 0); the fit's domain
    /// becomes that box. Files go to <fits-dir>/<name>.<var><lo>-<hi>…/.
    #[arg(long)]
    pub domain: Option<String>,
    /// Folder for tables (default `data`), and for the timings of fits under `<data-dir>/timing/`
    /// (with --table, timings are written only when --data-dir is given).
    #[arg(long)]
    pub data_dir: Option<PathBuf>,
    /// Folder for fits: files go to <fits-dir>/<model or table name>/.
    #[arg(long, default_value = "fits")]
    pub fits_dir: PathBuf,
    /// Write a single fit here instead of <fits-dir>/<model>/<form>-<degree>.json (`-`:
    /// standard output, the summary then goes to standard error).
    #[arg(long, conflicts_with = "sweep")]
    pub output: Option<PathBuf>,
    /// Print the N table points with the largest error of the fit (of each best-<budget> fit
    /// of a sweep), with the table value and the fit's there.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub worst: usize,
    /// Recompute the model's table even when cached.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

impl FitArgs {
    /// The table folder: `--data-dir`, or `data`.
    fn data_dir(&self) -> PathBuf {
        self.data_dir
            .clone()
            .unwrap_or_else(|| PathBuf::from("data"))
    }

    /// Where timings go: `<data-dir>/timing/<name>`, unless a user's table is fitted without
    /// an explicit --data-dir (its fit then writes nothing into the current folder's `data/`).
    fn timing_dir(&self, name: &str) -> Option<PathBuf> {
        if self.table.is_some() && self.data_dir.is_none() {
            None
        } else {
            Some(self.data_dir().join("timing").join(name))
        }
    }
}

impl ObjectiveArg {
    fn objective(self) -> Objective {
        match self {
            ObjectiveArg::Lsq => Objective::LeastSquares,
            ObjectiveArg::Mae => Objective::MeanAbsolute,
            ObjectiveArg::Minimax => Objective::Minimax,
        }
    }
}

/// The data to fit and the folder name under --fits-dir.
/// The data to fit, the fits folder's name and whether the data may have a grazing boundary
/// layer (a model's say-so; a user's table may).
/// The data to fit, its name, whether it has a grazing boundary layer, its off-grid check set
/// and (for a sweep of a model's 3-D table) its training set.
type Input = (FitInput, String, bool, Option<CheckSet>, Option<CheckSet>);

fn fit_input(args: &FitArgs) -> Result<Input> {
    if let Some(path) = &args.table {
        let axes = args.axes.as_deref().map(source::parse_axes).transpose()?;
        let input = source::load_user_table(
            path,
            &UserTableOptions {
                channel: Some(args.channel.clone()),
                axes,
            },
        )?;
        // a furnace table lives in data/<cache name>/<resolution>: fit into fits/<cache name>/
        let name = if input.source.kind == "furnace_table" {
            path.parent().and_then(Path::file_name)
        } else {
            path.file_stem()
        };
        let name = name
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "table".into());
        eprintln!(
            "{}: {} points in {} variable{} ({})",
            path.display(),
            input.data.len(),
            input.data.dim(),
            if input.data.dim() == 1 { "" } else { "s" },
            input.data.names.join(", ")
        );
        return Ok((input, name, true, None, None));
    }
    let name = args
        .model
        .as_deref()
        .ok_or_else(|| Error::InvalidInput("give --model or --table".into()))?;
    let model = args.quadrature.model(name)?;
    let resolution = parse_resolution(
        "--resolution",
        args.resolution.as_deref(),
        &model.default_resolution(),
    )?;
    let spec = TableSpec::new(model.as_ref(), &resolution, args.quadrature.settings()?)?;
    let t = get_table(model.as_ref(), &spec, &args.data_dir(), args.force)?;
    eprintln!(
        "{} {}: table {} in {:.1} s ({})",
        t.table.spec.model,
        t.table.spec.resolution_name(),
        if t.cached {
            "read from cache"
        } else {
            "computed"
        },
        t.seconds,
        t.stem.display()
    );
    // the off-grid check points measure E; other channels are measured at the nodes only
    let check = if args.channel == "E" {
        Some(check::get_or_compute(
            model.as_ref(),
            &t.table.spec,
            &t.stem,
        )?)
    } else {
        None
    };
    let input = source::from_table(&t.table, &args.channel, Some(&t.stem))?;
    let n = crate::fit::defaults::default_training_points(&input.data);
    let training = if args.sweep && check.is_some() && n > 0 {
        Some(check::training_get_or_compute(
            model.as_ref(),
            &t.table.spec,
            &t.stem,
            n,
        )?)
    } else {
        None
    };
    Ok((
        input,
        model.id().key(),
        model.grazing_boundary_layer(),
        check,
        training,
    ))
}

/// Folder name of fits restricted to a sub-box: `<name>.<var><lo>-<hi>…`.
fn boxed_name(name: &str, bounds: &[source::AxisDecl]) -> String {
    let mut s = name.to_string();
    for b in bounds {
        s.push_str(&format!(".{}{}-{}", b.name, b.lo, b.hi));
    }
    s
}

/// Refuses, before any table is read, computed or fitted, an output folder or file that cannot
/// be written: the fits folder (a sweep, or a fit without --output), the --output file, and the
/// data folder where tables and timings go.
fn check_outputs(args: &FitArgs) -> Result<()> {
    match &args.output {
        Some(p) if !args.sweep => {
            let target = Target::from_arg(p);
            target.check("--output")?;
            if let Some(table) = &args.table {
                target.check_not_input(&[(table.as_path(), "--table")], "--output")?;
            }
        }
        _ => output::check_dir_creatable(&args.fits_dir, "--fits-dir")?,
    }
    if args.table.is_none() || args.data_dir.is_some() {
        output::check_dir_creatable(&args.data_dir(), "--data-dir")?;
    }
    Ok(())
}

/// `furnace fit`.
pub fn fit_cmd(args: &FitArgs) -> Result<()> {
    check_outputs(args)?;
    let (mut input, mut name, layer, mut check, mut training) = fit_input(args)?;
    if let Some(text) = &args.domain {
        let bounds = source::parse_axes(text)
            .map_err(|e| Error::InvalidInput(e.to_string().replace("--axes", "--domain")))?;
        input = input.restrict(&bounds)?;
        check = check.and_then(|c| c.within(&input.data.domain));
        training = training.and_then(|c| c.within(&input.data.domain));
        name = boxed_name(&name, &bounds);
        eprintln!("restricted to {text}: {} points", input.data.len());
    }
    // a table of a registered model (furnace's, or a furnace table given with --table) must not
    // span one of the model's degenerate slices
    if let Some(model) = input
        .source
        .model
        .as_deref()
        .and_then(|m| crate::bsdf::find(m).ok())
        .filter(|m| m.axes().len() == input.data.dim())
    {
        crate::bsdf::check_no_degenerate_slice(
            model.as_ref(),
            &input.data.domain,
            &|a, (lo, hi)| {
                format!(
                    "leave the slice out with --domain {a}={lo}:{hi} (the model's default range)"
                )
            },
        )?;
    }
    let transforms = match &args.transform {
        Some(t) => Some(job::parse_transforms(t, &input.data.names)?),
        None => None,
    };
    let dir = args.fits_dir.join(&name);
    let timing_dir = args.timing_dir(&name);
    let check_data = check.as_ref().map(CheckSet::data).transpose()?;
    let check_on = check.as_ref().map(CheckSet::description);
    let checked = check_data.as_ref().zip(check_on.as_deref());
    if args.sweep {
        let mut plan = default_plan(
            &input.data,
            args.max_degree,
            transforms.clone(),
            args.objective.objective(),
            layer,
        );
        if let Some(f) = args.form {
            match f {
                FormArg::Rational => plan.polynomial_degrees.clear(),
                FormArg::Polynomial => {
                    plan.rational_degrees.clear();
                    plan.rational_pairs.clear();
                }
            }
        }
        if let Some(n) = args.fit_points {
            plan.max_fit_points = n;
        }
        let clock = Stopwatch::start();
        if training.is_none() {
            plan.training_points = 0;
        }
        let training_data = training.as_ref().map(CheckSet::data).transpose()?;
        let training_on = training.as_ref().map(CheckSet::training_description);
        let trained = training_data.as_ref().zip(training_on.as_deref());
        let mut outcome = job::sweep_fits_trained(&input, &plan, checked, trained, &mut |line| {
            eprintln!("  {line}")
        })?;
        stress_checked_best(&mut outcome);
        write_sweep(&outcome, &dir, timing_dir.as_deref(), &clock)?;
        for b in &outcome.best {
            if let Some(rec) = outcome.best_record(b.budget).filter(|_| args.worst > 0) {
                outln!("worst points of best-{}.json:", b.budget)?;
                out!("{}", worst_text(rec, &input, args.worst))?;
            }
        }
        return Ok(());
    }
    if let Some(text) = &args.spec {
        let form = crate::fit::parse_form(text, &input.data.names)
            .map_err(|m| Error::InvalidInput(format!("--spec: {m}")))?;
        let opts = crate::fit::FitOptions {
            rational: RationalOptions {
                method: args.solver.method(),
                ..RationalOptions::default()
            },
            ..Default::default()
        };
        let transforms = transforms
            .unwrap_or_else(|| vec![crate::fit::InputTransform::Identity; input.data.dim()]);
        let rec = job::fit_one_form(
            &input,
            &form,
            args.objective.objective(),
            &transforms,
            args.fit_points.unwrap_or(0),
            &opts,
        )?
        .with_off_grid(checked);
        let name = rec.file_name();
        let target = match &args.output {
            Some(p) => Target::from_arg(p),
            None => Target::File(dir.join(&name)),
        };
        target.write(rec.to_json()?.as_bytes())?;
        let mut text = record_text(&rec, &target.describe(), None);
        if args.worst > 0 {
            text.push_str(&worst_text(&rec, &input, args.worst));
        }
        if target.is_stdout() {
            eprint!("{text}");
        } else {
            out!("{text}")?;
        }
        for w in &rec.warnings {
            eprintln!("warning: {w}");
        }
        return Ok(());
    }
    let (Some(form), Some(degree)) = (args.form, args.degree) else {
        return Err(Error::InvalidInput(
            "give --form and --degree, or --sweep".into(),
        ));
    };
    let req = FitRequest {
        form: match form {
            FormArg::Rational => FormKind::Rational,
            FormArg::Polynomial => FormKind::Polynomial,
        },
        degree,
        objective: args.objective.objective(),
        transforms: transforms
            .unwrap_or_else(|| vec![crate::fit::InputTransform::Identity; input.data.dim()]),
        max_fit_points: args.fit_points.unwrap_or(0),
    };
    if args.solver != SolverArg::Lm && req.form != FormKind::Rational {
        return Err(Error::InvalidInput(
            "--solver applies to rational fits (a polynomial is a linear least-squares solve); drop it or use --form rational".into(),
        ));
    }
    let rational = RationalOptions {
        method: args.solver.method(),
        ..RationalOptions::default()
    };
    let clock = Stopwatch::start();
    let rec = job::fit_one_with(&input, &req, &rational)?.with_off_grid(checked);
    let name = match args.solver {
        SolverArg::Lm => rec.file_name(),
        SolverArg::TrustRegion => {
            let name = rec.file_name();
            let stem = name.strip_suffix(".json").unwrap_or(&name);
            format!("{stem}-trust-region.json")
        }
    };
    let target = match &args.output {
        Some(p) => Target::from_arg(p),
        None => Target::File(dir.join(&name)),
    };
    let time = FitTime {
        name: name.clone(),
        n_coefficients: rec.fit.n_coefficients,
        seconds: clock.wall_seconds(),
    };
    let timing = Timing::new(
        &target.describe(),
        &input.source,
        &rec.fitted_on,
        &clock,
        vec![time],
    );
    target.write(rec.to_json()?.as_bytes())?;
    let stem = match &target {
        Target::File(p) => p.file_stem().map(|s| s.to_string_lossy().into_owned()),
        Target::Stdout => None,
    }
    .unwrap_or_else(|| name.trim_end_matches(".json").to_string());
    let mut text = record_text(&rec, &target.describe(), Some(&timing));
    if let Some(dir) = &timing_dir {
        let timing_path = dir.join(format!("{stem}-timing.json"));
        output::write(&timing_path, timing.to_json()?.as_bytes())?;
        text.push_str(&format!("timing: {}\n", timing_path.display()));
    }
    if args.worst > 0 {
        text.push_str(&worst_text(&rec, &input, args.worst));
    }
    // the summary goes where the fit does not
    if target.is_stdout() {
        eprint!("{text}");
    } else {
        out!("{text}")?;
    }
    for w in &rec.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// The `n` points of `input` where `rec` errs most, as a table.
fn worst_text(rec: &FitRecord, input: &FitInput, n: usize) -> String {
    let names = input.data.names.join(", ");
    let mut s = format!(
        "    {:>4}  {:<40} {:>12} {:>12} {:>10}\n",
        "rank",
        format!("({names})"),
        "table",
        "fit",
        "|error|"
    );
    for (i, p) in crate::fit::metrics::worst_points(&rec.fit.approximant, &input.data, n)
        .iter()
        .enumerate()
    {
        let at =
            p.at.iter()
                .map(|x| format!("{x:.6}"))
                .collect::<Vec<_>>()
                .join(", ");
        s.push_str(&format!(
            "    {:>4}  {:<40} {:>12.8} {:>12.8} {:>10.3e}\n",
            i + 1,
            format!("({at})"),
            p.value,
            p.fit,
            p.abs_error
        ));
    }
    s
}

/// `12.3 s wall, 20.1 s CPU, 2 threads, load 1.52`: a timing for the terminal.
fn timing_text(t: &Timing) -> String {
    format!(
        "{:.2} s wall{}, {} threads{}",
        t.wall_seconds,
        t.cpu_seconds
            .map_or(String::new(), |c| format!(", {c:.2} s CPU")),
        t.threads,
        t.load_average
            .map_or(String::new(), |l| format!(", load {:.2}", l[0]))
    )
}

/// A fit's summary lines: file, form, metrics and verdict.
fn record_text(rec: &FitRecord, path: &str, timing: Option<&Timing>) -> String {
    let m = &rec.fit.metrics;
    let off_grid = rec.off_grid.as_ref().map_or(String::new(), |o| {
        format!(
            "    off-grid ({}): MAE {:.3e}, max {:.3e} at {:?}\n",
            o.on, o.metrics.mae, o.metrics.max_abs_error, o.metrics.max_abs_error_at
        )
    });
    format!(
        "{path}: {} [{}], {} coefficients{}; on {} points: MAE {:.3e}, RMSE {:.3e}, max {:.3e} at {:?}, max relative {:.3e}\n    {}\n",
        rec.fit.form.label_with(&rec.fit.approximant.variables),
        rec.fit.approximant.transforms.iter().map(|t| t.label(&rec.fit.approximant.variables)).collect::<Vec<_>>().join(", "),
        rec.fit.n_coefficients,
        timing.map_or(String::new(), |t| format!(", fitted in {}", timing_text(t))),
        m.n_points,
        m.mae,
        m.rmse,
        m.max_abs_error,
        m.max_abs_error_at,
        m.max_rel_error,
        rec.verdict
    ) + &off_grid
}

fn print_record(rec: &FitRecord, path: &Path, timing: Option<&Timing>) -> Result<()> {
    out!("{}", record_text(rec, &path.display().to_string(), timing))?;
    for w in &rec.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// Writes a sweep's files ([`write_sweep_files`]) and prints its table.
fn write_sweep(
    outcome: &SweepOutcome,
    dir: &Path,
    timing_dir: Option<&Path>,
    clock: &Stopwatch,
) -> Result<()> {
    let (_, timing) = write_sweep_files(outcome, dir, timing_dir, clock)?;
    let timing_note = timing_dir.map_or(String::new(), |d| {
        format!(", timings to {}", d.join("sweep-timing.json").display())
    });
    outln!("MAE and max: on {}", outcome.metrics_on)?;
    if let Some(b) = &outcome.paper_box {
        outln!("box MAE, box max: on {}", b.metrics_on)?;
    }
    if let Some(c) = &outcome.check {
        outln!("off MAE, off max: on {c}; * = on the Pareto front")?;
    }
    outln!(
        "{:<11} {:>5} {:<32} {:<8} {:>4} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>8} poles",
        "form",
        "deg",
        "transforms",
        "objective",
        "n",
        "MAE",
        "max",
        "box MAE",
        "box max",
        "off MAE",
        "off max",
        "seconds"
    )?;
    let cell = |b: Option<&job::BoxMetrics>| {
        b.map_or(("-".to_string(), "-".to_string()), |b| {
            (format!("{:.3e}", b.mae), format!("{:.3e}", b.max_abs_error))
        })
    };
    for (r, secs) in outcome.rows.iter().zip(&outcome.fit_seconds) {
        let (bm, bx) = cell(r.paper_box.as_ref());
        let (om, ox) = cell(r.off_grid.as_ref());
        let degree = match r.denominator_degree {
            Some(m) => format!("{}/{m}", r.degree),
            None => r.degree.to_string(),
        };
        outln!(
            "{:<11} {:>5} {:<32} {:<8} {:>4} {:>10.3e} {:>10.3e} {:>10} {:>10} {:>10} {:>10} {:>8.2} {}{}",
            r.form.name(),
            degree,
            r.transforms.join(" "),
            job::objective_name(r.objective),
            r.n_coefficients,
            r.mae,
            r.max_abs_error,
            bm,
            bx,
            om,
            ox,
            secs,
            r.poles,
            if r.pareto { " *" } else { "" }
        )?;
    }
    for b in &outcome.best {
        let path = dir.join(format!("best-{}.json", b.budget));
        match outcome.best_record(b.budget) {
            Some(rec) => {
                let (max, mae) = rec.headline();
                outln!(
                    "best with ≤ {} coefficients (lowest max error among the fits within {}× of the lowest MAE{}, {}): max {max:.3e}, MAE {mae:.3e}",
                    b.budget,
                    crate::fit::sweep::MAE_TOLERANCE,
                    if b.budget >= job::paper_coefficients(outcome.variables.len()) && outcome.paper_refit.is_some() {
                        ", no worse than the paper's degree-3 rational refitted here"
                    } else {
                        ""
                    },
                    if rec.off_grid.is_some() { "off-grid" } else { "at the nodes" },
                )?;
                print_record(rec, &path, None)?;
                if let Some(bm) = b.index.and_then(|i| outcome.rows[i].paper_box.as_ref()) {
                    outln!(
                        "    on the paper's box: MAE {:.3e}, max {:.3e} at {:?}",
                        bm.mae,
                        bm.max_abs_error,
                        bm.max_abs_error_at
                    )?;
                }
            }
            None => eprintln!(
                "warning: no usable fit with ≤ {} coefficients; {} not written",
                b.budget,
                path.display()
            ),
        }
    }

    for s in &outcome.skipped {
        eprintln!(
            "skipped {} [{}]: {}",
            s.form,
            s.transforms
                .iter()
                .map(|t| t.label(&outcome.variables))
                .collect::<Vec<_>>()
                .join(" "),
            s.reason
        );
    }
    let not_usable = outcome.rows.iter().filter(|r| !r.usable).count();
    if not_usable > 0 {
        eprintln!("warning: {not_usable} fits are not usable (pole or uncertified); they are listed with usable = false and never chosen as best");
    }
    outln!(
        "sweep of {} fits in {} ({}); wrote {}/sweep.{{json,csv}}{timing_note}",
        outcome.rows.len(),
        timing_text(&timing),
        outcome.fitted_on.selection,
        dir.display(),
    )?;
    Ok(())
}

#[derive(Args, Debug)]
pub struct ComparePaperArgs {
    /// The paper's data folder (coefficients/ and tables/).
    #[arg(long, default_value = "data/paper")]
    pub paper_data: PathBuf,
    /// Table nodes per axis for all four tables (default 1024² and 128³).
    #[arg(long)]
    pub resolution: Option<usize>,
    /// Table nodes per axis of the three 3D tables (overrides --resolution for them).
    #[arg(long)]
    pub resolution_3d: Option<usize>,
    /// Most points furnace's 3/3 fit sees (0 = all; default all in 2D, 64³ in 3D).
    #[arg(long)]
    pub fit_points: Option<usize>,
    /// Do not run a sweep for a missing best-40 fit; leave that column out.
    #[arg(long)]
    pub no_sweep: bool,
    /// Folder for tables.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Folder for fits (best-40.json is read from, or a sweep written to, <fits-dir>/<model>/;
    /// for the glossy table on the paper's F0 ∈ [0, 1], wider than the model's default,
    /// <fits-dir>/<model>.paper-domain/).
    #[arg(long, default_value = "fits")]
    pub fits_dir: PathBuf,
    /// Folder for compare-paper.{md,json}.
    #[arg(long, default_value = "reports")]
    pub reports_dir: PathBuf,
}

/// Points furnace's same-form fit sees in compare-paper by default: all in 2D, 64³ in 3D.
const COMPARE_FIT_POINTS_3D: usize = 64 * 64 * 64;

/// best-40.json of this exact table, or a fresh sweep's (timings to `timing_dir`).
fn best_40(
    input: &FitInput,
    dir: &Path,
    timing_dir: &Path,
    no_sweep: bool,
) -> Result<Option<FitRecord>> {
    let path = dir.join("best-40.json");
    if let Ok(text) = std::fs::read_to_string(&path) {
        if let Ok(rec) = FitRecord::from_json(&text) {
            let same = rec.source.content_hash == input.source.content_hash
                && rec.source.channel == input.source.channel
                && rec.source.restricted_to == input.source.restricted_to;
            if same {
                eprintln!("  best ≤ 40 from {}", path.display());
                return Ok(Some(rec));
            }
        }
    }
    if no_sweep {
        return Ok(None);
    }
    eprintln!(
        "  no best-40.json for this table in {}: running the default sweep",
        dir.display()
    );
    let plan = default_plan(&input.data, None, None, Objective::LeastSquares, true);
    let clock = Stopwatch::start();
    let mut outcome = job::sweep_fits(input, &plan, &mut |line| eprintln!("    {line}"))?;
    stress_checked_best(&mut outcome);
    write_sweep(&outcome, dir, Some(timing_dir), &clock)?;
    Ok(outcome.best_record(40).cloned())
}

fn compare_one(
    args: &ComparePaperArgs,
    pair: &PaperPair,
) -> Result<crate::fit::compare::CompareEntry> {
    let model = bsdf::get(pair.table_model())?;
    let d = model.axes().len();
    let (n, option) = match (d >= 3, args.resolution_3d) {
        (true, Some(n)) => (Some(n), "--resolution-3d"),
        _ => (args.resolution, "--resolution"),
    };
    let resolution = parse_resolution(
        option,
        n.map(|n| n.to_string()).as_deref(),
        &model.default_resolution(),
    )?;
    // the paper's own domain (its glossy table spans F0 ∈ [0, 1], wider than the model's
    // default); fits on another domain than the default go to a folder of their own
    let ranges = pair.paper.domain();
    let default_domain = model
        .axes()
        .iter()
        .zip(&ranges)
        .all(|(a, &r)| a.default_range == r);
    let spec = if default_domain {
        TableSpec::new(model.as_ref(), &resolution, QuadratureSettings::default())
    } else {
        TableSpec::with_ranges(
            model.as_ref(),
            &resolution,
            &ranges,
            QuadratureSettings::default(),
        )
    }
    .map_err(|e| e.for_option(option))?;
    let fits_name = if default_domain {
        model.id().key()
    } else {
        format!("{}.paper-domain", model.id().key())
    };
    let t = get_table(model.as_ref(), &spec, &args.data_dir, false)?;
    eprintln!(
        "{} ({}): {} table {} in {:.1} s",
        pair.paper_name,
        model.id().key(),
        spec.resolution_name(),
        if t.cached { "read" } else { "computed" },
        t.seconds
    );
    let input = source::from_table(&t.table, "E", Some(&t.stem))?;
    let points = args
        .fit_points
        .unwrap_or(if d >= 3 { COMPARE_FIT_POINTS_3D } else { 0 });
    let same = job::fit_one(&input, &same_form_request(pair, points))?;
    let timing = args.data_dir.join("timing");
    let best = best_40(
        &input,
        &args.fits_dir.join(&fits_name),
        &timing.join(&fits_name),
        args.no_sweep,
    )?;
    let bounds = paper_box(pair);
    let boxed = input.restrict(&bounds)?;
    let boxed_dir = boxed_name(&fits_name, &bounds);
    let best_box = best_40(
        &boxed,
        &args.fits_dir.join(&boxed_dir),
        &timing.join(&boxed_dir),
        args.no_sweep,
    )?;
    let entry = compare_model(
        &args.paper_data,
        pair,
        &input,
        &same,
        best.as_ref(),
        best_box.as_ref(),
    )?;
    if let Some(paper) = &entry.paper_result {
        // the published coefficients as a fit file, for `furnace eval --fit`
        let rec = FitRecord::new(paper.clone(), &input, FittedOn { points: 0, selection: "published coefficients (Sforza & Pellacini 2022, Appendix A); not fitted by furnace".into() });
        let path = args
            .reports_dir
            .join(format!("paper-{}.json", pair.paper_name));
        output::write(&path, rec.to_json()?.as_bytes())?;
    }
    Ok(entry)
}

/// `furnace compare-paper`.
pub fn compare_paper_cmd(args: &ComparePaperArgs) -> Result<()> {
    if !args.paper_data.join("coefficients").is_dir() {
        return Err(Error::file(&args.paper_data, "no coefficients/ folder here; point --paper-data at the paper's data (data/paper in the repository)"));
    }
    let entries = PAPER_PAIRS
        .iter()
        .map(|p| compare_one(args, p))
        .collect::<Result<Vec<_>>>()?;
    let report = CompareReport::new(entries);
    let md = report.to_markdown();
    output::write(&args.reports_dir.join("compare-paper.md"), md.as_bytes())?;
    output::write(
        &args.reports_dir.join("compare-paper.json"),
        report.to_json()?.as_bytes(),
    )?;
    out!("{md}")?;
    eprintln!(
        "wrote {}/compare-paper.{{md,json}}",
        args.reports_dir.display()
    );
    Ok(())
}
