//! Regenerates the fit-file fixtures of the emitter tests (`tests/fixtures/*.json`). They are
//! committed, so the emitter's snapshot tests depend on no solver and no external data:
//!
//! * `paper-conductors.json`, `paper-glossy.json`: the published degree-3 rationals of Sforza &
//!   Pellacini 2022 (Appendix A), measured on the paper's 32-point tables (paper repository data,
//!   `$FURNACE_PAPER_DATA`, default `data/paper` in the repository). The paper's renderer uses the
//!   separable Smith G, so the conductor fit is filed as `ggx-conductor-separable`; its glossy
//!   fit has a pole in its domain (the emitter must refuse it, the stress test must fail it).
//! * `ggx-dielectric.json`, `ggx-dielectric-inv.json`: furnace's own degree-3 rationals of the
//!   entering and leaving dielectric albedo over F0 of η ∈ [1.3, 1.7], r ∈ [0.05, 0.6], fitted
//!   to 12³ tables (small, so this runs in seconds) as `furnace run --scene` fits them: certified
//!   and passing the f32 stress test;
//! * `ggx-dielectric-inv-nearpole.json`: the fitter's first, default-margin fit of the same
//!   leaving table — certified, but its denominator comes within 8e-4 of zero and the f32 stress
//!   test fails it (the scene pipeline rejected it for the one above);
//! * `ggx-conductor-aniso.json` (`regenerate_aniso_fixture`): a degree-3/1 rational of the
//!   anisotropic conductor over r ∈ [0.2, 0.8] and the default aniso, μ and φ, fitted to a
//!   10 × 5 × 10 × 5 table as `furnace run --scene` fits an anisotropic conductor.
//!
//! Run: `cargo test --test emit_fixtures -- --ignored --nocapture`.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use furnace::bsdf;
use furnace::fit::job::FitRecord;
use furnace::fit::paper::{load_table, published_fit, PaperModel};
use furnace::fit::source::{from_table, FittedOn, Source};
use furnace::pipeline::scene::fit_table;
use furnace::quadrature::QuadratureSettings;
use furnace::scene::{f0_from_ior, FitSettings};
use furnace::table::{self, TableSpec};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

#[test]
#[ignore = "regenerates committed fixtures"]
fn regenerate_fixtures() {
    let dir = std::env::var_os("FURNACE_PAPER_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/paper"));
    for (name, model, file_model) in [
        (
            "conductors",
            PaperModel::Conductors,
            "ggx-conductor-separable",
        ),
        ("glossy", PaperModel::Glossy, "ggx-glossy-separable"),
    ] {
        let table_path = format!("data/paper/tables/{name}.csv");
        let table = load_table(&dir.join(format!("tables/{name}.csv")), model).unwrap();
        let fit =
            published_fit(&dir.join(format!("coefficients/{name}.csv")), model, &table).unwrap();
        let bytes = std::fs::read(dir.join(format!("tables/{name}.csv"))).unwrap();
        let source = Source {
            kind: "paper_table".into(),
            model: Some(file_model.into()),
            path: Some(table_path),
            content_hash: Sha256::digest(&bytes)
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect(),
            resolution: None,
            channel: "E".into(),
            points: fit.metrics.n_points,
            restricted_to: None,
        };
        let fitted_on = FittedOn {
            points: 0,
            selection:
                "published coefficients (Sforza & Pellacini 2022, Appendix A); not fitted by furnace"
                    .into(),
        };
        let f = FitRecord::from_source(fit, source, None, fitted_on);
        std::fs::write(
            fixtures().join(format!("paper-{name}.json")),
            f.to_json().unwrap(),
        )
        .unwrap();
        eprintln!("paper {name}: poles {:?}", f.fit.poles);
    }
    let f0 = (f0_from_ior(1.3), f0_from_ior(1.7));
    for model_name in ["ggx-dielectric", "ggx-dielectric-inv"] {
        let model = bsdf::find(model_name).unwrap();
        let spec = TableSpec::with_ranges(
            model.as_ref(),
            &[12, 12, 12],
            &[f0, (0.05, 0.6), (0.0, 1.0)],
            QuadratureSettings::default(),
        )
        .unwrap();
        let t = std::time::Instant::now();
        let table = table::tabulate(model.as_ref(), &spec, &|_| {}).unwrap();
        let stem = table::io::table_stem(Path::new("data"), model.as_ref(), &spec);
        let input = from_table(&table, "E", Some(&stem)).unwrap();
        let all = FittedOn {
            points: input.data.len(),
            selection: "all points".into(),
        };
        let record = |fit| FitRecord::new(fit, &input, all.clone());
        let stable = fit_table(&table, &FitSettings::default(), model_name, 100_000).unwrap();
        let fit = stable.fit;
        eprintln!(
            "{model_name}: table+fit {:.1} s, margin {}, MAE {:.2e}, max {:.2e}, poles {:?}, rejected {:?}",
            t.elapsed().as_secs_f64(),
            stable.margin,
            fit.metrics.mae,
            fit.metrics.max_abs_error,
            fit.poles,
            stable.rejected
        );
        let f = record(fit);
        std::fs::write(
            fixtures().join(format!("{model_name}.json")),
            f.to_json().unwrap(),
        )
        .unwrap();
        if !stable.rejected.is_empty() {
            // the first, rejected fit (default margin): a certified fit that fails the f32 stress test
            let near = fit_table(&table, &FitSettings::default(), model_name, 0).unwrap();
            let f = record(near.fit);
            std::fs::write(
                fixtures().join(format!("{model_name}-nearpole.json")),
                f.to_json().unwrap(),
            )
            .unwrap();
        }
    }
}

/// Run: `cargo test --release --test emit_fixtures -- --ignored --nocapture regenerate_aniso_fixture`.
#[test]
#[ignore = "regenerates a committed fixture"]
fn regenerate_aniso_fixture() {
    let model_name = "ggx-conductor-aniso";
    let model = bsdf::find(model_name).unwrap();
    let spec = TableSpec::with_ranges(
        model.as_ref(),
        &[10, 5, 10, 5],
        &[
            (0.2, 0.8),
            (0.0, 0.95),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ],
        QuadratureSettings::default(),
    )
    .unwrap();
    let table = table::tabulate(model.as_ref(), &spec, &|_| {}).unwrap();
    let stem = table::io::table_stem(Path::new("data"), model.as_ref(), &spec);
    let input = from_table(&table, "E", Some(&stem)).unwrap();
    let all = FittedOn {
        points: input.data.len(),
        selection: "all points".into(),
    };
    let settings = FitSettings {
        numerator_degree: 3,
        denominator_degree: 1,
    };
    let stable = fit_table(&table, &settings, model_name, 100_000).unwrap();
    eprintln!(
        "{model_name}: margin {}, MAE {:.2e}, max {:.2e}, poles {:?}",
        stable.margin, stable.fit.metrics.mae, stable.fit.metrics.max_abs_error, stable.fit.poles
    );
    let f = FitRecord::new(stable.fit, &input, all);
    std::fs::write(
        fixtures().join(format!("{model_name}.json")),
        f.to_json().unwrap(),
    )
    .unwrap();
}

/// The measurement behind `pipeline::scene::DENOMINATOR_MARGINS`: accuracy, denominator bound and f32
/// stress error of the 12³ dielectric fits at several denominator margins.
/// Run: `cargo test --test emit_fixtures -- --ignored --nocapture denominator_margin_sweep`.
#[test]
#[ignore = "measurement, not a check"]
fn denominator_margin_sweep() {
    use furnace::emit::stress::{stress, StressOptions};
    use furnace::fit::{fit_rational, FitData, InputTransform, Objective, RationalOptions};
    let f0 = (f0_from_ior(1.3), f0_from_ior(1.7));
    for model_name in ["ggx-dielectric-inv", "ggx-dielectric"] {
        let model = bsdf::find(model_name).unwrap();
        let spec = TableSpec::with_ranges(
            model.as_ref(),
            &[12, 12, 12],
            &[f0, (0.05, 0.6), (0.0, 1.0)],
            QuadratureSettings::default(),
        )
        .unwrap();
        let table = table::tabulate(model.as_ref(), &spec, &|_| {}).unwrap();
        let names: Vec<String> = table.spec.axes.iter().map(|a| a.name.clone()).collect();
        let axes: Vec<Vec<f64>> = table.spec.axes.iter().map(|a| a.nodes()).collect();
        let data = FitData::from_grid(names, &axes, table.output(0).to_vec()).unwrap();
        for margin in [1e-3, 1e-2, 3e-2, 1e-1, 0.3] {
            let t = std::time::Instant::now();
            let fit = fit_rational(
                &data,
                &[InputTransform::Identity; 3],
                3,
                3,
                Objective::LeastSquares,
                &RationalOptions {
                    denominator_margin: margin,
                    ..Default::default()
                },
            )
            .unwrap();
            let secs = t.elapsed().as_secs_f64();
            let r = stress(
                &fit,
                &furnace::emit::generate::albedo_function_name(model_name, "E"),
                &StressOptions {
                    random_points: 50_000,
                    ..Default::default()
                },
            )
            .unwrap();
            eprintln!("{model_name} margin {margin}: MAE {:.2e} max {:.2e} poles {:?} | {:?} f32 max {:.2e} κQ {:.1e} minQ {:.2e} ({secs:.1} s)", fit.metrics.mae, fit.metrics.max_abs_error, fit.poles, r.form, r.ieee.max_abs_diff.max(r.fused.max_abs_diff).max(r.gpu.max_abs_diff), r.max_condition_q.unwrap(), r.min_abs_q.unwrap());
        }
    }
}
