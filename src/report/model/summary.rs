//! The summary of a model's section (`reports/<model>/summary.json`): its fits, furnace rows,
//! paper comparison, the models it read and the SHA-256 of its inputs and outputs.

use crate::bsdf::{self, ModelId, Transmission};
use crate::error::Result;
use crate::material::furnace::FurnaceStats;
use crate::report::inputs::Measured;
use crate::report::offgrid::OffGridSummary;
use serde::{Deserialize, Serialize};

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
