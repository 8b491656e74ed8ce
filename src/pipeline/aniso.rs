//! The anisotropic conductor's fits in `furnace run`: the default degree sweep of its
//! 16 × 8 × 16 × 8 table ([`super::sweeps::sweep_or_reuse`], the table's nodes plus exact
//! training points, [`crate::fit::defaults::default_training_points`]) into
//! `fits/<model>/`, with `best-<N>.json` per budget, reused when its inputs are unchanged. The
//! model is not a table of the job's default set: its 4-D LUTs and per-model report section
//! would be tables of their own, and the report's anisotropic section reads these fits.

use super::sweeps::{best_paths, sweep_or_reuse, FitStep, SweepPlace};
use super::Job;
use crate::bsdf::{self, ModelId};
use crate::error::Result;
use crate::progress::Observer;
use crate::table::{get_or_tabulate, TableSpec};
use std::path::{Path, PathBuf};

/// The model fitted: the height-correlated anisotropic conductor of the report's section.
pub fn model() -> ModelId {
    crate::material::anisotropic::albedo_model(crate::report::aniso::SMITH)
}

/// What the step did: the model's fit folder name and its sweep.
#[derive(Clone, Debug)]
pub struct AnisoFits {
    pub name: String,
    pub step: FitStep,
}

impl AnisoFits {
    /// The best files, in budget order (what the emit stage emits).
    pub fn best_files(&self, fits_dir: &Path) -> Vec<PathBuf> {
        best_paths(&fits_dir.join(&self.name), &self.step.best)
    }
}

/// The sweep of [`model`]'s table of `resolution` nodes per axis (tabulated into the job's data
/// folder if missing), or the files of a previous sweep with the same inputs (unless the job
/// refits).
pub fn fits_or_reuse(
    job: &Job,
    resolution: &[usize],
    progress: &dyn Observer,
) -> Result<AnisoFits> {
    let id = model();
    let name = id.key();
    let model = bsdf::get(id)?;
    let spec = TableSpec::new(model.as_ref(), resolution, job.quadrature.clone())?;
    let t = get_or_tabulate(model.as_ref(), &spec, &job.data_dir, job.force, progress)?;
    let place = SweepPlace {
        dir: &job.fits_dir.join(&name),
        timing: &job.data_dir.join("timing").join(&name),
        max_degree: None,
        refit: job.refit || job.force,
    };
    let step = sweep_or_reuse(model.as_ref(), &t, place, progress)?;
    Ok(AnisoFits { name, step })
}
