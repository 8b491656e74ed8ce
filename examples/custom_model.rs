//! A new BSDF in one file: the worked example of docs/models.md, "Adding a model".
//!
//! The model is a white Lambertian base under a smooth dielectric coat seen through Schlick's
//! Fresnel approximation: f(ωo, ωi) = (1 − F(μo))(1 − F(μi))/π with F(μ) = F0 + (1 − F0)(1 − μ)⁵
//! (Schlick 1994, eq. 15). Its albedo is E(μo) = (1 − F(μo))·(1 − F0 − 2(1 − F0)/42), which the
//! example prints next to the quadrature so you can see the engine integrate it.
//!
//! Run: `cargo run --release --example custom_model`

use furnace::bsdf::{albedo, AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use furnace::quadrature::{
    integrate_2d, Integrand2D, QuadratureSettings, RuleCache, Rules, CHANNELS,
};
use std::f64::consts::PI;

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

fn main() {
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

#[test]
fn quadrature_matches_the_closed_form() {
    main();
}
