//! End to end, on the built binary and small tables: each structured form and each variable
//! transform of the fitter is fitted (`furnace fit --spec`), written, read back and checked
//! (`fit::file::load`), emitted to every language (`furnace emit`, which runs the f32 stress
//! test first; the WGSL and GLSL then pass naga's validator) and evaluated (`furnace eval
//! --fit`) against the f64 fit.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use furnace::fit::file as fitfile;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_furnace"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("forms")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("the furnace binary runs");
    assert!(
        out.status.success(),
        "command failed: {:?}\nstdout: {}\nstderr: {}",
        cmd,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().expect("the furnace binary runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "should have failed: {cmd:?}");
    assert!(!err.contains("panicked"), "a panic is not an error: {err}");
    err
}

/// Fits `spec` with `transforms` to `model` at `resolution`, then loads, emits and evaluates
/// it; returns the fit file's path.
fn round_trip(dir: &Path, model: &str, resolution: &str, spec: &str, transforms: &str) -> PathBuf {
    let out = dir.join("fit.json");
    run(bin()
        .args([
            "fit",
            "--model",
            model,
            "--resolution",
            resolution,
            "--spec",
            spec,
            "--transform",
            transforms,
            "--output",
        ])
        .arg(&out)
        .arg("--data-dir")
        .arg(dir.join("data"))
        .arg("--fits-dir")
        .arg(dir.join("fits")));
    let checked = fitfile::load(&out).unwrap_or_else(|e| panic!("{e}"));
    let fit = &checked.record.fit;
    assert!(fit.is_usable(), "{:?}", fit.poles);
    assert_eq!(
        fit.n_coefficients,
        fit.form.n_coefficients(fit.approximant.variables.len()),
        "every stored number counted"
    );
    // emit every language (the stress test gates it)
    run(bin()
        .args(["emit", "--lang", "rust,wgsl,glsl", "--fit"])
        .arg(&out));
    for ext in ["rs", "wgsl", "glsl"] {
        assert!(
            std::fs::read_dir(dir)
                .unwrap()
                .flatten()
                .any(|e| e.path().extension().is_some_and(|x| x == ext)),
            "no .{ext} next to the fit"
        );
    }
    // evaluate at points between the table nodes: the file's value is the f64 fit's
    let names = &fit.approximant.variables;
    let mut csv = names.join(",") + "\n";
    let mut points = Vec::new();
    for i in 0..7 {
        let x: Vec<f64> = fit
            .approximant
            .domain
            .iter()
            .enumerate()
            .map(|(k, &(lo, hi))| lo + (hi - lo) * ((0.37 + 0.29 * (i + k) as f64) % 1.0))
            .collect();
        csv += &(x
            .iter()
            .map(|v| v.to_string())
            .collect::<Vec<_>>()
            .join(",")
            + "\n");
        points.push(x);
    }
    let input = dir.join("points.csv");
    std::fs::write(&input, csv).unwrap();
    let o = run(bin()
        .args(["eval", "--fit"])
        .arg(&out)
        .arg("--input")
        .arg(&input)
        .args(["--output", "-"]));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), points.len(), "{text}");
    for (row, x) in rows.iter().zip(&points) {
        let e: f64 = row.split(',').nth(names.len()).unwrap().parse().unwrap();
        let want = fit.eval(x).clamp(0.0, 1.0);
        assert!((e - want).abs() < 1e-12, "{row}: {e} vs {want}");
    }
    out
}

#[test]
fn split_form_with_the_root_variable_round_trips() {
    let dir = scratch("split");
    let path = round_trip(
        &dir,
        "ggx-dielectric",
        "6x8x8",
        "split:f0:2:2/1",
        "f0=root:4:0.0125:0.25,r=square,mu=glayer:r:1:0:2",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    let q = fit.approximant.denominator.as_ref().unwrap();
    assert!(q.exponents.iter().all(|e| e[0] == 0), "Q has no f0");
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn per_variable_degrees_with_the_grazing_layer_round_trip() {
    let dir = scratch("tensor");
    round_trip(
        &dir,
        "ggx-conductor",
        "12",
        "tensor:2,3/1,1",
        "mu=glayer:r:1:0.5",
    );
}

#[test]
fn a_numerator_without_mu_terms_free_of_r_round_trips() {
    let dir = scratch("free-of-r");
    let path = round_trip(
        &dir,
        "oren-nayar-fon",
        "12",
        "tensor:1,5@r:0/1,0",
        "r=identity",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    assert_eq!(fit.n_coefficients, 8);
    let p = &fit.approximant.numerator;
    assert!(p.exponents.iter().all(|e| e[0] == 1 || e == &vec![0, 0]));
    assert!(fit.metrics.max_abs_error < 1e-3, "{:?}", fit.metrics);
}

#[test]
fn separate_denominators_round_trip_positive_and_certified() {
    let dir = scratch("sum");
    let path = round_trip(
        &dir,
        "ggx-dielectric",
        "6x8x8",
        "sum:f0:power:3:2/+1",
        "f0=root:4:0.0125:0.25,r=square,mu=glayer:r:1:0:2",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    let a = &fit.approximant;
    // three terms, each with its own denominator, none with f0
    assert_eq!(a.terms.len(), 2);
    assert_eq!(a.denominators().count(), 3);
    assert!(a
        .denominators()
        .all(|q| q.exponents.iter().all(|e| e[0] == 0)));
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn low_rank_round_trips() {
    let dir = scratch("lowrank");
    let path = round_trip(
        &dir,
        "ggx-dielectric-inv",
        "6x8x8",
        "lowrank:f0:2:2:2/1",
        "f0=root:4:0.0125:0.25,r=square,mu=glayer:r:1:0:2",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    // u_k of degree 2 (3), P_k of total degree 2 in (r, μ) (6), Q_k of degree 1 (3 − 1)
    assert_eq!(fit.n_coefficients, 2 * (3 + 6 + 2));
    assert!(fit.approximant.factor.is_some());
}

#[test]
fn low_rank_in_the_log_corrected_layer_round_trips() {
    // the default 3-D sweep's 40-coefficient separation in glayer:r:k:0:1:β
    let dir = scratch("lowrank-log");
    let (k, beta) = furnace::fit::defaults::LOG_LAYER_LOWRANK;
    let path = round_trip(
        &dir,
        "ggx-dielectric",
        "6x8x8",
        "lowrank:f0:2:2:2/1",
        &format!("f0=root:4:0.0125:0.25,r=square,mu=glayer:r:{k}:0:1:{beta}"),
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    assert_eq!(fit.n_coefficients, 2 * (3 + 6 + 2));
    assert_eq!(
        fit.approximant.transforms[2],
        furnace::fit::InputTransform::GrazingLayer {
            by: 1,
            k,
            w: 0.0,
            root: 1,
            beta
        }
    );
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn split_form_in_the_boundary_layer_variable_round_trips() {
    // the default 3-D sweep's 39-coefficient split sum in layer:r:k (smaller degrees here)
    let dir = scratch("split-layer");
    let k = furnace::fit::defaults::SPLIT_LAYER_SCALE;
    let n = furnace::fit::defaults::SPLIT_LAYER_F0_ROOT;
    let path = round_trip(
        &dir,
        "ggx-dielectric-separable",
        "6x8x8",
        "split:f0:2:2/1",
        &format!("f0=root:{n}:0.0125:0.25,r=square,mu=layer:r:{k}"),
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    assert_eq!(
        fit.approximant.transforms[2],
        furnace::fit::InputTransform::BoundaryLayer { by: 1, k }
    );
    // three powers of t_f0 times total degree 2 in (r, μ), Q of degree 1 without f0
    assert_eq!(fit.n_coefficients, 3 * 6 + 2);
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn split_form_in_the_root_layer_variable_round_trips() {
    // the width k r² (the default power) and k r³
    for (name, spec, k, power) in [
        ("root-layer", "slayer:r:3", 3.0, 2),
        ("root-layer-3", "slayer:r:10:3", 10.0, 3),
    ] {
        let dir = scratch(name);
        let path = round_trip(
            &dir,
            "ggx-glossy",
            "6x8x8",
            "split:f0:2:2/1",
            &format!("f0=root:4:0.0125:0.25,mu={spec}"),
        );
        let fit = fitfile::load(&path).unwrap().record.fit;
        assert_eq!(
            fit.approximant.transforms[2],
            furnace::fit::InputTransform::RootLayer { by: 1, k, power }
        );
        // three powers of t_f0 times total degree 2 in (r, μ), Q of degree 1 without f0
        assert_eq!(fit.n_coefficients, 3 * 6 + 2);
        assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
    }
}

#[test]
fn split_form_in_the_root_linear_f0_variable_round_trips() {
    // t ∝ F0^⅛ + F0/4 (the glossy split sum's F0 variable)
    let dir = scratch("root-linear");
    let path = round_trip(
        &dir,
        "ggx-glossy",
        "6x8x8",
        "split:f0:2:2/1",
        "f0=root:8:0.0125:0.25:0.25,mu=slayer:r:3",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    assert_eq!(
        fit.approximant.transforms[0],
        furnace::fit::InputTransform::RootNormalize {
            lo: 0.0125,
            hi: 0.25,
            root: 8,
            linear: 0.25
        }
    );
    assert_eq!(fit.n_coefficients, 3 * 6 + 2);
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn split_form_in_the_critical_angle_variable_round_trips() {
    let dir = scratch("critical");
    let path = round_trip(
        &dir,
        "ggx-dielectric-inv",
        "6x8x8",
        "split:f0:4:2/1",
        "f0=critical:0.0125:0.25,r=square,mu=glayer:r:1:0:2",
    );
    let fit = fitfile::load(&path).unwrap().record.fit;
    assert_eq!(
        fit.approximant.transforms[0],
        furnace::fit::InputTransform::CriticalAngle {
            lo: 0.0125,
            hi: 0.25
        }
    );
    // five powers of t_f0 times total degree 2 in (r, μ), Q of degree 1 without f0
    assert_eq!(fit.n_coefficients, 5 * 6 + 2);
    assert!(fit.metrics.max_abs_error < 0.1, "{:?}", fit.metrics);
}

#[test]
fn forms_the_data_cannot_determine_are_refused() {
    let dir = scratch("refused");
    let base = |spec: &str| {
        let mut c = bin();
        c.args([
            "fit",
            "--model",
            "ggx-dielectric",
            "--resolution",
            "4x6x6",
            "--spec",
            spec,
            "--output",
        ])
        .arg(dir.join("never.json"))
        .arg("--data-dir")
        .arg(dir.join("data"));
        c
    };
    let err = fails(&mut base("split:f0:4:2/1"));
    assert!(
        err.contains("4 distinct values of 'f0'") && err.contains("lower the degree"),
        "{err}"
    );
    let err = fails(&mut base("legendre:3"));
    assert!(err.contains("unknown form family 'legendre'"), "{err}");
    let err = fails(
        base("rational:1/1")
            .arg("--transform")
            .arg("f0=root:3:0.0125:0.25"),
    );
    assert!(err.contains("n = 2, 4 or 8"), "{err}");
    let err = fails(&mut base("sum:f0:chebyshev:2:2/1"));
    assert!(err.contains("unknown basis family 'chebyshev'"), "{err}");
    let err = fails(&mut base("sum:f0:power:5:2/1"));
    assert!(err.contains("4 distinct values of 'f0'"), "{err}");
    let err = fails(&mut base("tensor:1,1,1@r:0/1,0,0@r:0"));
    assert!(err.contains("only a numerator takes @"), "{err}");
    let err = fails(&mut base("tensor:1,1,1@eta:0/1,0,0"));
    assert!(err.contains("unknown variable 'eta'"), "{err}");
    let err = fails(&mut base("lowrank:f0:4:2:2/+1"));
    assert!(err.contains("at most 3 independent terms"), "{err}");
    assert!(!dir.join("never.json").exists(), "nothing written");
}
