//! Where a compensation gets its albedo E from: a table (multilinear interpolation, exact at the
//! nodes), a small LUT (the same thing at a coarse resolution) or a fit ([`FitResult`]).
//!
//! Every source is evaluated at a point in its model's axis order (`r, mu` or `f0, r, mu`).

use crate::bsdf::ModelId;
use crate::error::{Error, Result};
use crate::fit::{Approximant, FitResult};
pub use crate::material::Albedo;
use crate::table::Table;

/// Most axes of a source: the 4-D anisotropic conductor's (r, aniso, mu, phi).
pub const MAX_AXES: usize = 4;

/// Multilinear interpolation of output `E` of a table: bilinear in 2-D, trilinear in 3-D,
/// quadrilinear in 4-D, exact
/// at the nodes. With a coarse table this is the classic LUT (e.g. 32² bilinear).
#[derive(Clone, Debug)]
pub struct TableAlbedo {
    /// (lo, hi, n) per axis.
    axes: Vec<(f64, f64, usize)>,
    values: Vec<f64>,
}

impl TableAlbedo {
    pub fn new(table: &Table) -> TableAlbedo {
        TableAlbedo {
            axes: table.spec.axes.iter().map(|a| (a.lo, a.hi, a.n)).collect(),
            values: table.output(0).to_vec(),
        }
    }

    /// Resolution name, `32x32`.
    pub fn resolution(&self) -> String {
        self.axes
            .iter()
            .map(|a| a.2.to_string())
            .collect::<Vec<_>>()
            .join("x")
    }

    /// Value stored at node `index` (one node index per axis).
    pub fn node_value(&self, index: &[usize]) -> f64 {
        let mut flat = 0;
        for (i, a) in index.iter().zip(&self.axes) {
            flat = flat * a.2 + i;
        }
        self.values[flat]
    }
}

/// Cell index and weight of `x` on an axis of `n` nodes over [lo, hi] (clamped).
#[inline]
fn locate(x: f64, lo: f64, hi: f64, n: usize) -> (usize, f64) {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0) * (n - 1) as f64;
    let i = (t.floor() as usize).min(n - 2);
    (i, t - i as f64)
}

impl Albedo for TableAlbedo {
    fn albedo(&self, x: &[f64]) -> f64 {
        let d = self.axes.len();
        let mut cell = [(0usize, 0.0f64); MAX_AXES];
        for k in 0..d {
            let (lo, hi, n) = self.axes[k];
            cell[k] = locate(x[k], lo, hi, n);
        }
        let mut sum = 0.0;
        for corner in 0..(1usize << d) {
            let mut w = 1.0;
            let mut flat = 0;
            for k in 0..d {
                let bit = (corner >> (d - 1 - k)) & 1;
                let (i, t) = cell[k];
                w *= if bit == 1 { t } else { 1.0 - t };
                flat = flat * self.axes[k].2 + i + bit;
            }
            if w != 0.0 {
                sum += w * self.values[flat];
            }
        }
        sum
    }

    fn dim(&self) -> usize {
        self.axes.len()
    }
}

/// A fitted approximant as an albedo source. The fit's variables are matched to the model's axes
/// by name (case-insensitive, so the paper's `F0` is `f0`).
#[derive(Clone, Debug)]
pub struct FitAlbedo {
    approximant: Approximant,
    /// `order[k]` = the model axis feeding the fit's variable k.
    order: Vec<usize>,
    /// Whether E is clamped to [0, 1], as every emitted albedo is
    /// ([`crate::emit::generate::clamped`]).
    clamp_output: bool,
}

impl FitAlbedo {
    /// The fit as furnace's emitted code evaluates it: inputs clamped to the fit's domain, E to
    /// [0, 1]. A renderer's Kulla–Conty lobes divide by 1 − E_avg, which a fit's overshoot
    /// above 1 at low roughness (a few 1e-4) would make negative.
    pub fn new(fit: &FitResult, axes: &[String]) -> Result<FitAlbedo> {
        FitAlbedo::with_output_clamp(fit, axes, true)
    }

    /// A published fit as written, or a fit of a radiance-form table (whose values leave
    /// [0, 1], so that it is never emitted): inputs clamped to its domain, E as it comes.
    pub fn unclamped(fit: &FitResult, axes: &[String]) -> Result<FitAlbedo> {
        FitAlbedo::with_output_clamp(fit, axes, false)
    }

    /// furnace's fit of model `id`'s table: [`Self::new`], but [`Self::unclamped`] for a
    /// radiance-form table.
    pub fn of_model(fit: &FitResult, axes: &[String], id: ModelId) -> Result<FitAlbedo> {
        FitAlbedo::with_output_clamp(fit, axes, !id.is_radiance())
    }

    fn with_output_clamp(
        fit: &FitResult,
        axes: &[String],
        clamp_output: bool,
    ) -> Result<FitAlbedo> {
        let vars = &fit.approximant.variables;
        if vars.len() != axes.len() {
            return Err(Error::InvalidInput(format!(
                "fit has {} variables ({}) but the model has {} axes ({})",
                vars.len(),
                vars.join(","),
                axes.len(),
                axes.join(",")
            )));
        }
        let order = vars
            .iter()
            .map(|v| {
                axes.iter()
                    .position(|a| a.eq_ignore_ascii_case(v))
                    .ok_or_else(|| {
                        Error::InvalidInput(format!(
                            "fit variable '{v}' is not an axis of the model ({})",
                            axes.join(",")
                        ))
                    })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(FitAlbedo {
            approximant: fit.approximant.clone(),
            order,
            clamp_output,
        })
    }
}

impl Albedo for FitAlbedo {
    fn albedo(&self, x: &[f64]) -> f64 {
        let mut y = [0.0; MAX_AXES];
        for (k, &a) in self.order.iter().enumerate() {
            let (lo, hi) = self.approximant.domain[k];
            y[k] = x[a].clamp(lo, hi);
        }
        let e = self.approximant.eval(&y[..self.order.len()]);
        if self.clamp_output {
            e.clamp(0.0, 1.0)
        } else {
            e
        }
    }

    fn dim(&self) -> usize {
        self.order.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::QuadratureSettings;
    use crate::table::{ErrorSummary, GridAxis, TableSpec};

    /// A radiance-form table's fit is read as fitted (its values leave [0, 1]); the energy-form
    /// model's as its emitted code clamps it.
    #[test]
    fn radiance_form_fits_are_not_clamped() {
        use crate::fit::{fit_polynomial, FitData, InputTransform, Objective, PolynomialOptions};
        let r: Vec<f64> = (0..9).map(|i| i as f64 / 8.0).collect();
        let data = FitData::from_grid(
            vec!["r".into()],
            std::slice::from_ref(&r),
            r.iter().map(|x| 2.0 * x).collect(),
        )
        .unwrap();
        let fit = fit_polynomial(
            &data,
            &[InputTransform::Identity],
            1,
            Objective::LeastSquares,
            &PolynomialOptions::default(),
        )
        .unwrap();
        let axes = vec!["r".to_string()];
        let energy: ModelId = "ggx-dielectric-inv-separable".parse().unwrap();
        let radiance: ModelId = "ggx-dielectric-inv-separable-radiance".parse().unwrap();
        let at = |id| FitAlbedo::of_model(&fit, &axes, id).unwrap().albedo(&[0.8]);
        assert!((at(radiance) - 1.6).abs() < 1e-9, "{}", at(radiance));
        assert_eq!(at(energy), 1.0);
    }

    fn table(axes: Vec<GridAxis>, f: impl Fn(&[f64]) -> f64) -> Table {
        let spec = TableSpec {
            model: "test".into(),
            model_parameters: serde_json::Value::Null,
            axes,
            outputs: vec!["E".into()],
            quadrature: QuadratureSettings::default(),
        };
        let mut x = vec![0.0; spec.axes.len()];
        let values = (0..spec.cells())
            .map(|c| {
                spec.point(c, &mut x);
                f(&x)
            })
            .collect();
        let summary = ErrorSummary {
            max_error_estimate: 0.0,
            max_error_at: vec![],
            refined_cells: 0,
            unconverged_cells: 0,
            unconverged: vec![],
            max_order_used: 0,
        };
        Table {
            errors: vec![0.0; spec.cells()],
            spec,
            values,
            summary,
        }
    }

    #[test]
    fn multilinear_interpolation_is_exact_on_multilinear_functions() {
        let f = |x: &[f64]| 0.3 + 0.5 * x[0] - 0.2 * x[1] + 0.7 * x[0] * x[1] * x[2] + x[2];
        let t = table(
            vec![
                GridAxis::new("f0", 0.0125, 0.25, 5),
                GridAxis::new("r", 0.0, 1.0, 4),
                GridAxis::new("mu", 0.0, 1.0, 7),
            ],
            f,
        );
        let a = TableAlbedo::new(&t);
        for p in [
            [0.0125, 0.0, 0.0],
            [0.1, 0.37, 0.91],
            [0.25, 1.0, 1.0],
            [0.2, 0.5, 0.123],
        ] {
            assert!((a.albedo(&p) - f(&p)).abs() < 1e-14, "{p:?}");
        }
        // clamped outside
        assert!((a.albedo(&[0.3, 1.2, -0.1]) - f(&[0.25, 1.0, 0.0])).abs() < 1e-14);
        assert_eq!(a.resolution(), "5x4x7");
    }

    #[test]
    fn bilinear_error_is_second_order() {
        let f = |x: &[f64]| (2.0 * x[0]).sin() * (3.0 * x[1]).cos();
        let err = |n: usize| {
            let t = table(
                vec![
                    GridAxis::new("r", 0.0, 1.0, n),
                    GridAxis::new("mu", 0.0, 1.0, n),
                ],
                f,
            );
            let a = TableAlbedo::new(&t);
            (0..50)
                .flat_map(|i| (0..50).map(move |j| [i as f64 / 49.3, j as f64 / 49.7]))
                .map(|p| (a.albedo(&p) - f(&p)).abs())
                .fold(0.0, f64::max)
        };
        let (e16, e32) = (err(16), err(32));
        assert!(e32 < e16 / 3.0 && e32 > e16 / 5.5, "{e16} {e32}");
    }
}
