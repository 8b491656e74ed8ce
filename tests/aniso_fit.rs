//! Fits in four variables: `furnace fit` on a small `ggx-conductor-aniso` table makes a
//! pole-certified rational measured at off-grid points, and `furnace emit` prints
//! `ggx_conductor_aniso_albedo(r, aniso, mu, phi)` in every language, stress-tested in f32.

mod common;

use common::{furnace, scratch, stderr};

#[test]
fn a_four_variable_rational_is_certified_measured_off_grid_and_emitted() {
    let dir = scratch("rational-2");
    let fit = [
        "fit",
        "--model",
        "ggx-conductor-aniso",
        "--resolution",
        "6x3x5x3",
        "--form",
        "rational",
        "--degree",
        "2",
    ];
    let o = furnace(&fit, &dir);
    let err = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(o.status.success(), "{err}");
    assert!(err.contains("29 coefficients"), "{err}");
    assert!(err.contains("Bernstein certificate"), "{err}");
    let path = dir.join("fits/ggx-conductor-aniso/rational-2.json");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(json["usable"], true, "{json}");
    let names: Vec<&str> = json["fit"]["approximant"]["variables"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(names, ["r", "aniso", "mu", "phi"]);
    // the off-grid set covers the 4-D box (quasi-random, layers, all eight faces)
    let m = &json["off_grid"]["metrics"];
    assert_eq!(m["n_points"], 16384 + 3 * 2048 + 8 * 256, "{m}");
    let (mae, max) = (
        m["mae"].as_f64().unwrap(),
        m["max_abs_error"].as_f64().unwrap(),
    );
    assert!(mae > 0.0 && mae < 0.05 && max >= mae && max < 0.5, "{m}");

    let emit = [
        "emit",
        "--fit",
        "fits/ggx-conductor-aniso/rational-2.json",
        "--lang",
        "rust,wgsl,glsl,hlsl,cpp",
    ];
    let o = furnace(&emit, &dir);
    let err = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(o.status.success(), "{err}");
    // the f32 stress test ran on the 4-D box
    assert!(err.contains("stress points"), "{err}");
    let read = |ext: &str| {
        std::fs::read_to_string(dir.join(format!("fits/ggx-conductor-aniso/rational-2.{ext}")))
            .unwrap()
    };
    let signatures = [
        (
            "rs",
            "pub fn ggx_conductor_aniso_albedo(r: f32, aniso: f32, mu: f32, phi: f32) -> f32",
        ),
        (
            "wgsl",
            "fn ggx_conductor_aniso_albedo(r: f32, aniso: f32, mu: f32, phi: f32) -> f32",
        ),
        (
            "glsl",
            "float ggx_conductor_aniso_albedo(highp float r, highp float aniso, highp float mu, highp float phi)",
        ),
        (
            "hlsl",
            "float ggx_conductor_aniso_albedo(float r, float aniso, float mu, float phi)",
        ),
        ("h", "ggx_conductor_aniso_albedo(float r, float aniso, float mu, float phi)"),
    ];
    for (ext, sig) in signatures {
        let text = read(ext);
        assert!(text.contains(sig), "{ext}: no `{sig}` in\n{text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_projected_ratio_and_the_projected_log_layer_are_fitted_and_emitted() {
    let dir = scratch("pratio");
    let fit = [
        "fit",
        "--model",
        "ggx-conductor-aniso",
        "--resolution",
        "6x3x5x3",
        "--form",
        "rational",
        "--degree",
        "1",
        "--transform",
        "r=square,mu=player:r:aniso:phi:2:2:3,phi=pratio:aniso",
        "--output",
        "fit.json",
    ];
    let o = furnace(&fit, &dir);
    let err = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("player:r:aniso:phi:2:2:3, pratio:aniso"),
        "{err}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("fit.json")).unwrap()).unwrap();
    let t = &json["fit"]["approximant"]["transforms"];
    assert_eq!(t[2]["beta"], 3.0, "{t}");
    assert_eq!(t[3]["kind"], "projected_ratio", "{t}");
    assert_eq!(t[3]["aniso"], 1, "{t}");
    // emitted in every language; the f32 stress test compares the emitted operations with the
    // f64 transforms over the 4-D box and gates the emission
    let emit = [
        "emit",
        "--fit",
        "fit.json",
        "--lang",
        "rust,wgsl,glsl,hlsl,cpp",
    ];
    let o = furnace(&emit, &dir);
    let err = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(o.status.success(), "{err}");
    assert!(err.contains("stress points"), "{err}");
    let rs = std::fs::read_to_string(dir.join("fit.rs")).unwrap();
    for step in ["let phi_b", "let mu_logv", "let mu_alpha_o"] {
        assert!(rs.contains(step), "no `{step}` in\n{rs}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn five_variables_are_refused_with_the_limit() {
    let dir = scratch("five");
    let csv = "a,b,c,d,e,E\n0,0,0,0,0,0.5\n1,1,1,1,1,0.6\n";
    std::fs::write(dir.join("five.csv"), csv).unwrap();
    let o = furnace(
        &[
            "fit",
            "--table",
            "five.csv",
            "--form",
            "polynomial",
            "--degree",
            "1",
        ],
        &dir,
    );
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("1 to 4"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn azimuth_transforms_on_part_of_the_quadrant_are_emitted_in_every_form() {
    // φ ∈ [0.2, 1.2]: the transformed variables' ranges are not [0, 1], so the Bernstein form
    // maps them to u = (t − lo)/(hi − lo) next to the steps of sin²φ
    let dir = scratch("azimuth-forms");
    let mut csv = String::from("aniso,phi,E\n");
    for i in 0..9 {
        for j in 0..9 {
            let (aniso, phi) = (0.9 * i as f64 / 8.0, 0.2 + j as f64 / 8.0);
            let u2 = 1.0 - (1.0 - (1.0 - aniso) * (1.0 - aniso)) * phi.sin().powi(2);
            csv.push_str(&format!("{aniso},{phi},{}\n", 0.4 + 0.3 * u2.sqrt()));
        }
    }
    std::fs::write(dir.join("t.csv"), csv).unwrap();
    for (transform, name) in [("phi=sin2", "sin2"), ("phi=pratio:aniso", "pratio")] {
        let out = format!("{name}.json");
        let fit = [
            "fit",
            "--table",
            "t.csv",
            "--form",
            "rational",
            "--degree",
            "2",
            "--transform",
            transform,
            "--output",
            &out,
        ];
        let o = furnace(&fit, &dir);
        assert!(o.status.success(), "{}", stderr(&o));
        for form in ["monomial", "shifted", "bernstein"] {
            let emit = [
                "emit",
                "--fit",
                &out,
                "--lang",
                "rust,wgsl,glsl,hlsl,cpp",
                "--form",
                form,
            ];
            let o = furnace(&emit, &dir);
            let err = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
            assert!(o.status.success(), "{transform}, {form}: {err}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
