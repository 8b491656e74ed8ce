//! The `furnace` command as a user meets it: listing, tabulating with a cache, evaluating
//! points, and clear errors for bad input.

mod common;

use common::{furnace, scratch, stderr};
use std::path::{Path, PathBuf};
use std::process::Command;

#[test]
fn models_lists_every_model_with_axes() {
    let d = scratch("models");
    let o = furnace(&["models"], &d);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for m in furnace::bsdf::listed() {
        assert!(text.contains(&m.id().name()), "{} missing", m.id().name());
    }
    assert!(text.contains("f0") && text.contains("mu") && text.contains("default [0.0125, 0.25]"));
}

#[test]
fn tabulate_makes_the_four_dimensional_anisotropic_table() {
    let d = scratch("tabulate-aniso");
    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-conductor-aniso",
            "--resolution",
            "5x3x4x3",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stem = d.join("data/ggx-conductor-aniso/5x3x4x3");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(stem.with_extension("json")).unwrap())
            .unwrap();
    let names: Vec<&str> = (0..4)
        .map(|k| sidecar["axes"][k]["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["r", "aniso", "mu", "phi"]);
    let channels = furnace::table::io::read_exr_channels(&stem.with_extension("exr")).unwrap();
    let e = &channels.iter().find(|c| c.0 == "E").unwrap().1;
    assert_eq!(e.len(), 5 * 3 * 4 * 3);
    // row-major, φ fastest: index ((i_r·3 + i_aniso)·4 + i_mu)·3 + i_phi
    let at = |ir: usize, ia: usize, im: usize, ip: usize| e[((ir * 3 + ia) * 4 + im) * 3 + ip];
    for ip in 0..3 {
        assert_eq!(at(0, 2, 1, ip), 1.0, "r = 0 is a mirror");
        let e11 = at(4, 0, 3, ip) as f64;
        assert!((e11 - (1.0 - 2f64.ln())).abs() < 1e-7, "E(1, 0, 1) = {e11}");
        assert_eq!(
            at(3, 2, 3, ip),
            at(3, 2, 3, 0),
            "μ = 1 does not depend on φ"
        );
    }
    assert_ne!(
        at(3, 2, 1, 0),
        at(3, 2, 1, 2),
        "φ matters at μ < 1 when anisotropic"
    );
    let o = furnace(&["models"], &d);
    assert!(String::from_utf8_lossy(&o.stdout).contains("default resolution 64x16x64x16"));
}

#[test]
fn tabulate_writes_exr_and_sidecar_then_reads_the_cache() {
    let d = scratch("tabulate");
    let o = furnace(
        &["tabulate", "--model", "ggx-conductor", "--resolution", "16"],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("computed"));
    let stem = d.join("data/ggx-conductor/16x16");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(stem.with_extension("json")).unwrap())
            .unwrap();
    for key in [
        "model",
        "axes",
        "quadrature",
        "content_hash",
        "tool_version",
        "errors",
        "layout",
    ] {
        assert!(sidecar.get(key).is_some(), "sidecar lacks {key}");
    }
    assert_eq!(sidecar["axes"][1]["placement"], "endpoints");
    let channels = furnace::table::io::read_exr_channels(&stem.with_extension("exr")).unwrap();
    let e = &channels.iter().find(|c| c.0 == "E").unwrap().1;
    assert_eq!(e.len(), 256);
    assert_eq!(
        e[15 * 16],
        1.0,
        "r = 1 row starts at μ = 0; r = 0 column is the mirror (E = 1)"
    );
    assert!(
        (e[255] as f64 - (1.0 - 2f64.ln())).abs() < 1e-7,
        "E(1, 1) = 1 − ln 2, got {}",
        e[255]
    );
    // same inputs: read from the cache, byte-identical files
    let before = std::fs::read(stem.with_extension("f64")).unwrap();
    let o = furnace(
        &["tabulate", "--model", "ggx-conductor", "--resolution", "16"],
        &d,
    );
    assert!(stderr(&o).contains("read from cache"), "{}", stderr(&o));
    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-conductor",
            "--resolution",
            "16",
            "--force",
        ],
        &d,
    );
    assert!(stderr(&o).contains("computed"));
    assert_eq!(
        before,
        std::fs::read(stem.with_extension("f64")).unwrap(),
        "deterministic"
    );
    // other settings: not the cached table
    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-conductor",
            "--resolution",
            "16",
            "--order",
            "16",
        ],
        &d,
    );
    assert!(stderr(&o).contains("computed"), "{}", stderr(&o));
}

#[test]
fn eval_repeats_inputs_and_adds_outputs_with_many_digits() {
    let d = scratch("eval");
    std::fs::write(d.join("p.csv"), "mu,r,f0\n1.0,1.0,0.04\n0.5,0.0,0.04\n").unwrap();
    let o = furnace(
        &[
            "eval",
            "--model",
            "ggx-dielectric",
            "--input",
            "p.csv",
            "--output",
            "out.csv",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(d.join("out.csv")).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "mu,r,f0,E,E_R,E_T,err");
    assert!(lines[1].starts_with("1.0,1.0,0.04,"));
    let e: f64 = lines[2].split(',').nth(3).unwrap().parse().unwrap();
    assert_eq!(e, 1.0, "r = 0: E_R + E_T = 1");
    let digits = lines[1]
        .split(',')
        .nth(3)
        .unwrap()
        .split('e')
        .next()
        .unwrap()
        .replace(['.', '-'], "");
    assert!(
        digits.len() >= 12,
        "at least 12 significant digits: {}",
        lines[1]
    );
}

#[test]
fn bad_input_gets_clear_errors_and_no_files() {
    let d = scratch("bad");
    let o = furnace(&["tabulate", "--model", "ggx-metal"], &d);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("unknown model 'ggx-metal'") && stderr(&o).contains("ggx-conductor"),
        "{}",
        stderr(&o)
    );

    let o = furnace(
        &["tabulate", "--model", "ggx-conductor", "--resolution", "0"],
        &d,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("at least 2 nodes"),
        "{}",
        stderr(&o)
    );

    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-dielectric",
            "--resolution",
            "100000",
        ],
        &d,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("would need") && stderr(&o).contains("PiB"),
        "{}",
        stderr(&o)
    );

    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-dielectric",
            "--resolution",
            "8x8",
        ],
        &d,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("3 axes"),
        "{}",
        stderr(&o)
    );

    for (text, want) in [
        ("r\n0.5\n", "lacks the axis 'mu'"),
        ("r,mu\n0.5,abc\n", "row 2, column 'mu'"),
        ("r,mu\n0.5,0.5\nNaN,0.5\n", "row 3, column 'r'"),
        ("r,mu\n0.5,1.5\n", "outside the domain"),
    ] {
        std::fs::write(d.join("p.csv"), text).unwrap();
        let o = furnace(
            &[
                "eval",
                "--model",
                "ggx-conductor",
                "--input",
                "p.csv",
                "--output",
                "o.csv",
            ],
            &d,
        );
        assert!(!o.status.success(), "{text:?} accepted");
        assert!(stderr(&o).contains(want), "{text:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"));
    }
    assert!(
        !d.join("o.csv").exists(),
        "no output file from a failed run"
    );
    assert!(
        !d.join("data").exists(),
        "nothing tabulated for refused requests"
    );
}

#[test]
fn a_fit_from_furnace_fit_can_be_emitted_if_its_f32_code_passes_the_stress_test() {
    let d = scratch("fit-emit");
    let fit_of = |degree: &str| {
        let o = furnace(
            &[
                "fit",
                "--model",
                "ggx-conductor",
                "--form",
                "rational",
                "--degree",
                degree,
                "--resolution",
                "24",
            ],
            &d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        d.join(format!("fits/ggx-conductor/rational-{degree}.json"))
    };
    // certified, but its denominator comes within 1e-2 of zero: f32 rounding is amplified past
    // the stress test's limit in every evaluation form, so emit refuses it and writes nothing
    let fit = fit_of("3");
    let o = furnace(
        &["emit", "--fit", fit.to_str().unwrap(), "--lang", "all"],
        &d,
    );
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("fails the stress test")
            && e.contains("bernstein form max |f32 − f64|")
            && e.contains("not emitted"),
        "{e}"
    );
    assert!(!fit.with_extension("rs").exists() && !d.join("data/lut").exists());
    let fit = fit_of("2");
    let o = furnace(
        &[
            "emit",
            "--fit",
            fit.to_str().unwrap(),
            "--lang",
            "rust,wgsl,glsl",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // the fit file links its table, so the header measures the code on it
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("on its table (576 nodes)"), "{out}");
    for ext in ["rs", "wgsl", "glsl"] {
        let src = std::fs::read_to_string(fit.with_extension(ext)).unwrap();
        assert!(
            src.contains("ggx_conductor") && src.contains("Error at the 576 nodes of its table"),
            "{ext}: {}",
            &src[..src.len().min(300)]
        );
    }
}

/// The published conductor fit (certified; its f32 code passes the stress test) in `d`.
fn conductor_fit(d: &Path) -> &'static str {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(
        manifest.join("tests/fixtures/paper-conductors.json"),
        d.join("conductor.json"),
    )
    .unwrap();
    "conductor.json"
}

#[test]
fn a_points_file_with_only_a_header_is_refused() {
    let d = scratch("header-only");
    std::fs::write(d.join("h.csv"), "r,mu\n").unwrap();
    let fit = conductor_fit(&d);
    for source in [["--model", "ggx-conductor"], ["--fit", fit]] {
        let mut args = vec!["eval"];
        args.extend(source);
        args.extend(["--input", "h.csv", "--output", "o.csv"]);
        let o = furnace(&args, &d);
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains("no points: the header (r,mu) is not followed by any row"),
            "{}",
            stderr(&o)
        );
        assert!(!d.join("o.csv").exists());
    }
}

#[test]
fn negative_numbers_reach_the_check_that_names_the_fix() {
    let d = scratch("negative");
    let o = furnace(
        &[
            "tabulate",
            "--model",
            "ggx-conductor",
            "--resolution",
            "4",
            "--tolerance",
            "-1",
        ],
        &d,
    );
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("tolerance -1 must be a positive finite number")
            && !e.contains("unexpected argument"),
        "{e}"
    );
    let o = furnace(
        &[
            "emit",
            "--fit",
            "x.json",
            "--lang",
            "rust",
            "--lut-resolution",
            "-3",
        ],
        &d,
    );
    assert!(stderr(&o).contains("-3") && !stderr(&o).contains("unexpected argument"));
}

#[test]
fn an_io_error_is_printed_once() {
    let d = scratch("io-once");
    std::fs::write(d.join("pts.csv"), "r,mu\n0.5,0.5\n").unwrap();
    let o = furnace(
        &[
            "eval",
            "--fit",
            "missing.json",
            "--input",
            "pts.csv",
            "--output",
            "o.csv",
        ],
        &d,
    );
    let e = stderr(&o);
    assert!(!o.status.success());
    assert_eq!(e.matches("No such file or directory").count(), 1, "{e}");
    assert!(e.contains("missing.json"), "{e}");
}

#[test]
fn fits_of_user_tables_are_emitted_under_their_tables_names() {
    let d = scratch("user-names");
    for (name, slope) in [("brushed_steel", 0.2), ("velvet", 0.4)] {
        let mut csv = String::from("r,E\n");
        for i in 0..=16 {
            let r = i as f64 / 16.0;
            csv.push_str(&format!("{r},{}\n", 0.9 - slope * r * r));
        }
        std::fs::write(d.join(format!("{name}.csv")), csv).unwrap();
        let o = furnace(
            &[
                "fit",
                "--table",
                &format!("{name}.csv"),
                "--form",
                "polynomial",
                "--degree",
                "2",
            ],
            &d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let fit = format!("fits/{name}/polynomial-2.json");
        let o = furnace(
            &["emit", "--fit", &fit, "--lang", "wgsl", "--output", "-"],
            &d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let wgsl = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            wgsl.contains(&format!("fn {name}_albedo(r: f32) -> f32")),
            "{wgsl}"
        );
        assert!(
            wgsl.contains(&format!("Fitted to a user's table ({name}.csv)")),
            "{wgsl}"
        );
    }
    // fitting a user's table without --data-dir writes no data/ into the current folder
    assert!(!d.join("data").exists());
}

#[test]
fn bench_eval_leaves_no_temporary_folder_when_cargo_is_missing() {
    let d = scratch("bench-no-cargo");
    let tmp = d.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let fit = conductor_fit(&d);
    let o = Command::new(env!("CARGO_BIN_EXE_furnace"))
        .args([
            "bench",
            "eval",
            "--fit",
            fit,
            "--reference-2d",
            "9",
            "--points",
            "64",
            "--passes",
            "1",
        ])
        .current_dir(&d)
        .env("TMPDIR", &tmp)
        .env("CARGO", d.join("no-such-cargo"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(e.contains("needs cargo on PATH"), "{e}");
    let left: Vec<_> = std::fs::read_dir(&tmp).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn run_and_run_scene_refuse_an_unwritable_output_folder_before_computing() {
    let d = scratch("unwritable");
    // a folder cannot be made inside a file, whoever runs the test
    std::fs::write(d.join("file"), "").unwrap();
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/scene.json");
    let runs: [Vec<&str>; 2] = [
        vec![
            "run",
            "--data-dir",
            "data",
            "--fits-dir",
            "file/fits",
            "--reports-dir",
            "reports",
        ],
        vec![
            "run",
            "--scene",
            manifest.to_str().unwrap(),
            "--data-dir",
            "data",
            "--fits-dir",
            "file/fits",
        ],
    ];
    for args in runs {
        let o = furnace(&args, &d);
        let e = stderr(&o);
        assert!(!o.status.success());
        assert!(
            e.contains("file/fits") && e.contains("cannot write here") && e.contains("--fits-dir"),
            "{e}"
        );
        // nothing was tabulated: the data folder holds no table
        let tables = std::fs::read_dir(d.join("data")).map_or(0, |r| r.count());
        assert_eq!(tables, 0, "{args:?}");
    }
}

#[test]
fn single_output_commands_refuse_an_unwritable_output_before_computing() {
    let d = scratch("unwritable-output");
    // a folder cannot be made inside a file, whoever runs the test
    std::fs::write(d.join("file"), "").unwrap();
    std::fs::write(d.join("p.csv"), "r,mu\n0.5,0.5\n").unwrap();
    let fit = conductor_fit(&d);
    let runs: [(Vec<&str>, &str); 8] = [
        (
            vec![
                "fit",
                "--model",
                "ggx-conductor",
                "--resolution",
                "9",
                "--sweep",
                "--max-degree",
                "1",
                "--fits-dir",
                "file/fits",
            ],
            "--fits-dir",
        ),
        (
            vec![
                "fit",
                "--model",
                "ggx-conductor",
                "--resolution",
                "9",
                "--form",
                "polynomial",
                "--degree",
                "1",
                "--output",
                "file/fit.json",
            ],
            "--output",
        ),
        (
            vec![
                "fit",
                "--model",
                "ggx-conductor",
                "--resolution",
                "9",
                "--form",
                "polynomial",
                "--degree",
                "1",
                "--data-dir",
                "file/data",
            ],
            "--data-dir",
        ),
        (
            vec![
                "eval",
                "--model",
                "ggx-conductor",
                "--input",
                "p.csv",
                "--output",
                "file/o.csv",
            ],
            "--output",
        ),
        (
            vec![
                "eval",
                "--fit",
                fit,
                "--input",
                "p.csv",
                "--output",
                "file/o.csv",
            ],
            "--output",
        ),
        (
            vec![
                "emit",
                "--fit",
                fit,
                "--lang",
                "glsl",
                "--output",
                "file/o.glsl",
            ],
            "--output",
        ),
        (
            vec![
                "export",
                "--format",
                "cycles",
                "--output",
                "file/shader.tables",
            ],
            "--output",
        ),
        (
            vec![
                "report",
                "--model",
                "ggx-conductor",
                "--reports-dir",
                "file/reports",
            ],
            "--reports-dir",
        ),
    ];
    for (args, option) in runs {
        let o = furnace(&args, &d);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            e.contains("cannot write here: ")
                && e.contains("is not a folder")
                && e.contains(option),
            "{args:?}: {e}"
        );
        assert!(
            !e.contains("I/O error"),
            "refused by the check, not by the write: {e}"
        );
        // nothing was tabulated or fitted first
        assert!(
            !d.join("data").exists() && !d.join("fits").exists(),
            "{args:?}"
        );
    }
    // a new folder for the output is still made
    let o = furnace(
        &[
            "eval",
            "--fit",
            fit,
            "--input",
            "p.csv",
            "--output",
            "new/sub/o.csv",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("new/sub/o.csv").is_file());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_output_that_is_an_input_file_is_refused() {
    let d = scratch("output-is-input");
    let fit = conductor_fit(&d);
    std::fs::write(d.join("p.csv"), "r,mu\n0.5,0.5\n").unwrap();
    std::fs::write(d.join("t.csv"), "x,E\n0,1\n0.5,0.8\n1,0.7\n").unwrap();
    std::os::unix::fs::symlink("p.csv", d.join("link.csv")).unwrap();
    let fit_bytes = std::fs::read(d.join(fit)).unwrap();
    let runs: [(Vec<&str>, &str); 5] = [
        (
            vec!["emit", "--fit", fit, "--lang", "glsl", "--output", fit],
            "is also the --fit file",
        ),
        (
            vec!["eval", "--fit", fit, "--input", "p.csv", "--output", fit],
            "is also the --fit file",
        ),
        (
            vec![
                "eval", "--fit", fit, "--input", "p.csv", "--output", "link.csv",
            ],
            "is also the --input file",
        ),
        (
            vec![
                "eval",
                "--model",
                "ggx-conductor",
                "--input",
                "p.csv",
                "--output",
                "p.csv",
            ],
            "is also the --input file",
        ),
        (
            vec![
                "fit",
                "--table",
                "t.csv",
                "--form",
                "polynomial",
                "--degree",
                "1",
                "--output",
                "t.csv",
            ],
            "is also the --table file",
        ),
    ];
    for (args, want) in runs {
        let o = furnace(&args, &d);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            e.contains(want) && e.contains("give another path"),
            "{args:?}: {e}"
        );
    }
    // every input is as it was
    assert_eq!(std::fs::read(d.join(fit)).unwrap(), fit_bytes);
    assert_eq!(
        std::fs::read_to_string(d.join("p.csv")).unwrap(),
        "r,mu\n0.5,0.5\n"
    );
    assert!(std::fs::read_to_string(d.join("t.csv"))
        .unwrap()
        .starts_with("x,E\n"));
    let _ = std::fs::remove_dir_all(&d);
}
