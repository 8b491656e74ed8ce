//! The white furnace test of energy-compensated BSDFs, by quadrature of the compensated BSDF.
//!
//! Under a uniform white environment the radiance leaving a surface towards ωo is its
//! directional albedo E(ωo) = ∫ f(ωo, ωi) |n·ωi| dωi (Sforza & Pellacini 2022, eq. 2). An
//! energy-preserving white BSDF has E = 1 everywhere; the test reports max |1 − E| over a grid.
//!
//! # What is integrated, and how independently
//! A material's compensated BSDF ([`CompensatedBsdf`]) is a set of uncompensated lobes and the
//! rule combining their integrals with an albedo source. Each lobe is integrated over ωi with
//! this module's own rule, globally adaptive Gauss–Kronrod ([`super::quad`]): GGX microfacet
//! lobes over microfacet normals with every kink an interval end ([`super::microfacet`]),
//! diffuse lobes over (μi, φ) with kinks at μi = μo and φ = π/2, any other BSDF over (μi, φ)
//! directly. None of the engine's machinery ([`crate::quadrature`]) is used, so agreement with the
//! tables is evidence, not an identity — except for a [`Lobe::Model`] (the anisotropic
//! conductor), integrated by its model's own integrand at fixed orders, not the tables' refined
//! estimate.
//!
//! The compensations of the paper are scalings that depend on ωo only, so the integral of a
//! compensated lobe is the compensation factor times the integral of the uncompensated lobe; the
//! lobe integrals are therefore computed once per point ([`LobeIntegrals`]) and combined with each
//! albedo source (none, exact table, LUT, fit) — the factor is never folded into the source.

use super::microfacet::microfacet_albedo;
use super::quad::{integrate, Tolerance};
use super::{Albedo, CompensatedBsdf, Compensation, Lobe};
use crate::math::safe_sqrt;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Outer (x) tolerance of the lobe integrals: a hundredth of the table tolerance (1e-7), so that the
/// exact-table furnace measures the table, not this quadrature.
pub const OUTER_TOLERANCE: Tolerance = Tolerance {
    abs: 1e-9,
    rel: 0.0,
    max_intervals: 400,
};
/// Inner (φ) tolerance, divided by the weight of its line: a tenth of the outer one.
pub const INNER_TOLERANCE: Tolerance = Tolerance {
    abs: 1e-10,
    rel: 0.0,
    max_intervals: 200,
};

/// The integrals of a material's uncompensated lobes at one point.
#[derive(Clone, Debug, PartialEq)]
pub struct LobeIntegrals {
    /// ∫ f_k |μi| dωi of each lobe, in the order of [`CompensatedBsdf::lobes`].
    pub values: Vec<f64>,
    /// Sum of the adaptive integrator's error estimates.
    pub error: f64,
    /// False if an integral ran out of intervals before meeting its tolerance.
    pub converged: bool,
}

/// ∫ ρ μi dωi of a diffuse BRDF `f(μi, μo, s)` over (μi, φ), with kinks at μi = μo and φ = π/2
/// (where s = sinθi sinθo cos φ changes sign; EON paper eqs. 4, 11).
fn diffuse_albedo(mu_o: f64, f: &dyn Fn(f64, f64, f64) -> f64) -> (f64, f64, bool) {
    let sin_o = safe_sqrt(1.0 - mu_o * mu_o);
    let mut breaks = vec![0.0, 1.0];
    if mu_o > 0.0 && mu_o < 1.0 {
        breaks.insert(1, mu_o);
    }
    let r = integrate(
        |mu_i: f64| {
            let sin_i = safe_sqrt(1.0 - mu_i * mu_i);
            let inner = integrate(
                |phi: f64| f(mu_i, mu_o, sin_i * sin_o * phi.cos()) * mu_i,
                &[0.0, FRAC_PI_2, PI],
                &INNER_TOLERANCE,
            );
            2.0 * inner.value // the BRDF is even in φ: [−π, π] folds onto [0, π]
        },
        &breaks,
        &OUTER_TOLERANCE,
    );
    (r.value, r.error, r.converged)
}

/// ∫ f(ωi) |μi| dωi over μi ∈ [0, 1] (and [−1, 0] when `transmits`), with kinks at
/// `mu_breaks`, and φ ∈ [0, 2π]: (value, error estimate, converged). The error adds the outer
/// estimate and the largest inner one.
fn directional_albedo(
    f: &dyn Fn([f64; 3]) -> f64,
    transmits: bool,
    mu_breaks: &[f64],
) -> (f64, f64, bool) {
    let lo = if transmits { -1.0 } else { 0.0 };
    let mut breaks = vec![lo, 0.0, 1.0];
    breaks.extend(mu_breaks.iter().copied().filter(|m| *m > lo && *m < 1.0));
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    let mut inner_error = 0.0f64;
    let mut inner_converged = true;
    let r = integrate(
        |mu_i: f64| {
            let sin_i = safe_sqrt(1.0 - mu_i * mu_i);
            let inner = integrate(
                |phi: f64| {
                    let (s, c) = phi.sin_cos();
                    f([sin_i * c, sin_i * s, mu_i]) * mu_i.abs()
                },
                &[0.0, PI, 2.0 * PI],
                &INNER_TOLERANCE,
            );
            inner_error = inner_error.max(inner.error);
            inner_converged &= inner.converged;
            inner.value
        },
        &breaks,
        &OUTER_TOLERANCE,
    );
    (
        r.value,
        r.error + inner_error,
        r.converged && inner_converged,
    )
}

/// E of `model` at `x` by its integrand at each of `orders`: (value at the last, the largest
/// difference from the others, true); an unknown model gives NaN, unconverged.
fn model_albedo(model: crate::bsdf::ModelId, x: &[f64], orders: &[usize]) -> (f64, f64, bool) {
    let Ok(m) = crate::bsdf::get(model) else {
        return (f64::NAN, f64::INFINITY, false);
    };
    let rules: Vec<crate::quadrature::Rules> = orders
        .iter()
        .map(|&n| crate::quadrature::Rules::new(n))
        .collect();
    let refs: Vec<&crate::quadrature::Rules> = rules.iter().collect();
    let values: Vec<f64> = m.integrate_orders(x, &refs).iter().map(|v| v[0]).collect();
    let Some(&last) = values.last() else {
        return (f64::NAN, f64::INFINITY, false);
    };
    let error = values.iter().map(|v| (v - last).abs()).fold(0.0, f64::max);
    (last, error, true)
}

/// The lobe integrals of `material` at `x` (its primary albedo model's axes).
pub fn lobe_integrals(material: &dyn CompensatedBsdf, x: &[f64]) -> LobeIntegrals {
    let mut out = LobeIntegrals {
        values: Vec::new(),
        error: 0.0,
        converged: true,
    };
    for lobe in material.lobes(x) {
        let (v, e, c) = match lobe {
            Lobe::Exact(v) => (v, 0.0, true),
            Lobe::Microfacet {
                alpha,
                mu_o,
                smith,
                lobe,
            } => microfacet_albedo(alpha, mu_o, smith, lobe, &OUTER_TOLERANCE, &INNER_TOLERANCE),
            Lobe::Diffuse { mu_o, brdf } => diffuse_albedo(mu_o, &*brdf),
            Lobe::Model { model, x, orders } => model_albedo(model, &x, &orders),
            Lobe::Directional {
                f,
                transmits,
                mu_breaks,
                ..
            } => directional_albedo(&*f, transmits, &mu_breaks),
        };
        out.values.push(v);
        out.error += e;
        out.converged &= c;
    }
    out
}

/// Lobe integrals at many points, in parallel (results in input order).
pub fn lobe_integrals_at(
    material: &dyn CompensatedBsdf,
    points: &[Vec<f64>],
) -> Vec<LobeIntegrals> {
    points
        .par_iter()
        .map(|x| lobe_integrals(material, x))
        .collect()
}

/// ⟨E⟩ = 2∫ E(r, μ) μ dμ of a 2-D (r, μ) source (Kulla & Conty 2017; paper eq. 5).
pub fn average_albedo(albedo: &dyn Albedo, r: f64) -> f64 {
    average_albedo_at(albedo, &[r])
}

/// ⟨E⟩ = 2∫ E(lead, μ) μ dμ of a source whose last axis is μ, the others fixed at `lead`
/// ((r) of a 2-D source, (F0, r) of a 3-D one; Kulla & Conty 2017), by adaptive Gauss–Kronrod.
pub fn average_albedo_at(albedo: &dyn Albedo, lead: &[f64]) -> f64 {
    let mut x = lead.to_vec();
    x.push(0.0);
    let last = lead.len();
    let res = integrate(
        |mu: f64| {
            let mut x = x.clone();
            x[last] = mu;
            2.0 * albedo.albedo(&x) * mu
        },
        &[0.0, 1.0],
        &OUTER_TOLERANCE,
    );
    res.value
}

/// Summary of a furnace run over a set of points.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FurnaceStats {
    /// max |1 − E| over the points.
    pub max_deviation: f64,
    /// Where it occurs (albedo model axes).
    pub at: Vec<f64>,
    /// E there.
    pub value_at_max: f64,
    /// Mean |1 − E|.
    pub mean_deviation: f64,
    /// min and max E.
    pub min_albedo: f64,
    pub max_albedo: f64,
    pub points: usize,
}

/// Furnace values of `compensation` at `points` (with their precomputed lobe integrals).
pub fn furnace_values(
    material: &dyn CompensatedBsdf,
    points: &[Vec<f64>],
    lobes: &[LobeIntegrals],
    compensation: &Compensation,
) -> Vec<f64> {
    let prepared = material.prepare(compensation, points);
    points
        .iter()
        .zip(lobes)
        .map(|(x, l)| material.albedo(&l.values, x, compensation, &prepared))
        .collect()
}

/// Summarises furnace values (max |1 − E| and where).
pub fn furnace_stats(points: &[Vec<f64>], values: &[f64]) -> FurnaceStats {
    let mut s = FurnaceStats {
        max_deviation: 0.0,
        at: points.first().cloned().unwrap_or_default(),
        value_at_max: values.first().copied().unwrap_or(1.0),
        mean_deviation: 0.0,
        min_albedo: f64::INFINITY,
        max_albedo: f64::NEG_INFINITY,
        points: points.len(),
    };
    let mut sum = crate::math::CompensatedSum::default();
    for (x, &e) in points.iter().zip(values) {
        let d = (1.0 - e).abs();
        sum.add(d);
        if d > s.max_deviation {
            s.max_deviation = d;
            s.at = x.clone();
            s.value_at_max = e;
        }
        s.min_albedo = s.min_albedo.min(e);
        s.max_albedo = s.max_albedo.max(e);
    }
    s.mean_deviation = if points.is_empty() {
        0.0
    } else {
        sum.value() / points.len() as f64
    };
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::builtin::{Kind, Material};
    use crate::math::SmithForm;
    use std::path::PathBuf;

    fn reference(name: &str) -> Vec<Vec<f64>> {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("data/reference")
            .join(name);
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (vendored under data/reference)", path.display()));
        text.lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split(',')
                    .map(|v| v.trim().parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    }

    /// The lobe integrals against the independently computed reference albedos.
    #[test]
    fn lobe_integrals_match_reference_albedos() {
        let mut worst = 0.0f64;
        for row in reference("ref2d.csv").iter().step_by(4) {
            for (smith, want) in [
                (SmithForm::HeightCorrelated, row[2]),
                (SmithForm::Separable, row[3]),
            ] {
                let m = Material::new(Kind::Conductor, smith);
                let l = lobe_integrals(&m, &[row[0], row[1]]);
                assert!(l.converged, "{row:?}");
                worst = worst.max((l.values[0] - want).abs());
                assert!(
                    (l.values[0] - want).abs() < 1e-8,
                    "conductor {smith:?} at {row:?}: {} vs {want}",
                    l.values[0]
                );
            }
        }
        for row in reference("ref3d.csv").iter().step_by(4) {
            let (f0, r, mu) = (row[0], row[2], row[3]);
            for (inverse, want) in [(false, row[5] + row[6]), (true, row[7] + row[8])] {
                let m = Material::new(Kind::Dielectric, SmithForm::HeightCorrelated);
                let m = if inverse { m.leaving() } else { m };
                let l = lobe_integrals(&m, &[f0, r, mu]);
                worst = worst.max((l.values[0] - want).abs());
                assert!(
                    (l.values[0] - want).abs() < 1e-8,
                    "dielectric inverse={inverse} at {row:?}: {} vs {want}",
                    l.values[0]
                );
            }
            let m = Material::new(Kind::Glossy, SmithForm::HeightCorrelated);
            let l = lobe_integrals(&m, &[f0, r, mu]);
            assert!(
                (l.values[0] - row[5]).abs() < 1e-8,
                "glossy specular at {row:?}: {} vs {}",
                l.values[0],
                row[5]
            );
            assert!((l.values[1] - 1.0).abs() < 1e-12);
        }
        eprintln!("max |lobe integral − reference| = {worst:.2e}");
    }

    #[test]
    fn thin_dielectric_integrates_like_the_conductor() {
        for (r, mu) in [(0.3, 0.7), (0.8, 0.05), (1.0, 0.0), (0.05, 0.5)] {
            let c = lobe_integrals(
                &Material::new(Kind::Conductor, SmithForm::HeightCorrelated),
                &[r, mu],
            );
            let t = lobe_integrals(
                &Material::new(Kind::ThinDielectric, SmithForm::HeightCorrelated),
                &[r, mu],
            );
            assert!(
                (c.values[0] - t.values[0]).abs() < 1e-9,
                "r={r} mu={mu}: {} vs {}",
                c.values[0],
                t.values[0]
            );
        }
    }

    #[test]
    fn rough_diffuse_matches_the_closed_form_fon_albedo() {
        let m = Material::new(Kind::RoughDiffuse, SmithForm::HeightCorrelated);
        for (r, mu) in [(0.0, 0.5), (0.5, 0.0), (1.0, 0.3), (0.7, 1.0), (0.2, 0.9)] {
            let l = lobe_integrals(&m, &[r, mu]);
            let want = crate::bsdf::diffuse::fon_albedo_analytic(r, mu);
            assert!(
                (l.values[0] - want).abs() < 1e-9,
                "r={r} mu={mu}: {} vs {want}",
                l.values[0]
            );
        }
    }

    /// A BSDF given only as f(ωo, ωi) is integrated over directions by the general rule: the
    /// FON BRDF that way against the closed form, and a Lambertian transmitter on the sphere.
    #[test]
    fn directional_lobes_integrate_any_bsdf() {
        use crate::bsdf::diffuse::{fon_albedo_analytic, fon_brdf};
        use crate::material::{Lobe, Prepared};
        struct Fon;
        impl CompensatedBsdf for Fon {
            fn id(&self) -> String {
                "fon".into()
            }
            fn label(&self) -> String {
                "FON".into()
            }
            fn albedos(&self) -> Vec<crate::bsdf::ModelId> {
                vec![crate::bsdf::lookup("oren-nayar-fon").unwrap()]
            }
            fn lobes(&self, x: &[f64]) -> Vec<Lobe> {
                let (r, mu_o) = (x[0], x[1]);
                let wo = [safe_sqrt(1.0 - mu_o * mu_o), 0.0, mu_o];
                vec![
                    Lobe::Directional {
                        mu_o,
                        f: std::sync::Arc::new(move |wi: [f64; 3]| {
                            let s = wi[0] * wo[0] + wi[1] * wo[1];
                            fon_brdf(r, wi[2], mu_o, s)
                        }),
                        transmits: false,
                        mu_breaks: vec![mu_o],
                    },
                    Lobe::Directional {
                        mu_o,
                        f: std::sync::Arc::new(|_| 0.5 / PI),
                        transmits: true,
                        mu_breaks: vec![],
                    },
                ]
            }
            fn albedo(&self, l: &[f64], _: &[f64], _: &Compensation, _: &Prepared) -> f64 {
                l[0]
            }
        }
        for (r, mu) in [(0.5, 0.3), (1.0, 0.9), (0.2, 0.0)] {
            let l = lobe_integrals(&Fon, &[r, mu]);
            let want = fon_albedo_analytic(r, mu);
            assert!(l.converged, "{l:?}");
            assert!(
                (l.values[0] - want).abs() < 1e-9,
                "r={r} mu={mu}: {} vs {want}",
                l.values[0]
            );
            assert!((l.values[1] - 1.0).abs() < 1e-12, "{}", l.values[1]);
        }
    }

    #[test]
    fn grazing_and_tiny_roughness_are_finite_and_bounded() {
        let hc = SmithForm::HeightCorrelated;
        for m in [
            Material::new(Kind::Conductor, hc),
            Material::new(Kind::Dielectric, hc),
            Material::new(Kind::Dielectric, hc).leaving(),
        ] {
            for (r, mu) in [
                (1e-3, 0.0),
                (1e-3, 1e-6),
                (0.01, 0.001),
                (1.0, 0.0),
                (1.0, 1.0),
            ] {
                let x: Vec<f64> = if m.kind == Kind::Dielectric {
                    vec![0.04, r, mu]
                } else {
                    vec![r, mu]
                };
                let l = lobe_integrals(&m, &x);
                assert!(
                    l.values[0].is_finite() && l.values[0] > 0.0 && l.values[0] <= 1.0 + 1e-9,
                    "{m:?} r={r} mu={mu}: {l:?}"
                );
            }
        }
    }
}
