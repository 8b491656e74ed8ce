//! One form fitted as a default 3-D sweep fits it: the sweep's fitting points (graded nodes and
//! exact training points), least squares, then the minimax refit with its Lawson path, every
//! iterate measured at the table's off-grid check points. What docs/fitting.md's one-form
//! measurements ("Budget 160: the logarithmic layer") come from; the model's 128³ table, check
//! set and training set are read from `data/` (computed there when missing, as a sweep does).
//!
//! `cargo run --release --example one_form_sweep -- MODEL SPEC TRANSFORMS [OUT_DIR] [--lp P,…]
//! [--grading G,…] [--fit-points N] [--training N] [--maxmean λ,…]`, e.g.
//! `… ggx-dielectric-inv lowrank:f0:4:4:5/4 f0=root:4:0.0125:0.25,r=square,mu=glayer:r:2:0:1:3`;
//! with OUT_DIR every fit is written there as a fit file (for `furnace stress --fit`); `--lp`
//! adds an L_p polish with these p to the minimax refit (`SweepPlan::lp_polish`), `--grading`
//! replaces the plan's grading exponents of the fitting nodes, one per variable
//! (`SweepPlan::fit_grading`), `--fit-points` the most table nodes the solver sees
//! (`SweepPlan::max_fit_points`, the graded subset's size) and `--training` the number of exact
//! training points (`SweepPlan::training_points`; a new count is computed and cached in `data/`);
//! `--maxmean` replaces the λ of the plan's max–mean polish (`SweepPlan::max_mean_polish`).
use furnace::fit::check;
use furnace::fit::defaults::{default_plan, default_training_points};
use furnace::fit::job;
use furnace::fit::parse_form;
use furnace::fit::Objective;
use furnace::quadrature::QuadratureSettings;
use furnace::table::TableSpec;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut a: Vec<String> = std::env::args().collect();
    let usage = "usage: one_form_sweep MODEL SPEC TRANSFORMS [OUT_DIR] [--lp P,…] [--grading G,…] \
                 [--fit-points N] [--training N]";
    // the flags and their comma-separated values, taken out of the positional arguments
    let mut flag = |name: &str| -> Result<Vec<f64>, Box<dyn std::error::Error>> {
        let Some(k) = a.iter().position(|x| x == name) else {
            return Ok(Vec::new());
        };
        let v = a.get(k + 1).ok_or(usage)?.clone();
        a.drain(k..k + 2);
        Ok(v.split(',')
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()?)
    };
    let lp = flag("--lp")?;
    let max_mean = flag("--maxmean")?;
    let grading = flag("--grading")?;
    let fit_points = flag("--fit-points")?;
    let training_n = flag("--training")?;
    if a.len() < 4 {
        return Err(usage.into());
    }
    let model = furnace::bsdf::find(&a[1])?;
    let spec = TableSpec::new(
        model.as_ref(),
        &model.default_resolution(),
        QuadratureSettings::default(),
    )?;
    let t = furnace::cli::get_table(model.as_ref(), &spec, Path::new("data"), false)?;
    let input = furnace::fit::source::from_table(&t.table, "E", Some(&t.stem))?;
    let checks = check::get_or_compute(model.as_ref(), &t.table.spec, &t.stem)?;
    let n = match training_n.first() {
        Some(&n) => n as usize,
        None => default_training_points(&input.data),
    };
    let training = check::training_get_or_compute(model.as_ref(), &t.table.spec, &t.stem, n)?;
    let transforms = job::parse_transforms(&a[3], &input.data.names)?;
    let form = parse_form(&a[2], &input.data.names)?;
    let size = form.n_coefficients(input.data.dim());
    // the default plan with its forms replaced by this one (and the smallest polynomial, which
    // a plan needs in one transform set)
    let mut plan = default_plan(
        &input.data,
        None,
        None,
        Objective::LeastSquares,
        model.grazing_boundary_layer(),
    );
    plan.polynomial_degrees = vec![1];
    plan.rational_degrees.clear();
    plan.rational_pairs.clear();
    plan.transform_sets = vec![transforms.clone()];
    plan.forms = vec![job::PlannedForm::new(form, transforms)];
    plan.budgets = vec![size];
    plan.lp_polish = lp;
    if !max_mean.is_empty() {
        plan.max_mean_polish = max_mean;
    }
    if !grading.is_empty() {
        plan.fit_grading = grading;
    }
    if let Some(&m) = fit_points.first() {
        plan.max_fit_points = m as usize;
    }
    plan.training_points = n;
    let (check_data, training_data) = (checks.data()?, training.data()?);
    let (check_on, training_on) = (checks.description(), training.training_description());
    let out = job::sweep_fits_trained(
        &input,
        &plan,
        Some((&check_data, &check_on)),
        Some((&training_data, &training_on)),
        &mut |line| eprintln!("  {line}"),
    )?;
    for (i, r) in out.records.iter().enumerate() {
        if r.fit.n_coefficients != size {
            continue;
        }
        let (max, mae) = r.headline();
        let iterate = r
            .fit
            .solver
            .as_ref()
            .and_then(|s| s.lawson_path.as_ref())
            .map(|p| format!(", {}", p.label(" ", " ")))
            .unwrap_or_default();
        let at = r
            .off_grid
            .as_ref()
            .map(|o| format!("{:.4?}", o.metrics.max_abs_error_at))
            .unwrap_or_default();
        println!(
            "{} {} in {}: {}{iterate}, {size} coefficients, off grid {max:.3e} / MAE {mae:.3e} (max at {at}), usable {}, {:.1} s",
            a[1],
            a[2],
            a[3],
            job::objective_name(r.fit.objective),
            r.usable,
            r.fit.fit_seconds
        );
        if let Some(dir) = a.get(4) {
            std::fs::create_dir_all(dir)?;
            std::fs::write(Path::new(dir).join(format!("fit-{i}.json")), r.to_json()?)?;
        }
    }
    Ok(())
}
