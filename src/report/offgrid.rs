//! The off-grid comparison of a model's fits with its LUTs: the best fits (`best-<N>.json`) and
//! the 16-, 32- and 64-per-axis multilinear LUTs ([`LUT_CHECK_RESOLUTIONS`]) measured at the same
//! check points ([`crate::fit::check`]) against the model's exact values
//! (`fits/<model>/off-grid.json`, computed by [`crate::pipeline::offgrid`]), and every sweep fit's
//! errors at those points (the `off_grid` of each row of `fits/<model>/sweep.json`), grouped by
//! form family for the report's error-against-stored-values figure.

use crate::error::{Error, Result};
use crate::output;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Nodes per axis of the LUTs measured beside the fits.
pub const LUT_CHECK_RESOLUTIONS: [usize; 3] = [16, 32, 64];

/// The LUT resolution a chosen fit must beat (`furnace run` flags it otherwise).
pub const LUT_TO_BEAT: usize = 32;

/// Errors below this are within the check values' own quadrature tolerance (the tables' and the
/// check set's 1e-7 per value), so a fit and a LUT that both reach it are not ranked against each
/// other on it.
pub const INDISTINGUISHABLE: f64 = 1e-7;

/// Name of the file in each model's fit folder.
pub use super::inputs::OFF_GRID_FILE;

/// Errors at the check points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointErrors {
    pub max_abs_error: f64,
    pub mae: f64,
    pub max_abs_error_at: Vec<f64>,
}

/// A LUT's errors at the check points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LutErrors {
    pub per_axis: usize,
    /// Stored values (nodes).
    pub values: usize,
    pub errors: PointErrors,
}

/// A best fit's errors at the check points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BudgetErrors {
    pub budget: usize,
    pub file: String,
    pub form: String,
    pub n_coefficients: usize,
    pub max_abs_error: f64,
    pub mae: f64,
}

/// `fits/<model>/off-grid.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OffGridSummary {
    pub what: String,
    pub tool: String,
    pub tool_version: String,
    pub model: String,
    pub check_set: String,
    pub best: Vec<BudgetErrors>,
    pub luts: Vec<LutErrors>,
}

impl OffGridSummary {
    /// Writes `<dir>/off-grid.json`.
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join(OFF_GRID_FILE);
        let json =
            serde_json::to_string_pretty(self).map_err(|e| Error::file(&path, e.to_string()))?;
        output::write(&path, format!("{json}\n").as_bytes())?;
        Ok(path)
    }

    /// Whether best fit `b` loses to the [`LUT_TO_BEAT`]-per-axis LUT on max error or MAE at the
    /// check points, by more than [`INDISTINGUISHABLE`].
    pub fn loses(&self, b: &BudgetErrors) -> bool {
        self.luts
            .iter()
            .find(|l| l.per_axis == LUT_TO_BEAT)
            .is_some_and(|lut| {
                b.max_abs_error > lut.errors.max_abs_error.max(INDISTINGUISHABLE)
                    || b.mae > lut.errors.mae.max(INDISTINGUISHABLE)
            })
    }

    /// One sentence per best fit that loses to the [`LUT_TO_BEAT`]-per-axis LUT on max error or
    /// MAE at the check points, by more than [`INDISTINGUISHABLE`].
    pub fn losses(&self) -> Vec<String> {
        let Some(lut) = self.luts.iter().find(|l| l.per_axis == LUT_TO_BEAT) else {
            return Vec::new();
        };
        self.best
            .iter()
            .filter_map(|b| {
                let max = b.max_abs_error > lut.errors.max_abs_error.max(INDISTINGUISHABLE);
                let mae = b.mae > lut.errors.mae.max(INDISTINGUISHABLE);
                (max || mae).then(|| {
                    format!(
                        "{} best-{} ({} coefficients) loses to the {n}-per-axis LUT ({} values) on {}: max {:.1e} vs {:.1e}, MAE {:.1e} vs {:.1e}",
                        self.model,
                        b.budget,
                        b.n_coefficients,
                        lut.values,
                        match (max, mae) {
                            (true, true) => "max error and MAE",
                            (true, false) => "max error",
                            _ => "MAE",
                        },
                        b.max_abs_error,
                        lut.errors.max_abs_error,
                        b.mae,
                        lut.errors.mae,
                        n = LUT_TO_BEAT,
                    )
                })
            })
            .collect()
    }
}

/// Reads `<dir>/off-grid.json`; `None` when the file is missing or not an off-grid summary.
pub fn read_summary(dir: &Path) -> Option<OffGridSummary> {
    let text = std::fs::read_to_string(dir.join(OFF_GRID_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

/// One sweep fit at the check points.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    /// The form family (`polynomial`, `rational`, … as the sweep names it).
    pub family: String,
    pub n_coefficients: usize,
    pub max_abs_error: f64,
    pub mae: f64,
}

/// The usable (pole-free) fits of `<dir>/sweep.json` with their errors at the check points, in
/// the file's order; empty when the file is missing or records no off-grid errors.
pub fn read_sweep_points(dir: &Path) -> Vec<SweepPoint> {
    let Ok(text) = std::fs::read_to_string(dir.join("sweep.json")) else {
        return Vec::new();
    };
    let Ok(value) = serde_json::from_str::<serde_json::Value>(&text) else {
        return Vec::new();
    };
    let Some(rows) = value.get("rows").and_then(|r| r.as_array()) else {
        return Vec::new();
    };
    rows.iter()
        .filter(|r| r.get("usable").and_then(|u| u.as_bool()) != Some(false))
        .filter_map(|r| {
            let og = r.get("off_grid")?;
            let point = SweepPoint {
                family: r.get("form")?.as_str()?.to_string(),
                n_coefficients: r.get("n_coefficients")?.as_u64()? as usize,
                max_abs_error: og.get("max_abs_error")?.as_f64()?,
                mae: og.get("mae")?.as_f64()?,
            };
            (point.max_abs_error.is_finite() && point.mae.is_finite()).then_some(point)
        })
        .collect()
}

/// The form families of `points`, in order of first appearance.
pub fn families(points: &[SweepPoint]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for p in points {
        if !out.contains(&p.family) {
            out.push(p.family.clone());
        }
    }
    out
}

/// The fit of `family` with the lowest max error among those with at most `budget`
/// coefficients (ties: the lower MAE).
pub fn lowest_max_within<'p>(
    points: &'p [SweepPoint],
    family: &str,
    budget: usize,
) -> Option<&'p SweepPoint> {
    points
        .iter()
        .filter(|p| p.family == family && p.n_coefficients <= budget)
        .min_by(|a, b| {
            a.max_abs_error
                .total_cmp(&b.max_abs_error)
                .then(a.mae.total_cmp(&b.mae))
        })
}

/// The lower envelope of `family`: for each coefficient count, the lowest `pick` among the fits
/// with at most that many coefficients, at the counts where it improves.
pub fn envelope(
    points: &[SweepPoint],
    family: &str,
    pick: &dyn Fn(&SweepPoint) -> f64,
) -> Vec<(f64, f64)> {
    let mut counts: Vec<usize> = points
        .iter()
        .filter(|p| p.family == family)
        .map(|p| p.n_coefficients)
        .collect();
    counts.sort_unstable();
    counts.dedup();
    let mut out: Vec<(f64, f64)> = Vec::new();
    for n in counts {
        let best = points
            .iter()
            .filter(|p| p.family == family && p.n_coefficients == n)
            .map(pick)
            .fold(f64::INFINITY, f64::min);
        if out.last().is_none_or(|&(_, y)| best < y) {
            out.push((n as f64, best));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_points_group_by_family_and_the_envelope_only_falls() {
        let p = |family: &str, n: usize, max: f64| SweepPoint {
            family: family.into(),
            n_coefficients: n,
            max_abs_error: max,
            mae: max / 10.0,
        };
        let points = vec![
            p("polynomial", 3, 1e-1),
            p("rational", 5, 5e-2),
            p("polynomial", 6, 2e-2),
            p("polynomial", 6, 3e-2),
            p("polynomial", 10, 4e-2),
            p("polynomial", 15, 1e-3),
        ];
        assert_eq!(families(&points), ["polynomial", "rational"]);
        assert_eq!(
            envelope(&points, "polynomial", &|s| s.max_abs_error),
            [(3.0, 1e-1), (6.0, 2e-2), (15.0, 1e-3)]
        );
        assert_eq!(
            lowest_max_within(&points, "polynomial", 10).map(|s| s.n_coefficients),
            Some(6)
        );
        assert!(lowest_max_within(&points, "rational", 4).is_none());
    }

    #[test]
    fn a_sweep_file_gives_its_usable_rows_with_off_grid_errors() {
        let dir = std::env::temp_dir().join(format!("furnace-offgrid-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(read_sweep_points(&dir).is_empty());
        std::fs::write(
            dir.join("sweep.json"),
            r#"{"rows": [
                {"form": "rational", "n_coefficients": 7, "usable": true, "off_grid": {"mae": 1e-3, "max_abs_error": 1e-2}},
                {"form": "rational", "n_coefficients": 9, "usable": false, "off_grid": {"mae": 1e-4, "max_abs_error": 1e-3}},
                {"form": "polynomial", "n_coefficients": 3, "usable": true}
            ], "fits": []}"#,
        )
        .unwrap();
        let points = read_sweep_points(&dir);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(points.len(), 1);
        assert_eq!(points[0].family, "rational");
        assert_eq!(points[0].n_coefficients, 7);
    }
}
