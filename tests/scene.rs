//! Scene manifests end to end: a conductor-only scene tabulates only 2-D conductor tables over
//! the narrower domain, fits and stress-tests them, and emits only the conductor functions.

use std::path::PathBuf;

use furnace::emit::Lang;
use furnace::pipeline::scene::RunOptions;
use furnace::pipeline::{self, Job, Outcome};
use furnace::quadrature::QuadratureSettings;
use furnace::scene::Manifest;

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("furnace-scene-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The scene's job through the pipeline, its log on stderr.
fn run(manifest: &Manifest, opts: &RunOptions, quiet: bool) -> furnace::Result<Outcome> {
    struct Log(bool);
    impl furnace::progress::Observer for Log {
        fn line(&self, text: &str) {
            if !self.0 {
                eprintln!("{text}");
            }
        }
    }
    pipeline::run(&Job::scene(manifest, opts)?, &Log(quiet))
}

fn walk(dir: &std::path::Path, out: &mut Vec<PathBuf>) {
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out)
            } else {
                out.push(p)
            }
        }
    }
}

#[test]
fn conductor_only_scene_tabulates_fits_and_emits_only_2d_conductor_code() {
    let dir = scratch("metals");
    let manifest = Manifest::parse(
        r#"{"name": "metals", "resolution": {"2d": 24, "3d": 8}, "materials": [
            {"name": "gold", "kind": "conductor", "r": [0.2, 0.6]},
            {"name": "window", "kind": "thin-dielectric", "alpha": [0.04, 0.09]}]}"#,
        std::path::Path::new("metals.json"),
    )
    .unwrap();
    let opts = RunOptions {
        data_dir: dir.join("data"),
        fits_dir: dir.join("fits"),
        lut_dir: dir.join("data/lut"),
        force: false,
        quadrature: QuadratureSettings::default(),
        langs: vec![Lang::Rust, Lang::Wgsl, Lang::Glsl, Lang::Lut],
        lut_resolution: 8,
        stress_points: 5_000,
        command: "furnace run --scene metals.json".into(),
    };
    let out = run(&manifest, &opts, false).unwrap();
    // one table: ggx-conductor over r ∈ [0.2, 0.6] (the union of [0.2, 0.6] and √[0.04, 0.09])
    assert_eq!(out.rows.len(), 1);
    let row = &out.rows[0];
    assert_eq!(row.id.key(), "ggx-conductor");
    assert_eq!(row.ranges[0], (0.2, 0.6));
    let t = row.one().unwrap();
    assert_eq!(
        t.fit.approximant.domain[0],
        (0.2, 0.6),
        "the fit covers the narrower domain only"
    );
    assert!(t.stress.as_ref().unwrap().passed());
    // no 3-D table was made: every cached table is 2-D
    let mut files = Vec::new();
    walk(&dir.join("data"), &mut files);
    let sidecars: Vec<&PathBuf> = files
        .iter()
        .filter(|p| {
            p.extension().is_some_and(|e| e == "json") && !p.to_string_lossy().contains("/lut/")
        })
        .collect();
    assert!(!sidecars.is_empty());
    for s in &sidecars {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(s).unwrap()).unwrap();
        assert_eq!(v["axes"].as_array().unwrap().len(), 2, "{}", s.display());
        assert_eq!(v["model"], "ggx-conductor");
    }
    // emitted: the conductor albedo, Turquin's scale and the Kulla–Conty helpers (gold) and 1/E
    // (window) — nothing else
    let rs = std::fs::read_to_string(dir.join("fits/metals/metals.rs")).unwrap();
    let fns: Vec<&str> = rs
        .lines()
        .filter_map(|l| l.strip_prefix("pub fn "))
        .map(|l| l.split('(').next().unwrap())
        .collect();
    assert_eq!(
        fns,
        [
            "ggx_conductor_albedo",
            "ggx_conductor_turquin_scale",
            "ggx_conductor_turquin_scale_rgb",
            "ggx_conductor_kulla_conty_lobe",
            "ggx_conductor_kulla_conty_color",
            "ggx_conductor_kulla_conty_color_rgb",
            "ggx_conductor_kulla_conty_diffuse_weight",
            "ggx_conductor_normalization"
        ]
    );
    assert!(rs.contains("fitted domain [0.2, 0.6]"), "{rs}");
    for ext in ["wgsl", "glsl"] {
        assert!(dir.join(format!("fits/metals/metals.{ext}")).exists());
    }
    assert!(dir.join("fits/metals/ggx-conductor.json").exists());
    // a LUT of the same narrow domain, compared with the fit at the table's nodes
    let lut: Vec<&PathBuf> = files
        .iter()
        .filter(|p| {
            p.to_string_lossy().contains("/lut/") && p.extension().is_some_and(|e| e == "json")
        })
        .collect();
    assert_eq!(lut.len(), 1, "{files:?}");
    let desc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(lut[0]).unwrap()).unwrap();
    assert_eq!(desc["axes"][0]["lo"], 0.2);
    assert!(desc["comparison"]["fit_f32_max"].as_f64().unwrap() < 0.05);
    // a second run reads the table from the cache and writes identical code
    let again = run(&manifest, &opts, true).unwrap();
    assert!(again.rows[0].cached);
    assert_eq!(
        std::fs::read_to_string(dir.join("fits/metals/metals.rs")).unwrap(),
        rs
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_example_manifest_parses_and_plans() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/scene.json");
    let m = Manifest::read(&path).unwrap();
    let p = furnace::scene::plan(&m).unwrap();
    assert!(!p.tables.is_empty());
}

fn naga_ok(wgsl: &str, glsl: &str) {
    furnace::emit::validate::wgsl(wgsl).unwrap_or_else(|e| panic!("{e}"));
    furnace::emit::validate::glsl(glsl).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn every_kind_in_one_scene_emits_valid_shaders_with_only_the_needed_helpers() {
    let dir = scratch("all-kinds");
    let manifest = Manifest::parse(
        r#"{"name": "all-kinds", "resolution": {"2d": 12, "3d": 6}, "materials": [
            {"name": "glass", "kind": "dielectric", "r": [0.1, 0.4], "ior": [1.4, 1.6]},
            {"name": "plastic", "kind": "glossy", "r": [0.1, 0.4], "ior": 1.5},
            {"name": "clay", "kind": "rough-diffuse", "r": [0.5, 1.0]}]}"#,
        std::path::Path::new("all-kinds.json"),
    )
    .unwrap();
    let opts = RunOptions {
        data_dir: dir.join("data"),
        fits_dir: dir.join("fits"),
        lut_dir: dir.join("data/lut"),
        force: false,
        quadrature: QuadratureSettings::default(),
        langs: vec![Lang::Rust, Lang::Wgsl, Lang::Glsl],
        lut_resolution: 8,
        stress_points: 2_000,
        command: "furnace run --scene all-kinds.json".into(),
    };
    let out = run(&manifest, &opts, false).unwrap();
    let models: Vec<String> = out.rows.iter().map(|r| r.id.key()).collect();
    assert_eq!(
        models,
        [
            "ggx-conductor",
            "ggx-dielectric",
            "ggx-dielectric-inv",
            "ggx-glossy",
            "oren-nayar-fon"
        ]
    );
    let rs = std::fs::read_to_string(dir.join("fits/all-kinds/all-kinds.rs")).unwrap();
    let fns: Vec<&str> = rs
        .lines()
        .filter_map(|l| l.strip_prefix("pub fn "))
        .map(|l| l.split('(').next().unwrap())
        .collect();
    // glossy needs the conductor's 1/E_ss but no Turquin scale: no conductor material here
    assert!(
        fns.contains(&"ggx_conductor_normalization")
            && !fns.contains(&"ggx_conductor_turquin_scale"),
        "{fns:?}"
    );
    for f in [
        "ggx_dielectric_sided_albedo",
        "ggx_dielectric_sided_normalization",
        "ggx_glossy_diffuse_weight",
        "oren_nayar_fon_albedo",
    ] {
        assert!(fns.contains(&f), "{f} missing from {fns:?}");
    }
    let wgsl = std::fs::read_to_string(dir.join("fits/all-kinds/all-kinds.wgsl")).unwrap();
    let glsl = std::fs::read_to_string(dir.join("fits/all-kinds/all-kinds.glsl")).unwrap();
    naga_ok(&wgsl, &glsl);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_scene_job_can_sweep_its_tables_and_emit_the_best_fits_in_one_file() {
    let dir = scratch("swept");
    let manifest = Manifest::parse(
        r#"{"name": "swept", "resolution": {"2d": 17}, "materials": [
            {"name": "gold", "kind": "conductor", "r": [0.2, 0.6]}]}"#,
        std::path::Path::new("swept.json"),
    )
    .unwrap();
    let opts = RunOptions {
        data_dir: dir.join("data"),
        fits_dir: dir.join("fits"),
        lut_dir: dir.join("data/lut"),
        force: false,
        quadrature: QuadratureSettings::default(),
        langs: vec![Lang::Rust],
        lut_resolution: 8,
        stress_points: 0,
        command: "furnace run --scene swept.json".into(),
    };
    let mut job = Job::scene(&manifest, &opts).unwrap();
    job.fit = pipeline::FitStage::Sweep {
        max_degree: Some(2),
    };
    let out = pipeline::run(&job, &furnace::progress::Quiet).unwrap();
    let sweep = out.rows[0].sweep().expect("a sweep");
    let (budget, best) = sweep
        .best
        .iter()
        .rev()
        .find(|b| b.1.is_some())
        .expect("a best fit");
    let folder = dir.join("fits/swept/ggx-conductor");
    assert!(folder.join("sweep.json").is_file() && folder.join("off-grid.json").is_file());
    // the one file holds the largest-budget best fit, over the scene's narrower domain
    let rs = std::fs::read_to_string(dir.join("fits/swept/swept.rs")).unwrap();
    assert!(rs.contains(&format!("best-{budget}.json")), "{rs}");
    assert!(rs.contains("fitted domain [0.2, 0.6]"), "{rs}");
    assert!(rs.contains("pub fn ggx_conductor_turquin_scale("), "{rs}");
    assert_eq!(
        out.functions[0].n_coefficients,
        best.as_ref().unwrap().n_coefficients
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// An anisotropic conductor end to end: a 4-D `ggx-conductor-aniso` table over the material's r
/// and aniso ranges only, a certified and stress-tested rational fit, and emitted code with the
/// tangent-frame helpers, which validate in WGSL and GLSL.
#[test]
fn anisotropic_conductor_scene_tabulates_a_4d_table_over_its_ranges_and_emits_its_helpers() {
    let dir = scratch("brushed");
    let manifest = Manifest::parse(
        r#"{"name": "brushed", "resolution": {"4d": [7, 4, 7, 4]},
            "fit": {"numerator_degree": 2, "denominator_degree": 1}, "materials": [
            {"name": "steel", "kind": "anisotropic-conductor", "r": [0.3, 0.6], "aniso": [0.2, 0.8]}]}"#,
        std::path::Path::new("brushed.json"),
    )
    .unwrap();
    let opts = RunOptions {
        data_dir: dir.join("data"),
        fits_dir: dir.join("fits"),
        lut_dir: dir.join("data/lut"),
        force: false,
        quadrature: QuadratureSettings::default(),
        langs: vec![Lang::Rust, Lang::Wgsl, Lang::Glsl],
        lut_resolution: 8,
        stress_points: 5_000,
        command: "furnace run --scene brushed.json".into(),
    };
    let out = run(&manifest, &opts, false).unwrap();
    assert_eq!(out.rows.len(), 1);
    let row = &out.rows[0];
    assert_eq!(row.id.key(), "ggx-conductor-aniso");
    assert_eq!(row.resolution, "7x4x7x4");
    let t = row.one().unwrap();
    let domain = &t.fit.approximant.domain;
    assert_eq!(domain[0], (0.3, 0.6));
    assert_eq!(domain[1], (0.2, 0.8));
    assert_eq!(domain[3], (0.0, std::f64::consts::FRAC_PI_2));
    assert!(t.fit.is_usable() && t.stress.as_ref().unwrap().passed());
    // a degree-2/1 rational follows the table to a few per cent (every node)
    assert!(t.fit.metrics.max_abs_error < 0.1, "{:?}", t.fit.metrics);
    let read = |ext: &str| {
        std::fs::read_to_string(dir.join(format!("fits/brushed/brushed.{ext}"))).unwrap()
    };
    let rs = read("rs");
    for f in [
        "pub fn ggx_conductor_aniso_albedo(r: f32, aniso: f32, mu: f32, phi: f32) -> f32",
        "pub fn ggx_conductor_aniso_direction_albedo(r: f32, aniso: f32, wo: [f32; 3]) -> f32",
        "pub fn ggx_conductor_aniso_turquin_scale(f0: f32, r: f32, aniso: f32, wo: [f32; 3]) -> f32",
        "pub fn ggx_conductor_aniso_turquin_scale_rgb(f0: [f32; 3], r: f32, aniso: f32, wo: [f32; 3]) -> [f32; 3]",
    ] {
        assert!(rs.contains(f), "no `{f}` in\n{rs}");
    }
    furnace::emit::validate::wgsl(&read("wgsl")).unwrap();
    furnace::emit::validate::glsl(&read("glsl")).unwrap();
    assert!(read("wgsl").contains("fn ggx_conductor_aniso_turquin_scale_rgb(f0: vec3<f32>, r: f32, aniso: f32, wo: vec3<f32>) -> vec3<f32>"));
    let _ = std::fs::remove_dir_all(&dir);
}
