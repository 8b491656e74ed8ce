//! `furnace export` as a user meets it: Filament's DFG table in each encoding, the generic
//! format, Cycles' arrays spliced into Cycles' own file, and clear errors that write nothing.

use furnace::export::filament::{column_mu, f16_value, row_r};
mod common;

use common::{furnace, scratch, stderr};
use std::path::Path;
use std::process::Command;

/// The folder holds exactly these names.
fn assert_holds(d: &Path, names: &[&str]) {
    let mut found: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    found.sort();
    let mut want: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(found, want);
}

#[test]
fn filament_binary_holds_the_split_sum_at_cmgens_texels() {
    let d = scratch("filament-bin");
    let o = furnace(
        &[
            "export",
            "--format",
            "filament",
            "--size",
            "16",
            "--output",
            "dfg.bin",
            "--no-cache",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(d.join("dfg.bin")).unwrap();
    assert_eq!(bytes.len(), 16 * 16 * 2 * 2, "RG16F: two halves per texel");
    let header: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("dfg.bin.json")).unwrap()).unwrap();
    assert_eq!(header["texture_format"], "RG16F");
    assert_eq!(header["size"], 16);
    assert!(header["max_error_estimate"].as_f64().unwrap() <= 1e-7);
    // every texel against an independent evaluation of the split sum at cmgen's (μ, r)
    let model = furnace::bsdf::get(furnace::export::filament::model()).unwrap();
    let settings = furnace::quadrature::QuadratureSettings::default();
    let cache = furnace::quadrature::RuleCache::new(&settings);
    for j in [0usize, 5, 15] {
        for x in [0usize, 7, 15] {
            let (r, mu) = (row_r(j, 16), column_mu(x, 16));
            let e = furnace::bsdf::albedo(model.as_ref(), &[r, mu], &settings, &cache);
            let (a, b) = (e.value[0], e.value[1]);
            let k = 4 * (j * 16 + x);
            let h = |o: usize| f16_value(u16::from_le_bytes([bytes[k + o], bytes[k + o + 1]]));
            assert!(
                (h(0) - b).abs() <= b * 2f64.powi(-11) + 1e-7,
                "DFG1 at ({x}, {j})"
            );
            assert!(
                (h(2) - (a + b)).abs() <= (a + b) * 2f64.powi(-11),
                "DFG2 at ({x}, {j})"
            );
        }
    }
    // the same bytes again: deterministic, and a file furnace wrote may be replaced
    let o = furnace(
        &[
            "export",
            "--format",
            "filament",
            "--size",
            "16",
            "--output",
            "dfg.bin",
            "--no-cache",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.join("dfg.bin")).unwrap(), bytes);
}

#[test]
fn filament_sources_declare_the_table() {
    let d = scratch("filament-src");
    for (file, extra, needle) in [
        ("dfg.inc", vec![], "0x"),
        (
            "dfg.h",
            vec!["--precision", "f32"],
            "const float DFG_LUT[512] = {",
        ),
        ("dfg.js", vec![], "export const DFG_LUT = new Uint16Array(["),
    ] {
        let mut args = vec![
            "export", "--format", "filament", "--size", "16", "--output", file,
        ];
        args.extend(extra);
        let o = furnace(&args, &d);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        let text = std::fs::read_to_string(d.join(file)).unwrap();
        assert!(text.starts_with("// Written by furnace export"), "{file}");
        assert!(text.contains("Max quadrature error estimate"), "{file}");
        assert!(text.contains(needle), "{file}");
    }
    // the C++ header compiles
    let cpp = d.join("use.cpp");
    std::fs::write(
        &cpp,
        "#include \"dfg.h\"\nint main() { return DFG_LUT_SIZE == 16 && DFG_LUT[1] > 0.0f ? 0 : 1; }\n",
    )
    .unwrap();
    let compiled = Command::new("g++")
        .args(["-std=c++17", "-Wall", "-Werror", "use.cpp", "-o", "use"])
        .current_dir(&d)
        .status();
    if let Ok(status) = compiled {
        assert!(status.success(), "g++ rejects the exported header");
        assert!(Command::new(d.join("use")).status().unwrap().success());
    }
}

#[test]
fn generic_writes_furnace_table_files_with_the_definition() {
    let d = scratch("generic");
    let o = furnace(
        &[
            "export",
            "--format",
            "generic",
            "--model",
            "ggx-conductor-avg",
            "--resolution",
            "9",
            "--output",
            "eavg.exr",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("eavg.json")).unwrap()).unwrap();
    assert_eq!(json["tool"], "furnace");
    assert!(json["definition"]
        .as_str()
        .unwrap()
        .contains("ggx-conductor-avg"));
    assert!(d.join("eavg.exr").is_file() && d.join("eavg.f64").is_file());
}

#[test]
fn cycles_splice_keeps_the_rest_of_cycles_file() {
    let d = scratch("cycles-splice");
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/data/cycles/shader.tables");
    std::fs::copy(shipped, d.join("shader.tables")).unwrap();
    // a wrong base is refused before anything is computed
    std::fs::write(
        d.join("other.tables"),
        "static const float x[2] = {1.0f, 2.0f};\n",
    )
    .unwrap();
    let o = furnace(
        &[
            "export",
            "--format",
            "cycles",
            "--splice",
            "other.tables",
            "--output",
            "out.tables",
        ],
        &d,
    );
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("has no array table_ggx_E[1024]"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("out.tables").exists());
    // furnace's parse of the spliced file: Cycles' sheen and thin-film arrays unchanged
    let text = |p: &str| std::fs::read_to_string(d.join(p)).unwrap();
    let before = furnace::export::cycles::parse_arrays(&text("shader.tables"));
    let o = furnace(
        &[
            "export",
            "--format",
            "cycles",
            "--splice",
            "shader.tables",
            "--output",
            "shader.tables",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let after = furnace::export::cycles::parse_arrays(&text("shader.tables"));
    assert_eq!(before.len(), after.len());
    for (b, a) in before.iter().zip(&after) {
        assert_eq!(b.0, a.0);
        assert_eq!(b.1.len(), a.1.len(), "{}", a.0);
        if a.0 == "table_sheen_ltc" || a.0 == "table_thin_film_cmf" {
            assert_eq!(b.1, a.1, "{}", a.0);
        }
    }
    assert!(text("shader.tables").contains("Written by furnace export"));
    assert!(text("shader.tables").starts_with("/* SPDX-FileCopyrightText"));
}

#[test]
fn bad_input_is_refused_clearly_and_writes_nothing() {
    let d = scratch("bad");
    std::fs::write(d.join("mine.inc"), "a user's file\n").unwrap();
    std::fs::create_dir(d.join("folder.inc")).unwrap();
    let cases: [(&[&str], &str); 8] = [
        (
            &["export", "--format", "unreal", "--output", "x.tables"],
            "invalid value 'unreal'",
        ),
        (
            &[
                "export", "--format", "filament", "--size", "48", "--output", "x.inc",
            ],
            "power of two",
        ),
        (
            &[
                "export", "--format", "filament", "--size", "4096", "--output", "x.inc",
            ],
            "power of two from 4 to 1024",
        ),
        (
            &[
                "export",
                "--format",
                "filament",
                "--precision",
                "f32",
                "--output",
                "x.inc",
            ],
            "dfg.inc holds RG16F",
        ),
        (
            &[
                "export", "--format", "cycles", "--size", "64", "--output", "x.tables",
            ],
            "fixed sizes",
        ),
        (
            &[
                "export", "--format", "filament", "--size", "16", "--output", "mine.inc",
            ],
            "not written by furnace export",
        ),
        (
            &[
                "export",
                "--format",
                "filament",
                "--size",
                "16",
                "--output",
                "folder.inc",
            ],
            "is a folder",
        ),
        (
            &["export", "--format", "filament", "--output", "x.png"],
            "cannot tell the encoding",
        ),
    ];
    for (args, needle) in cases {
        let o = furnace(args, &d);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{args:?}");
    }
    assert_eq!(
        std::fs::read_to_string(d.join("mine.inc")).unwrap(),
        "a user's file\n"
    );
    assert_holds(&d, &["mine.inc", "folder.inc"]);
}

#[test]
fn one_file_exports_go_to_standard_output() {
    let d = scratch("stdout");
    let file = furnace(
        &[
            "export", "--format", "filament", "--size", "16", "--output", "dfg.inc",
        ],
        &d,
    );
    assert!(file.status.success(), "{}", stderr(&file));
    let o = furnace(
        &[
            "export",
            "--format",
            "filament",
            "--size",
            "16",
            "--encoding",
            "inc",
            "--output",
            "-",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(o.stdout, std::fs::read(d.join("dfg.inc")).unwrap());
    assert!(
        stderr(&o).contains("wrote standard output"),
        "{}",
        stderr(&o)
    );
    assert_holds(&d, &["data", "dfg.inc"]); // the table cache and the one file
                                            // what is not one file, or has no encoding to go by, is refused before anything is computed
    for (args, needle) in [
        (
            &[
                "export", "--format", "filament", "--size", "16", "--output", "-",
            ][..],
            "give --encoding inc, cpp or js",
        ),
        (
            &[
                "export",
                "--format",
                "filament",
                "--size",
                "16",
                "--encoding",
                "bin",
                "--output",
                "-",
            ][..],
            "cannot go to standard output",
        ),
        (
            &[
                "export",
                "--format",
                "generic",
                "--model",
                "oren-nayar-fon",
                "--output",
                "-",
            ][..],
            "three files",
        ),
    ] {
        let o = furnace(args, &d);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{args:?} wrote to standard output");
    }
    assert_holds(&d, &["data", "dfg.inc"]); // the table cache and the one file
}
