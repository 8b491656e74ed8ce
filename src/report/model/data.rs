//! A model's table, LUTs, fits and paper fit, loaded once per report run.

use super::{Dependency, FitRow, ReportOptions, Reporter};
use crate::bsdf::{self, Model, ModelId};
use crate::error::Result;
use crate::fit::FitResult;
use crate::report::albedo::{FitAlbedo, TableAlbedo};
use crate::report::inputs::{
    self, choose_fit, load_fits, measure, paper_link, short_form, FitFiles, Measured,
};
use crate::report::offgrid::{self, OffGridSummary, SweepPoint};
use crate::table::Table;
use std::rc::Rc;
use std::sync::Arc;

/// A model's table, LUT, fits and paper fit, loaded once per report run.
pub(super) struct ModelData {
    pub(super) name: String,
    pub(super) model: Arc<dyn Model>,
    pub(super) axes: Vec<String>,
    pub(super) table: Table,
    pub(super) lut: TableAlbedo,
    /// The LUTs of [`ReportOptions::furnace_luts`] other than `lut`, by nodes per axis.
    pub(super) luts: Vec<(usize, TableAlbedo)>,
    pub(super) exact: TableAlbedo,
    pub(super) fits: FitFiles,
    pub(super) fit_albedos: Vec<Option<FitAlbedo>>,
    /// (N, index into `fits`) of every usable `best-<N>.json`, by N.
    pub(super) budgets: Vec<(usize, usize)>,
    pub(super) off_grid: Option<OffGridSummary>,
    pub(super) sweep_points: Vec<SweepPoint>,
    pub(super) measured: Vec<Measured>,
    pub(super) chosen: Option<usize>,
    pub(super) chosen_albedo: Option<FitAlbedo>,
    pub(super) paper: Option<(FitResult, FitAlbedo, Measured)>,
}

impl ModelData {
    pub(super) fn dims(&self) -> usize {
        self.axes.len()
    }

    pub(super) fn lut_per_axis(&self) -> usize {
        self.lut
            .resolution()
            .split('x')
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or(0)
    }

    /// The LUT of `n` nodes per axis, if loaded.
    pub(super) fn lut_of(&self, n: usize) -> Option<&TableAlbedo> {
        if n == self.lut_per_axis() {
            return Some(&self.lut);
        }
        self.luts.iter().find(|(m, _)| *m == n).map(|(_, l)| l)
    }

    /// The albedo of `best-<n>.json`, if there is one and it can be evaluated.
    pub(super) fn budget_albedo(&self, n: usize) -> Option<&FitAlbedo> {
        let &(_, k) = self.budgets.iter().find(|(b, _)| *b == n)?;
        self.fit_albedos[k].as_ref()
    }

    pub(super) fn fit_row(&self, k: usize) -> FitRow {
        fit_row(
            &self.fits.fits[k].source,
            &self.fits.fits[k].fit,
            &self.measured[k],
        )
    }
}

pub(super) fn fit_row(source: &str, fit: &FitResult, measured: &Measured) -> FitRow {
    FitRow {
        source: source.into(),
        form: short_form(&fit.form),
        n_coefficients: fit.n_coefficients,
        usable: fit.is_usable(),
        measured: measured.clone(),
        reported_mae: fit.metrics.mae,
        reported_max: fit.metrics.max_abs_error,
        reported_max_rel: fit.metrics.max_rel_error,
    }
}

/// A LUT of `m` nodes per axis: every k-th node of `table` when (n − 1) is a multiple of (m − 1)
/// (the tabulated values, no resampling), else `None`.
pub(super) fn subsample_lut(table: &Table, m: usize) -> Option<Table> {
    let axes = &table.spec.axes;
    if m < 2 || axes.iter().any(|a| !(a.n - 1).is_multiple_of(m - 1)) {
        return None;
    }
    let mut spec = table.spec.clone();
    for a in &mut spec.axes {
        a.n = m;
    }
    // every output, then every k-th node of each table axis
    let strides: Vec<isize> = std::iter::once(1)
        .chain(axes.iter().map(|a| ((a.n - 1) / (m - 1)) as isize))
        .collect();
    let values: Vec<f64> = table
        .arrays()
        .slice_each_axis(|ax| ndarray::Slice::new(0, None, strides[ax.axis.index()]))
        .iter()
        .copied()
        .collect();
    let cells = spec.cells();
    Some(Table {
        spec,
        values,
        errors: vec![0.0; cells],
        summary: table.summary.clone(),
    })
}

impl Reporter<'_> {
    pub(super) fn data(&self, id: ModelId) -> Result<Rc<ModelData>> {
        self.used.borrow_mut().insert(Dependency::new(id));
        let k = id.key();
        if let Some(d) = self.loaded.borrow().get(&k) {
            return Ok(d.clone());
        }
        let model = bsdf::get(id)?;
        let axes: Vec<String> = model.axes().iter().map(|a| a.name.clone()).collect();
        (self.progress)(&format!("{k}: table"));
        let table = self
            .tables
            .table(model.as_ref(), &self.options.resolution(axes.len()))
            .map_err(|e| e.for_option(ReportOptions::resolution_option(axes.len())))?;
        let lut_n = self.options.lut(axes.len());
        let lut_table = match subsample_lut(&table, lut_n) {
            Some(t) => t,
            None => {
                (self.progress)(&format!("{k}: LUT {lut_n}"));
                self.tables
                    .table(model.as_ref(), &vec![lut_n; axes.len()])
                    .map_err(|e| e.for_option(ReportOptions::lut_option(axes.len())))?
            }
        };
        let mut luts = Vec::new();
        for &n in &self.options.furnace_luts {
            if n != lut_n && !luts.iter().any(|(m, _)| *m == n) {
                (self.progress)(&format!("{k}: LUT {n}"));
                let t = self.tables.table(model.as_ref(), &vec![n; axes.len()])?;
                luts.push((n, TableAlbedo::new(&t)));
            }
        }
        luts.sort_by_key(|(n, _)| *n);
        let fit_data = crate::fit::source::from_table(&table, "E", None)?.data;
        let mut fits = load_fits(&self.options.fits_dir.join(model.id().key()), &fit_data)?;
        let fit_albedos: Vec<Option<FitAlbedo>> = fits
            .fits
            .iter()
            .map(|f| {
                // a radiance-form table's fits are measured as fitted, as the paper's are
                FitAlbedo::of_model(&f.fit, &axes, id)
                    .map_err(|e| format!("cannot evaluate `{}` on {k}: {e}", f.source))
            })
            .collect::<Vec<_>>()
            .into_iter()
            .map(|r| r.map_err(|e| fits.notes.push(e)).ok())
            .collect();
        let measured: Vec<Measured> = fit_albedos
            .iter()
            .map(|a| match a {
                Some(a) => measure(a, &table),
                None => Measured {
                    mae: f64::INFINITY,
                    max_abs: f64::INFINITY,
                    max_abs_at: vec![],
                    max_rel: f64::INFINITY,
                    points: 0,
                },
            })
            .collect();
        let chosen = choose_fit(&fits, axes.len(), &measured);
        let chosen_albedo = chosen.and_then(|k| fit_albedos[k].clone());
        let mut budgets: Vec<(usize, usize)> = fits
            .fits
            .iter()
            .enumerate()
            .filter_map(|(j, f)| {
                inputs::best_budget(&f.source)
                    .filter(|_| f.fit.is_usable() && fit_albedos[j].is_some())
                    .map(|b| (b, j))
            })
            .collect();
        budgets.sort_unstable();
        let fits_dir = self.options.fits_dir.join(model.id().key());
        let off_grid = offgrid::read_summary(&fits_dir);
        let sweep_points = offgrid::read_sweep_points(&fits_dir);
        let paper = match (&self.options.paper_dir, paper_link(id)) {
            (Some(dir), Some(link)) if link.model == id => {
                let fit = inputs::load_paper_fit(dir, &link)?;
                let albedo = FitAlbedo::unclamped(&fit, &axes)?;
                let m = measure(&albedo, &table);
                Some((fit, albedo, m))
            }
            _ => None,
        };
        let data = Rc::new(ModelData {
            name: k.clone(),
            exact: TableAlbedo::new(&table),
            lut: TableAlbedo::new(&lut_table),
            luts,
            model,
            axes,
            table,
            fits,
            fit_albedos,
            budgets,
            off_grid,
            sweep_points,
            measured,
            chosen,
            chosen_albedo,
            paper,
        });
        self.loaded.borrow_mut().insert(k, data.clone());
        Ok(data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_subsampled_lut_is_every_kth_node_of_every_output() {
        use crate::quadrature::QuadratureSettings;
        use crate::table::{tabulate, TableSpec};
        let model = crate::bsdf::find("oren-nayar-fon").unwrap();
        let spec = TableSpec::new(model.as_ref(), &[9, 5], QuadratureSettings::default()).unwrap();
        let table = tabulate(model.as_ref(), &spec, &|_| {}).unwrap();
        let lut = subsample_lut(&table, 3).unwrap();
        assert_eq!(lut.shape(), [3, 3]);
        let (full, sub) = (table.array(0), lut.array(0));
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(sub[[i, j]], full[[4 * i, 2 * j]]);
            }
        }
        assert_eq!(lut.values.len(), 3 * 3 * table.spec.outputs.len());
        assert!(
            subsample_lut(&table, 4).is_none(),
            "8 is not a multiple of 3"
        );
    }
}
