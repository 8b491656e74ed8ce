//! One model's section of the report: its fits measured against its table (the paper's Fig. 3),
//! error heat maps and E(μ) slices of the chosen fit, the paper comparison, and the white furnace
//! test of the materials its albedo compensates, with sphere images.
//!
//! Everything is written under `reports/<model>/`: the figures, `section.md` (the section's
//! markdown, with links relative to `reports/`, included in `reports/README.md`) and
//! `summary.json` (the numbers the README's summary tables are assembled from, so that
//! `furnace report --model M` can update one model and rebuild the README).
//!
//! - `summary`: the section's summary types (`summary.json`).
//! - `data`: a model's table, LUTs, fits and paper fit, loaded once per report run.
//! - `reuse`: the digest of a section's inputs, and whether a written section can be reused.
//! - `figures`: Fig. 3, the off-grid chart, heat maps and E(μ) slices.
//! - `furnace`: the white furnace test of a material and its sphere images.
//! - `paper`: the comparison with the paper's published fit.
//! - `section`: the section's markdown.
//! - `nodes`: which table nodes the slices and the furnace grid take.
//! - `format`: number and point formatting of the markdown.

mod data;
mod figures;
mod format;
mod furnace;
mod nodes;
mod paper;
pub(crate) mod reuse;
mod section;
mod summary;

pub use format::{fmt_e, fmt_f};
pub use nodes::{furnace_axis, slice_indices};
pub use paper::paper_table_markdown;
pub use summary::{
    Dependency, FileHash, FitRow, FurnaceRow, FurnaceVariant, ModelSummary, PaperRow,
};

use crate::bsdf::ModelId;
use crate::digest::sha256_hex;
use crate::error::{Error, Result};
use crate::material::compensated_for;
use crate::report::inputs::{paper_link, TableProvider};
use data::ModelData;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

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
    /// Nodes of (r, aniso, mu, phi) of the anisotropic conductor's section
    /// ([`crate::report::aniso`]); None leaves the section out.
    pub anisotropy: Option<Vec<usize>>,
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
            anisotropy: Some(crate::report::aniso::DEFAULT_RESOLUTION.to_vec()),
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

    /// The option of `furnace report` that sets [`Self::resolution`].
    fn resolution_option(dims: usize) -> &'static str {
        if dims <= 2 {
            "--resolution-2d"
        } else {
            "--resolution-3d"
        }
    }

    /// The option of `furnace report` that sets [`Self::lut`].
    fn lut_option(dims: usize) -> &'static str {
        if dims <= 2 {
            "--lut-2d"
        } else {
            "--lut-3d"
        }
    }

    fn lut(&self, dims: usize) -> usize {
        if dims <= 2 {
            self.lut_2d
        } else {
            self.lut_3d
        }
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
    /// The table source.
    pub(crate) fn tables(&self) -> &dyn TableProvider {
        self.tables
    }
    /// Where progress messages go.
    pub(crate) fn progress(&self) -> &dyn Fn(&str) {
        self.progress
    }
    fn model_dir(&self, name: &str) -> PathBuf {
        self.options.reports_dir.join(name)
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
}
