//! One model's section of the report: its fits measured against its table (the paper's Fig. 3),
//! error heat maps and E(μ) slices of the chosen fit, the paper comparison, and the white furnace
//! test of the materials its albedo compensates, with sphere images.
//!
//! Everything is written under `reports/<model>/`: the figures, `section.md` (the section's
//! markdown, with links relative to `reports/`, included in `reports/README.md`) and
//! `summary.json` (the numbers the README's summary tables are assembled from, so that
//! `furnace report --model M` can update one model and rebuild the README).

use super::albedo::{Albedo, FitAlbedo, TableAlbedo};
use super::inputs::{
    self, choose_fit, load_fits, measure, paper_link, short_form, FitFiles, Measured, TableProvider,
};
use super::offgrid::{self, OffGridSummary, SweepPoint};
use super::plot::{
    self, color, Axis, Chart, ColorScale, Figure, Formats, HeatFigure, HeatPanel, LegendAt, Marker,
    Series, Style,
};
use super::spheres::{sphere_columns, Show, SphereFigure, SphereRow};
use crate::bsdf::{self, Family, Model, ModelId, Side, Transmission};
use crate::digest::{sha256_hex, values_sha256};
use crate::error::{Error, Result};
use crate::fit::FitResult;
use crate::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at, FurnaceStats};
use crate::material::{compensated_for, CompensatedBsdf, Compensation};
use crate::math::SmithForm;
use crate::table::Table;
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// What a report covers and where it reads and writes.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Output folder (`reports`).
    pub reports_dir: PathBuf,
    /// Fit files, one folder per model (`fits`).
    pub fits_dir: PathBuf,
    /// Benchmark CSV files (`reports/bench`), written only by the benchmark commands.
    pub bench_dir: PathBuf,
    /// The paper's published coefficients and tables (`coefficients/`, `tables/`), if available.
    pub paper_dir: Option<PathBuf>,
    /// Nodes per axis of the tables fits are measured against, 2-D and 3-D.
    pub resolution_2d: usize,
    pub resolution_3d: usize,
    /// Nodes per axis of the LUTs (multilinear), 2-D and 3-D: the LUT of the sphere images.
    pub lut_2d: usize,
    pub lut_3d: usize,
    /// Nodes per axis of the LUTs the white furnace test is also run with (every model: 16, 32
    /// and 64, the LUTs `fits/<model>/off-grid.json` measures beside the fits).
    pub furnace_luts: Vec<usize>,
    /// Furnace grid: at most this many table nodes per r and μ axis…
    pub furnace_nodes: usize,
    /// …and this many F0 slices of 3-D tables.
    pub furnace_f0_slices: usize,
    /// Roughness of the spheres, left to right.
    pub sphere_roughness: Vec<f64>,
    /// F0 of the spheres of 3-D classes (glossy, dielectrics): 0.04, η = 1.5.
    pub sphere_f0: f64,
}

impl ReportOptions {
    /// Small, fast defaults (2-D 65², 3-D 17³ tables; 32-per-axis LUTs, the size `furnace run`
    /// emits under `data/lut/`, whose interior nodes fall between the table's), rooted at `root`.
    pub fn new(root: &Path) -> ReportOptions {
        ReportOptions {
            reports_dir: root.join("reports"),
            fits_dir: root.join("fits"),
            bench_dir: root.join("reports").join("bench"),
            paper_dir: None,
            resolution_2d: 65,
            resolution_3d: 17,
            lut_2d: 32,
            lut_3d: 32,
            furnace_luts: super::offgrid::LUT_CHECK_RESOLUTIONS.to_vec(),
            furnace_nodes: 33,
            furnace_f0_slices: 3,
            sphere_roughness: vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
            sphere_f0: 0.04,
        }
    }

    fn resolution(&self, dims: usize) -> Vec<usize> {
        vec![
            if dims <= 2 {
                self.resolution_2d
            } else {
                self.resolution_3d
            };
            dims
        ]
    }

    fn lut(&self, dims: usize) -> usize {
        if dims <= 2 {
            self.lut_2d
        } else {
            self.lut_3d
        }
    }
}

/// The models `furnace report` covers by default: the paper's set in both Smith forms and the
/// rough-diffuse models.
pub const REPORT_MODELS: &[ModelId] = &[
    ModelId::ggx_conductor(SmithForm::HeightCorrelated),
    ModelId::ggx_conductor(SmithForm::Separable),
    ModelId::ggx_glossy(SmithForm::HeightCorrelated),
    ModelId::ggx_glossy(SmithForm::Separable),
    ModelId::ggx_dielectric(Side::Entering, SmithForm::HeightCorrelated),
    ModelId::ggx_dielectric(Side::Entering, SmithForm::Separable),
    ModelId::ggx_dielectric(Side::Leaving, SmithForm::HeightCorrelated),
    ModelId::ggx_dielectric(Side::Leaving, SmithForm::Separable),
    ModelId::new(Family::OREN_NAYAR_QON),
    ModelId::new(Family::OREN_NAYAR_FON),
    ModelId::new(Family::EON),
];

/// A fit's row in the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitRow {
    /// File (relative to `fits/<model>/`) or "paper".
    pub source: String,
    pub form: String,
    pub n_coefficients: usize,
    /// Proved pole-free and finite.
    pub usable: bool,
    /// Measured here against the report's table.
    pub measured: Measured,
    /// As recorded in the fit (on the data it was fitted to).
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub reported_mae: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub reported_max: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub reported_max_rel: f64,
}

/// The white furnace result of one compensation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FurnaceVariant {
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stats: Option<FurnaceStats>,
    /// Why there is no result, or what the albedo source is.
    pub note: String,
}

/// The furnace test of one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FurnaceRow {
    pub material: String,
    pub id: String,
    pub points: usize,
    /// Largest error estimate of the furnace quadrature over the points.
    pub quadrature_error: f64,
    pub unconverged: usize,
    pub variants: Vec<FurnaceVariant>,
    /// Sphere images (relative to `reports/`).
    pub images: Vec<String>,
}

/// The paper comparison of a model (its four tables are conductors, glossy, dielectrics and
/// dielectrics_inv_eta).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperRow {
    pub paper_table: String,
    /// The furnace model in the paper's convention (radiance-form transmission for dielectrics).
    pub convention_model: String,
    pub resolution: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub furnace_fit: Option<FitRow>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub furnace_fit_furnace: Option<f64>,
    pub paper_fit: FitRow,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper_fit_furnace: Option<f64>,
    /// Why a number is missing.
    pub notes: Vec<String>,
}

/// Everything the README's summary needs from one model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelSummary {
    pub model: String,
    pub description: String,
    pub resolution: String,
    pub table_max_error_estimate: f64,
    pub fits: Vec<FitRow>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chosen: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper: Option<PaperRow>,
    /// The best fits' and the LUTs' errors at the off-grid check points
    /// (`fits/<model>/off-grid.json`), if the sweep measured them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off_grid: Option<OffGridSummary>,
    pub furnace: Vec<FurnaceRow>,
    /// Every file the section links (relative to `reports/`).
    pub files: Vec<String>,
    /// The models (with their options) whose tables and fits the section read.
    #[serde(default)]
    pub dependencies: Vec<Dependency>,
    /// SHA-256 of everything the section was computed from (see [`Reporter::inputs_digest`]).
    #[serde(default)]
    pub inputs_sha256: String,
    /// The section's files (figures and `section.md`, relative to `reports/`) with their SHA-256.
    #[serde(default)]
    pub outputs: Vec<FileHash>,
}

/// A model (with its transmission convention) a section read.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Dependency {
    pub model: String,
    pub radiance_transmission: bool,
}

impl Dependency {
    pub fn new(id: ModelId) -> Dependency {
        Dependency {
            model: id.name(),
            radiance_transmission: id.is_radiance(),
        }
    }

    /// The registered model this names.
    pub fn id(&self) -> Result<ModelId> {
        let id = bsdf::lookup(&self.model)?;
        Ok(if self.radiance_transmission {
            id.with_transmission(Transmission::Radiance)
        } else {
            id
        })
    }
}

/// A file and its SHA-256.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileHash {
    pub file: String,
    pub sha256: String,
}

/// A model's table, LUT, fits and paper fit, loaded once per report run.
struct ModelData {
    name: String,
    model: Arc<dyn Model>,
    axes: Vec<String>,
    table: Table,
    lut: TableAlbedo,
    /// The LUTs of [`ReportOptions::furnace_luts`] other than `lut`, by nodes per axis.
    luts: Vec<(usize, TableAlbedo)>,
    exact: TableAlbedo,
    fits: FitFiles,
    fit_albedos: Vec<Option<FitAlbedo>>,
    /// (N, index into `fits`) of every usable `best-<N>.json`, by N.
    budgets: Vec<(usize, usize)>,
    off_grid: Option<OffGridSummary>,
    sweep_points: Vec<SweepPoint>,
    measured: Vec<Measured>,
    chosen: Option<usize>,
    chosen_albedo: Option<FitAlbedo>,
    paper: Option<(FitResult, FitAlbedo, Measured)>,
}

impl ModelData {
    fn dims(&self) -> usize {
        self.axes.len()
    }

    fn lut_per_axis(&self) -> usize {
        self.lut
            .resolution()
            .split('x')
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or(0)
    }

    /// The LUT of `n` nodes per axis, if loaded.
    fn lut_of(&self, n: usize) -> Option<&TableAlbedo> {
        if n == self.lut_per_axis() {
            return Some(&self.lut);
        }
        self.luts.iter().find(|(m, _)| *m == n).map(|(_, l)| l)
    }

    /// The albedo of `best-<n>.json`, if there is one and it can be evaluated.
    fn budget_albedo(&self, n: usize) -> Option<&FitAlbedo> {
        let &(_, k) = self.budgets.iter().find(|(b, _)| *b == n)?;
        self.fit_albedos[k].as_ref()
    }

    fn fit_row(&self, k: usize) -> FitRow {
        fit_row(
            &self.fits.fits[k].source,
            &self.fits.fits[k].fit,
            &self.measured[k],
        )
    }
}

fn fit_row(source: &str, fit: &FitResult, measured: &Measured) -> FitRow {
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

/// A report run: options, the table source, and the models loaded so far.
pub struct Reporter<'a> {
    pub options: ReportOptions,
    tables: &'a dyn TableProvider,
    progress: &'a dyn Fn(&str),
    loaded: RefCell<BTreeMap<String, Rc<ModelData>>>,
    /// Models read since the current section started.
    used: RefCell<std::collections::BTreeSet<Dependency>>,
}

/// A LUT of `m` nodes per axis: every k-th node of `table` when (n − 1) is a multiple of (m − 1)
/// (the tabulated values, no resampling), else `None`.
fn subsample_lut(table: &Table, m: usize) -> Option<Table> {
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

impl<'a> Reporter<'a> {
    pub fn new(
        options: ReportOptions,
        tables: &'a dyn TableProvider,
        progress: &'a dyn Fn(&str),
    ) -> Reporter<'a> {
        Reporter {
            options,
            tables,
            progress,
            loaded: RefCell::new(BTreeMap::new()),
            used: RefCell::new(Default::default()),
        }
    }

    fn data(&self, id: ModelId) -> Result<Rc<ModelData>> {
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
            .table(model.as_ref(), &self.options.resolution(axes.len()))?;
        let lut_n = self.options.lut(axes.len());
        let lut_table = match subsample_lut(&table, lut_n) {
            Some(t) => t,
            None => {
                (self.progress)(&format!("{k}: LUT {lut_n}"));
                self.tables
                    .table(model.as_ref(), &vec![lut_n; axes.len()])?
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
                FitAlbedo::new(&f.fit, &axes)
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
                let albedo = FitAlbedo::new(&fit, &axes)?;
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

    fn model_dir(&self, name: &str) -> PathBuf {
        self.options.reports_dir.join(name)
    }

    /// SHA-256 of everything a section computed from `deps` reads: the report options, the
    /// furnace version, and per model its report table's and LUT's values, every file under its
    /// fits folder, and the paper's files for it.
    pub fn inputs_digest(&self, deps: &[Dependency]) -> Result<String> {
        let o = &self.options;
        let mut text = format!(
            "furnace {}\nresolution {} {} lut {} {} furnace luts {:?} nodes {} f0 slices {} spheres {:?} f0 {} paper {}\n",
            crate::VERSION,
            o.resolution_2d,
            o.resolution_3d,
            o.lut_2d,
            o.lut_3d,
            o.furnace_luts,
            o.furnace_nodes,
            o.furnace_f0_slices,
            o.sphere_roughness,
            o.sphere_f0,
            o.paper_dir.is_some()
        );
        for d in deps {
            let id = d.id()?;
            let model = bsdf::get(id)?;
            let dims = model.axes().len();
            let table = self
                .tables
                .table(model.as_ref(), &self.options.resolution(dims))?;
            let _ = writeln!(
                text,
                "model {} table {} {}",
                model.id().key(),
                table.spec.resolution_name(),
                values_sha256(&table.values)
            );
            if subsample_lut(&table, self.options.lut(dims)).is_none() {
                let lut = self
                    .tables
                    .table(model.as_ref(), &vec![self.options.lut(dims); dims])?;
                let _ = writeln!(text, "lut {}", values_sha256(&lut.values));
            }
            for &n in &self.options.furnace_luts {
                if n != self.options.lut(dims) {
                    let lut = self.tables.table(model.as_ref(), &vec![n; dims])?;
                    let _ = writeln!(text, "lut {n} {}", values_sha256(&lut.values));
                }
            }
            let dir = self.options.fits_dir.join(model.id().key());
            for (rel, sha) in files_digest(&dir)? {
                let _ = writeln!(text, "fit {rel} {sha}");
            }
            if let (Some(paper), Some(link)) = (&self.options.paper_dir, paper_link(id)) {
                if link.model == id {
                    for sub in ["coefficients", "tables"] {
                        let p = paper.join(sub).join(format!("{}.csv", link.stem));
                        let sha = std::fs::read(&p)
                            .map(|b| sha256_hex(&b))
                            .unwrap_or_else(|_| "missing".into());
                        let _ = writeln!(text, "paper {sub} {sha}");
                    }
                }
            }
        }
        Ok(sha256_hex(text.as_bytes()))
    }

    /// The summary of `reports/<name>/` if it was made from the same inputs as now and its
    /// files are intact (their SHA-256 as recorded), so that it need not be regenerated.
    pub fn reusable_section(&self, id: ModelId) -> Result<Option<ModelSummary>> {
        let name = id.key();
        let path = self.model_dir(&name).join("summary.json");
        let Ok(text) = std::fs::read_to_string(&path) else {
            return Ok(None);
        };
        let Ok(summary) = serde_json::from_str::<ModelSummary>(&text) else {
            return Ok(None);
        };
        if summary.model != name || summary.dependencies.is_empty() || summary.outputs.is_empty() {
            return Ok(None);
        }
        for f in &summary.outputs {
            match std::fs::read(self.options.reports_dir.join(&f.file)) {
                Ok(bytes) if sha256_hex(&bytes) == f.sha256 => {}
                _ => return Ok(None),
            }
        }
        if self.inputs_digest(&summary.dependencies)? != summary.inputs_sha256 {
            return Ok(None);
        }
        Ok(Some(summary))
    }

    /// Generates `reports/<name>/` (figures, `section.md`, `summary.json`) and returns the summary.
    pub fn report_model(&self, id: ModelId) -> Result<ModelSummary> {
        self.used.borrow_mut().clear();
        let name = &id.key();
        let data = self.data(id)?;
        let dir = self.model_dir(name);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let mut files = Vec::new();
        let rel = |p: &Path| {
            p.strip_prefix(&self.options.reports_dir)
                .unwrap_or(p)
                .to_string_lossy()
                .replace('\\', "/")
        };

        (self.progress)(&format!("{name}: figures"));
        let fig3 = self.fig_error_vs_coefficients(&data, &dir.join("error-vs-coefficients"))?;
        files.extend(fig3.iter().map(|p| rel(p)));
        let heat = self.fig_heatmaps(&data, &dir)?;
        files.extend(heat.iter().map(|p| rel(p)));
        let slices = self.fig_slices(&data, &dir.join("slices"))?;
        files.extend(slices.iter().map(|p| rel(p)));
        let off_grid = self.fig_off_grid(&data, &dir.join("off-grid"))?;
        files.extend(off_grid.iter().map(|p| rel(p)));

        let paper = match paper_link(id) {
            Some(link) => match &self.options.paper_dir {
                Some(_) => Some(self.paper_row(id, link)?),
                None => None,
            },
            None => None,
        };

        let mut furnace = Vec::new();
        for material in compensated_for(id) {
            (self.progress)(&format!("{name}: furnace {}", material.label()));
            let row = self.furnace_row(material.as_ref(), &dir)?;
            files.extend(row.images.iter().cloned());
            furnace.push(row);
        }

        let summary = ModelSummary {
            model: name.to_string(),
            description: data.model.summary(),
            resolution: data.table.spec.resolution_name(),
            table_max_error_estimate: data.table.summary.max_error_estimate,
            fits: (0..data.fits.fits.len()).map(|k| data.fit_row(k)).collect(),
            chosen: data.chosen,
            paper,
            off_grid: data.off_grid.clone(),
            furnace,
            files,
            dependencies: Vec::new(),
            inputs_sha256: String::new(),
            outputs: Vec::new(),
        };
        let mut summary = summary;
        let section = self.section_markdown(&data, &summary);
        crate::output::write(&dir.join("section.md"), section.as_bytes())?;
        summary.dependencies = self.used.borrow().iter().cloned().collect();
        summary.inputs_sha256 = self.inputs_digest(&summary.dependencies)?;
        let mut outputs = summary.files.clone();
        outputs.push(format!("{name}/section.md"));
        for f in outputs {
            let p = self.options.reports_dir.join(&f);
            let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
            summary.outputs.push(FileHash {
                file: f,
                sha256: sha256_hex(&bytes),
            });
        }
        let json = serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::file(dir.join("summary.json"), e.to_string()))?;
        crate::output::write(&dir.join("summary.json"), format!("{json}\n").as_bytes())?;
        Ok(summary)
    }

    /// Paper's Fig. 3: MAE and max error against number of coefficients.
    fn fig_error_vs_coefficients(&self, data: &ModelData, stem: &Path) -> Result<Vec<PathBuf>> {
        if data.fits.fits.is_empty() && data.paper.is_none() {
            return Ok(vec![]);
        }
        // best (lowest MAE) fit per (kind, coefficient count)
        let mut best: BTreeMap<(bool, usize), usize> = BTreeMap::new();
        for (k, f) in data.fits.fits.iter().enumerate() {
            let rational = matches!(f.fit.form, crate::fit::Form::Rational { .. });
            let e = best.entry((rational, f.fit.n_coefficients)).or_insert(k);
            if data.measured[k].mae < data.measured[*e].mae {
                *e = k;
            }
        }
        let max_n = data
            .fits
            .fits
            .iter()
            .map(|f| f.fit.n_coefficients)
            .chain(data.paper.iter().map(|p| p.0.n_coefficients))
            .max()
            .unwrap_or(1);
        let chart = |title: &str, y_label: &str, pick: &dyn Fn(&Measured) -> f64| {
            let mut series = Vec::new();
            for (rational, name, c, marker) in [
                (false, "polynomial", 0, Marker::Circle),
                (true, "rational", 1, Marker::Square),
            ] {
                let pts: Vec<(f64, f64)> = best
                    .iter()
                    .filter(|((r, _), _)| *r == rational)
                    .map(|((_, n), &k)| (*n as f64, pick(&data.measured[k])))
                    .collect();
                if !pts.is_empty() {
                    series.push(Series::new(name, pts, color(c), Style::LinePoints).marker(marker));
                }
            }
            if let Some(k) = data.chosen {
                let f = &data.fits.fits[k];
                series.push(
                    Series::new(
                        &format!("chosen: {}", f.short_form()),
                        vec![(f.fit.n_coefficients as f64, pick(&data.measured[k]))],
                        color(2),
                        Style::Points,
                    )
                    .marker(Marker::Triangle),
                );
            }
            if let Some((fit, _, m)) = &data.paper {
                series.push(
                    Series::new(
                        "paper's published fit (rational 3/3)",
                        vec![(fit.n_coefficients as f64, pick(m))],
                        color(3),
                        Style::Points,
                    )
                    .marker(Marker::Cross),
                );
            }
            let room = legend_room(&series);
            Chart {
                title: title.into(),
                x: Axis::linear("number of coefficients")
                    .with_range(0.0, max_n as f64 * 1.08 + 2.0),
                y: Axis::log(y_label),
                series,
                legend: LegendAt::UpperRight,
                legend_room: room,
            }
        };
        let fig = Figure {
            title: Some(format!(
                "{}: error against number of coefficients (on the {} table)",
                data.name,
                data.table.spec.resolution_name()
            )),
            charts: vec![
                chart("mean absolute error", "MAE of E", &|m: &Measured| m.mae),
                chart(
                    "maximum absolute error",
                    "max |fit − table|",
                    &|m: &Measured| m.max_abs,
                ),
            ],
            size: (1300, 560),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }

    /// Error against stored values at the off-grid check points: the lower envelope of every
    /// form family of the sweep, the `best-<N>.json` fits and the 16/32/64-per-axis LUTs, max
    /// error and MAE side by side.
    fn fig_off_grid(&self, data: &ModelData, stem: &Path) -> Result<Vec<PathBuf>> {
        let Some(og) = &data.off_grid else {
            return Ok(vec![]);
        };
        let points = &data.sweep_points;
        let families = offgrid::families(points);
        let markers = [Marker::Circle, Marker::Square, Marker::Cross];
        let chart = |title: &str,
                     y_label: &str,
                     fit: &dyn Fn(&SweepPoint) -> f64,
                     lut: &dyn Fn(&offgrid::PointErrors) -> f64,
                     best: &dyn Fn(&offgrid::BudgetErrors) -> f64| {
            let mut series = Vec::new();
            for (c, family) in families.iter().enumerate() {
                let pts = offgrid::envelope(points, family, fit);
                if !pts.is_empty() {
                    series.push(
                        Series::new(
                            &format!("{family} (best of the sweep)"),
                            pts,
                            color(c),
                            Style::LinePoints,
                        )
                        .marker(markers[c % markers.len()]),
                    );
                }
            }
            if !og.best.is_empty() {
                series.push(
                    Series::new(
                        "best-<N>.json",
                        og.best
                            .iter()
                            .map(|b| (b.n_coefficients as f64, best(b)))
                            .collect(),
                        color(families.len()),
                        Style::Points,
                    )
                    .marker(Marker::Triangle),
                );
            }
            if !og.luts.is_empty() {
                series.push(
                    Series::new(
                        &format!(
                            "LUT {} per axis ({})",
                            og.luts
                                .iter()
                                .map(|l| l.per_axis.to_string())
                                .collect::<Vec<_>>()
                                .join("/"),
                            if data.dims() == 2 {
                                "bilinear"
                            } else {
                                "trilinear"
                            }
                        ),
                        og.luts
                            .iter()
                            .map(|l| (l.values as f64, lut(&l.errors)))
                            .collect(),
                        RGBColorKey::black(),
                        Style::LinePoints,
                    )
                    .marker(Marker::Square),
                );
            }
            let room = legend_room(&series);
            Chart {
                title: title.into(),
                x: Axis::log("stored values (fit: coefficients; LUT: nodes)"),
                y: Axis::log(y_label),
                series,
                legend: LegendAt::UpperRight,
                legend_room: room,
            }
        };
        let fig = Figure {
            title: Some(format!(
                "{}: error against stored values at {} off-grid points",
                data.name,
                og.check_set.split(" off-grid").next().unwrap_or("the")
            )),
            charts: vec![
                chart(
                    "maximum absolute error",
                    "max |E − exact|",
                    &|p| p.max_abs_error,
                    &|e| e.max_abs_error,
                    &|b| b.max_abs_error,
                ),
                chart(
                    "mean absolute error",
                    "MAE of E",
                    &|p| p.mae,
                    &|e| e.mae,
                    &|b| b.mae,
                ),
            ],
            size: (1300, 560),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }

    /// Heat maps of the chosen fit's error: |fit − table| (log) and fit − table (signed).
    fn fig_heatmaps(&self, data: &ModelData, dir: &Path) -> Result<Vec<PathBuf>> {
        let (Some(k), Some(fit)) = (data.chosen, &data.chosen_albedo) else {
            return Ok(vec![]);
        };
        let form = data.fits.fits[k].short_form();
        let t = &data.table;
        let axes = &t.spec.axes;
        let dims = axes.len();
        let (ra, ma) = (&axes[dims - 2], &axes[dims - 1]);
        let slices: Vec<usize> = if dims == 3 {
            slice_indices(axes[0].n, 3)
        } else {
            vec![0]
        };
        const MAX_CELLS: usize = 128;
        let (br, bm) = (ra.n.div_ceil(MAX_CELLS), ma.n.div_ceil(MAX_CELLS));
        let (ny, nx) = (ra.n.div_ceil(br), ma.n.div_ceil(bm));
        let mut abs_panels = Vec::new();
        let mut signed_panels = Vec::new();
        let mut all_abs = Vec::new();
        for &s in &slices {
            // signed error with the largest magnitude in each display block (max-pooling keeps peaks)
            let mut cells = vec![0.0f64; nx * ny];
            let mut worst = (0.0f64, (0.0, 0.0));
            let mut x = vec![0.0; dims];
            for i in 0..ra.n {
                for j in 0..ma.n {
                    let cell = (s * ra.n + i) * ma.n + j;
                    t.spec.point(cell, &mut x);
                    let e = fit.albedo(&x) - t.output(0)[cell];
                    let c = &mut cells[(i / br) * nx + j / bm];
                    if e.abs() > c.abs() {
                        *c = e;
                    }
                    if e.abs() > worst.0 {
                        worst = (e.abs(), (x[dims - 1], x[dims - 2]));
                    }
                }
            }
            let title = if dims == 3 {
                format!(
                    "{} = {}",
                    axes[0].name,
                    plot::format_number(axes[0].node(s))
                )
            } else {
                data.name.clone()
            };
            let half_r = 0.5 * (ra.hi - ra.lo) / (ra.n - 1) as f64 * br as f64;
            let half_m = 0.5 * (ma.hi - ma.lo) / (ma.n - 1) as f64 * bm as f64;
            let mark = Some((
                worst.1,
                format!(
                    "max {} at μ = {}, r = {}",
                    plot::format_number(worst.0),
                    plot::format_number(worst.1 .0),
                    plot::format_number(worst.1 .1)
                ),
            ));
            let panel = |values: Vec<f64>| HeatPanel {
                title: title.clone(),
                x_label: "μ = cos θo".into(),
                y_label: "r = √α".into(),
                x_range: (ma.lo - half_m, ma.lo - half_m + 2.0 * half_m * nx as f64),
                y_range: (ra.lo - half_r, ra.lo - half_r + 2.0 * half_r * ny as f64),
                nx,
                ny,
                values,
                mark: mark.clone(),
            };
            all_abs.extend(cells.iter().map(|v| v.abs()));
            abs_panels.push(panel(cells.iter().map(|v| v.abs()).collect()));
            signed_panels.push(panel(cells));
        }
        let width = (150 + 520 * slices.len() as u32).max(1000);
        let mut out = Vec::new();
        let abs = HeatFigure {
            title: Some(format!(
                "|fit − table| of the chosen fit ({form}, {} coefficients)",
                data.fits.fits[k].fit.n_coefficients
            )),
            panels: abs_panels,
            scale: ColorScale::log_for(&all_abs, 6.0),
            colorbar_label: "|fit − table| (log scale)".into(),
            size: (width, 580),
        };
        out.extend(plot::save(
            &abs,
            &dir.join("heatmap-abs"),
            Formats::PngAndSvg,
        )?);
        let signed_values: Vec<f64> = signed_panels
            .iter()
            .flat_map(|p| p.values.iter().copied())
            .collect();
        let signed = HeatFigure {
            title: Some(format!(
                "fit − table of the chosen fit ({form}; red: fit too high, blue: too low)"
            )),
            scale: ColorScale::signed_for(&signed_values),
            panels: signed_panels,
            colorbar_label: "fit − table".into(),
            size: (width, 580),
        };
        out.extend(plot::save(
            &signed,
            &dir.join("heatmap-signed"),
            Formats::PngAndSvg,
        )?);
        Ok(out)
    }

    /// E(μ) at several r: table, chosen fit, paper's fit; and their differences.
    fn fig_slices(&self, data: &ModelData, stem: &Path) -> Result<Vec<PathBuf>> {
        let t = &data.table;
        let axes = &t.spec.axes;
        let dims = axes.len();
        let (ra, ma) = (&axes[dims - 2], &axes[dims - 1]);
        let f0_index = if dims == 3 {
            nearest_node(&axes[0], self.options.sphere_f0)
        } else {
            0
        };
        let rs: Vec<usize> = [0.1, 0.3, 0.6, 1.0]
            .iter()
            .map(|&r| nearest_node(ra, r))
            .collect();
        let fit = data.chosen.zip(data.chosen_albedo.as_ref());
        let paper = data.paper.as_ref().map(|p| &p.1);
        let mut left = Vec::new();
        let mut right = Vec::new();
        let marker_stride = (ma.n / 16).max(1);
        for (c, &i) in rs.iter().enumerate() {
            let r = ra.node(i);
            let point = |j: usize| -> Vec<f64> {
                let mu = ma.node(j);
                if dims == 3 {
                    vec![axes[0].node(f0_index), r, mu]
                } else {
                    vec![r, mu]
                }
            };
            let cell = |j: usize| (f0_index * ra.n + i) * ma.n + j;
            let table: Vec<(f64, f64)> = (0..ma.n)
                .map(|j| (ma.node(j), t.output(0)[cell(j)]))
                .collect();
            left.push(Series::new(
                &format!("r = {}", plot::format_number(r)),
                table,
                color(c),
                Style::Line,
            ));
            if let Some((_, f)) = fit {
                left.push(Series::new(
                    "",
                    (0..ma.n)
                        .map(|j| (ma.node(j), f.albedo(&point(j))))
                        .collect(),
                    color(c),
                    Style::Dashed,
                ));
                right.push(Series::new(
                    &format!("fit, r = {}", plot::format_number(r)),
                    (0..ma.n)
                        .map(|j| (ma.node(j), f.albedo(&point(j)) - t.output(0)[cell(j)]))
                        .collect(),
                    color(c),
                    Style::Line,
                ));
            }
            if let Some(p) = paper {
                left.push(
                    Series::new(
                        "",
                        (0..ma.n)
                            .step_by(marker_stride)
                            .map(|j| (ma.node(j), p.albedo(&point(j))))
                            .collect(),
                        color(c),
                        Style::Points,
                    )
                    .marker(Marker::Cross),
                );
                right.push(Series::new(
                    &format!("paper, r = {}", plot::format_number(r)),
                    (0..ma.n)
                        .map(|j| (ma.node(j), p.albedo(&point(j)) - t.output(0)[cell(j)]))
                        .collect(),
                    color(c),
                    Style::Dashed,
                ));
            }
        }
        let key = RGBColorKey::black();
        left.push(Series::new(
            &format!("table ({})", t.spec.resolution_name()),
            vec![],
            key,
            Style::Line,
        ));
        if let Some((k, _)) = fit {
            left.push(Series::new(
                &format!("fit: {}", data.fits.fits[k].short_form()),
                vec![],
                key,
                Style::Dashed,
            ));
        }
        if paper.is_some() {
            left.push(Series::new("paper's fit", vec![], key, Style::Points).marker(Marker::Cross));
        }
        let f0_text = if dims == 3 {
            format!(
                " at {} = {}",
                axes[0].name,
                plot::format_number(axes[0].node(f0_index))
            )
        } else {
            String::new()
        };
        let y_label = offset_nearly_constant(&mut left)
            .map_or("directional albedo E".to_string(), |c| {
                format!("E − {} (E is nearly constant)", plot::format_number(c))
            });
        let mut charts = vec![Chart {
            title: format!("E(μ){f0_text}"),
            x: Axis::linear("μ = cos θo").with_range(0.0, 1.0),
            y: Axis::linear(&y_label),
            legend_room: 0.0,
            series: left,
            legend: LegendAt::Right,
        }];
        if !right.is_empty() {
            let what = match (fit.is_some(), paper.is_some()) {
                (true, true) => "solid: chosen fit, dashed: paper's fit",
                (true, false) => "chosen fit",
                _ => "paper's fit",
            };
            charts.push(Chart {
                title: format!("fit − table{f0_text} ({what})"),
                x: Axis::linear("μ = cos θo").with_range(0.0, 1.0),
                y: Axis::linear("E(fit) − E(table)"),
                legend_room: 0.0,
                series: right,
                legend: LegendAt::Right,
            });
        }
        let width = if charts.len() == 2 { 1600 } else { 860 };
        let fig = Figure {
            title: Some(format!("{}: slices of E at several r", data.name)),
            charts,
            size: (width, 620),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }

    /// Furnace points of a material: table nodes of its albedo model (see [`furnace_axis`]).
    fn furnace_points(&self, data: &ModelData) -> Vec<Vec<f64>> {
        let axes = &data.table.spec.axes;
        let dims = axes.len();
        let per_axis: Vec<Vec<usize>> = axes
            .iter()
            .enumerate()
            .map(|(d, a)| {
                if dims == 3 && d == 0 {
                    slice_indices(a.n, self.options.furnace_f0_slices)
                } else {
                    furnace_axis(a.n, self.options.furnace_nodes)
                }
            })
            .collect();
        let mut points = vec![vec![]];
        for (d, idx) in per_axis.iter().enumerate() {
            points = points
                .into_iter()
                .flat_map(|p: Vec<f64>| {
                    idx.iter().map(move |&i| {
                        let mut q = p.clone();
                        q.push(axes[d].node(i));
                        q
                    })
                })
                .collect();
        }
        points
    }

    /// The point of `data`'s axes at roughness `r` and cosine `mu` for the sphere images: `f0` at
    /// [`ReportOptions::sphere_f0`], any other axis at the middle of its table's range.
    fn sphere_point(&self, data: &ModelData, r: f64, mu: f64) -> Vec<f64> {
        data.table
            .spec
            .axes
            .iter()
            .map(|a| match a.name.as_str() {
                "r" => r,
                "mu" => mu,
                "f0" => self.options.sphere_f0,
                _ => 0.5 * (a.lo + a.hi),
            })
            .collect()
    }

    /// The furnace test of one material (none, exact table, LUT, fit, paper fit) and its spheres.
    fn furnace_row(&self, material: &dyn CompensatedBsdf, dir: &Path) -> Result<FurnaceRow> {
        let albedos = material.albedos();
        let data = self.data(albedos[0])?;
        let others: Vec<Rc<ModelData>> = albedos[1..]
            .iter()
            .map(|&m| self.data(m))
            .collect::<Result<_>>()?;
        let points = self.furnace_points(&data);
        let lobes = lobe_integrals_at(material, &points);
        let quadrature_error = lobes.iter().map(|l| l.error).fold(0.0, f64::max);
        let unconverged = lobes.iter().filter(|l| !l.converged).count();

        let lut_name = |n: usize| {
            format!(
                "LUT {} ({})",
                vec![n.to_string(); data.dims()].join("×"),
                if data.dims() == 2 {
                    "bilinear"
                } else {
                    "trilinear"
                }
            )
        };
        // the same kind of source for the primary albedo and every other one
        let sources = |pick: &dyn for<'d> Fn(&'d ModelData) -> Option<&'d dyn Albedo>| {
            std::iter::once(&data)
                .chain(&others)
                .map(|d| pick(d))
                .collect::<Option<Vec<&dyn Albedo>>>()
        };
        let mut variants: Vec<(String, std::result::Result<Compensation, String>, String)> =
            Vec::new();
        variants.push((
            "no compensation".into(),
            Ok(Compensation::None),
            "single-scattering BSDF".into(),
        ));
        variants.push((
            format!("exact table ({})", data.table.spec.resolution_name()),
            Ok(Compensation::With(
                sources(&|d| Some(&d.exact)).expect("every table is loaded"),
            )),
            "the furnace points are table nodes".into(),
        ));
        // the LUT of the sphere images, then every other size, by nodes per axis
        let main_lut = data.lut_per_axis();
        let mut lut_sizes = vec![main_lut];
        lut_sizes.extend(self.options.furnace_luts.iter().filter(|&&n| n != main_lut));
        lut_sizes.sort_unstable();
        lut_sizes.dedup();
        for &n in &lut_sizes {
            variants.push((
                lut_name(n),
                Ok(Compensation::With(
                    sources(&|d| d.lut_of(n).map(|l| l as _)).expect("every LUT is loaded"),
                )),
                "multilinear in the tabulated values at its nodes".into(),
            ));
        }
        let chosen = sources(&|d| d.chosen_albedo.as_ref().map(|a| a as _));
        let fit_variant = match (&data.chosen_albedo, data.chosen, chosen) {
            (Some(_), Some(k), Some(s)) => {
                let mut note = data.fits.fits[k].short_form();
                for (j, o) in others.iter().enumerate() {
                    let ok = o.chosen.expect("a chosen albedo has a chosen fit");
                    note.push_str(&format!(
                        " + {} {}",
                        material.albedo_role(j + 1),
                        o.fits.fits[ok].short_form()
                    ));
                }
                Ok((Compensation::With(s), note))
            }
            (Some(_), Some(_), None) => {
                let missing = others
                    .iter()
                    .find(|o| o.chosen_albedo.is_none())
                    .expect("only another albedo can lack its fit");
                Err(format!(
                    "needs a fit of {} too: run `furnace fit --model {} --sweep` first",
                    missing.name, missing.name
                ))
            }
            _ => Err(format!(
                "no fit of {}: run `furnace fit --model {} --sweep` first",
                data.name,
                data.model.id().name()
            )),
        };
        match fit_variant {
            Ok((c, note)) => variants.push(("furnace fit".into(), Ok(c), note)),
            Err(e) => variants.push(("furnace fit".into(), Err(e.clone()), e)),
        }
        // every budget of the sweep (`best-<N>.json` of each albedo the material reads)
        for &(b, k) in &data.budgets {
            let name = format!("best-{b}");
            match sources(&|d| d.budget_albedo(b).map(|a| a as _)) {
                Some(s) => {
                    let f = &data.fits.fits[k];
                    let note = format!(
                        "`best-{b}.json`: {}, {} coefficients",
                        f.short_form(),
                        f.fit.n_coefficients
                    );
                    variants.push((name, Ok(Compensation::With(s)), note));
                }
                None => {
                    let missing = others
                        .iter()
                        .find(|o| o.budget_albedo(b).is_none())
                        .map_or(data.name.as_str(), |o| o.name.as_str());
                    let e = format!("no `best-{b}.json` of {missing}");
                    variants.push((name, Err(e.clone()), e));
                }
            }
        }
        if data.paper.is_some() {
            let v = match sources(&|d| d.paper.as_ref().map(|p| &p.1 as _)) {
                Some(s) => Ok(Compensation::With(s)),
                None => {
                    let j = others.iter().position(|o| o.paper.is_none()).unwrap_or(0);
                    Err(format!(
                        "needs the paper's {} fit too",
                        material.albedo_role(j + 1)
                    ))
                }
            };
            variants.push((
                "paper's fit".into(),
                v,
                "Sforza & Pellacini 2022, Appendix A".into(),
            ));
        }

        let mut out = Vec::new();
        for (name, comp, note) in &variants {
            let stats = comp
                .as_ref()
                .ok()
                .map(|c| furnace_stats(&points, &furnace_values(material, &points, &lobes, c)));
            out.push(FurnaceVariant {
                name: name.clone(),
                stats,
                note: match comp {
                    Ok(_) => note.clone(),
                    Err(e) => e.clone(),
                },
            });
        }

        // spheres: none, the report's LUT, the chosen fit (and the paper's fit)
        let sphere_lut = lut_name(main_lut);
        let sphere_rows: Vec<&(String, std::result::Result<Compensation, String>, String)> =
            variants
                .iter()
                .filter(|v| {
                    !v.0.starts_with("exact table")
                        && !v.0.starts_with("best-")
                        && (!v.0.starts_with("LUT") || v.0 == sphere_lut)
                })
                .collect();
        let comps: Vec<Compensation> = sphere_rows
            .iter()
            .filter_map(|v| v.1.as_ref().ok().cloned())
            .collect();
        let point = |r: f64, mu: f64| self.sphere_point(&data, r, mu);
        let mut columns =
            sphere_columns(material, &point, &self.options.sphere_roughness, &comps).into_iter();
        let rows: Vec<SphereRow> = sphere_rows
            .iter()
            .map(|v| {
                let cols = match &v.1 {
                    Ok(_) => Ok(columns
                        .next()
                        .expect("one column set per available compensation")),
                    Err(e) => Err(format!("not available: {e}")),
                };
                let note = match &cols {
                    Ok(c) => format!(
                        "max |1 − E| = {}",
                        plot::format_number(
                            c.iter()
                                .flat_map(|s| s.values.iter())
                                .map(|e| (1.0 - e).abs())
                                .fold(0.0, f64::max)
                        )
                    ),
                    Err(_) => String::new(),
                };
                SphereRow {
                    label: v.0.clone(),
                    note,
                    columns: cols,
                }
            })
            .collect();
        let f0 = material.fixed_f0().or_else(|| {
            data.axes
                .iter()
                .any(|a| a == "f0")
                .then_some(self.options.sphere_f0)
        });
        let f0_text = match f0 {
            Some(f0) => format!(", F0 = {}", plot::format_number(f0)),
            None => String::new(),
        };
        let column_labels: Vec<String> = self
            .options
            .sphere_roughness
            .iter()
            .map(|r| format!("r = {}", plot::format_number(*r)))
            .collect();
        let caption = "Orthographic view of spheres under a uniform white environment: pixel = albedo E of the BSDF at μ = n·v (computed by quadrature). Faint circles outline the spheres.".to_string();
        let dev_caption = "Pixel = E − 1 of the compensated BSDF on a symmetric log colour scale (|E − 1| below the bar's smallest tick is white). Faint circles outline the spheres.".to_string();
        let albedo_fig = SphereFigure {
            title: format!("White furnace: {}{f0_text}", material.label()),
            column_labels: column_labels.clone(),
            rows: rows.clone(),
            show: Show::Albedo,
            scale: ColorScale::Gray { lo: 0.0, hi: 1.0 },
            colorbar_label: "E (pixel value, linear; shown sRGB)".into(),
            caption: caption.clone(),
        };
        let mut images = Vec::new();
        let stem = dir.join(format!("furnace-{}", material.id()));
        images.extend(plot::save(&albedo_fig, &stem, Formats::Png)?);
        let compensated: Vec<SphereRow> = rows
            .into_iter()
            .filter(|r| r.label != "no compensation")
            .collect();
        let deviations: Vec<f64> = compensated
            .iter()
            .filter_map(|r| r.columns.as_ref().ok())
            .flat_map(|c| c.iter().flat_map(|s| s.values.iter().map(|e| e - 1.0)))
            .collect();
        let dev_fig = SphereFigure {
            title: format!(
                "White furnace, E − 1 of the compensated BSDFs: {}{f0_text}",
                material.label()
            ),
            column_labels,
            rows: compensated,
            show: Show::Deviation,
            scale: ColorScale::signed_log_for(&deviations, 4.0),
            colorbar_label: "E − 1 (red: energy gain, blue: loss)".into(),
            caption: dev_caption,
        };
        images.extend(plot::save(
            &dev_fig,
            &dir.join(format!("furnace-{}-deviation", material.id())),
            Formats::Png,
        )?);
        let images = images
            .iter()
            .map(|p| {
                p.strip_prefix(&self.options.reports_dir)
                    .unwrap_or(p)
                    .to_string_lossy()
                    .replace('\\', "/")
            })
            .collect();
        Ok(FurnaceRow {
            material: material.label(),
            id: material.id(),
            points: points.len(),
            quadrature_error,
            unconverged,
            variants: out,
            images,
        })
    }

    /// The paper comparison: both fits measured on the furnace table in the paper's convention,
    /// with their furnace max |1 − E|.
    fn paper_row(&self, id: ModelId, link: inputs::PaperLink) -> Result<PaperRow> {
        let name = id.key();
        let data = self.data(link.model)?;
        let mut notes = Vec::new();
        let (paper_fit, _, paper_measured) = data
            .paper
            .as_ref()
            .ok_or_else(|| Error::InvalidInput(format!("{name}: the paper's fit did not load")))?;
        let material = compensated_for(link.model).into_iter().next();
        let others: Vec<Rc<ModelData>> = match &material {
            Some(m) => m.albedos()[1..]
                .iter()
                .map(|&o| self.data(o))
                .collect::<Result<_>>()?,
            None => Vec::new(),
        };
        // the lobe integrals do not depend on the compensation: computed once for both fits
        let points = self.furnace_points(&data);
        let lobes: RefCell<Option<Vec<_>>> = RefCell::new(None);
        let furnace_of = |sources: Vec<&dyn Albedo>| -> Option<f64> {
            let m = material.as_deref()?;
            let mut lobes = lobes.borrow_mut();
            let lobes = lobes.get_or_insert_with(|| lobe_integrals_at(m, &points));
            let values = furnace_values(m, &points, lobes, &Compensation::With(sources));
            Some(furnace_stats(&points, &values).max_deviation)
        };
        let other_sources = |pick: &dyn for<'d> Fn(&'d ModelData) -> Option<&'d dyn Albedo>| {
            others
                .iter()
                .map(|d| pick(d))
                .collect::<Option<Vec<&dyn Albedo>>>()
        };
        let paper_fit_furnace = match other_sources(&|d| d.paper.as_ref().map(|p| &p.1 as _)) {
            Some(rest) => {
                let mut s: Vec<&dyn Albedo> = vec![&data.paper.as_ref().expect("checked").1];
                s.extend(rest);
                furnace_of(s)
            }
            None => None,
        };
        let (furnace_fit, furnace_fit_furnace) = match (data.chosen, &data.chosen_albedo) {
            (Some(k), Some(f)) => {
                let ff = match other_sources(&|d| d.chosen_albedo.as_ref().map(|a| a as _)) {
                    Some(rest) => {
                        let mut s: Vec<&dyn Albedo> = vec![f];
                        s.extend(rest);
                        furnace_of(s)
                    }
                    None => {
                        let m = material.as_deref().expect("others come from a material");
                        let j = others
                            .iter()
                            .position(|o| o.chosen_albedo.is_none())
                            .unwrap_or(0);
                        notes.push(format!(
                            "the furnace number of furnace's {} fit needs a {} fit too",
                            m.albedo_role(0),
                            m.albedo_role(j + 1)
                        ));
                        None
                    }
                };
                (Some(data.fit_row(k)), ff)
            }
            _ => {
                notes.push(format!(
                    "no furnace fit of {}: run `furnace fit --model {}{} --sweep` first",
                    data.name,
                    name,
                    if link.model.is_radiance() {
                        " --transmission radiance"
                    } else {
                        ""
                    }
                ));
                (None, None)
            }
        };
        Ok(PaperRow {
            paper_table: link.stem.to_string(),
            convention_model: data.name.clone(),
            resolution: data.table.spec.resolution_name(),
            furnace_fit,
            furnace_fit_furnace,
            paper_fit: fit_row("paper", paper_fit, paper_measured),
            paper_fit_furnace,
            notes,
        })
    }

    fn section_markdown(&self, data: &ModelData, s: &ModelSummary) -> String {
        let mut md = String::new();
        let name = &s.model;
        let _ = writeln!(md, "### {name}\n");
        let _ = writeln!(md, "{}.\n", s.description.trim_end_matches('.'));
        let _ = writeln!(
            md,
            "Table: {} nodes over the default domain, largest per-cell quadrature error estimate {}; fits are measured against it at every node.\n",
            s.resolution,
            fmt_e(s.table_max_error_estimate)
        );
        let link = |f: &str| format!("{name}/{f}");
        let has = |f: &str| s.files.iter().any(|x| *x == link(f));

        let _ = writeln!(md, "#### Error against number of coefficients\n");
        if data.fits.fits.is_empty() {
            let _ = writeln!(
                md,
                "No fits found under `fits/{}/`: run `furnace fit --model {} --sweep` first.\n",
                data.model.id().key(),
                data.model.id().name()
            );
        }
        for n in &data.fits.notes {
            let _ = writeln!(md, "- {n}");
        }
        if !data.fits.notes.is_empty() {
            md.push('\n');
        }
        if has("error-vs-coefficients.png") {
            let _ = writeln!(
                md,
                "![{name}: MAE and max error against number of coefficients]({}) ([SVG]({}))\n",
                link("error-vs-coefficients.png"),
                link("error-vs-coefficients.svg")
            );
        }
        if !s.fits.is_empty() || data.paper.is_some() {
            let _ = writeln!(md, "| fit | form | coefficients | MAE | max error | max rel. error | pole-free | as fitted: MAE / max |");
            let _ = writeln!(
                md,
                "| --- | --- | ---: | ---: | ---: | ---: | :---: | ---: |"
            );
            let mut order: Vec<usize> = (0..s.fits.len()).collect();
            order.sort_by(|&a, &b| {
                (
                    s.fits[a].form.starts_with("rational"),
                    s.fits[a].n_coefficients,
                    &s.fits[a].source,
                )
                    .cmp(&(
                        s.fits[b].form.starts_with("rational"),
                        s.fits[b].n_coefficients,
                        &s.fits[b].source,
                    ))
            });
            for k in order {
                let f = &s.fits[k];
                let chosen = if s.chosen == Some(k) {
                    " **(chosen)**"
                } else {
                    ""
                };
                let _ = writeln!(
                    md,
                    "| `{}`{chosen} | {} | {} | {} | {} | {} | {} | {} / {} |",
                    f.source,
                    f.form,
                    f.n_coefficients,
                    fmt_e(f.measured.mae),
                    fmt_e(f.measured.max_abs),
                    fmt_e(f.measured.max_rel),
                    if f.usable { "yes" } else { "no" },
                    fmt_e(f.reported_mae),
                    fmt_e(f.reported_max)
                );
            }
            if let Some((fit, _, m)) = &data.paper {
                let _ = writeln!(
                    md,
                    "| paper (published) | {} | {} | {} | {} | {} | {} | {} / {} |",
                    short_form(&fit.form),
                    fit.n_coefficients,
                    fmt_e(m.mae),
                    fmt_e(m.max_abs),
                    fmt_e(m.max_rel),
                    if fit.is_usable() { "yes" } else { "no" },
                    fmt_e(fit.metrics.mae),
                    fmt_e(fit.metrics.max_abs_error)
                );
            }
            let _ = writeln!(md, "\n\"As fitted\" is what the fit file records (on the data it was fitted to; for the paper, its own 32-point table).\n");
        }

        if let Some(og) = &s.off_grid {
            let _ = writeln!(md, "#### Off-grid errors: fits against LUTs\n");
            let _ = writeln!(
                md,
                "Every fit of the sweep and the multilinear LUTs of the same model, measured at the same points against the exact values: {}.\n",
                og.check_set
            );
            if has("off-grid.png") {
                let _ = writeln!(
                    md,
                    "![{name}: off-grid error against stored values]({}) ([SVG]({}))\n",
                    link("off-grid.png"),
                    link("off-grid.svg")
                );
            }
            md.push_str(&offgrid_markdown(og, &data.sweep_points, data.dims()));
        }

        let _ = writeln!(md, "#### Error of the chosen fit over the domain\n");
        if has("heatmap-abs.png") {
            let _ = writeln!(
                md,
                "![{name}: |fit − table|]({}) ([SVG]({}))\n",
                link("heatmap-abs.png"),
                link("heatmap-abs.svg")
            );
            let _ = writeln!(
                md,
                "![{name}: fit − table]({}) ([SVG]({}))\n",
                link("heatmap-signed.png"),
                link("heatmap-signed.svg")
            );
        } else {
            let _ = writeln!(
                md,
                "No chosen fit yet (run `furnace fit --model {} --sweep` first).\n",
                data.model.id().name()
            );
        }
        let _ = writeln!(md, "#### Slices E(μ) at several r\n");
        if has("slices.png") {
            let _ = writeln!(
                md,
                "![{name}: E(μ) slices]({}) ([SVG]({}))\n",
                link("slices.png"),
                link("slices.svg")
            );
        }

        if let Some(p) = &s.paper {
            let _ = writeln!(
                md,
                "#### Against the paper's published fit (`{}`)\n",
                p.paper_table
            );
            let _ = writeln!(md, "{}\n", paper_table_markdown(std::slice::from_ref(p)));
            for n in &p.notes {
                let _ = writeln!(md, "- {n}");
            }
            if !p.notes.is_empty() {
                md.push('\n');
            }
        }

        if !s.furnace.is_empty() {
            let _ = writeln!(md, "#### White furnace test\n");
            let _ = writeln!(md, "max |1 − E| of the energy-compensated BSDF, E integrated by quadrature of the BSDF over incident directions (`furnace::material::furnace`), at table nodes.\n");
            for row in &s.furnace {
                let _ = writeln!(
                    md,
                    "**{}** ({} points; quadrature error estimate ≤ {}{})\n",
                    row.material,
                    row.points,
                    fmt_e(row.quadrature_error),
                    if row.unconverged > 0 {
                        format!(", {} points unconverged", row.unconverged)
                    } else {
                        String::new()
                    }
                );
                let _ = writeln!(md, "| compensation | max \\|1 − E\\| | at | mean \\|1 − E\\| | E range | albedo source |");
                let _ = writeln!(md, "| --- | ---: | --- | ---: | --- | --- |");
                for v in &row.variants {
                    match &v.stats {
                        Some(st) => {
                            let _ = writeln!(
                                md,
                                "| {} | {} | {} | {} | [{}, {}] | {} |",
                                v.name,
                                fmt_e(st.max_deviation),
                                fmt_point(&st.at, &data_axes_for(&row.id, &data.axes)),
                                fmt_e(st.mean_deviation),
                                fmt_f(st.min_albedo),
                                fmt_f(st.max_albedo),
                                v.note
                            );
                        }
                        None => {
                            let _ = writeln!(md, "| {} | – | | | | {} |", v.name, v.note);
                        }
                    }
                }
                md.push('\n');
                for img in &row.images {
                    let _ = writeln!(md, "![{}]({img})\n", row.material);
                }
            }
        }
        md
    }
}

/// The off-grid tables of a section: the best fits and the LUTs (with the flag of a best fit
/// that loses to the [`offgrid::LUT_TO_BEAT`]-per-axis LUT), then the lowest max error of every
/// form family within each budget.
fn offgrid_markdown(og: &OffGridSummary, points: &[SweepPoint], dims: usize) -> String {
    let mut md = String::new();
    let losing: Vec<usize> = og
        .best
        .iter()
        .filter(|b| og.loses(b))
        .map(|b| b.budget)
        .collect();
    let _ = writeln!(
        md,
        "| albedo source | form | stored values | max error | MAE |"
    );
    let _ = writeln!(md, "| --- | --- | ---: | ---: | ---: |");
    for b in &og.best {
        let flag = if losing.contains(&b.budget) {
            format!(" (loses to the LUT {})", offgrid::LUT_TO_BEAT)
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| `{}`{flag} | {} | {} | {} | {} |",
            b.file,
            b.form,
            b.n_coefficients,
            fmt_e(b.max_abs_error),
            fmt_e(b.mae)
        );
    }
    for l in &og.luts {
        let _ = writeln!(
            md,
            "| LUT {} | {} | {} | {} | {} |",
            vec![l.per_axis.to_string(); dims].join("×"),
            if dims == 2 { "bilinear" } else { "trilinear" },
            l.values,
            fmt_e(l.errors.max_abs_error),
            fmt_e(l.errors.mae)
        );
    }
    md.push('\n');
    let families = offgrid::families(points);
    if !families.is_empty() {
        let budgets = crate::fit::job::default_budgets(dims);
        let _ = writeln!(
            md,
            "Lowest off-grid max error of each form family of the sweep within each budget (max / MAE, coefficients):\n"
        );
        let _ = writeln!(
            md,
            "| form family | {} |",
            budgets
                .iter()
                .map(|b| format!("≤ {b}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(md, "| --- |{}", " ---: |".repeat(budgets.len()));
        for f in &families {
            let cells: Vec<String> = budgets
                .iter()
                .map(|&b| {
                    offgrid::lowest_max_within(points, f, b).map_or("–".into(), |p| {
                        format!(
                            "{} / {} ({})",
                            fmt_e(p.max_abs_error),
                            fmt_e(p.mae),
                            p.n_coefficients
                        )
                    })
                })
                .collect();
            let _ = writeln!(md, "| {f} | {} |", cells.join(" | "));
        }
        md.push('\n');
    }
    md
}

/// Axis names for a furnace row (its albedo model's).
fn data_axes_for(_id: &str, axes: &[String]) -> Vec<String> {
    axes.to_vec()
}

/// `{:.2e}`, or "–" for a non-finite value.
pub fn fmt_e(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2e}")
    } else {
        "–".into()
    }
}

/// `{:.4}`, or "–".
pub fn fmt_f(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "–".into()
    }
}

/// "r = 0.5, μ = 0.25".
fn fmt_point(x: &[f64], axes: &[String]) -> String {
    let names: Vec<String> = if axes.len() == x.len() {
        axes.to_vec()
    } else if x.len() == 3 {
        vec!["f0".into(), "r".into(), "mu".into()]
    } else {
        vec!["r".into(), "mu".into()]
    };
    x.iter()
        .zip(names)
        .map(|(v, n)| {
            format!(
                "{} = {}",
                if n == "mu" { "μ".to_string() } else { n },
                plot::format_number(*v)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The side-by-side table of furnace's fit and the paper's published fit.
pub fn paper_table_markdown(rows: &[PaperRow]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "| paper table | measured on | fit | form | coefficients | MAE | max error | furnace max \\|1 − E\\| |");
    let _ = writeln!(md, "| --- | --- | --- | --- | ---: | ---: | ---: | ---: |");
    for p in rows {
        let on = format!("`{}` {}", p.convention_model, p.resolution);
        match &p.furnace_fit {
            Some(f) => {
                let _ = writeln!(
                    md,
                    "| {} | {on} | furnace (`{}`) | {} | {} | {} | {} | {} |",
                    p.paper_table,
                    f.source,
                    f.form,
                    f.n_coefficients,
                    fmt_e(f.measured.mae),
                    fmt_e(f.measured.max_abs),
                    p.furnace_fit_furnace.map_or("–".into(), fmt_e)
                );
            }
            None => {
                let _ = writeln!(
                    md,
                    "| {} | {on} | furnace | no fit yet | | | | |",
                    p.paper_table
                );
            }
        }
        let f = &p.paper_fit;
        let _ = writeln!(
            md,
            "| {} | {on} | paper (published) | {} | {} | {} | {} | {} |",
            p.paper_table,
            f.form,
            f.n_coefficients,
            fmt_e(f.measured.mae),
            fmt_e(f.measured.max_abs),
            p.paper_fit_furnace.map_or("–".into(), fmt_e)
        );
    }
    md.trim_end().to_string()
}

/// (path relative to `dir`, SHA-256) of every file under `dir`, recursively, sorted; none if
/// `dir` does not exist.
fn files_digest(dir: &Path) -> Result<Vec<(String, String)>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, String)>) -> Result<()> {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return Ok(());
        };
        let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        for p in paths {
            if p.is_dir() {
                walk(root, &p, out)?;
            } else if p.extension().is_some_and(|e| e == "json") {
                let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
                out.push((
                    p.strip_prefix(root)
                        .unwrap_or(&p)
                        .to_string_lossy()
                        .replace('\\', "/"),
                    sha256_hex(&bytes),
                ));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    Ok(out)
}

/// Relative spread below which the values of a chart are shown as offsets from a constant: tick
/// labels of 3 significant digits could not tell them apart (EON's albedo is 1 to 1e-9).
const NEARLY_CONSTANT: f64 = 1e-4;

/// If every y value of `series` lies within [`NEARLY_CONSTANT`]·max(1, |y|) of the others,
/// subtracts their midpoint (rounded to 3 significant digits) and returns it.
fn offset_nearly_constant(series: &mut [Series]) -> Option<f64> {
    let ys = series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
        (lo.min(y), hi.max(y))
    });
    if !(lo.is_finite() && hi.is_finite()) || hi - lo >= NEARLY_CONSTANT * hi.abs().max(1.0) {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    let c: f64 = plot::format_number(mid).parse().unwrap_or(mid);
    for s in series.iter_mut() {
        for p in &mut s.points {
            p.1 -= c;
        }
    }
    Some(c)
}

/// Node index of `axis` nearest to `v`.
fn nearest_node(axis: &crate::table::GridAxis, v: f64) -> usize {
    let t = ((v - axis.lo) / (axis.hi - axis.lo)).clamp(0.0, 1.0) * (axis.n - 1) as f64;
    t.round() as usize
}

/// Indices of `count` slices of an axis of `n` nodes: both ends and odd interior nodes in between
/// (odd, so that the interior slices fall between the nodes of a LUT taking every other node).
pub fn slice_indices(n: usize, count: usize) -> Vec<usize> {
    if n <= count || count < 2 {
        return (0..n).collect();
    }
    let mut v = vec![0, n - 1];
    for k in 1..count - 1 {
        let t = k as f64 * (n - 1) as f64 / (count - 1) as f64;
        let mut i = t.round() as usize;
        if i.is_multiple_of(2) {
            i = if (t - i as f64) >= 0.0 { i + 1 } else { i - 1 };
        }
        v.push(i.clamp(1, n - 2));
    }
    v.sort_unstable();
    v.dedup();
    v
}

/// Indices of at most `cap` nodes of an axis of `n` (all when n ≤ cap): both ends and odd interior
/// nodes, which a LUT taking every other node does not contain.
pub fn furnace_axis(n: usize, cap: usize) -> Vec<usize> {
    if n <= cap {
        return (0..n).collect();
    }
    slice_indices(n, cap.max(2))
}

/// Room to leave for a legend of the chart's labelled series (fraction of the y span).
fn legend_room(series: &[Series]) -> f64 {
    0.09 * series.iter().filter(|s| !s.label.is_empty()).count() as f64
}

/// Plain black for style keys in legends.
struct RGBColorKey;
impl RGBColorKey {
    fn black() -> plotters::style::RGBColor {
        plotters::style::RGBColor(0, 0, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearly_constant_values_are_shown_as_offsets() {
        let key = RGBColorKey::black();
        let mut s = vec![
            Series::new(
                "a",
                vec![(0.0, 1.0 + 1e-9), (1.0, 1.0 - 2e-9)],
                key,
                Style::Line,
            ),
            Series::new("key", vec![], key, Style::Line),
        ];
        assert_eq!(offset_nearly_constant(&mut s), Some(1.0));
        assert!((s[0].points[1].1 + 2e-9).abs() < 1e-15);
        let mut s = vec![Series::new(
            "a",
            vec![(0.0, 0.3), (1.0, 0.9)],
            key,
            Style::Line,
        )];
        assert_eq!(offset_nearly_constant(&mut s), None);
        assert_eq!(s[0].points[0].1, 0.3);
    }

    #[test]
    fn slices_include_ends_and_odd_interior_nodes() {
        assert_eq!(slice_indices(17, 3), vec![0, 9, 16]);
        assert_eq!(slice_indices(5, 7), vec![0, 1, 2, 3, 4]);
        assert_eq!(furnace_axis(65, 33).len(), 33);
        assert!(furnace_axis(65, 33)[1..32].iter().all(|i| i % 2 == 1));
        assert_eq!(furnace_axis(9, 33), (0..9).collect::<Vec<_>>());
    }

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
