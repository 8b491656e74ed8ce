//! How wrong the isotropic shortcuts are for the anisotropic GGX conductor: renderers that
//! compensate an anisotropic lobe look its albedo up in the isotropic table E_iso(r_eff, μ) at
//! an effective roughness. This measures |E_aniso(r, aniso, μ, φ) − E_iso(r_eff, μ)| for
//!
//! * `same-r`: the isotropic table at OpenPBR's r (α = r²), what a table keyed by the material's
//!   roughness returns;
//! * `geometric`: α = √(α_t α_b);
//! * `projected`: the projected roughness of ωo, α = √(α_t² cos²φ + α_b² sin²φ);
//! * `larger`: α = α_t;
//!
//! on an off-grid sample of the default box (r ∈ (0, 1], aniso ∈ (0, 0.95], μ ∈ (0, 1],
//! φ ∈ [0, π/2]), both albedos by direct quadrature at furnace's default settings (error
//! estimate ≤ 1e-7). An r_eff above 1 (α_t reaches 1.41) is clamped to the table's edge, as a
//! lookup would. Prints the max and mean error of each shortcut over the box, then the max over
//! (r, μ) for every (aniso, φ) of the sample.
//!
//! Run: `cargo run --release --example aniso_shortcuts`

use furnace::bsdf::{albedo, find};
use furnace::math::anisotropic_alphas;
use furnace::quadrature::{QuadratureSettings, RuleCache};
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;

const SHORTCUTS: [&str; 4] = ["same-r", "geometric", "projected", "larger"];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let aniso_model = find("ggx-conductor-aniso")?;
    let iso_model = find("ggx-conductor")?;
    let settings = QuadratureSettings::default();
    let cache = RuleCache::new(&settings);
    // off-grid: no value on a node of the default 64 × 16 × 64 × 16 axes
    let rs: Vec<f64> = (0..20).map(|i| (i as f64 + 0.5) / 20.0).collect();
    let anisos: Vec<f64> = [0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95].to_vec();
    let mus: Vec<f64> = (0..20).map(|i| (i as f64 + 0.5) / 20.0).collect();
    let phis: Vec<f64> = (0..7).map(|i| FRAC_PI_2 * i as f64 / 6.0).collect();
    let mut points = Vec::new();
    for (ia, &aniso) in anisos.iter().enumerate() {
        for (ip, &phi) in phis.iter().enumerate() {
            for &r in &rs {
                for &mu in &mus {
                    points.push((ia, ip, r, aniso, mu, phi));
                }
            }
        }
    }
    // per point: the error of each shortcut
    let errors: Vec<(usize, usize, [f64; 4])> = points
        .par_iter()
        .map(|&(ia, ip, r, aniso, mu, phi)| {
            let exact = albedo(
                aniso_model.as_ref(),
                &[r, aniso, mu, phi],
                &settings,
                &cache,
            );
            let (at, ab) = anisotropic_alphas(r, aniso);
            let alphas = [
                r * r,
                (at * ab).sqrt(),
                (at * at * phi.cos().powi(2) + ab * ab * phi.sin().powi(2)).sqrt(),
                at,
            ];
            let mut e = [0.0; 4];
            for (k, &alpha) in alphas.iter().enumerate() {
                let r_eff = alpha.sqrt().min(1.0);
                let iso = albedo(iso_model.as_ref(), &[r_eff, mu], &settings, &cache);
                e[k] = (exact.value[0] - iso.value[0]).abs();
            }
            (ia, ip, e)
        })
        .collect();
    println!(
        "{} points: r, μ ∈ {{0.025, 0.075, …, 0.975}}, aniso ∈ {anisos:?}, φ ∈ {{0, π/12, …, π/2}}\n",
        points.len()
    );
    println!("| shortcut | max \\|ΔE\\| | mean \\|ΔE\\| |\n| --- | --- | --- |");
    for (k, name) in SHORTCUTS.iter().enumerate() {
        let max = errors.iter().map(|e| e.2[k]).fold(0.0, f64::max);
        let mean = errors.iter().map(|e| e.2[k]).sum::<f64>() / errors.len() as f64;
        println!("| {name} | {max:.2e} | {mean:.2e} |");
    }
    for (k, name) in SHORTCUTS.iter().enumerate() {
        println!("\nmax |ΔE| over (r, μ) of `{name}`, rows aniso, columns φ = 0, π/12, …, π/2:\n");
        println!(
            "| aniso |{}\n| --- |{}",
            phis.iter()
                .map(|p| format!(" {p:.3} |"))
                .collect::<String>(),
            " --- |".repeat(phis.len())
        );
        for (ia, aniso) in anisos.iter().enumerate() {
            let row: String = (0..phis.len())
                .map(|ip| {
                    let m = errors
                        .iter()
                        .filter(|e| e.0 == ia && e.1 == ip)
                        .map(|e| e.2[k])
                        .fold(0.0, f64::max);
                    format!(" {m:.1e} |")
                })
                .collect();
            println!("| {aniso} |{row}");
        }
    }
    Ok(())
}
