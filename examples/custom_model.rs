//! A new BSDF and a new material class in one file: the worked example of docs/models.md,
//! "Adding a model", and docs/architecture.md, "Adding a material class".
//!
//! The model is a white Lambertian base under a smooth dielectric coat seen through Schlick's
//! Fresnel approximation: f(ωo, ωi) = (1 − F(μo))(1 − F(μi))/π with F(μ) = F0 + (1 − F0)(1 − μ)⁵
//! (Schlick 1994, eq. 15). Its albedo is E(μo) = (1 − F(μo))·(1 − F0 − 2(1 − F0)/42), which the
//! example prints next to the quadrature so you can see the engine integrate it.
//!
//! The material class `coated-diffuse` is that base under the coat with the coat's own mirror
//! reflection F(μo) added, and the base rescaled so that it carries all the energy the coat lets
//! through: F(μo) δ + (1 − F(μo))·f/E(μo), which integrates to F + (1 − F) = 1 exactly; the
//! `1/E` helper is emitted next to the albedo fit for it. Once both are registered
//! ([`furnace::bsdf::register_in_default_set`], which also puts the model in the default set of
//! `furnace run` and the report, and [`furnace::material::register`]), the library's pipeline
//! ([`furnace::pipeline::run`] on the default set's job: table → degree sweep → Rust/WGSL/GLSL
//! and a LUT → report with the white furnace test of the new class) and a scene whose material
//! is of the new kind (the same `run` on [`furnace::pipeline::Job::scene`]) take them with no
//! other change. The example runs both at small sizes into a temporary folder and checks what
//! they wrote.
//!
//! Run: `cargo run --release --example custom_model`

use furnace::bsdf::{albedo, AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use furnace::emit::Lang;
use furnace::material::{
    CompensatedBsdf, Compensation, Helper, HelperUse, Lobe, MaterialClass, Prepared, TableUse,
};
use furnace::math::SmithForm;
use furnace::pipeline::{self, FitStage, Job};
use furnace::progress::Quiet;
use furnace::quadrature::{
    integrate_2d, Integrand2D, QuadratureSettings, RuleCache, Rules, CHANNELS,
};
use furnace::scene::Manifest;
use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

struct CoatedLambert;

/// ∫ f μi dωi over (μi, φ) ∈ [0, 1] × [0, 2π]: smooth, so one panel per axis is enough.
struct Integrand {
    f0: f64,
    mu_o: f64,
}

fn schlick(f0: f64, mu: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - mu).powi(5) // Schlick 1994, eq. 15
}

impl Integrand2D for Integrand {
    /// The outer coordinate μi, kept for the inner integral over φ.
    type Line = f64;
    fn outer_breaks(&self, out: &mut Vec<f64>) {
        out.extend([0.0, 1.0]); // μi: no kinks, one panel
    }
    fn line(&self, mu_i: f64, inner: &mut Vec<f64>) -> f64 {
        inner.extend([0.0, 2.0 * PI]); // φ: no kinks, one panel
        mu_i
    }
    fn eval(&self, &mu_i: &f64, _phi: f64) -> [f64; CHANNELS] {
        let f = (1.0 - schlick(self.f0, self.mu_o)) * (1.0 - schlick(self.f0, mu_i)) / PI;
        [f * mu_i, 0.0] // f·|n·ωi|, with dωi = dμi dφ
    }
}

impl Model for CoatedLambert {
    fn id(&self) -> ModelId {
        ModelId::new(Family::new("coated-lambert"))
    }
    fn summary(&self) -> String {
        "white Lambertian under a Schlick-Fresnel coat (the worked example of docs/models.md)"
            .into()
    }
    fn axes(&self) -> Vec<AxisSpec> {
        vec![
            AxisSpec::new(
                "f0",
                (0.02, 0.1),
                (0.0, 1.0),
                "coat reflectance at normal incidence",
            ),
            AxisSpec::new(
                "mu",
                (0.0, 1.0),
                (0.0, 1.0),
                "cosine of the outgoing direction",
            ),
        ]
    }
    fn outputs(&self) -> Vec<&'static str> {
        vec!["E"]
    }
    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        let c = integrate_2d(
            &Integrand {
                f0: x[0],
                mu_o: x[1],
            },
            rules,
        );
        [c[0], 0.0, 0.0]
    }
}

/// The BSDF seen from ωo = (sin θo, 0, μo): (1 − F(μo))(1 − F(μi))/π.
fn coated_lambert(f0: f64, mu_o: f64, mu_i: f64) -> f64 {
    (1.0 - schlick(f0, mu_o)) * (1.0 - schlick(f0, mu_i)) / PI
}

/// The material class: a coated diffuse surface, F(μo) δ + (1 − F(μo))·f/E.
struct CoatedDiffuse;

impl MaterialClass for CoatedDiffuse {
    fn kind(&self) -> &'static str {
        "coated-diffuse"
    }
    fn summary(&self) -> String {
        "white Lambertian under a Schlick-Fresnel coat: the coat's mirror F(μo) plus (1 − F(μo))·f/E".into()
    }
    fn tables(&self, _smith: SmithForm) -> Vec<TableUse> {
        vec![TableUse::new(
            CoatedLambert.id(),
            vec![HelperUse::new(
                Helper::Normalization,
                &["coated diffuse: multiply the coated Lambert BSDF by (1 − F(μo)) times it"],
            )],
        )]
    }
    fn compensated(
        &self,
        _smith: SmithForm,
        _transmission: furnace::bsdf::Transmission,
    ) -> Vec<Arc<dyn CompensatedBsdf>> {
        vec![Arc::new(CoatedDiffuseBsdf)]
    }
}

/// Smallest albedo divided by (the base's E vanishes only where the coat passes nothing).
const ALBEDO_FLOOR: f64 = 1e-9;

/// The compensated BSDF the white furnace test integrates: the coat's mirror (its integral is
/// F(μo)) and the coated base f; the compensated albedo is F(μo) + (1 − F(μo))·∫f|μi|dωi / E.
struct CoatedDiffuseBsdf;

impl CompensatedBsdf for CoatedDiffuseBsdf {
    fn id(&self) -> String {
        "coated-diffuse".into()
    }
    fn label(&self) -> String {
        "coated diffuse".into()
    }
    fn albedos(&self) -> Vec<ModelId> {
        vec![CoatedLambert.id()]
    }
    fn lobes(&self, x: &[f64]) -> Vec<Lobe> {
        let (f0, mu_o) = (x[0], x[1]);
        vec![
            Lobe::Exact(schlick(f0, mu_o)),
            Lobe::Directional {
                mu_o,
                f: Arc::new(move |wi: [f64; 3]| coated_lambert(f0, mu_o, wi[2])),
                transmits: false,
                mu_breaks: vec![],
            },
        ]
    }
    fn albedo(&self, lobes: &[f64], x: &[f64], compensation: &Compensation, _: &Prepared) -> f64 {
        let (mirror, base) = (lobes[0], lobes[1]);
        match compensation {
            Compensation::None => mirror + base,
            Compensation::With(sources) => {
                // at grazing the coat reflects everything: no base, whatever E is there
                let through = 1.0 - mirror;
                if through <= 0.0 {
                    return mirror;
                }
                mirror + through * base / sources[0].albedo(x).max(ALBEDO_FLOOR)
            }
        }
    }
}

/// The engine against the closed form.
fn check_quadrature() {
    let model = CoatedLambert;
    let settings = QuadratureSettings::default();
    let cache = RuleCache::new(&settings);
    println!(
        "{:>6} {:>6} {:>20} {:>20}",
        "f0", "mu", "E (quadrature)", "E (closed form)"
    );
    for (f0, mu) in [(0.04, 0.0), (0.04, 0.5), (0.1, 1.0)] {
        let e = albedo(&model, &[f0, mu], &settings, &cache);
        // ∫0^1 2μ(1 − μ)^5 dμ = 2/42
        let exact = (1.0 - schlick(f0, mu)) * (1.0 - f0 - (1.0 - f0) * 2.0 / 42.0);
        println!("{f0:>6} {mu:>6} {:>20.15} {:>20.15}", e.value[0], exact);
        assert!((e.value[0] - exact).abs() < 1e-12);
    }
}

/// Registers the model and the class, then runs the pipeline on the model and a scene of the
/// class into `root`; returns the compensated BSDF's worst |1 − E| with the fitted albedo.
fn run_everything(root: &Path) -> furnace::Result<f64> {
    let id = furnace::bsdf::register_in_default_set(CoatedLambert)?;
    furnace::material::register(CoatedDiffuse)?;

    // tables → degree sweep → emitted code and LUT → report (small sizes); the default set
    // now ends with the model, so `furnace run`'s job has it with no other change
    let mut job = Job::default_set(root);
    assert!(job.tables.iter().any(|t| t.model == id));
    assert_eq!(furnace::bsdf::default_set().last(), Some(&id));
    job.only(&[id.key()])?;
    job.set_resolution(33, 17);
    job.fit = FitStage::Sweep {
        max_degree: Some(4),
    };
    job.quick_report();
    let outcome = pipeline::run(&job, &Quiet)?;
    let row = &outcome.rows[0];
    println!(
        "pipeline: {} table {}, {} fit files, {} emitted files, {} report files",
        row.name,
        row.resolution,
        row.sweep().map_or(0, |s| s.files.len()),
        row.emitted.len(),
        row.report_files
    );
    let fits = root.join("fits").join(id.key());
    for file in [
        "sweep.json",
        "best-20.json",
        "best-20.rs",
        "best-20.wgsl",
        "best-20.glsl",
    ] {
        assert!(fits.join(file).is_file(), "{file} missing");
    }
    let rust = std::fs::read_to_string(fits.join("best-20.rs")).expect("emitted Rust");
    assert!(
        rust.contains("pub fn coated_lambert_normalization("),
        "{rust}"
    );
    let section = std::fs::read_to_string(root.join("reports").join(id.key()).join("section.md"))
        .expect("report section");
    assert!(section.contains("coated diffuse"), "{section}");
    let furnace = row
        .furnace
        .expect("the white furnace test of coated-diffuse");

    // a scene of the new kind: only its table, fitted and emitted with its helper
    let manifest = Manifest::parse(
        r#"{"name": "studio", "resolution": {"2d": 17},
            "materials": [{"name": "paint", "kind": "coated-diffuse", "ior": [1.4, 1.6]}]}"#,
        Path::new("studio.json"),
    )?;
    let opts = pipeline::scene::RunOptions {
        data_dir: root.join("data"),
        fits_dir: root.join("fits"),
        lut_dir: root.join("data").join("lut"),
        force: false,
        quadrature: QuadratureSettings::default(),
        langs: vec![Lang::Rust, Lang::Wgsl, Lang::Glsl],
        lut_resolution: 8,
        stress_points: 1000,
        command: "cargo run --example custom_model".into(),
    };
    let out = pipeline::run(&Job::scene(&manifest, &opts)?, &Quiet)?;
    assert_eq!(out.rows.len(), 1);
    assert_eq!(out.rows[0].id, id);
    let wgsl = std::fs::read_to_string(root.join("fits/studio/studio.wgsl")).expect("scene WGSL");
    assert!(wgsl.contains("fn coated_lambert_normalization("), "{wgsl}");
    println!(
        "scene studio: {} files, fit max error {:.1e}",
        out.written.len(),
        out.rows[0]
            .one()
            .expect("the scene's one fit")
            .fit
            .metrics
            .max_abs_error
    );
    Ok(furnace)
}

fn main() {
    check_quadrature();
    let root = std::env::temp_dir().join(format!("furnace-custom-model-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let result = run_everything(&root);
    let _ = std::fs::remove_dir_all(&root);
    let furnace = result.unwrap_or_else(|e| panic!("{e}"));
    println!("white furnace of coated-diffuse with the fitted albedo: max |1 − E| = {furnace:.1e}");
    // f/E with E from a fit of ≤ 20 coefficients: 1 to the fit's accuracy
    assert!(furnace < 1e-3, "{furnace}");
}

#[test]
fn a_model_and_a_material_class_from_outside_run_through_the_whole_pipeline() {
    main();
}
