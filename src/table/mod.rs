//! Tables of directional albedo: grids, parallel tabulation with per-cell error estimates,
//! the on-disk cache (EXR + exact f64 + JSON sidecar) and interpolation-free point evaluation.
//!
//! # Grid
//! Every axis has `n ≥ 2` nodes *including both endpoints*: x_i = lo + (hi − lo)·i/(n − 1).
//! At μ = 0 the value is the limit μ → 0⁺ (the integrand is continuous there for α > 0, so the
//! quadrature evaluates it directly). At r = 0 the value is the smooth interface's exact albedo
//! (E = 1 for a conductor; E_R = F(μ), E_T = 1 − F(μ) for a dielectric), which also defines the
//! corner (r, μ) = (0, 0), where E is discontinuous.
//!
//! # Layout
//! Values are stored row-major with the last axis fastest: for axes (f0, r, mu) the cell
//! (k, i, j) is at `(k·n_r + i)·n_mu + j`. The EXR file is a single image `n_mu` wide and
//! `n_f0·n_r` tall (row `k·n_r + i`, the same flattening as the paper's CSV tables), one f32
//! channel per output (`E`, `E_R`, `E_T`) plus `err`, the per-cell error estimate. The exact f64
//! values are kept beside it in `<name>.f64` (little-endian, outputs one after the other) and the
//! sidecar `<name>.json` records the model, axes, quadrature settings, error summary and the
//! content hash that keys the cache.

pub mod cache;
pub mod io;
pub mod points;
pub mod shard;

pub use cache::{get_or_tabulate, Tabulated};

use crate::bsdf::{albedo, albedo_column, Model, ModelId, Transmission, MAX_OUTPUTS};
use crate::error::{human_bytes, Error, Result};
use crate::quadrature::{QuadratureSettings, RuleCache};
use ndarray::{ArrayViewD, IxDyn};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One cell's outcome while tabulating: outputs, error estimate, final order, converged.
pub(crate) type CellResult = ([f64; MAX_OUTPUTS], f64, usize, bool);

/// Bumped whenever a change to the engine can change a table value: it is hashed into every
/// cache key, so stale tables are recomputed rather than trusted.
pub const ENGINE_VERSION: u32 = 6;

/// Refuse tables whose values and error estimates would need more memory than this.
pub const MAX_TABLE_BYTES: u128 = 8 << 30;

/// One grid axis: `n` nodes from `lo` to `hi`, endpoints included.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct GridAxis {
    pub name: String,
    pub lo: f64,
    pub hi: f64,
    pub n: usize,
    /// `"endpoints"`: x_i = lo + (hi − lo)·i/(n − 1); `"explicit"`: the nodes are listed in
    /// [`GridAxis::nodes`] (a renderer's own node placement, see [`crate::export`]).
    pub placement: String,
    /// The nodes of an `"explicit"` axis, increasing, `lo` first and `hi` last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<Vec<f64>>,
}

impl GridAxis {
    pub fn new(name: &str, lo: f64, hi: f64, n: usize) -> GridAxis {
        GridAxis {
            name: name.into(),
            lo,
            hi,
            n,
            placement: "endpoints".into(),
            nodes: None,
        }
    }

    /// An axis with the given nodes (at least two, finite, strictly increasing).
    pub fn explicit(name: &str, nodes: Vec<f64>) -> Result<GridAxis> {
        if nodes.len() < 2
            || nodes.iter().any(|v| !v.is_finite())
            || nodes.windows(2).any(|w| w[1] <= w[0])
        {
            return Err(Error::InvalidInput(format!(
                "axis {name}: explicit nodes must be at least two finite, strictly increasing numbers"
            )));
        }
        Ok(GridAxis {
            name: name.into(),
            lo: nodes[0],
            hi: nodes[nodes.len() - 1],
            n: nodes.len(),
            placement: "explicit".into(),
            nodes: Some(nodes),
        })
    }

    /// Coordinate of node `i`.
    #[inline]
    pub fn node(&self, i: usize) -> f64 {
        if let Some(nodes) = &self.nodes {
            return nodes[i];
        }
        if self.n <= 1 {
            return self.lo;
        }
        if i + 1 == self.n {
            return self.hi; // exact endpoint, whatever the rounding of the affine map
        }
        self.lo + (self.hi - self.lo) * i as f64 / (self.n - 1) as f64
    }

    pub fn nodes(&self) -> Vec<f64> {
        (0..self.n).map(|i| self.node(i)).collect()
    }
}

/// What to tabulate: a model on a grid with quadrature settings.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct TableSpec {
    pub model: String,
    pub model_parameters: serde_json::Value,
    pub axes: Vec<GridAxis>,
    pub outputs: Vec<String>,
    pub quadrature: QuadratureSettings,
}

impl TableSpec {
    /// The model's default domain at the given resolution (one count per axis).
    pub fn new(
        model: &dyn Model,
        resolution: &[usize],
        quadrature: QuadratureSettings,
    ) -> Result<TableSpec> {
        let axes = model.axes();
        if resolution.len() != axes.len() {
            return Err(Error::InvalidInput(format!(
                "model {} has {} axes ({}), but --resolution gives {} counts; use e.g. --resolution {}",
                model.id().name(),
                axes.len(),
                crate::bsdf::axis_names(model),
                resolution.len(),
                vec!["64"; axes.len()].join("x")
            )));
        }
        let grid = axes
            .iter()
            .zip(resolution)
            .map(|(a, &n)| GridAxis::new(&a.name, a.default_range.0, a.default_range.1, n))
            .collect();
        let spec = TableSpec {
            model: model.id().name(),
            model_parameters: model.parameters(),
            axes: grid,
            outputs: model.outputs().iter().map(|s| s.to_string()).collect(),
            quadrature,
        };
        spec.validate()?;
        Ok(spec)
    }

    /// A narrower (or wider, within the model's valid ranges) domain than the default: one
    /// `(lo, hi)` per axis. Used by scene manifests, whose materials need only part of the domain.
    pub fn with_ranges(
        model: &dyn Model,
        resolution: &[usize],
        ranges: &[(f64, f64)],
        quadrature: QuadratureSettings,
    ) -> Result<TableSpec> {
        let mut spec = TableSpec::new(model, resolution, quadrature)?;
        if ranges.len() != spec.axes.len() {
            return Err(Error::InvalidInput(format!(
                "{} ranges given for the {} axes of {}",
                ranges.len(),
                spec.axes.len(),
                model.id().name()
            )));
        }
        for ((g, &(lo, hi)), a) in spec.axes.iter_mut().zip(ranges).zip(model.axes()) {
            if lo.is_nan()
                || hi.is_nan()
                || lo >= hi
                || lo < a.valid_range.0
                || hi > a.valid_range.1
            {
                return Err(Error::InvalidInput(format!(
                    "range [{lo}, {hi}] of axis {} is empty, inverted or outside the model's domain [{}, {}]",
                    a.name, a.valid_range.0, a.valid_range.1
                )));
            }
            g.lo = lo;
            g.hi = hi;
        }
        spec.validate()?;
        Ok(spec)
    }

    /// A table on the given axes (one per model axis, in order, named as the model's), e.g. with
    /// [explicit](GridAxis::explicit) nodes; every node must lie in the model's valid range.
    pub fn with_axes(
        model: &dyn Model,
        axes: Vec<GridAxis>,
        quadrature: QuadratureSettings,
    ) -> Result<TableSpec> {
        let specs = model.axes();
        if axes.len() != specs.len() || axes.iter().zip(&specs).any(|(g, a)| g.name != a.name) {
            return Err(Error::InvalidInput(format!(
                "a table of {} needs the axes {} in that order",
                model.id().name(),
                crate::bsdf::axis_names(model)
            )));
        }
        for (g, a) in axes.iter().zip(&specs) {
            if g.lo < a.valid_range.0 || g.hi > a.valid_range.1 {
                return Err(Error::InvalidInput(format!(
                    "axis {} spans [{}, {}], outside the model's domain [{}, {}]",
                    a.name, g.lo, g.hi, a.valid_range.0, a.valid_range.1
                )));
            }
        }
        let spec = TableSpec {
            model: model.id().name(),
            model_parameters: model.parameters(),
            axes,
            outputs: model.outputs().iter().map(|s| s.to_string()).collect(),
            quadrature,
        };
        spec.validate()?;
        Ok(spec)
    }

    /// Refuses empty, single-node and absurdly large grids before anything is allocated.
    pub fn validate(&self) -> Result<()> {
        for a in &self.axes {
            if a.n < 2 {
                return Err(Error::InvalidInput(format!(
                    "resolution {} on axis {} is too small: a grid needs at least 2 nodes per axis (both endpoints)",
                    a.n, a.name
                )));
            }
            if !(a.lo.is_finite() && a.hi.is_finite() && a.lo < a.hi) {
                return Err(Error::InvalidInput(format!(
                    "axis {} has an empty or invalid range [{}, {}]",
                    a.name, a.lo, a.hi
                )));
            }
            if let Some(nodes) = &a.nodes {
                let consistent = nodes.len() == a.n
                    && nodes.first() == Some(&a.lo)
                    && nodes.last() == Some(&a.hi)
                    && nodes.windows(2).all(|w| w[1] > w[0]);
                if !consistent || a.placement != "explicit" {
                    return Err(Error::InvalidInput(format!(
                        "axis {}: its explicit nodes do not match its range and count",
                        a.name
                    )));
                }
            }
        }
        self.quadrature.validate().map_err(Error::InvalidInput)?;
        let cells = self
            .axes
            .iter()
            .try_fold(1u128, |acc, a| acc.checked_mul(a.n as u128))
            .unwrap_or(u128::MAX);
        let channels = self.outputs.len() + 1;
        let bytes = cells.saturating_mul(channels as u128 * 8);
        if bytes > MAX_TABLE_BYTES {
            return Err(Error::TooLarge {
                cells,
                channels,
                bytes,
                human: human_bytes(bytes),
                limit_human: human_bytes(MAX_TABLE_BYTES),
                option: "--resolution".into(),
            });
        }
        Ok(())
    }

    pub fn cells(&self) -> usize {
        self.axes.iter().map(|a| a.n).product()
    }

    /// `1024x1024`, `128x128x128`.
    pub fn resolution_name(&self) -> String {
        self.axes
            .iter()
            .map(|a| a.n.to_string())
            .collect::<Vec<_>>()
            .join("x")
    }

    /// The coordinates of cell `index` (row-major, last axis fastest).
    pub fn point(&self, mut index: usize, out: &mut [f64]) {
        for (d, a) in self.axes.iter().enumerate().rev() {
            out[d] = a.node(index % a.n);
            index /= a.n;
        }
    }

    /// The transmission convention the model parameters record (dielectrics), if any.
    pub fn transmission(&self) -> Option<Transmission> {
        serde_json::from_value(self.model_parameters.get("transmission")?.clone()).ok()
    }

    /// The registered model this spec tabulates: its name, in the transmission convention its
    /// parameters record.
    pub fn model_id(&self) -> Result<ModelId> {
        let id = crate::bsdf::lookup(&self.model)?;
        Ok(match (id.transmission, self.transmission()) {
            (Some(_), Some(t)) => id.with_transmission(t),
            _ => id,
        })
    }

    /// SHA-256 of the canonical JSON of everything that determines the values, plus the
    /// engine version and the model's [`Model::integrator_revision`] (when not 0): the cache
    /// key.
    pub fn content_hash(&self) -> String {
        let revision = self
            .model_id()
            .and_then(crate::bsdf::get)
            .map_or(0, |m| m.integrator_revision());
        let canonical = if revision == 0 {
            serde_json::json!({ "engine": ENGINE_VERSION, "spec": self })
        } else {
            serde_json::json!({ "engine": ENGINE_VERSION, "integrator": revision, "spec": self })
        };
        crate::digest::sha256_hex(canonical.to_string().as_bytes())
    }
}

/// Error summary of a table, recorded in its sidecar.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorSummary {
    /// Largest per-cell error estimate.
    pub max_error_estimate: f64,
    /// Where it occurs.
    pub max_error_at: Vec<f64>,
    /// Cells that needed more than the base order.
    pub refined_cells: usize,
    /// Cells whose estimate still exceeds the tolerance at `max_order` (listed, never hidden).
    pub unconverged_cells: usize,
    /// Up to [`MAX_LISTED`] of them: coordinates and estimate.
    pub unconverged: Vec<(Vec<f64>, f64)>,
    /// Highest order any cell used.
    pub max_order_used: usize,
}

/// How many unconverged cells a sidecar lists by coordinate.
pub const MAX_LISTED: usize = 100;

/// A computed table.
#[derive(Clone, Debug)]
pub struct Table {
    pub spec: TableSpec,
    /// `values[o * cells + cell]` for output `o`.
    pub values: Vec<f64>,
    /// Per-cell error estimate (max over outputs).
    pub errors: Vec<f64>,
    pub summary: ErrorSummary,
}

impl Table {
    pub fn cells(&self) -> usize {
        self.spec.cells()
    }

    /// The values of output `o` (0 is `E`).
    pub fn output(&self, o: usize) -> &[f64] {
        let n = self.cells();
        &self.values[o * n..(o + 1) * n]
    }

    /// Node counts per axis, in table order (the shape of [`Table::array`]).
    pub fn shape(&self) -> Vec<usize> {
        self.spec.axes.iter().map(|a| a.n).collect()
    }

    /// Output `o` (0 is `E`) as an array with one axis per table axis, in table order:
    /// `array(o)[[i, j, k]]` is the value at node i of the first axis, j of the second, k of the
    /// third.
    ///
    /// ```
    /// use furnace::quadrature::QuadratureSettings;
    /// use furnace::table::{tabulate, TableSpec};
    ///
    /// let model = furnace::bsdf::find("oren-nayar-fon")?;
    /// let spec = TableSpec::new(model.as_ref(), &[5, 9], QuadratureSettings::default())?;
    /// let table = tabulate(model.as_ref(), &spec, &|_| {})?;
    /// let e = table.array(0);
    /// assert_eq!(e.shape(), &[5, 9]);
    /// // E → 1 as the roughness r → 0 (a Lambertian surface), at every μ
    /// assert!((0..9).all(|j| (e[[0, j]] - 1.0).abs() < 1e-9));
    /// # Ok::<(), furnace::Error>(())
    /// ```
    pub fn array(&self, o: usize) -> ArrayViewD<'_, f64> {
        ArrayViewD::from_shape(IxDyn(&self.shape()), self.output(o))
            .expect("a table holds one value per node of each output")
    }

    /// Every output: an array of shape `[outputs, n_1, …, n_d]`.
    pub fn arrays(&self) -> ArrayViewD<'_, f64> {
        let mut shape = vec![self.spec.outputs.len()];
        shape.extend(self.shape());
        ArrayViewD::from_shape(IxDyn(&shape), &self.values)
            .expect("a table holds one value per node of each output")
    }

    /// The per-cell error estimates, shaped as [`Table::array`].
    pub fn errors_array(&self) -> ArrayViewD<'_, f64> {
        ArrayViewD::from_shape(IxDyn(&self.shape()), &self.errors)
            .expect("a table holds one error estimate per node")
    }

    /// Index of a named output.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.spec.outputs.iter().position(|o| o == name)
    }
}

/// Progress callback: called with the number of cells finished since the last call.
pub type Progress<'a> = &'a (dyn Fn(u64) + Sync);

/// Tabulates `spec` in parallel. Every cell is integrated at the base order and half of it;
/// cells whose difference exceeds the tolerance are recomputed at higher orders (×1.25 each) up to
/// `max_order`, and any still above it are counted and listed in the summary.
pub fn tabulate(model: &dyn Model, spec: &TableSpec, progress: Progress) -> Result<Table> {
    check_request(model, spec)?;
    let layout = Units::of(model, spec);
    let unit_results = compute_units(model, spec, &layout, 0..layout.units, progress);
    let mut ordered: Vec<Option<CellResult>> = vec![None; spec.cells()];
    for (unit, results) in unit_results.into_iter().enumerate() {
        for (k, r) in results.into_iter().enumerate() {
            ordered[layout.cell_of(unit, k)] = Some(r);
        }
    }
    assemble(spec, ordered)
}

/// Refuses a spec that is invalid or names another model.
fn check_request(model: &dyn Model, spec: &TableSpec) -> Result<()> {
    spec.validate()?;
    if spec.model != model.id().name() {
        return Err(Error::InvalidInput(format!(
            "table spec is for {} but the model is {}",
            spec.model,
            model.id().name()
        )));
    }
    Ok(())
}

/// The units of parallel work (and of progress, and of shards): a row along the last axis; or,
/// in 3-D and beyond and for models that share geometry along their first axis, a column along
/// the first axis (f0), which the model may integrate with one shared geometry.
struct Units {
    units: usize,
    unit_len: usize,
    column: bool,
}

impl Units {
    fn of(model: &dyn Model, spec: &TableSpec) -> Units {
        let (cells, dims) = (spec.cells(), spec.axes.len());
        let column = dims >= 3 || (dims == 2 && model.shares_column_geometry());
        let unit_len = if column {
            spec.axes[0].n
        } else {
            spec.axes[dims - 1].n
        };
        Units {
            units: cells / unit_len,
            unit_len,
            column,
        }
    }

    /// The cell of the `k`-th point of `unit`.
    fn cell_of(&self, unit: usize, k: usize) -> usize {
        if self.column {
            k * self.units + unit
        } else {
            unit * self.unit_len + k
        }
    }
}

/// The cells of the units `range`, in parallel, each unit's in order.
fn compute_units(
    model: &dyn Model,
    spec: &TableSpec,
    layout: &Units,
    range: std::ops::Range<usize>,
    progress: Progress,
) -> Vec<Vec<CellResult>> {
    let dims = spec.axes.len();
    let cache = RuleCache::new(&spec.quadrature);
    range
        .into_par_iter()
        .map(|unit| {
            let xs: Vec<Vec<f64>> = (0..layout.unit_len)
                .map(|k| {
                    let mut x = vec![0.0; dims];
                    spec.point(layout.cell_of(unit, k), &mut x);
                    x
                })
                .collect();
            let out = if layout.column {
                albedo_column(model, &xs, &spec.quadrature, &cache)
                    .into_iter()
                    .map(|e| (e.value, e.error, e.order, e.converged))
                    .collect()
            } else {
                xs.iter()
                    .map(|x| {
                        let e = albedo(model, x, &spec.quadrature, &cache);
                        (e.value, e.error, e.order, e.converged)
                    })
                    .collect()
            };
            progress(layout.unit_len as u64);
            out
        })
        .collect()
}

/// The table from every cell's outcome (in cell order), with its error summary; refuses a
/// non-finite value.
fn assemble(spec: &TableSpec, ordered: Vec<Option<CellResult>>) -> Result<Table> {
    let cells = spec.cells();
    let dims = spec.axes.len();
    let n_out = spec.outputs.len();
    let mut values = vec![0.0; n_out * cells];
    let mut errors = vec![0.0; cells];
    let mut summary = ErrorSummary {
        max_error_estimate: 0.0,
        max_error_at: vec![],
        refined_cells: 0,
        unconverged_cells: 0,
        unconverged: vec![],
        max_order_used: 0,
    };
    let mut x = vec![0.0; dims];
    for (cell, (v, err, order, converged)) in ordered
        .into_iter()
        .map(|r| r.expect("every cell computed"))
        .enumerate()
    {
        for o in 0..n_out {
            if !v[o].is_finite() {
                spec.point(cell, &mut x);
                return Err(Error::InvalidInput(format!(
                    "{}: non-finite {} = {} at {:?} (a bug in the model; please report it)",
                    spec.model, spec.outputs[o], v[o], x
                )));
            }
            values[o * cells + cell] = v[o];
        }
        errors[cell] = err;
        if err > summary.max_error_estimate || summary.max_error_at.is_empty() {
            summary.max_error_estimate = err;
            spec.point(cell, &mut x);
            summary.max_error_at = x.clone();
        }
        if order > spec.quadrature.order {
            summary.refined_cells += 1;
        }
        summary.max_order_used = summary.max_order_used.max(order);
        if !converged {
            summary.unconverged_cells += 1;
            if summary.unconverged.len() < MAX_LISTED {
                spec.point(cell, &mut x);
                summary.unconverged.push((x.clone(), err));
            }
        }
    }
    Ok(Table {
        spec: spec.clone(),
        values,
        errors,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::ggx::LEAVING_INTEGRATOR_REVISION;

    /// A model's integrator revision keys its own tables only: the cache keys of the other
    /// models are those of the engine version alone.
    #[test]
    fn the_integrator_revision_keys_only_its_models_tables() {
        for (name, revision) in [
            ("ggx-conductor", 0),
            ("ggx-dielectric", 0),
            ("ggx-dielectric-inv", LEAVING_INTEGRATOR_REVISION),
            ("ggx-dielectric-inv-separable", LEAVING_INTEGRATOR_REVISION),
        ] {
            let model = crate::bsdf::find(name).unwrap();
            assert_eq!(model.integrator_revision(), revision, "{name}");
            let resolution = vec![8; model.axes().len()];
            let spec = TableSpec::new(&*model, &resolution, QuadratureSettings::default()).unwrap();
            let bare = serde_json::json!({ "engine": ENGINE_VERSION, "spec": spec });
            let bare = crate::digest::sha256_hex(bare.to_string().as_bytes());
            assert_eq!(spec.content_hash() == bare, revision == 0, "{name}");
        }
    }
}
