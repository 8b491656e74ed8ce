//! Nothing unsafe reaches a user: output files are written without replacing links, FIFOs or
//! devices; `emit` refuses inconsistent fit files and states what its code's arguments mean,
//! what the stress test measured and a bound; suffixes let several fits of one model share a
//! shader; the emitted GLSL passes glslangValidator (ES 3.00 and 4.50, whose SPIR-V passes
//! spirv-val), the emitted HLSL passes glslangValidator's HLSL front end (SPIR-V checked by
//! spirv-val), the emitted C/C++ header compiles as C++17 and C99 (g++/gcc, warnings as errors)
//! and the emitted Rust compiles under `#![no_std]`.

mod common;

use common::{furnace, repository as root, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn ok(o: &Output) -> &Output {
    assert!(
        o.status.success(),
        "{}\n{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    o
}

/// Fails, says `want` on stderr, and never panics.
fn refused(o: &Output, want: &str) -> String {
    let e = text(&o.stderr);
    assert!(!o.status.success(), "should fail: {e}");
    assert!(e.contains(want), "expected '{want}' in: {e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A folder with the published conductor fit (certified, passes the stress test) and points.
fn conductor_dir(name: &str) -> PathBuf {
    let d = scratch(name);
    std::fs::copy(
        root().join("tests/fixtures/paper-conductors.json"),
        d.join("conductor.json"),
    )
    .unwrap();
    std::fs::write(d.join("pts.csv"), "r,mu\n0.5,0.5\n0.1,0.9\n").unwrap();
    d
}

fn eval_to(d: &Path, output: &str) -> Output {
    furnace(
        &[
            "eval",
            "--fit",
            "conductor.json",
            "--input",
            "pts.csv",
            "--output",
            output,
        ],
        d,
    )
}

#[test]
fn output_files_replace_regular_files_follow_symlinks_and_write_fifos_in_place() {
    use std::os::unix::fs::{symlink, FileTypeExt};
    let d = conductor_dir("outputs");
    // standard output
    let o = eval_to(&d, "-");
    ok(&o);
    let csv = text(&o.stdout);
    assert!(
        csv.starts_with("r,mu,E\n0.5,0.5,0.") && csv.lines().count() == 3,
        "{csv}"
    );
    assert!(text(&o.stderr).contains("evaluated to standard output"));
    // a regular file, written twice: the same bytes, no temporary file left
    ok(&eval_to(&d, "out.csv"));
    ok(&eval_to(&d, "out.csv"));
    assert_eq!(std::fs::read_to_string(d.join("out.csv")).unwrap(), csv);
    assert!(
        !listing(&d).iter().any(|f| f.contains(".tmp")),
        "{:?}",
        listing(&d)
    );
    // a symlink: its target is written, the link stays a link
    std::fs::write(d.join("real.csv"), "old").unwrap();
    symlink("real.csv", d.join("link.csv")).unwrap();
    ok(&eval_to(&d, "link.csv"));
    assert!(std::fs::symlink_metadata(d.join("link.csv"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(d.join("real.csv")).unwrap(), csv);
    // a FIFO: written in place (a reader gets the bytes), never replaced by a file
    let fifo = d.join("pipe");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    ok(&eval_to(&d, "pipe"));
    assert_eq!(reader.join().unwrap(), csv);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    // a folder is refused by name
    std::fs::create_dir(d.join("folder")).unwrap();
    refused(&eval_to(&d, "folder"), "is a folder");
    // fit --output - and emit --output -: the file on stdout, the notes on stderr
    std::fs::write(d.join("line.csv"), "x,E\n0,0.5\n0.5,0.6\n1,0.7\n").unwrap();
    let o = furnace(
        &[
            "fit",
            "--table",
            "line.csv",
            "--form",
            "polynomial",
            "--degree",
            "1",
            "--output",
            "-",
        ],
        &d,
    );
    ok(&o);
    let rec: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(rec["tool"], "furnace");
    assert!(text(&o.stderr).contains("standard output: polynomial of degree 1"));
    assert!(!d.join("fits").exists() && !d.join("data").exists());
    let o = furnace(
        &[
            "emit",
            "--fit",
            "conductor.json",
            "--lang",
            "wgsl",
            "--output",
            "-",
        ],
        &d,
    );
    ok(&o);
    assert!(text(&o.stdout).contains("fn ggx_conductor_separable_albedo(r: f32, mu: f32) -> f32"));
    assert!(!d.join("conductor.wgsl").exists());
    refused(
        &furnace(
            &[
                "emit",
                "--fit",
                "conductor.json",
                "--lang",
                "all",
                "--output",
                "-",
            ],
            &d,
        ),
        "--output writes one file",
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Each edit of the published conductor's fit file that emit must refuse, and what it must say.
#[test]
fn emit_refuses_inconsistent_fit_files_and_writes_nothing() {
    let d = conductor_dir("inconsistent");
    let good: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("conductor.json")).unwrap()).unwrap();
    type Edit = fn(&mut serde_json::Value);
    let cases: [(&str, Edit, &str); 7] = [
        (
            "twice",
            |v| v["fit"]["approximant"]["variables"] = serde_json::json!(["r", "r"]),
            "duplicate variables: 'r' appears twice",
        ),
        (
            "case",
            |v| v["fit"]["approximant"]["variables"] = serde_json::json!(["R", "r"]),
            "'R' and 'r' name the same argument",
        ),
        (
            "other-model",
            |v| v["source"]["model"] = "ggx-dielectric".into(),
            "model/variables mismatch: ggx-dielectric has the axes [f0, r, mu]",
        ),
        (
            "unknown-variable",
            |v| v["fit"]["approximant"]["variables"] = serde_json::json!(["r", "theta"]),
            "'theta' not an axis of ggx-conductor-separable",
        ),
        (
            "unknown-model",
            |v| v["source"]["model"] = "ggx-unobtainium".into(),
            "unknown model 'ggx-unobtainium'",
        ),
        (
            "output",
            |v| v["source"]["channel"] = "E_T".into(),
            "model/output mismatch",
        ),
        (
            "domain",
            |v| v["fit"]["approximant"]["domain"][0] = serde_json::json!([0.0, 2.0]),
            "reaches outside the valid range [0, 1]",
        ),
    ];
    for (name, edit, want) in cases {
        let mut v = good.clone();
        edit(&mut v);
        let file = format!("{name}.json");
        std::fs::write(d.join(&file), v.to_string()).unwrap();
        let before = listing(&d);
        let e = refused(
            &furnace(&["emit", "--fit", &file, "--lang", "all"], &d),
            want,
        );
        assert!(e.contains(&file) && e.contains("re-create"), "{name}: {e}");
        assert_eq!(listing(&d), before, "{name}: nothing may be written");
        // eval --fit and stress read the same format with the same checks
        refused(
            &furnace(
                &[
                    "eval", "--fit", &file, "--input", "pts.csv", "--output", "o.csv",
                ],
                &d,
            ),
            want,
        );
        refused(&furnace(&["stress", "--fit", &file], &d), want);
    }
    // a fit that is not an albedo (here, three times the conductor's): the output clamp would
    // replace it, so it is not emitted
    let mut v = good.clone();
    for c in v["fit"]["approximant"]["numerator"]["coefficients"]
        .as_array_mut()
        .unwrap()
    {
        *c = (3.0 * c.as_f64().unwrap()).into();
    }
    std::fs::write(d.join("tripled.json"), v.to_string()).unwrap();
    refused(
        &furnace(&["emit", "--fit", "tripled.json", "--lang", "wgsl"], &d),
        "the fit's values leave [0, 1] by up to",
    );
    assert!(!d.join("tripled.wgsl").exists());
    // the verdict stored in a file is not trusted: re-proved, and the message never
    // contradicts itself ("not usable: usable: …")
    let mut glossy: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("tests/fixtures/paper-glossy.json")).unwrap(),
    )
    .unwrap();
    glossy["usable"] = true.into();
    glossy["verdict"] = "usable: trust me".into();
    std::fs::write(d.join("glossy.json"), glossy.to_string()).unwrap();
    let e = refused(
        &furnace(&["emit", "--fit", "glossy.json", "--lang", "rust"], &d),
        "uncertified denominator: Q changes sign",
    );
    assert!(!e.contains("usable"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The number after `label` in `text`, e.g. the bound in "Bound: |f32 - f64| <= 1.30e-5".
fn number_after(text: &str, label: &str) -> f64 {
    let at = text
        .find(label)
        .unwrap_or_else(|| panic!("no '{label}' in the header"))
        + label.len();
    text[at..]
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == '-'))
        .find(|s| !s.is_empty())
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn headers_say_what_the_arguments_mean_and_state_the_stress_numbers_and_a_bound() {
    let d = scratch("headers");
    for f in ["paper-conductors.json", "ggx-dielectric-inv.json"] {
        std::fs::copy(root().join("tests/fixtures").join(f), d.join(f)).unwrap();
    }
    for (file, lang) in [
        ("paper-conductors.json", "rust"),
        ("paper-conductors.json", "wgsl"),
        ("ggx-dielectric-inv.json", "glsl"),
    ] {
        let o = furnace(
            &["emit", "--fit", file, "--lang", lang, "--output", "-"],
            &d,
        );
        ok(&o);
        assert!(o.stdout.is_ascii(), "{file} {lang}: emitted text is ASCII");
        let h = text(&o.stdout);
        for want in [
            "Arguments (f32, dimensionless; an input outside its fitted domain is clamped to it):",
            "r: square root of GGX alpha (alpha = r^2); fitted domain",
            "mu: cosine of the outgoing direction, mu_o = n*w_o; fitted domain [0, 1]",
            "measured at the stress test's 1000000 random + ",
            "(every op rounded, as this Rust)",
            "(fused multiply-add)",
            "(GPU division/sqrt error)",
            "for every input, in all three rounding models",
        ] {
            assert!(h.contains(want), "{file} {lang}: no '{want}' in\n{h}");
        }
        // the stated bound covers the measured differences
        let bound = number_after(&h, "Bound: |f32 - f64| <= ");
        let measured = number_after(&h, "edge points (`furnace stress`, seed 0x5eedf00d): max ");
        assert!(
            bound.is_finite() && measured > 0.0 && measured <= bound,
            "{measured} vs {bound}"
        );
    }
    // what f0 means for a fit of the leaving dielectric
    let o = furnace(
        &[
            "emit",
            "--fit",
            "ggx-dielectric-inv.json",
            "--lang",
            "wgsl",
            "--output",
            "-",
        ],
        &d,
    );
    assert!(text(&ok(&o).stdout).contains(
        "f0: normal-incidence reflectance F0 of the interface (the same from either side: pass the material's F0); the light leaves the medium"
    ));
    let _ = std::fs::remove_dir_all(&d);
}

/// A note the test harness does not capture: written to the terminal even when the test passes.
fn visible(note: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{note}");
}

fn tool(name: &str) -> bool {
    Command::new(name)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The emitted files of the published conductor fit with two suffixes, and of the dielectric
/// pair: what the toolchain tests compile.
fn emitted(d: &Path) -> Vec<(String, String)> {
    for f in [
        "paper-conductors.json",
        "ggx-dielectric.json",
        "ggx-dielectric-inv.json",
    ] {
        std::fs::copy(root().join("tests/fixtures").join(f), d.join(f)).unwrap();
    }
    let mut out = Vec::new();
    for lang in ["rust", "wgsl", "glsl", "hlsl", "cpp"] {
        let mut both = String::new();
        for suffix in ["_a", "_b"] {
            let o = furnace(
                &[
                    "emit",
                    "--fit",
                    "paper-conductors.json",
                    "--lang",
                    lang,
                    "--suffix",
                    suffix,
                    "--output",
                    "-",
                ],
                d,
            );
            both.push_str(&text(&ok(&o).stdout));
        }
        out.push((format!("two-budgets.{lang}"), both));
    }
    for snapshot in ["dielectric-pair", "paper-conductors"] {
        for ext in ["rs", "wgsl", "glsl", "hlsl", "h"] {
            let name = format!("{snapshot}.{ext}");
            let t = std::fs::read_to_string(root().join("tests/snapshots").join(&name)).unwrap();
            out.push((name, t));
        }
    }
    out
}

#[test]
fn suffixes_let_two_fits_of_one_model_share_a_shader() {
    let d = scratch("suffixes");
    for (name, src) in emitted(&d) {
        if !name.starts_with("two-budgets") {
            continue;
        }
        for f in [
            "ggx_conductor_separable_albedo",
            "ggx_conductor_separable_turquin_scale_rgb",
        ] {
            assert!(
                src.contains(&format!("{f}_a(")) && src.contains(&format!("{f}_b(")),
                "{name}"
            );
        }
        if name.ends_with(".wgsl") {
            furnace::emit::validate::wgsl(&src).unwrap();
        }
        if name.ends_with(".glsl") {
            // two include guards, one per file
            assert!(src.contains("FURNACE_GGX_CONDUCTOR_SEPARABLE_PAPER_CONDUCTORS_A_GLSL"));
            furnace::emit::validate::glsl(&src).unwrap();
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A fragment shader of GLSL `version` with `src` pasted after the version line and `body` as
/// its `main`.
fn fragment(version: &str, src: &str, body: &str) -> String {
    let (head, io) = if version.contains("es") {
        (
            "precision mediump float;\n",
            "uniform highp vec3 x;\nout highp vec4 color;\n",
        )
    } else {
        (
            "",
            "layout(location = 0) in vec3 x;\nlayout(location = 0) out vec4 color;\n",
        )
    };
    format!("#version {version}\n{head}{src}\n{io}void main() {{\n{body}\n}}\n")
}

#[test]
fn emitted_glsl_passes_glslang_and_spirv_val_and_rust_compiles_under_no_std() {
    let d = scratch("toolchains");
    let files = emitted(&d);
    if tool("glslangValidator") && tool("spirv-val") {
        for (name, src) in files.iter().filter(|(n, _)| n.ends_with(".glsl")) {
            let body = if name.starts_with("dielectric") {
                "    color = vec4(ggx_dielectric_sided_albedo(x.x, x.y, x.z), ggx_dielectric_normalization(x.x, x.y, x.z), ggx_dielectric_kulla_conty_bsdf(0.08, 0.9, 0.8, x.x, x.y, x.z, -x.z), 1.0);"
            } else if name.starts_with("two-budgets") {
                "    color = vec4(ggx_conductor_separable_turquin_scale_rgb_a(x, x.y, x.z) + ggx_conductor_separable_turquin_scale_rgb_b(x, x.y, x.z), 1.0);"
            } else {
                "    color = vec4(ggx_conductor_separable_turquin_scale_rgb(x, x.y, x.z), ggx_conductor_separable_albedo(x.x, x.y));"
            };
            // GLSL ES 3.00 with a mediump default: the highp declarations must carry it
            let es = d.join(format!("{name}.es.frag"));
            std::fs::write(&es, fragment("300 es", src, body)).unwrap();
            let o = Command::new("glslangValidator").arg(&es).output().unwrap();
            assert!(
                o.status.success(),
                "{name} as GLSL ES 3.00: {}",
                text(&o.stdout)
            );
            // GLSL 4.50 to Vulkan SPIR-V, which spirv-val checks
            let frag = d.join(format!("{name}.frag"));
            let spv = d.join(format!("{name}.spv"));
            std::fs::write(&frag, fragment("450", src, body)).unwrap();
            let o = Command::new("glslangValidator")
                .arg("-V")
                .arg(&frag)
                .arg("-o")
                .arg(&spv)
                .output()
                .unwrap();
            assert!(o.status.success(), "{name} to SPIR-V: {}", text(&o.stdout));
            let o = Command::new("spirv-val").arg(&spv).output().unwrap();
            assert!(o.status.success(), "{name}: spirv-val: {}", text(&o.stderr));
        }
        // the validator is not vacuous
        let bad = d.join("bad.frag");
        std::fs::write(&bad, fragment("450", "float f(float x) { return y; }", "")).unwrap();
        assert!(!Command::new("glslangValidator")
            .arg("-V")
            .arg(&bad)
            .output()
            .unwrap()
            .status
            .success());
    } else {
        visible("SKIPPED: glslangValidator or spirv-val not found (Debian packages glslang-tools and spirv-tools; .ci/run installs them) — the emitted GLSL was not compiled to SPIR-V");
    }
    if !tool("rustc") {
        visible("SKIPPED: rustc not found — the emitted Rust was not compiled under no_std");
        return;
    }
    // a fit with a square-root transform, so the no_std path of sqrt is exercised
    let sqrt_rs = sqrt_fit_rust(&d);
    let libm = libm_rlib();
    let mut rust: Vec<(String, String)> = files
        .into_iter()
        .filter(|(n, _)| n.ends_with(".rs"))
        .collect();
    rust.push(("sqrt-fit.rs".into(), sqrt_rs));
    for (k, (name, src)) in rust.iter().enumerate() {
        let file = d.join(name);
        std::fs::write(&file, src).unwrap();
        let lib = d.join(format!("nostd_{k}.rs"));
        std::fs::write(
            &lib,
            format!("#![no_std]\n#![deny(warnings)]\ninclude!({:?});\n", file),
        )
        .unwrap();
        let o = Command::new("rustc")
            .args([
                "--edition",
                "2021",
                "--crate-type",
                "rlib",
                "--cfg",
                "feature=\"libm\"",
            ])
            .arg("--extern")
            .arg(format!("libm={}", libm.display()))
            .arg("--out-dir")
            .arg(&d)
            .arg(&lib)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{name} under no_std: {}",
            text(&o.stderr)
        );
    }
    // without the feature and without std, the message names the square root
    let lib = d.join("nolibm.rs");
    std::fs::write(
        &lib,
        format!("#![no_std]\ninclude!({:?});\n", d.join("sqrt-fit.rs")),
    )
    .unwrap();
    let o = Command::new("rustc")
        .args(["--edition", "2021", "--crate-type", "rlib", "--out-dir"])
        .arg(&d)
        .arg(&lib)
        .output()
        .unwrap();
    assert!(!o.status.success() && text(&o.stderr).contains("sqrt"));
    let _ = std::fs::remove_dir_all(&d);
}

/// An HLSL pixel shader with `src` pasted before its `main`, which returns `body`.
fn pixel_shader(src: &str, body: &str) -> String {
    format!("{src}\nfloat4 main(float3 x : TEXCOORD0) : SV_Target {{\n    return {body};\n}}\n")
}

#[test]
fn emitted_hlsl_passes_glslang_and_spirv_val_and_cpp_compiles_as_cpp17_and_c99() {
    let d = scratch("hlsl-cpp");
    let files = emitted(&d);
    if tool("glslangValidator") && tool("spirv-val") {
        let hlsl: Vec<_> = files.iter().filter(|(n, _)| n.ends_with(".hlsl")).collect();
        assert_eq!(hlsl.len(), 3);
        for (name, src) in hlsl {
            let body = if name.starts_with("dielectric") {
                "float4(ggx_dielectric_sided_albedo(x.x, x.y, x.z), ggx_dielectric_sided_normalization(x.x, x.y, x.z), ggx_dielectric_normalization(x.x, x.y, x.z), ggx_dielectric_inv_normalization(x.x, x.y, x.z))"
            } else if name.starts_with("two-budgets") {
                "float4(ggx_conductor_separable_turquin_scale_rgb_a(x, x.y, x.z) + ggx_conductor_separable_turquin_scale_rgb_b(x, x.y, x.z), ggx_conductor_separable_turquin_scale_a(x.x, x.y, x.z))"
            } else {
                "float4(ggx_conductor_separable_turquin_scale_rgb(x, x.y, x.z), ggx_conductor_separable_albedo(x.x, x.y) + ggx_conductor_separable_normalization(x.x, x.y))"
            };
            let file = d.join(format!("{name}.ps.hlsl"));
            let spv = d.join(format!("{name}.hlsl.spv"));
            std::fs::write(&file, pixel_shader(src, body)).unwrap();
            // -D: HLSL input; -e main -S frag: the entry point and its stage; -V: SPIR-V out
            let o = Command::new("glslangValidator")
                .args(["-D", "-e", "main", "-S", "frag", "-V"])
                .arg(&file)
                .arg("-o")
                .arg(&spv)
                .output()
                .unwrap();
            assert!(o.status.success(), "{name} to SPIR-V: {}", text(&o.stdout));
            let o = Command::new("spirv-val").arg(&spv).output().unwrap();
            assert!(o.status.success(), "{name}: spirv-val: {}", text(&o.stderr));
        }
        // the HLSL front end is not vacuous
        let bad = d.join("bad.hlsl");
        std::fs::write(
            &bad,
            pixel_shader(
                "float f(float x) { return y; }",
                "float4(f(x.x), 0.0f, 0.0f, 1.0f)",
            ),
        )
        .unwrap();
        assert!(!Command::new("glslangValidator")
            .args(["-D", "-e", "main", "-S", "frag", "-V"])
            .arg(&bad)
            .arg("-o")
            .arg(d.join("bad.spv"))
            .output()
            .unwrap()
            .status
            .success());
    } else {
        visible("SKIPPED: glslangValidator or spirv-val not found (Debian packages glslang-tools and spirv-tools; .ci/run installs them) — the emitted HLSL was not compiled to SPIR-V");
    }
    let headers: Vec<_> = files
        .iter()
        .filter(|(n, _)| n.ends_with(".cpp") || n.ends_with(".h"))
        .collect();
    assert_eq!(headers.len(), 3);
    for (compiler, std, lang) in [("g++", "-std=c++17", "c++"), ("gcc", "-std=c99", "c")] {
        if !tool(compiler) {
            visible(&format!("SKIPPED: {compiler} not found — the emitted C/C++ header was not compiled as {lang}"));
            continue;
        }
        for (name, src) in &headers {
            let file = d.join(format!("{name}.{lang}.h"));
            std::fs::write(&file, src).unwrap();
            let o = Command::new(compiler)
                .args([
                    std,
                    "-fsyntax-only",
                    "-Wall",
                    "-Wextra",
                    "-pedantic",
                    "-Werror",
                    "-x",
                    lang,
                ])
                .arg(&file)
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "{name} as {lang} ({compiler} {std}): {}",
                text(&o.stderr)
            );
        }
        // the compiler is not vacuous
        let bad = d.join(format!("bad.{lang}.h"));
        std::fs::write(&bad, "static inline float f(float x) { return y; }\n").unwrap();
        assert!(!Command::new(compiler)
            .args([std, "-fsyntax-only", "-x", lang])
            .arg(&bad)
            .output()
            .unwrap()
            .status
            .success());
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The emitted Rust of a small polynomial fit in √x of a user's table.
fn sqrt_fit_rust(d: &Path) -> String {
    let mut csv = String::from("x,E\n");
    for i in 0..=32 {
        let x = i as f64 / 32.0;
        csv.push_str(&format!("{x},{}\n", 0.2 + 0.5 * x.sqrt()));
    }
    std::fs::write(d.join("sqrt-table.csv"), csv).unwrap();
    ok(&furnace(
        &[
            "fit",
            "--table",
            "sqrt-table.csv",
            "--form",
            "polynomial",
            "--degree",
            "2",
            "--transform",
            "x=sqrt",
            "--output",
            "sqrt-fit.json",
        ],
        d,
    ));
    let o = furnace(
        &[
            "emit",
            "--fit",
            "sqrt-fit.json",
            "--lang",
            "rust",
            "--output",
            "-",
        ],
        d,
    );
    let src = text(&ok(&o).stdout);
    // a user's table: named after its file
    assert!(
        src.contains("pub fn sqrt_table_albedo(x: f32) -> f32"),
        "{src}"
    );
    assert!(src.contains("use libm::sqrtf;"));
    src
}

/// The libm the tests link: furnace's dev-dependency, built next to this test.
fn libm_rlib() -> PathBuf {
    // the dev-dependency is used here too: its sqrtf is f32::sqrt bit for bit
    for i in 0..10_000u32 {
        let x = f32::from_bits(i.wrapping_mul(2_654_435_761) & 0x7f7f_ffff);
        assert_eq!(libm::sqrtf(x).to_bits(), x.sqrt().to_bits(), "{x:e}");
    }
    let deps = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    std::fs::read_dir(&deps)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("liblibm-") && n.ends_with(".rlib"))
        })
        .unwrap_or_else(|| panic!("no liblibm-*.rlib in {}", deps.display()))
}

#[test]
fn emit_notes_a_fits_table_only_when_it_emits_and_names_an_edited_table_record() {
    let d = scratch("table-notes");
    let good: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("fits/ggx-conductor/best-20.json")).unwrap(),
    )
    .unwrap();
    // its table is not in this folder's cache: emitted with a note saying so
    std::fs::write(d.join("linked.json"), good.to_string()).unwrap();
    let o = furnace(
        &[
            "emit",
            "--fit",
            "linked.json",
            "--lang",
            "glsl",
            "--output",
            "-",
        ],
        &d,
    );
    ok(&o);
    assert!(
        text(&o.stderr).contains("note: the table of linked.json is not in the cache"),
        "{}",
        text(&o.stderr)
    );
    // a pole: refused, and no note about the table comes before the refusal
    let mut pole = good.clone();
    let q = &mut pole["fit"]["approximant"]["denominator"]["coefficients"];
    for c in q.as_array_mut().unwrap().iter_mut().skip(1) {
        *c = 0.0.into();
    }
    q[1] = (-3.0).into();
    std::fs::write(d.join("pole.json"), pole.to_string()).unwrap();
    let e = refused(
        &furnace(&["emit", "--fit", "pole.json", "--lang", "glsl"], &d),
        "uncertified denominator: Q changes sign",
    );
    assert!(!e.contains("note:"), "{e}");
    assert!(!d.join("pole.glsl").exists());
    // a table record whose spec no longer hashes to its content hash is named as such
    let mut edited = good.clone();
    edited["table"]["spec"]["quadrature"]["order"] = 13.into();
    std::fs::write(d.join("edited.json"), edited.to_string()).unwrap();
    let o = ok(&furnace(
        &[
            "emit",
            "--fit",
            "edited.json",
            "--lang",
            "glsl",
            "--output",
            "-",
        ],
        &d,
    ))
    .clone();
    assert!(
        text(&o.stderr).contains("the table record of edited.json does not match its content hash"),
        "{}",
        text(&o.stderr)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn emit_refuses_a_pole_free_fit_whose_f32_code_fails_the_stress_test() {
    let d = scratch("f32-gate");
    let mut csv = String::from("x,y,E\n");
    for i in 0..=8 {
        for j in 0..=8 {
            let (x, y) = (i as f64 / 8.0, j as f64 / 8.0);
            csv.push_str(&format!("{x},{y},{}\n", 0.5 + 0.1 * x - 0.05 * y * y));
        }
    }
    std::fs::write(d.join("t.csv"), csv).unwrap();
    ok(&furnace(
        &[
            "fit", "--table", "t.csv", "--form", "rational", "--degree", "2", "--output", "t.json",
        ],
        &d,
    ));
    // E = 0.5 / (1 + 1000 (x - y)^2): Q >= 1, so pole-free, but Q cancels in f32 near x = y
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("t.json")).unwrap()).unwrap();
    let a = &mut v["fit"]["approximant"];
    let coefficient = |e: &serde_json::Value, table: &[([i64; 2], f64)]| {
        let e = [e[0].as_i64().unwrap(), e[1].as_i64().unwrap()];
        table.iter().find(|(k, _)| *k == e).map_or(0.0, |(_, c)| *c)
    };
    for (part, table) in [
        ("numerator", vec![([0, 0], 0.5)]),
        (
            "denominator",
            vec![([0, 0], 1.0), ([2, 0], 1e3), ([1, 1], -2e3), ([0, 2], 1e3)],
        ),
    ] {
        let c: Vec<f64> = a[part]["exponents"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| coefficient(e, &table))
            .collect();
        a[part]["coefficients"] = serde_json::json!(c);
    }
    std::fs::write(d.join("cancels.json"), v.to_string()).unwrap();
    let before = listing(&d);
    let e = refused(
        &furnace(&["emit", "--fit", "cancels.json", "--lang", "all"], &d),
        "the f32 code fails the stress test",
    );
    assert!(
        e.contains("cancels.json") && e.contains("so it is not emitted") && e.contains("refit"),
        "{e}"
    );
    assert_eq!(listing(&d), before, "nothing may be written");
    refused(
        &furnace(&["stress", "--fit", "cancels.json"], &d),
        "stress test of cancels.json failed",
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_f0_argument_of_every_dielectric_gives_the_range_of_eta_not_of_one_over_eta() {
    for name in [
        "ggx-dielectric",
        "ggx-dielectric-separable",
        "ggx-dielectric-inv",
        "ggx-dielectric-inv-separable",
    ] {
        let model = furnace::bsdf::find(name).unwrap();
        let f0 = &model.axes()[0];
        assert_eq!(f0.name, "f0");
        // η = (1+√F0)/(1−√F0) spans 1.25 … 3 over the default F0 range; 1/η spans 1/3 … 0.8
        let d = &f0.description;
        let range = d.find("(1.25 … 3 by default)").expect(d);
        assert!(
            d[..range].trim_end().ends_with("η = (1+√F0)/(1−√F0)"),
            "{name}: the range follows η itself: {d}"
        );
    }
}

#[test]
fn a_user_tables_fit_is_measured_on_the_tables_points_while_the_table_is_unchanged() {
    let d = scratch("user-points");
    let mut csv = String::from("x,E\n");
    for i in 0..=40 {
        let x = i as f64 / 40.0;
        csv.push_str(&format!("{x},{}\n", 1.0 / (1.0 + x)));
    }
    std::fs::write(d.join("t.csv"), &csv).unwrap();
    ok(&furnace(
        &[
            "fit",
            "--table",
            "t.csv",
            "--form",
            "polynomial",
            "--degree",
            "3",
            "--output",
            "fits/t.json",
        ],
        &d,
    ));
    let emit = |dir: &Path| {
        let o = furnace(
            &[
                "emit",
                "--fit",
                "fits/t.json",
                "--lang",
                "glsl",
                "--output",
                "-",
            ],
            dir,
        );
        text(&ok(&o).stdout)
    };
    let src = emit(&d);
    assert!(
        src.contains("// Error at the 41 points of its table t.csv (output clamp applied)"),
        "{src}"
    );
    assert!(!src.contains("not at hand"), "{src}");
    // changed, the table is no longer the one fitted: the header falls back to the bound
    std::fs::write(d.join("t.csv"), csv.replace("x,E\n0,1\n", "x,E\n0,0.9\n")).unwrap();
    let src = emit(&d);
    assert!(
        src.contains("the table was not at hand to measure it"),
        "{src}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A fit for which the interval error analysis gives no finite bound (the committed glossy
/// best-40) says that no bound was proved, never "<= inf".
#[test]
fn an_unproved_bound_is_said_so() {
    let d = scratch("unproved-bound");
    let fit = root().join("fits/ggx-glossy/best-40.json");
    let o = furnace(
        &[
            "emit",
            "--fit",
            fit.to_str().unwrap(),
            "--lang",
            "rust",
            "--output",
            "-",
        ],
        &d,
    );
    let h = text(&ok(&o).stdout);
    assert!(h.contains("Bound: none proved"), "{h}");
    assert!(!h.contains("<= inf") && !h.contains("+ inf"), "{h}");
}
