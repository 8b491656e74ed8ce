//! Checks against the paper's own data (Sforza & Pellacini 2022; tables and coefficients from
//! their repository). The data directory is `$FURNACE_PAPER_DATA`, default
//! `data/paper/` (vendored, MIT).
//!
//! The timing check (1024² degree-3 rational ≤ 10 s) and the report tests that print the numbers
//! quoted in reviews are `#[ignore]`d because they need a release build; run them with
//! `cargo test --release --lib fit::paper_tests -- --ignored --nocapture --test-threads 1`.

use std::path::PathBuf;
use std::time::Instant;

use super::paper::{load_coefficients, load_table, published_fit, PaperModel};
use super::*;

fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("FURNACE_PAPER_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/paper"));
    assert!(
        dir.join("tables/conductors.csv").exists(),
        "paper data not found in {} (it is vendored under data/paper; FURNACE_PAPER_DATA overrides)",
        dir.display()
    );
    Some(dir)
}

#[test]
fn published_conductor_fit_reproduces_the_papers_error() {
    let Some(dir) = data_dir() else { return };
    let table = load_table(&dir.join("tables/conductors.csv"), PaperModel::Conductors).unwrap();
    let r = published_fit(
        &dir.join("coefficients/conductors.csv"),
        PaperModel::Conductors,
        &table,
    )
    .unwrap();
    eprintln!(
        "published conductors on 32²: MAE {:.5}, max {:.5} at {:?}, poles {:?}",
        r.metrics.mae, r.metrics.max_abs_error, r.metrics.max_abs_error_at, r.poles
    );
    // README of the paper data: 0.0041 / 0.027
    assert!(
        (r.metrics.mae - 0.0041).abs() < 0.00005,
        "{}",
        r.metrics.mae
    );
    assert!(
        (r.metrics.max_abs_error - 0.027).abs() < 0.0005,
        "{}",
        r.metrics.max_abs_error
    );
    assert!(r.poles.is_certified(), "{:?}", r.poles);
}

#[test]
fn published_3d_fits_reproduce_the_papers_errors() {
    let Some(dir) = data_dir() else { return };
    // (model, table, coefficients, MAE, max) from the paper data README
    for (model, name, mae, max) in [
        (PaperModel::Glossy, "glossy", 0.0071, 0.128),
        (PaperModel::Dielectrics, "dielectrics", 0.0042, 0.18),
        (
            PaperModel::DielectricsInvEta,
            "dielectrics_inv_eta",
            0.049,
            1.86,
        ),
    ] {
        let table = load_table(&dir.join(format!("tables/{name}.csv")), model).unwrap();
        let r =
            published_fit(&dir.join(format!("coefficients/{name}.csv")), model, &table).unwrap();
        eprintln!(
            "published {name} on 32³: MAE {:.5}, max {:.4}, poles {:?}",
            r.metrics.mae, r.metrics.max_abs_error, r.poles
        );
        assert!(
            (r.metrics.mae - mae).abs() < 0.03 * mae,
            "{name}: MAE {}",
            r.metrics.mae
        );
        assert!(
            (r.metrics.max_abs_error - max).abs() < 0.03 * max,
            "{name}: max {}",
            r.metrics.max_abs_error
        );
    }
}

#[test]
fn our_degree3_rational_beats_the_papers_on_its_table() {
    let Some(dir) = data_dir() else { return };
    let table = load_table(&dir.join("tables/conductors.csv"), PaperModel::Conductors).unwrap();
    let t = Instant::now();
    let r = fit_rational(
        &table,
        &[InputTransform::Identity; 2],
        3,
        3,
        Objective::LeastSquares,
        &RationalOptions::default(),
    )
    .unwrap();
    eprintln!(
        "our LS 3/3 on conductors 32²: MAE {:.5}, RMSE {:.5}, max {:.5}, {:.2} s (debug), poles {:?}, starts {:?}",
        r.metrics.mae,
        r.metrics.rmse,
        r.metrics.max_abs_error,
        t.elapsed().as_secs_f64(),
        r.poles,
        r.solver.as_ref().unwrap().starts.iter().map(|s| (s.name.clone(), s.cost, s.certified)).collect::<Vec<_>>()
    );
    assert_eq!(r.n_coefficients, 19);
    assert!(r.is_usable(), "{:?}", r.poles);
    assert!(r.metrics.mae <= 0.0041, "MAE {}", r.metrics.mae);
    // the emitted coefficients use the paper's layout: Q's constant is 1
    assert_eq!(
        r.approximant.denominator.as_ref().unwrap().coefficients[0],
        1.0
    );
    // a JSON round trip evaluates identically
    let back = FitResult::from_json(&r.to_json().unwrap()).unwrap();
    assert_eq!(
        back.eval(&[0.3, 0.6]).to_bits(),
        r.eval(&[0.3, 0.6]).to_bits()
    );
}

#[test]
fn published_coefficients_seed_our_fit_in_their_layout() {
    let Some(dir) = data_dir() else { return };
    let a = load_coefficients(
        &dir.join("coefficients/conductors.csv"),
        PaperModel::Conductors,
    )
    .unwrap();
    assert_eq!(a.n_coefficients(), 19);
    assert!((a.numerator.coefficients[0] - 1.0247217).abs() < 1e-12);
    assert!((a.denominator.as_ref().unwrap().coefficients[9] - -5.930959).abs() < 1e-12); // a18 · μ³
    let e = load_coefficients(&dir.join("coefficients/conductors.csv"), PaperModel::Glossy)
        .unwrap_err();
    assert!(e.to_string().contains("right model"), "{e}");
}

/// A smooth albedo-like 1024² data set: the paper's conductor rational plus a non-rational
/// perturbation, so the fit has real work to do.
fn synthetic_1024(dir: &std::path::Path) -> FitData {
    let a = load_coefficients(
        &dir.join("coefficients/conductors.csv"),
        PaperModel::Conductors,
    )
    .unwrap();
    let n = 1024;
    let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    let vals = ax
        .iter()
        .flat_map(|&r| ax.iter().map(move |&m| (r, m)))
        .map(|(r, m)| a.eval(&[r, m]) + 0.01 * (3.0 * r).sin() * (2.0 * m).cos())
        .collect();
    FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap()
}

#[test]
#[ignore = "timing: run in release (see module docs)"]
fn timing_1024_squared_degree3_rational() {
    let Some(dir) = data_dir() else { return };
    let data = synthetic_1024(&dir);
    let t = Instant::now();
    let r = fit_rational(
        &data,
        &[InputTransform::Identity; 2],
        3,
        3,
        Objective::LeastSquares,
        &RationalOptions::default(),
    )
    .unwrap();
    let secs = t.elapsed().as_secs_f64();
    let s = r.solver.as_ref().unwrap();
    eprintln!(
        "1024² 3/3 rational: {secs:.2} s on {} threads; MAE {:.2e}, RMSE {:.2e}, max {:.2e}; {:?} after {} LM steps; poles {:?}",
        rayon::current_num_threads(),
        r.metrics.mae,
        r.metrics.rmse,
        r.metrics.max_abs_error,
        s.termination,
        s.iterations,
        r.poles
    );
    for st in &s.starts {
        eprintln!(
            "  start {}: cost {:?}, {:?}, {} steps, certified {}",
            st.name, st.cost, st.termination, st.iterations, st.certified
        );
    }
    assert!(r.is_usable());
    assert!(secs <= 10.0, "{secs} s");
}

fn verdict(p: &PoleVerdict) -> String {
    match p {
        PoleVerdict::Certified {
            min_lower_bound, ..
        } => format!("certified |Q| ≥ {min_lower_bound:.3}"),
        PoleVerdict::PoleFound { at } => format!("POLE near {at:.3?}"),
        PoleVerdict::Undecided { reason, .. } => format!("undecided ({reason})"),
        PoleVerdict::NoDenominator => "polynomial".into(),
    }
}

/// Prints the paper-table comparison quoted in reports (release: see module docs).
#[test]
#[ignore = "report: run in release (see module docs)"]
fn report_paper_tables() {
    let Some(dir) = data_dir() else { return };
    let table = load_table(&dir.join("tables/conductors.csv"), PaperModel::Conductors).unwrap();
    let p = published_fit(
        &dir.join("coefficients/conductors.csv"),
        PaperModel::Conductors,
        &table,
    )
    .unwrap();
    eprintln!(
        "conductors 32², published 3/3: MAE {:.6}, RMSE {:.6}, max {:.6}, {}",
        p.metrics.mae,
        p.metrics.rmse,
        p.metrics.max_abs_error,
        verdict(&p.poles)
    );
    for obj in [
        Objective::LeastSquares,
        Objective::MeanAbsolute,
        Objective::Minimax,
    ] {
        let t = Instant::now();
        let r = fit_rational(
            &table,
            &[InputTransform::Identity; 2],
            3,
            3,
            obj,
            &RationalOptions::default(),
        )
        .unwrap();
        eprintln!(
            "conductors 32², ours 3/3 {obj:?}: MAE {:.6}, RMSE {:.6}, max {:.6}, {:.3} s, {:?}, {}",
            r.metrics.mae,
            r.metrics.rmse,
            r.metrics.max_abs_error,
            t.elapsed().as_secs_f64(),
            r.solver.as_ref().unwrap().termination,
            verdict(&r.poles)
        );
    }
    for (model, name) in [
        (PaperModel::Glossy, "glossy"),
        (PaperModel::Dielectrics, "dielectrics"),
        (PaperModel::DielectricsInvEta, "dielectrics_inv_eta"),
    ] {
        let table = load_table(&dir.join(format!("tables/{name}.csv")), model).unwrap();
        let p =
            published_fit(&dir.join(format!("coefficients/{name}.csv")), model, &table).unwrap();
        eprintln!(
            "{name} 32³, published 3/3: MAE {:.5}, max {:.4}, {}",
            p.metrics.mae,
            p.metrics.max_abs_error,
            verdict(&p.poles)
        );
        for obj in [Objective::LeastSquares, Objective::MeanAbsolute] {
            let t = Instant::now();
            let r = fit_rational(
                &table,
                &model.transforms(),
                3,
                3,
                obj,
                &RationalOptions::default(),
            )
            .unwrap();
            eprintln!(
                "{name} 32³, ours 3/3 {obj:?}: MAE {:.5}, max {:.4}, {:.2} s, {}",
                r.metrics.mae,
                r.metrics.max_abs_error,
                t.elapsed().as_secs_f64(),
                verdict(&r.poles)
            );
            for st in &r.solver.as_ref().unwrap().starts {
                eprintln!("    start {}: cost {:?} / all {:?}, {:?}, {} steps, constrained {}, certified {}", st.name, st.cost, st.cost_all_points, st.termination, st.iterations, st.certified_steps, st.certified);
            }
        }
    }
}

/// The paper's Fig. 3 sweep on its 32² conductor table (release: see module docs).
#[test]
#[ignore = "report: run in release (see module docs)"]
fn report_conductor_sweep() {
    let Some(dir) = data_dir() else { return };
    let table = load_table(&dir.join("tables/conductors.csv"), PaperModel::Conductors).unwrap();
    let mut opts = SweepOptions::for_dimension(2);
    opts.transform_sets
        .push(vec![InputTransform::Identity, InputTransform::Sqrt]);
    let rep = sweep_detailed(&table, &opts).unwrap();
    for r in &rep.results {
        eprintln!(
            "{:<28} {:<9} n={:<3} MAE {:.2e} max {:.2e} {:>7.3} s  {}",
            r.form.label(),
            r.approximant.transforms[1].name(),
            r.n_coefficients,
            r.metrics.mae,
            r.metrics.max_abs_error,
            r.fit_seconds,
            verdict(&r.poles)
        );
    }
    for s in &rep.skipped {
        eprintln!("skipped {} ({:?}): {}", s.form, s.transforms, s.reason);
    }
    for budget in [10, 19, 30, 50] {
        if let Some(b) = best_under_budget(&rep.results, budget) {
            eprintln!(
                "best ≤ {budget} coefficients: {} [{}], n={}, max {:.2e}",
                b.form.label(),
                b.approximant.transforms[1].name(),
                b.n_coefficients,
                b.metrics.max_abs_error
            );
        }
    }
}

/// Fit times on the 1024² synthetic set and a 64³ 3D set (release: see module docs).
#[test]
#[ignore = "report: run in release (see module docs)"]
fn report_large_fits() {
    let Some(dir) = data_dir() else { return };
    let data = synthetic_1024(&dir);
    let t = Instant::now();
    let p = fit_polynomial(
        &data,
        &[InputTransform::Identity; 2],
        10,
        Objective::LeastSquares,
        &PolynomialOptions::default(),
    )
    .unwrap();
    eprintln!(
        "1024² polynomial 10: {:.2} s, MAE {:.2e}, max {:.2e}",
        t.elapsed().as_secs_f64(),
        p.metrics.mae,
        p.metrics.max_abs_error
    );
    for deg in [5u32, 7] {
        let t = Instant::now();
        let r = fit_rational(
            &data,
            &[InputTransform::Identity; 2],
            deg,
            deg,
            Objective::LeastSquares,
            &RationalOptions::default(),
        )
        .unwrap();
        let s = r.solver.as_ref().unwrap();
        eprintln!(
            "1024² rational {deg}/{deg}: {:.2} s, MAE {:.2e}, max {:.2e}, {:?} after {} steps, {}",
            t.elapsed().as_secs_f64(),
            r.metrics.mae,
            r.metrics.max_abs_error,
            s.termination,
            s.iterations,
            verdict(&r.poles)
        );
    }
    // 3D: the published dielectric rational plus a perturbation on 64³
    let a = load_coefficients(
        &dir.join("coefficients/dielectrics.csv"),
        PaperModel::Dielectrics,
    )
    .unwrap();
    let n = 64;
    let ax: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    let f0: Vec<f64> = ax.iter().map(|t| (0.0125 + t * 0.2375).min(0.25)).collect();
    let mut vals = Vec::with_capacity(n * n * n);
    for &x in &f0 {
        for &r in &ax {
            for &m in &ax {
                vals.push(a.eval(&[x, r, m]) + 0.01 * (2.0 * r).sin() * (3.0 * m).cos());
            }
        }
    }
    let mut data3 = FitData::from_grid(
        PaperModel::Dielectrics.variables(),
        &[f0, ax.clone(), ax],
        vals,
    )
    .unwrap();
    data3.domain = PaperModel::Dielectrics.domain();
    let t = Instant::now();
    let r = fit_rational(
        &data3,
        &PaperModel::Dielectrics.transforms(),
        3,
        3,
        Objective::LeastSquares,
        &RationalOptions::default(),
    )
    .unwrap();
    eprintln!(
        "64³ rational 3/3: {:.2} s, MAE {:.2e}, max {:.2e}, {}",
        t.elapsed().as_secs_f64(),
        r.metrics.mae,
        r.metrics.max_abs_error,
        verdict(&r.poles)
    );
}
