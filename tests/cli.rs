//! The `furnace` command as a user meets it: listing, tabulating with a cache, evaluating
//! points, and clear errors for bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn furnace(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_furnace"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("runs")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("furnace-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

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
