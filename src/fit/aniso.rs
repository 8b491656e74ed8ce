//! Budget fits of a 4-D albedo E(r, aniso, μ, φ) (`ggx-conductor-aniso`): under each budget of
//! [`BUDGETS`], of the rational [`RATIONAL_DEGREES`] and the largest 4-D exponent form of a
//! sweep under it ([`aniso_exponent_forms`]), the fit with the lowest max error at its points.
//!
//! The fits are minimax on a grid uniform in the fit variables r², aniso, √L(μ; α_o) and sin²φ
//! ([`fit_grid`], [`layer_points`]), whose values come from the model by quadrature: the nodes
//! of a table uniform in μ leave the grazing layer μ ≲ α_o unsampled at small r
//! (docs/anisotropy.md, "Fits on points that resolve the layer").

use super::data::transformed_box;
use super::defaults::{aniso_exponent_forms, physics_transforms};
use super::{fit_form, FitData, FitOptions, FitResult, Form, InputTransform, Objective};
use crate::bsdf::{albedo, Model};
use crate::error::Result;
use crate::quadrature::RuleCache;
use crate::table::Table;
use rayon::prelude::*;

/// The coefficient budgets of the 4-D fits.
pub const BUDGETS: [usize; 2] = [80, 160];
/// Degrees of the rational among the candidates (also what `furnace run --scene` fits).
pub const RATIONAL_DEGREES: (u32, u32) = (3, 3);
/// The fit variables ([`physics_transforms`]), in words.
pub const FIT_VARIABLES: &str = "r², aniso, √L(μ; α_o), α_o/α_t";

/// Points per variable of the grid the fits are fitted on ([`layer_points`]): for a table of
/// n_r × n_a × n_μ × n_φ nodes, ⌈5n_r/2⌉ × ⌈3n_a/2⌉ × 3n_μ × ⌈3n_φ/2⌉ (16 × 8 × 16 × 8 →
/// 40 × 12 × 48 × 12, 276 480 points).
pub fn fit_grid(resolution: &[usize]) -> [usize; 4] {
    let n = |k: usize, num: usize, den: usize| (resolution[k] * num).div_ceil(den).max(2);
    [n(0, 5, 2), n(1, 3, 2), n(2, 3, 1), n(3, 3, 2)]
}

/// A grid of (r, aniso, μ, φ) over `domain` uniform in r², aniso, sin²φ and the layer variable
/// t of μ (`mu_layer`, the transform of variable 2: μ solved from t for each r, aniso, φ), `grid`
/// points per variable, row-major (φ fastest).
pub fn layer_points(
    grid: [usize; 4],
    domain: &[(f64, f64)],
    mu_layer: &InputTransform,
    t_range: (f64, f64),
) -> Vec<f64> {
    let step = |k: usize, i: usize| i as f64 / (grid[k] - 1) as f64;
    let lerp = |(lo, hi): (f64, f64), s: f64| lo + (hi - lo) * s;
    let (r2, s2) = (
        (domain[0].0.powi(2), domain[0].1.powi(2)),
        (domain[3].0.sin().powi(2), domain[3].1.sin().powi(2)),
    );
    let mut out = Vec::with_capacity(4 * grid.iter().product::<usize>());
    for i0 in 0..grid[0] {
        let r = lerp(r2, step(0, i0)).sqrt().clamp(domain[0].0, domain[0].1);
        for i1 in 0..grid[1] {
            let aniso = lerp(domain[1], step(1, i1));
            for i2 in 0..grid[2] {
                let t = lerp(t_range, step(2, i2));
                for i3 in 0..grid[3] {
                    let phi = lerp(s2, step(3, i3))
                        .sqrt()
                        .asin()
                        .clamp(domain[3].0, domain[3].1);
                    let mut x = [r, aniso, 0.0, phi];
                    x[2] = mu_layer.inverse(2, t, &x).clamp(domain[2].0, domain[2].1);
                    out.extend(x);
                }
            }
        }
    }
    out
}

/// One budget's fit.
#[derive(Clone, Debug)]
pub struct BudgetFit {
    pub budget: usize,
    /// Its metrics are at the points it was fitted on.
    pub fit: FitResult,
}

/// The fits and the points they were fitted on.
#[derive(Clone, Debug)]
pub struct BudgetFits {
    /// [`fit_grid`] of the table's resolution.
    pub grid: [usize; 4],
    pub points: usize,
    /// One per budget that has a certified fit, in [`BUDGETS`] order.
    pub fits: Vec<BudgetFit>,
}

impl BudgetFits {
    /// How the points were chosen, in words (a fit file's `fitted_on.selection`).
    pub fn selection(&self) -> String {
        let g = self.grid;
        format!(
            "{} × {} × {} × {} grid uniform in r², aniso, √L(μ; α_o) and sin²φ, exact values by quadrature",
            g[0], g[1], g[2], g[3]
        )
    }
}

/// The budget fits of `model` on the [`layer_points`] of [`fit_grid`] of `table`'s resolution
/// over its box; fits that are not certified pole-free are left out. None when the table's
/// variables have no layer transform ([`physics_transforms`]).
pub fn budget_fits(model: &dyn Model, table: &Table) -> Result<Option<BudgetFits>> {
    let names: Vec<String> = table.spec.axes.iter().map(|a| a.name.clone()).collect();
    // the box of the table's nodes, as a fit of the table has it (`FitData::from_grid`)
    let domain: Vec<(f64, f64)> = table
        .spec
        .axes
        .iter()
        .map(|a| {
            a.nodes()
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                })
        })
        .collect();
    let probe = FitData::new(
        names.clone(),
        vec![0.5; names.len()],
        vec![0.5],
        domain.clone(),
    )?;
    let Some(transforms) = physics_transforms(&probe, true) else {
        return Ok(None);
    };
    let t_box = transformed_box(&names, &domain, &transforms)?;
    let n: Vec<usize> = table.spec.axes.iter().map(|a| a.n).collect();
    let grid = fit_grid(&n);
    let coords = layer_points(grid, &domain, &transforms[2], t_box[2]);
    let cache = RuleCache::new(&table.spec.quadrature);
    let values: Vec<f64> = coords
        .par_chunks(4)
        .map(|x| albedo(model, x, &table.spec.quadrature, &cache).value[0])
        .collect();
    let data = FitData::new(names, coords, values, domain)?;
    let exponent_forms = aniso_exponent_forms(&transforms);
    let mut candidates = vec![Form::Rational {
        numerator_degree: RATIONAL_DEGREES.0,
        denominator_degree: RATIONAL_DEGREES.1,
    }];
    for budget in BUDGETS {
        if let Some(form) = exponent_forms
            .iter()
            .filter(|f| f.n_coefficients(4) <= budget)
            .max_by_key(|f| f.n_coefficients(4))
        {
            if !candidates.contains(form) {
                candidates.push(form.clone());
            }
        }
    }
    let mut fitted = Vec::new();
    for form in &candidates {
        let fit = fit_form(
            &data,
            &transforms,
            form,
            Objective::Minimax,
            &FitOptions::default(),
        )?;
        if fit.is_usable() {
            fitted.push(fit);
        }
    }
    let fits = BUDGETS
        .iter()
        .filter_map(|&budget| {
            fitted
                .iter()
                .filter(|f| f.n_coefficients <= budget)
                .min_by(|a, b| a.metrics.max_abs_error.total_cmp(&b.metrics.max_abs_error))
                .map(|fit| BudgetFit {
                    budget,
                    fit: fit.clone(),
                })
        })
        .collect();
    Ok(Some(BudgetFits {
        grid,
        points: data.len(),
        fits,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_grid_is_uniform_in_the_fit_variables() {
        assert_eq!(fit_grid(&[16, 8, 16, 8]), [40, 12, 48, 12]);
        let names: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let domain = vec![
            (0.0, 1.0),
            (0.0, 0.95),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ];
        let data = FitData::new(names.clone(), vec![0.5; 4], vec![0.5], domain.clone()).unwrap();
        let transforms = physics_transforms(&data, true).unwrap();
        let t_box = transformed_box(&names, &domain, &transforms).unwrap();
        let grid = [4, 3, 5, 3];
        let points = layer_points(grid, &domain, &transforms[2], t_box[2]);
        assert_eq!(points.len(), 4 * 4 * 3 * 5 * 3);
        for (k, x) in points.chunks(4).enumerate() {
            let (i0, i1, i2, i3) = (k / 45, (k / 15) % 3, (k / 3) % 5, k % 3);
            assert!(x
                .iter()
                .zip(&domain)
                .all(|(v, (lo, hi))| v >= lo && v <= hi));
            assert!((x[0] * x[0] - i0 as f64 / 3.0).abs() < 1e-12, "{x:?}");
            assert!((x[1] - 0.95 * i1 as f64 / 2.0).abs() < 1e-12, "{x:?}");
            assert!(
                (x[3].sin().powi(2) - i3 as f64 / 2.0).abs() < 1e-12,
                "{x:?}"
            );
            // μ solved from the layer variable: t back from μ on the uniform grid (at r = 0
            // the layer has no width and every μ maps to one t)
            let (lo, hi) = t_box[2];
            let t = lo + (hi - lo) * i2 as f64 / 4.0;
            if i0 > 0 {
                // (t = √L: next to t = 0 a rounding of μ near 1e-19 moves t by 1e-9)
                let back = transforms[2].apply(2, x);
                assert!((back - t).abs() < 1e-8, "{x:?}: {t} {back}");
            }
        }
    }
}
