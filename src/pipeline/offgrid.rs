//! Off-grid errors of a model's chosen fits next to its LUTs: every `best-<N>.json` and the
//! 16-, 32- and 64-per-axis multilinear LUTs ([`LUT_CHECK_RESOLUTIONS`]) measured at the same
//! check points ([`crate::fit::check`]) against the model's exact values. Written to
//! `fits/<model>/off-grid.json`; `furnace run`'s summary flags every best fit that loses to the
//! 32-per-axis LUT.

use super::sweeps::BestSummary;
use crate::bsdf::Model;
use crate::error::Result;
use crate::fit::check::CheckSet;
use crate::math::CompensatedSum;
use crate::progress::Observer;
use crate::quadrature::QuadratureSettings;
use crate::report::albedo::{Albedo, TableAlbedo};
use crate::table::{get_or_tabulate, TableSpec};
use std::path::Path;

pub use crate::report::offgrid::{
    BudgetErrors, LutErrors, OffGridSummary, PointErrors, INDISTINGUISHABLE, LUT_CHECK_RESOLUTIONS,
    LUT_TO_BEAT, OFF_GRID_FILE,
};

/// Errors of `albedo` at the points of `check`.
pub fn errors_of(albedo: &dyn Albedo, check: &CheckSet) -> PointErrors {
    let d = check.names.len();
    let mut sum = CompensatedSum::default();
    let mut worst = (-1.0, 0);
    for (i, (x, &y)) in check.coords.chunks(d).zip(&check.values).enumerate() {
        let e = (albedo.albedo(x) - y).abs();
        sum.add(e);
        if e > worst.0 {
            worst = (e, i);
        }
    }
    PointErrors {
        max_abs_error: worst.0.max(0.0),
        mae: sum.value() / check.len().max(1) as f64,
        max_abs_error_at: check.coords[worst.1 * d..(worst.1 + 1) * d].to_vec(),
    }
}

/// The multilinear LUTs of `model` at [`LUT_CHECK_RESOLUTIONS`] over the check set's box
/// (tables from the cache under `data_dir`, tabulated when missing), measured on `check`.
pub fn lut_errors(
    model: &dyn Model,
    check: &CheckSet,
    data_dir: &Path,
    progress: &dyn Observer,
) -> Result<Vec<LutErrors>> {
    LUT_CHECK_RESOLUTIONS
        .iter()
        .map(|&n| {
            let d = check.names.len();
            let spec = TableSpec::with_ranges(
                model,
                &vec![n; d],
                &check.domain,
                QuadratureSettings::default(),
            )?;
            let t = get_or_tabulate(model, &spec, data_dir, false, progress)?;
            Ok(LutErrors {
                per_axis: n,
                values: t.table.cells(),
                errors: errors_of(&TableAlbedo::new(&t.table), check),
            })
        })
        .collect()
}

/// The summary of one model; `best` as the sweep step reports it.
pub fn summary(
    model: &str,
    check: &CheckSet,
    best: &[(usize, Option<BestSummary>)],
    luts: Vec<LutErrors>,
) -> OffGridSummary {
    OffGridSummary {
        what: "errors of each best-<N>.json and of multilinear LUTs (N nodes per axis, f64) at the same off-grid check points, against the model's exact values; max abs error and MAE".into(),
        tool: "furnace".into(),
        tool_version: crate::VERSION.into(),
        model: model.into(),
        check_set: check.description(),
        best: best
            .iter()
            .filter_map(|(b, s)| {
                s.as_ref().filter(|s| s.off_grid).map(|s| BudgetErrors {
                    budget: *b,
                    file: format!("best-{b}.json"),
                    form: s.label.clone(),
                    n_coefficients: s.n_coefficients,
                    max_abs_error: s.max_abs_error,
                    mae: s.mae,
                })
            })
            .collect(),
        luts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lut_is_exact_on_its_nodes_and_losses_are_named() {
        let model = crate::bsdf::find("oren-nayar-fon").unwrap();
        let spec = TableSpec::new(model.as_ref(), &[3, 3], QuadratureSettings::default()).unwrap();
        let mut check = CheckSet::compute(model.as_ref(), &spec).unwrap();
        // keep three points: LUT errors are measured point by point
        check.coords.truncate(6);
        check.values.truncate(3);
        let table = crate::table::tabulate(model.as_ref(), &spec, &|_| {}).unwrap();
        let lut = TableAlbedo::new(&table);
        let e = errors_of(&lut, &check);
        assert!(e.max_abs_error > 0.0 && e.mae <= e.max_abs_error);
        let s = OffGridSummary {
            what: String::new(),
            tool: String::new(),
            tool_version: String::new(),
            model: "m".into(),
            check_set: String::new(),
            best: vec![BudgetErrors {
                budget: 8,
                file: "best-8.json".into(),
                form: String::new(),
                n_coefficients: 8,
                max_abs_error: 2.0 * e.max_abs_error,
                mae: 0.0,
            }],
            luts: vec![LutErrors {
                per_axis: LUT_TO_BEAT,
                values: 1024,
                errors: e,
            }],
        };
        let l = s.losses();
        assert_eq!(l.len(), 1);
        assert!(
            l[0].contains("best-8") && l[0].contains("on max error:"),
            "{}",
            l[0]
        );
        // both at the quadrature's own level: no loss to report
        let mut tiny = s.clone();
        tiny.luts[0].errors.max_abs_error = 1e-9;
        tiny.luts[0].errors.mae = 5e-12;
        tiny.best[0].max_abs_error = 2e-9;
        tiny.best[0].mae = 1e-11;
        assert!(tiny.losses().is_empty(), "{:?}", tiny.losses());
        tiny.best[0].max_abs_error = 2e-7;
        assert_eq!(tiny.losses().len(), 1);
    }
}
