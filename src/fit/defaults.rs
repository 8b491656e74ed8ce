//! The default sweep of a table: what `furnace run` and `furnace fit --sweep` fit when told
//! nothing else. The paper's degrees and furnace's transform sets ([`SweepPlan::paper`]), the
//! unequal-degree rationals of [`default_rational_pairs`], the budgets of
//! [`super::job::default_budgets`], and only the transforms right for the data: the
//! boundary-layer coordinate only where the model has a grazing layer that collapses onto one
//! value at r = 0 (`Model::grazing_boundary_layer`).

use super::data::{FitData, InputTransform};
use super::job::SweepPlan;
use super::result::Objective;

/// Rationals with unequal total degrees (numerator, denominator) a default sweep adds.
/// - 1-D and 2-D: (2, 1) and (1, 2), 8 coefficients in 2-D (the budget of `best-8`), and
///   (3, 2), (2, 3), 15 coefficients.
/// - 3-D: (4, 3), 54 coefficients, between the n/n rationals' 39 and 69.
pub fn default_rational_pairs(d: usize) -> Vec<(u32, u32)> {
    if d <= 2 {
        vec![(2, 1), (1, 2), (3, 2), (2, 3)]
    } else {
        vec![(4, 3)]
    }
}

/// The default plan for `data`: [`SweepPlan::paper`] (capped or extended by `max_degree`, with
/// `extra` as one more transform set), [`default_rational_pairs`] within the degree cap, and
/// without the boundary-layer transform sets unless `grazing_layer` (the model's say-so; a
/// user's table may have one) — `extra` is kept whatever it is.
pub fn default_plan(
    data: &FitData,
    max_degree: Option<u32>,
    extra: Option<Vec<InputTransform>>,
    objective: Objective,
    grazing_layer: bool,
) -> SweepPlan {
    let mut plan = SweepPlan::paper(data, max_degree, extra.clone(), objective);
    if !grazing_layer {
        plan = plan.without_boundary_layer(extra.as_deref());
    }
    plan.rational_pairs = default_rational_pairs(data.dim())
        .into_iter()
        .filter(|&(n, m)| max_degree.is_none_or(|c| n <= c && m <= c))
        .collect();
    plan
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(names: &[&str]) -> FitData {
        let ax: Vec<f64> = (0..5).map(|i| i as f64 / 4.0).collect();
        let axes = vec![ax; names.len()];
        let n = 5usize.pow(names.len() as u32);
        FitData::from_grid(
            names.iter().map(|s| s.to_string()).collect(),
            &axes,
            vec![0.5; n],
        )
        .unwrap()
    }

    #[test]
    fn plans_are_model_aware_and_serialise() {
        let d2 = data(&["r", "mu"]);
        let p = default_plan(&d2, None, None, Objective::LeastSquares, true);
        assert_eq!(p.budgets, vec![8, 20, 40, 80, 160]);
        assert!(p.rational_pairs.contains(&(2, 1)));
        let layer = |p: &SweepPlan| {
            p.transform_sets
                .iter()
                .flatten()
                .any(|t| matches!(t, InputTransform::BoundaryLayer { .. }))
        };
        assert!(layer(&p));
        let glossy = default_plan(&d2, None, None, Objective::LeastSquares, false);
        assert!(!layer(&glossy));
        let d3 = data(&["f0", "r", "mu"]);
        let p3 = default_plan(&d3, Some(4), None, Objective::LeastSquares, true);
        assert_eq!(p3.budgets, vec![20, 40, 80, 160]);
        assert_eq!(p3.rational_pairs, vec![(4, 3)]);
        let json = serde_json::to_string(&p3).unwrap();
        let back: SweepPlan = serde_json::from_str(&json).unwrap();
        assert_eq!(back, p3);
        assert_ne!(json, serde_json::to_string(&p).unwrap());
    }
}
