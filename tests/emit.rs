//! The emitters' proof: the generated text is pinned (snapshots), the generated Rust compiles
//! (`include!` of the snapshot) and matches the f64 fit and the f32 model of the same operations
//! bit for bit, the WGSL and GLSL pass naga's front ends and validator, the f32 stress test
//! passes on good fits and fails on the paper's glossy fit, and bad inputs are refused.
//!
//! The snapshots in `tests/snapshots/` are pinned to the generator by `tests/emit_snapshots.rs`.

mod common;

use std::path::{Path, PathBuf};

use furnace::emit::generate::{albedo_function_name, choose_form, reference, FormChoice};
use furnace::emit::ir::{Arith, Compiled, Program};
use furnace::emit::stress::{edge_values, stress, StressOptions};
use furnace::emit::SourceFit;
use furnace::fit::file as fitfile;
use furnace::fit::job::FitRecord;

#[allow(dead_code)]
mod emitted_conductor {
    include!("snapshots/paper-conductors.rs");
}
#[allow(dead_code)]
mod emitted_dielectric {
    include!("snapshots/dielectric-pair.rs");
}
#[allow(dead_code)]
mod emitted_aniso {
    include!("snapshots/aniso-conductor.rs");
}

use common::repository as root;

fn fixture(name: &str) -> FitRecord {
    let path = root().join("tests/fixtures").join(name);
    fitfile::read(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn name_of(file: &FitRecord) -> String {
    albedo_function_name(&fitfile::subject_name(file), &file.source.channel)
}

/// Dense grid plus every combination of edge values (out-of-range inputs included).
fn check_points(domain: &[(f32, f32)], n: usize) -> Vec<Vec<f32>> {
    let d = domain.len();
    let mut lists: Vec<Vec<f32>> = domain
        .iter()
        .map(|&(lo, hi)| {
            (0..n)
                .map(|i| lo + (hi - lo) * i as f32 / (n - 1) as f32)
                .collect()
        })
        .collect();
    let mut pts = Vec::new();
    let total: usize = lists.iter().map(Vec::len).product();
    for idx in 0..total {
        let mut r = idx;
        let mut x = vec![0.0; d];
        for k in (0..d).rev() {
            x[k] = lists[k][r % n];
            r /= n;
        }
        pts.push(x);
    }
    lists = domain.iter().map(|&(lo, hi)| edge_values(lo, hi)).collect();
    let total: usize = lists.iter().map(Vec::len).product();
    for idx in 0..total {
        let mut r = idx;
        let mut x = vec![0.0; d];
        for k in (0..d).rev() {
            x[k] = lists[k][r % lists[k].len()];
            r /= lists[k].len();
        }
        pts.push(x);
    }
    pts
}

/// The compiled Rust against the f32 model (bit for bit) and the f64 fit (≤ 1e-5).
fn check_compiled(file: &FitRecord, f: &dyn Fn(&[f32]) -> f32, n: usize) -> (usize, f64) {
    let name = name_of(file);
    let (function, _) = choose_form(&name, &[], &file.fit, FormChoice::Auto).unwrap();
    let model = Compiled::new(
        &Program {
            functions: vec![function],
        },
        &name,
    )
    .unwrap();
    let domain = furnace::emit::generate::domain_f32(&file.fit);
    let mut regs = Vec::new();
    let mut worst = 0.0f64;
    let mut worst_at = Vec::new();
    let pts = check_points(&domain, n);
    for x in &pts {
        let got = f(x);
        let want_bits = model.eval_f32(x, Arith::Ieee, &mut regs);
        assert_eq!(
            got.to_bits(),
            want_bits.to_bits(),
            "{name} at {x:?}: compiled {got} vs model {want_bits}"
        );
        assert!(
            got.is_finite() && (0.0..=1.0).contains(&got),
            "{name} at {x:?}: {got}"
        );
        let (r, _) = reference(&file.fit, x);
        if (got as f64 - r).abs() > worst {
            worst = (got as f64 - r).abs();
            worst_at = x.clone();
        }
    }
    assert!(
        worst <= 1e-5,
        "{name}: max |f32 − f64| {worst:e} at {worst_at:?}"
    );
    (pts.len(), worst)
}

#[test]
fn emitted_rust_compiles_and_matches_the_fit() {
    let c = fixture("paper-conductors.json");
    let (n, w) = check_compiled(
        &c,
        &|x| emitted_conductor::ggx_conductor_separable_albedo(x[0], x[1]),
        257,
    );
    eprintln!("paper conductors: {n} points, max |f32 − f64| {w:.2e}");
    let d = fixture("ggx-dielectric.json");
    let (n, w) = check_compiled(
        &d,
        &|x| emitted_dielectric::ggx_dielectric_albedo(x[0], x[1], x[2]),
        41,
    );
    eprintln!("ggx-dielectric: {n} points, max |f32 − f64| {w:.2e}");
    let i = fixture("ggx-dielectric-inv.json");
    let (n, w) = check_compiled(
        &i,
        &|x| emitted_dielectric::ggx_dielectric_inv_albedo(x[0], x[1], x[2]),
        41,
    );
    eprintln!("ggx-dielectric-inv: {n} points, max |f32 − f64| {w:.2e}");
}

#[test]
fn emitted_helpers_compute_the_papers_factors() {
    use emitted_conductor as c;
    use emitted_dielectric as d;
    for &(r, mu) in &[(0.0f32, 0.0f32), (0.3, 0.7), (1.0, 0.05), (0.9, 1.0)] {
        let e = c::ggx_conductor_separable_albedo(r, mu);
        for f0 in [0.0f32, 0.5, 1.0] {
            // Sforza & Pellacini 2022, eq. 13: 1 + F0 (1 − E)/E
            let want = 1.0 + f0 * ((1.0 - e.max(1e-3)) / e.max(1e-3));
            assert_eq!(c::ggx_conductor_separable_turquin_scale(f0, r, mu), want);
        }
        assert_eq!(
            c::ggx_conductor_separable_normalization(r, mu),
            1.0 / e.max(1e-3)
        );
        assert!(c::ggx_conductor_separable_turquin_scale(1.0, r, mu) >= 1.0);
        // Kulla & Conty 2017: f_ms, F_ms and the weight of a diffuse base
        for (e_avg, mu_i) in [(0.9f32, 0.4f32), (0.5, 1.0), (0.999, 0.0)] {
            let ei = c::ggx_conductor_separable_albedo(r, mu_i);
            let want = (1.0 - e) * (1.0 - ei) / (std::f32::consts::PI * (1.0 - e_avg));
            assert_eq!(
                c::ggx_conductor_separable_kulla_conty_lobe(e_avg, r, mu, mu_i),
                want
            );
            // off where 1 − E_avg is below the floor
            assert_eq!(
                c::ggx_conductor_separable_kulla_conty_lobe(1.0, r, mu, mu_i),
                0.0
            );
            for f_avg in [0.0f32, 0.5, 1.0] {
                let f_ms = f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg)).max(1e-3);
                assert_eq!(
                    c::ggx_conductor_separable_kulla_conty_color(f_avg, e_avg),
                    f_ms
                );
                assert_eq!(
                    c::ggx_conductor_separable_kulla_conty_color_rgb([f_avg, 0.5, f_avg], e_avg),
                    [
                        f_ms,
                        c::ggx_conductor_separable_kulla_conty_color(0.5, e_avg),
                        f_ms
                    ]
                );
                assert_eq!(
                    c::ggx_conductor_separable_kulla_conty_diffuse_weight(f_avg, e_avg, r, mu),
                    (1.0 - (f_avg * e + f_ms * (1.0 - e))).max(0.0)
                );
            }
            assert!((c::ggx_conductor_separable_kulla_conty_color(1.0, e_avg) - 1.0).abs() < 1e-6);
        }
    }
    for &(f0, r, cos_o) in &[
        (0.03f32, 0.2f32, 0.7f32),
        (0.05, 0.5, -0.3),
        (0.02, 0.05, 0.0),
        (0.06, 0.6, -1.0),
    ] {
        let sided = d::ggx_dielectric_sided_albedo(f0, r, cos_o);
        let want = if cos_o >= 0.0 {
            d::ggx_dielectric_albedo(f0, r, cos_o)
        } else {
            d::ggx_dielectric_inv_albedo(f0, r, -cos_o)
        };
        assert_eq!(
            sided, want,
            "side of the surface picks the table (paper §3.3)"
        );
        assert_eq!(
            d::ggx_dielectric_sided_normalization(f0, r, cos_o),
            1.0 / want.max(1e-3)
        );
        assert_eq!(
            d::ggx_dielectric_normalization(f0, r, cos_o.abs()),
            1.0 / d::ggx_dielectric_albedo(f0, r, cos_o.abs()).max(1e-3)
        );
        // Kulla & Conty 2017, rough dielectric: the lobe by side, and its reciprocal split
        let (f_avg, e_avg, e_avg_inv) = (0.08f32, 0.93f32, 0.81f32);
        let x = d::ggx_dielectric_kulla_conty_split(e_avg, e_avg_inv);
        assert_eq!(x, (1.0 - e_avg_inv) / ((1.0 - e_avg) + (1.0 - e_avg_inv)));
        let q = (1.0 - f0.sqrt()) / (1.0 + f0.sqrt()); // 1/η
        let t_out = d::ggx_dielectric_kulla_conty_transmission(f_avg, e_avg, e_avg_inv, f0, 0.5);
        let t_in = d::ggx_dielectric_kulla_conty_transmission(f_avg, e_avg, e_avg_inv, f0, -0.5);
        assert_eq!(t_out, (1.0 - f_avg) * x);
        // t_out (1 − E_avg,η) = η² t_in (1 − E_avg,1/η)
        let balance = t_out * (1.0 - e_avg) - t_in * (1.0 - e_avg_inv) / (q * q);
        assert!(balance.abs() < 1e-6, "{balance}");
        for cos_i in [0.6f32, -0.6, 0.0, -1.0] {
            let e_o = d::ggx_dielectric_sided_albedo(f0, r, cos_o);
            let e_i = d::ggx_dielectric_sided_albedo(f0, r, cos_i);
            let t = if cos_o >= 0.0 { t_out } else { t_in };
            let share = if (cos_o >= 0.0) == (cos_i >= 0.0) {
                1.0 - t
            } else {
                t
            };
            let norm = if cos_i >= 0.0 {
                1.0 - e_avg
            } else {
                1.0 - e_avg_inv
            };
            let want = share * ((1.0 - e_o) * (1.0 - e_i)) / (std::f32::consts::PI * norm);
            let got =
                d::ggx_dielectric_kulla_conty_bsdf(f_avg, e_avg, e_avg_inv, f0, r, cos_o, cos_i);
            assert!(
                (got - want).abs() <= 1e-6 * want.abs().max(1e-3),
                "{cos_o} {cos_i}: {got} vs {want}"
            );
        }
        // off where 1 − E_avg of ωi's side is below the floor
        assert_eq!(
            d::ggx_dielectric_kulla_conty_bsdf(f_avg, 1.0, e_avg_inv, f0, r, cos_o, 0.5),
            0.0
        );
    }
}

/// The tangent-frame helpers of the anisotropic conductor: E at a view direction equals the
/// albedo called with μ = ωo·n and the azimuth reduced to [0, π/2], at that azimuth and at its
/// mirror images and rotations by π (φ, −φ, π − φ, π + φ, φ ± 2π: both orientations of the
/// tangent and of the bitangent); Turquin's scale is 1 + F0(1 − E)/E of that E.
#[test]
fn emitted_tangent_frame_helpers_equal_the_direct_call_at_mirrored_directions() {
    use emitted_aniso as a;
    use std::f64::consts::{FRAC_PI_2, PI};
    let mut worst = 0.0f32;
    let mut checked = 0;
    for &(r, aniso) in &[(0.25f32, 0.0f32), (0.5, 0.5), (0.8, 0.9), (0.6, 0.95)] {
        for &mu in &[0.05f64, 0.4, 0.85, 0.995] {
            for k in 0..=12 {
                let phi = FRAC_PI_2 * k as f64 / 12.0;
                let direct = a::ggx_conductor_aniso_albedo(r, aniso, mu as f32, phi as f32);
                let sin = (1.0 - mu * mu).sqrt();
                for az in [
                    phi,
                    -phi,
                    PI - phi,
                    PI + phi,
                    phi - PI,
                    phi + 2.0 * PI,
                    -phi - 2.0 * PI,
                ] {
                    let wo = [(sin * az.cos()) as f32, (sin * az.sin()) as f32, mu as f32];
                    let e = a::ggx_conductor_aniso_direction_albedo(r, aniso, wo);
                    worst = worst.max((e - direct).abs());
                    checked += 1;
                    for f0 in [0.0f32, 0.3, 1.0] {
                        // Sforza & Pellacini 2022, eq. 13
                        let want = 1.0 + f0 * ((1.0 - e.max(1e-3)) / e.max(1e-3));
                        assert_eq!(a::ggx_conductor_aniso_turquin_scale(f0, r, aniso, wo), want);
                    }
                    let rgb =
                        a::ggx_conductor_aniso_turquin_scale_rgb([0.0, 0.3, 1.0], r, aniso, wo);
                    assert_eq!(
                        rgb,
                        [0.0f32, 0.3, 1.0]
                            .map(|f0| a::ggx_conductor_aniso_turquin_scale(f0, r, aniso, wo))
                    );
                }
            }
        }
    }
    // the helper's φ differs from the f64 azimuth by the f32 rounding of the direction and A&S
    // 4.4.49's 2e-8; E moves by less than that times |∂E/∂φ| ≤ 1
    assert!(
        worst < 2e-6,
        "max |E(direction) − E(μ, φ)| {worst:e} over {checked} directions"
    );
    eprintln!("tangent-frame helper: {checked} directions, max |difference| {worst:.1e}");
    // normal incidence: any tangent, no NaN
    let e = a::ggx_conductor_aniso_direction_albedo(0.7, 0.8, [0.0, 0.0, 1.0]);
    assert_eq!(e, a::ggx_conductor_aniso_albedo(0.7, 0.8, 1.0, 0.0));
}

fn naga_wgsl(src: &str) -> Result<(), String> {
    furnace::emit::validate::wgsl(src).map_err(|e| e.to_string())
}

fn naga_glsl(src: &str) -> Result<(), String> {
    furnace::emit::validate::glsl(src).map_err(|e| e.to_string())
}

#[test]
fn wgsl_and_glsl_pass_naga() {
    let mut checked = 0;
    let mut names: Vec<String> = std::fs::read_dir(root().join("tests/snapshots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    for name in names {
        let text = std::fs::read_to_string(root().join("tests/snapshots").join(&name)).unwrap();
        if name.ends_with(".wgsl") {
            naga_wgsl(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
            checked += 1;
        } else if name.ends_with(".glsl") {
            naga_glsl(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
    // the validators are not vacuous
    assert!(naga_wgsl("fn f(x: f32) -> f32 { return x + y; }").is_err());
    assert!(naga_glsl("float f(float x) { return x + undefined_name; }").is_err());
}

#[test]
fn stress_passes_on_good_fits_and_fails_on_the_papers_glossy_fit() {
    let opts = StressOptions {
        random_points: 20_000,
        ..Default::default()
    };
    for name in [
        "paper-conductors.json",
        "ggx-dielectric.json",
        "ggx-dielectric-inv.json",
    ] {
        let f = fixture(name);
        let r = stress(&f.fit, &name_of(&f), &opts).unwrap();
        eprint!("{}", r.render());
        assert!(r.passed(), "{name}: {:?}", r.failures);
        assert!(r.edge_points > 1000);
        assert!(
            r.min_abs_q.unwrap() >= r.q_lower_bound.unwrap() * 0.999,
            "sampled |Q| cannot beat the proved bound"
        );
    }
    // certified, but Q comes within 8e-4 of zero: f32 rounding is amplified past 1e-5 on an edge
    let f = fixture("ggx-dielectric-inv-nearpole.json");
    let r = stress(&f.fit, &name_of(&f), &opts).unwrap();
    eprint!("{}", r.render());
    assert!(!r.passed());
    assert!(
        r.failures.iter().all(|f| f.contains("max |f32 − f64|")),
        "{:?}",
        r.failures
    );
    let f = fixture("paper-glossy.json");
    let r = stress(&f.fit, &name_of(&f), &opts).unwrap();
    eprint!("{}", r.render());
    assert!(!r.passed());
    assert!(
        r.failures
            .iter()
            .any(|f| f.contains("not proved pole-free")),
        "{:?}",
        r.failures
    );
    assert!(
        r.max_condition_p > 1e3,
        "the ±400 coefficients cancel: κ_P = {}",
        r.max_condition_p
    );
}

#[test]
fn emitting_refuses_the_papers_glossy_fit() {
    let f = fixture("paper-glossy.json");
    let e = SourceFit::new("paper-glossy.json", f, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("uncertified denominator") && e.contains("refit"),
        "{e}"
    );
}

fn furnace(args: &[&str], dir: &Path) -> (bool, String, String) {
    let out = common::furnace(args, dir);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A scratch folder with an empty `fits/ggx-conductor/`.
fn scratch(name: &str) -> PathBuf {
    let dir = common::scratch(name);
    std::fs::create_dir_all(dir.join("fits/ggx-conductor")).unwrap();
    dir
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn cli_emits_next_to_the_fit_and_refuses_bad_input_without_writing() {
    let dir = scratch("cli");
    let fits = dir.join("fits/ggx-conductor");
    let good =
        std::fs::read_to_string(root().join("tests/fixtures/paper-conductors.json")).unwrap();
    std::fs::write(fits.join("rational-3.json"), &good).unwrap();

    let (ok, out, err) = furnace(
        &[
            "emit",
            "--fit",
            "fits/ggx-conductor/rational-3.json",
            "--lang",
            "all",
            "--lut-resolution",
            "8",
        ],
        &dir,
    );
    assert!(ok, "{out}\n{err}");
    let listed = files_in(&fits);
    for f in ["rational-3.rs", "rational-3.wgsl", "rational-3.glsl"] {
        assert!(listed.contains(&f.to_string()), "{listed:?}");
    }
    assert!(!listed.iter().any(|f| f.contains(".tmp")), "{listed:?}");
    let lut = dir.join("data/lut/ggx-conductor-separable");
    assert_eq!(
        files_in(&lut),
        ["8x8.exr", "8x8.f16", "8x8.f32", "8x8.json"]
    );
    assert_eq!(
        std::fs::metadata(lut.join("8x8.f32")).unwrap().len(),
        4 * 64
    );
    let desc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(lut.join("8x8.json")).unwrap()).unwrap();
    assert_eq!(desc["cells"], 64);
    // the EXR holds the same f32 values as the raw file, and f16 is within its rounding of them
    let raw: Vec<f32> = std::fs::read(lut.join("8x8.f32"))
        .unwrap()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let exr = furnace::table::io::read_exr_channels(&lut.join("8x8.exr")).unwrap();
    assert_eq!(exr.len(), 1);
    assert_eq!(exr[0].0, "E");
    assert_eq!(exr[0].1, raw);
    let half: Vec<u16> = std::fs::read(lut.join("8x8.f16"))
        .unwrap()
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(half.len(), 64);
    let f16_err = desc["f16_max_rounding_error"].as_f64().unwrap();
    assert!(f16_err > 0.0 && f16_err <= 2f64.powi(-12), "{f16_err}");
    assert!(raw.iter().all(|v| (0.0..=1.0).contains(v)));
    let rs = std::fs::read_to_string(fits.join("rational-3.rs")).unwrap();
    assert!(rs.contains("pub fn ggx_conductor_separable_albedo(r: f32, mu: f32) -> f32"));

    // bad inputs: each names the fix, and nothing new is written
    let mut other_version: serde_json::Value = serde_json::from_str(&good).unwrap();
    other_version["tool_version"] = "0.0.9".into();
    let mut missing: serde_json::Value = serde_json::from_str(&good).unwrap();
    missing.as_object_mut().unwrap().remove("source");
    let bare =
        serde_json::to_string(&serde_json::from_str::<serde_json::Value>(&good).unwrap()["fit"])
            .unwrap();
    let mut no_numerator: serde_json::Value = serde_json::from_str(&good).unwrap();
    no_numerator["fit"]["approximant"]
        .as_object_mut()
        .unwrap()
        .remove("numerator");
    let glossy = std::fs::read_to_string(root().join("tests/fixtures/paper-glossy.json")).unwrap();
    let cases: Vec<(&str, String, Vec<&str>, &str)> = vec![
        (
            "version.json",
            other_version.to_string(),
            vec!["--lang", "rust"],
            "written by furnace 0.0.9, but this is furnace",
        ),
        (
            "missing.json",
            missing.to_string(),
            vec!["--lang", "rust"],
            "the field 'source' is missing",
        ),
        (
            "bare.json",
            bare,
            vec!["--lang", "rust"],
            "looks like a bare fit result",
        ),
        (
            "nonum.json",
            no_numerator.to_string(),
            vec!["--lang", "rust"],
            "missing field `numerator`",
        ),
        (
            "glossy.json",
            glossy,
            vec!["--lang", "rust"],
            "uncertified denominator",
        ),
        (
            "lang.json",
            good.clone(),
            vec!["--lang", "rust,msl"],
            "unknown language 'msl' for --lang; choose from rust, wgsl, glsl, hlsl, cpp (C/C++/CUDA header), lut, all",
        ),
    ];
    for (file, text, extra, want) in cases {
        std::fs::write(fits.join(file), text).unwrap();
        let before = files_in(&fits);
        let path = format!("fits/ggx-conductor/{file}");
        let mut args = vec!["emit", "--fit", path.as_str()];
        args.extend(extra);
        let (ok, _, err) = furnace(&args, &dir);
        assert!(!ok, "{file} should fail");
        assert!(err.contains(want), "{file}: {err}");
        assert_eq!(files_in(&fits), before, "{file}: nothing may be written");
    }
    // the stress command fails the glossy fit with a non-zero exit and says why
    let (ok, out, err) = furnace(
        &[
            "stress",
            "--fit",
            "fits/ggx-conductor/glossy.json",
            "--points",
            "2000",
        ],
        &dir,
    );
    assert!(!ok);
    assert!(
        out.contains("FAIL: the denominator is not proved pole-free"),
        "{out}"
    );
    assert!(
        err.contains("stress test of fits/ggx-conductor/glossy.json failed"),
        "{err}"
    );
    let (ok, out, _) = furnace(
        &[
            "stress",
            "--fit",
            "fits/ggx-conductor/rational-3.json",
            "--points",
            "2000",
        ],
        &dir,
    );
    assert!(ok && out.contains("PASS"), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Fits of two outputs of one model (the split sum's A and B) get LUTs of their own beside each
/// other, each holding its output.
#[test]
fn luts_of_two_outputs_of_one_model_do_not_overwrite_each_other() {
    let dir = scratch("lut-outputs");
    for ch in ["A", "B"] {
        let fit = format!("fits/split-sum-{ch}.json");
        let (ok, out, err) = furnace(
            &[
                "fit",
                "--model",
                "ggx-split-sum",
                "--channel",
                ch,
                "--form",
                "rational",
                "--degree",
                "2",
                "--resolution",
                "17",
                "--output",
                &fit,
            ],
            &dir,
        );
        assert!(ok, "{out}\n{err}");
        let (ok, out, err) = furnace(
            &[
                "emit",
                "--fit",
                &fit,
                "--lang",
                "lut",
                "--lut-resolution",
                "8",
            ],
            &dir,
        );
        assert!(ok, "{out}\n{err}");
    }
    let lut = dir.join("data/lut/ggx-split-sum");
    let listed = files_in(&lut);
    let mut values = Vec::new();
    for ch in ["A", "B"] {
        for ext in ["exr", "f16", "f32", "json"] {
            let f = format!("8x8-{ch}.{ext}");
            assert!(listed.contains(&f), "{f} missing: {listed:?}");
        }
        let exr =
            furnace::table::io::read_exr_channels(&lut.join(format!("8x8-{ch}.exr"))).unwrap();
        assert_eq!(exr[0].0, ch);
        values.push(exr[0].1.clone());
    }
    assert_ne!(values[0], values[1]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The units of the snapshots, built as `tests/emit_snapshots.rs` builds them.
fn snapshot_units() -> Vec<furnace::emit::Unit> {
    let src =
        |name: &str| SourceFit::new(format!("tests/fixtures/{name}"), fixture(name), None).unwrap();
    let opts = furnace::emit::EmitOptions::default();
    let (a, _) = furnace::emit::build_unit(
        "paper-conductors",
        "FURNACE_PAPER_CONDUCTORS_GLSL",
        &[src("paper-conductors.json")],
        "furnace emit --fit tests/fixtures/paper-conductors.json --lang all",
        &opts,
    )
    .unwrap();
    let (b, _) = furnace::emit::build_unit(
        "dielectric-pair",
        "FURNACE_DIELECTRIC_PAIR_GLSL",
        &[src("ggx-dielectric.json"), src("ggx-dielectric-inv.json")],
        "furnace run --scene (a dielectric material; see tests/emit_snapshots.rs)",
        &opts,
    )
    .unwrap();
    let (c, _) = furnace::emit::build_unit(
        "aniso-conductor",
        "FURNACE_ANISO_CONDUCTOR_GLSL",
        &[src("ggx-conductor-aniso.json")],
        "furnace emit --fit tests/fixtures/ggx-conductor-aniso.json --lang all",
        &opts,
    )
    .unwrap();
    vec![a, b, c]
}

/// Deterministic arguments: values over [−0.25, 1.25] (outside every fitted domain on both
/// sides) with every 8th coordinate an edge value (±0, 1, −1, the smallest normal and
/// subnormal, ±∞).
fn arguments(n: usize, width: usize, seed: u64) -> Vec<f32> {
    const EDGES: [f32; 9] = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f32::MIN_POSITIVE,
        1e-45,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.5,
    ];
    let mut state = seed;
    (0..n * width)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 40) as f32 / (1u64 << 24) as f32;
            if (state >> 20).is_multiple_of(8) {
                EDGES[((state >> 8) % EDGES.len() as u64) as usize]
            } else {
                -0.25 + 1.5 * u
            }
        })
        .collect()
}

/// The emitted C/C++ header, compiled by g++ with `-ffp-contract=off` (GCC contracts `a * b + c`
/// into a fused multiply–add by default in C++ wherever the target has FMA, which rounds once
/// instead of twice) and run: every function of both snapshot units, at 20000 points each
/// (edges, infinities and out-of-domain inputs included), gives the bits of the f32 evaluation
/// of the IR with every operation rounded once ([`Arith::Ieee`], what the emitted Rust computes).
#[test]
fn emitted_cpp_runs_bit_identical_to_the_rust_f32_evaluation() {
    let ok = std::process::Command::new("g++")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: g++ not found — the emitted C/C++ was not compiled and run");
        return;
    }
    use furnace::emit::Emitter;
    let d = std::env::temp_dir().join(format!("furnace-emit-test-cpp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    const N: usize = 20_000;
    let mut compared = 0;
    for unit in snapshot_units() {
        let header = furnace::emit::cpp::Cpp.produce(&unit).unwrap().remove(0);
        std::fs::write(d.join(&header.file_name), &header.bytes).unwrap();
        let mut main = format!(
            "#include \"{}\"\n#include <cstdio>\n#include <cstdlib>\n\
             static float rd(FILE* f) {{ float x; if (std::fread(&x, 4, 1, f) != 1) std::exit(2); return x; }}\n\
             static void wr(FILE* f, float y) {{ std::fwrite(&y, 4, 1, f); }}\n\
             int main(int argc, char** argv) {{\n    if (argc != 3) return 3;\n    FILE* in = std::fopen(argv[1], \"rb\");\n    FILE* out = std::fopen(argv[2], \"wb\");\n    if (!in || !out) return 4;\n",
            header.file_name
        );
        let mut inputs = Vec::new();
        let mut models = Vec::new();
        for (k, f) in unit.program.functions.iter().enumerate() {
            let model = Compiled::new(&unit.program, &f.name).unwrap();
            let width = model.n_params();
            inputs.extend(arguments(N, width, 0x5eed + k as u64));
            main.push_str(&format!("    for (int j = 0; j < {N}; j++) {{\n"));
            let mut args = Vec::new();
            for p in &f.params {
                if f.is_vector_param(p) {
                    main.push_str(&format!(
                        "        const float {p}_x = rd(in);\n        const float {p}_y = rd(in);\n        const float {p}_z = rd(in);\n"
                    ));
                    args.push(format!("furnace_rgb_make({p}_x, {p}_y, {p}_z)"));
                } else {
                    main.push_str(&format!("        const float {p} = rd(in);\n"));
                    args.push(p.clone());
                }
            }
            let call = format!("{}({})", f.name, args.join(", "));
            if f.returns_vector() {
                main.push_str(&format!(
                    "        const furnace_rgb y = {call};\n        wr(out, y.x);\n        wr(out, y.y);\n        wr(out, y.z);\n    }}\n"
                ));
            } else {
                main.push_str(&format!("        wr(out, {call});\n    }}\n"));
            }
            models.push((f.name.clone(), model, width));
        }
        main.push_str("    std::fclose(out);\n    return 0;\n}\n");
        let stem = &unit.stem;
        let src = d.join(format!("{stem}-main.cpp"));
        let exe = d.join(format!("{stem}-main"));
        std::fs::write(&src, main).unwrap();
        let o = std::process::Command::new("g++")
            .args([
                "-std=c++17",
                "-O2",
                "-ffp-contract=off",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-o",
            ])
            .arg(&exe)
            .arg(&src)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{stem}.h with g++: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let bytes: Vec<u8> = inputs.iter().flat_map(|x| x.to_le_bytes()).collect();
        let (fin, fout) = (d.join(format!("{stem}.in")), d.join(format!("{stem}.out")));
        std::fs::write(&fin, bytes).unwrap();
        let o = std::process::Command::new(&exe)
            .arg(&fin)
            .arg(&fout)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{stem}: the compiled program failed: {o:?}"
        );
        let out: Vec<f32> = std::fs::read(&fout)
            .unwrap()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let (mut at_in, mut at_out) = (0, 0);
        let mut regs = Vec::new();
        for (name, model, width) in &models {
            for _ in 0..N {
                let x = &inputs[at_in..at_in + width];
                at_in += width;
                model.eval_f32(x, Arith::Ieee, &mut regs);
                for &r in model.results() {
                    let (got, want) = (out[at_out], regs[r]);
                    at_out += 1;
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "{stem}.h {name} at {x:?}: C++ {got:e}, Rust f32 {want:e}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(at_out, out.len(), "{stem}: every output compared");
    }
    eprintln!("emitted C/C++ (g++ -O2 -ffp-contract=off): {compared} outputs bit-identical to the Rust f32 evaluation");
    let _ = std::fs::remove_dir_all(&d);
}

/// A fit whose numerator leaves out the μ-terms without r (`tensor:1,5@r:0/1,0`, the FON
/// albedo's shape) emits in every language, and every evaluation form computes the fit.
#[test]
fn a_numerator_without_mu_terms_free_of_r_emits_and_matches_the_fit() {
    let dir = common::scratch("fon-shape");
    // the FON albedo (EON paper, eq. 12) at 33² nodes of [0, 1]²
    let mut csv = String::from("r,mu,E\n");
    for i in 0..33 {
        for j in 0..33 {
            let (r, mu) = (i as f64 / 32.0, j as f64 / 32.0);
            let e = furnace::bsdf::diffuse::fon_albedo_analytic(r, mu);
            csv.push_str(&format!("{r},{mu},{e}\n"));
        }
    }
    std::fs::write(dir.join("fon.csv"), csv).unwrap();
    std::fs::create_dir_all(dir.join("fits")).unwrap();
    let (ok, out, err) = furnace(
        &[
            "fit",
            "--table",
            "fon.csv",
            "--spec",
            "tensor:1,5@r:0/1,0",
            "--output",
            "fits/fon.json",
        ],
        &dir,
    );
    assert!(ok, "{out}\n{err}");
    let record = fitfile::read(&dir.join("fits/fon.json")).unwrap();
    assert_eq!(record.fit.n_coefficients, 8);
    assert!(!record
        .fit
        .approximant
        .numerator
        .exponents
        .contains(&vec![0, 1]));
    let (ok, out, err) = furnace(
        &[
            "emit",
            "--fit",
            "fits/fon.json",
            "--lang",
            "rust,wgsl,glsl,hlsl,cpp",
        ],
        &dir,
    );
    assert!(ok, "{out}\n{err}");
    let text = |ext: &str| std::fs::read_to_string(dir.join(format!("fits/fon.{ext}"))).unwrap();
    naga_wgsl(&text("wgsl")).unwrap();
    naga_glsl(&text("glsl")).unwrap();
    assert!(text("rs").contains("(r: f32, mu: f32) -> f32"));
    // each evaluation form, in the f32 model of the emitted operations, against the f64 fit
    let name = name_of(&record);
    for form in furnace::emit::generate::EvalForm::ALL {
        let function =
            furnace::emit::generate::albedo_function(&name, vec![], &record.fit, form).unwrap();
        let model = Compiled::new(
            &Program {
                functions: vec![function],
            },
            &name,
        )
        .unwrap();
        let mut regs = Vec::new();
        let domain = furnace::emit::generate::domain_f32(&record.fit);
        let mut worst = 0.0f64;
        for x in check_points(&domain, 41) {
            let got = model.eval_f32(&x, Arith::Ieee, &mut regs);
            let (want, _) = reference(&record.fit, &x);
            worst = worst.max((got as f64 - want).abs());
        }
        assert!(worst <= 1e-5, "{form:?}: max |f32 − f64| {worst:e}");
        let st = stress(
            &record.fit,
            &name,
            &StressOptions {
                random_points: 2000,
                form: FormChoice::Force(form),
                ..Default::default()
            },
        )
        .unwrap();
        assert!(st.passed(), "{}", st.render());
    }
}
