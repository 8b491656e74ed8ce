//! What one run of the pipeline does: a [`Job`] lists the tables, says how each is fitted
//! ([`FitStage`]), what is emitted ([`EmitStage`]), whether a report is written, and where
//! everything is read and written. [`crate::pipeline::run`] runs any job.
//!
//! `furnace run` knows two jobs, made by two constructors:
//!
//! | | [`Job::default_set`] | [`Job::scene`] |
//! |---|---|---|
//! | tables | every model of [`crate::bsdf::default_set`] and [`PAPER_RADIANCE_MODELS`], over its default domain | what the manifest's materials read ([`crate::scene::plan`]), over the union of their ranges |
//! | fits | [`FitStage::Sweep`]: best fit per coefficient budget | [`FitStage::OnePerTable`]: the manifest's rational |
//! | emit | [`EmitStage::EachFit`]: code next to every best fit, a LUT per table | [`EmitStage::OneFilePerLanguage`]: `<scene>.rs`, … with the helpers the materials use |
//! | report | `reports/` | none |
//!
//! The stages are independent choices: a library user may, say, sweep a scene's tables
//! (`job.fit = FitStage::Sweep { max_degree: None }`) or report on it.

use crate::bsdf::{self, ModelId, Side, Transmission};
use crate::emit::Lang;
use crate::error::{Error, Result};
use crate::material;
use crate::math::SmithForm;
use crate::quadrature::QuadratureSettings;
use crate::report::model::ReportOptions;
use crate::scene::{self, FitSettings, Manifest, DEFAULT_RESOLUTION_2D, DEFAULT_RESOLUTION_3D};
use std::path::{Path, PathBuf};

use super::scene::RunOptions;

/// Largest nodes per axis of the radiance-form tables, which exist only to set furnace's fit
/// beside the paper's published one: 32³ is what a sweep fits on anyway
/// (`job::default_sweep_points`).
pub const RUN_RESOLUTION_PAPER_RADIANCE: usize = 32;

/// Nodes per axis of the LUTs `furnace run` emits.
pub const RUN_LUT_RESOLUTION: usize = 32;

/// Models also tabulated and fitted with radiance-form transmission (×1/η² entering, ×η²
/// leaving): the paper's two dielectric tables are in that form, and its published fits are
/// compared with furnace's on the same convention.
pub const PAPER_RADIANCE_MODELS: &[ModelId] = &[
    ModelId::ggx_dielectric(Side::Entering, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
    ModelId::ggx_dielectric(Side::Leaving, SmithForm::Separable)
        .with_transmission(Transmission::Radiance),
];

/// One table of a job: a registered model over a box of its axes.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedTable {
    pub model: ModelId,
    /// One (lo, hi) per axis of the model.
    pub ranges: Vec<(f64, f64)>,
    /// Nodes per axis.
    pub resolution: Vec<usize>,
    /// What reads it: a scene's materials, or the material classes of the default set.
    pub used_by: Vec<String>,
}

impl PlannedTable {
    /// `model` over its default domain, at `n` nodes per axis.
    pub fn default_domain(model: ModelId, n: usize) -> Result<PlannedTable> {
        let axes = bsdf::get(model)?.axes();
        Ok(PlannedTable {
            model,
            ranges: axes.iter().map(|a| a.default_range).collect(),
            resolution: vec![n; axes.len()],
            used_by: Vec::new(),
        })
    }
}

/// How a job fits each table (output `E`).
#[derive(Clone, Debug, PartialEq)]
pub enum FitStage {
    /// The degree sweep of the model's default forms ([`crate::fit::defaults::default_plan`],
    /// degrees up to `max_degree`, default the paper's): `<fits>/<model>/sweep.{json,csv}`,
    /// `best-<N>.json` per coefficient budget and `off-grid.json`, reused rather than redone
    /// when its inputs are unchanged ([`super::sweeps`]).
    Sweep { max_degree: Option<u32> },
    /// One rational of the given degrees per table (`<fits>/<model>.json`), certified
    /// pole-free and, with `stress_points` > 0, passing the f32 stress test
    /// ([`super::scene::fit_table`]).
    OnePerTable {
        degrees: FitSettings,
        stress_points: usize,
    },
}

/// What a job emits from its fits.
#[derive(Clone, Debug, PartialEq)]
pub enum EmitStage {
    /// Rust, WGSL, GLSL, HLSL and C/C++ next to each fit file, with every helper the material
    /// classes write for its model, and one LUT of `lut_resolution` nodes per axis per table
    /// (compared with the table's last fit), reused when the inputs are unchanged
    /// ([`super::emits`]). Radiance-form tables are not emitted.
    EachFit { lut_resolution: usize },
    /// One file per language, `<fits>/<job name>.<ext>`, with the function of every table's
    /// fit (a sweep's largest-budget best fit) and only the helpers named; with [`Lang::Lut`],
    /// a LUT of `lut_resolution` nodes per axis per table. `command` is quoted in the headers.
    OneFilePerLanguage {
        langs: Vec<Lang>,
        helpers: Vec<String>,
        lut_resolution: usize,
        command: String,
    },
}

/// What a run of the pipeline does and where it reads and writes.
#[derive(Clone, Debug)]
pub struct Job {
    /// Names the run in its log, and the files of [`EmitStage::OneFilePerLanguage`].
    pub name: String,
    /// The tables, in order (registered models: [`crate::bsdf::register`] adds a user's).
    pub tables: Vec<PlannedTable>,
    pub fit: FitStage,
    pub emit: EmitStage,
    /// The report's folders and grids; `None` skips the report.
    pub report: Option<ReportOptions>,
    /// Table cache (`data`); sweep timings go to `<data_dir>/timing`.
    pub data_dir: PathBuf,
    /// Fits and emitted code (`fits`; a scene's `fits/<scene>`).
    pub fits_dir: PathBuf,
    /// LUTs (`data/lut`).
    pub lut_dir: PathBuf,
    pub quadrature: QuadratureSettings,
    /// Recompute tables even when cached (implies [`Job::refit`]).
    pub force: bool,
    /// Redo every sweep and emit even when its inputs are unchanged.
    pub refit: bool,
    /// Stop after the tables.
    pub tables_only: bool,
    /// The anisotropic conductor's budget fits ([`super::aniso`]) on a table of these nodes per
    /// axis (the report's section reads them); None leaves them out.
    pub anisotropic_fits: Option<Vec<usize>>,
}

impl Job {
    /// The default set at full size: every model of [`crate::bsdf::default_set`] (which
    /// [`crate::bsdf::register_in_default_set`] extends) at [`DEFAULT_RESOLUTION_2D`]² or
    /// [`DEFAULT_RESOLUTION_3D`]³, then [`PAPER_RADIANCE_MODELS`] at
    /// [`RUN_RESOLUTION_PAPER_RADIANCE`]³, each over its default domain and swept; code next to
    /// every best fit, [`RUN_LUT_RESOLUTION`]-per-axis LUTs and the report; reading and writing
    /// `data/`, `fits/` and `reports/` under `root` (the paper's data from `root/data/paper`
    /// when it is there).
    pub fn default_set(root: &Path) -> Job {
        let mut report = ReportOptions::new(root);
        let paper = root.join("data").join("paper");
        report.paper_dir = paper.join("coefficients").is_dir().then_some(paper);
        let mut job = Job {
            name: "default set".into(),
            tables: bsdf::default_set()
                .into_iter()
                .chain(PAPER_RADIANCE_MODELS.iter().copied())
                .filter_map(|id| PlannedTable::default_domain(id, 2).ok())
                .map(|mut t| {
                    t.used_by = classes_reading(t.model);
                    t
                })
                .collect(),
            fit: FitStage::Sweep { max_degree: None },
            emit: EmitStage::EachFit {
                lut_resolution: RUN_LUT_RESOLUTION,
            },
            report: Some(report),
            data_dir: root.join("data"),
            fits_dir: root.join("fits"),
            lut_dir: root.join("data").join("lut"),
            quadrature: QuadratureSettings::default(),
            force: false,
            refit: false,
            tables_only: false,
            anisotropic_fits: Some(crate::report::aniso::DEFAULT_RESOLUTION.to_vec()),
        };
        job.set_resolution(DEFAULT_RESOLUTION_2D, DEFAULT_RESOLUTION_3D);
        job
    }

    /// A scene: the tables its materials need over the union of their ranges
    /// ([`crate::scene::plan`]), one stress-tested rational per table, one file per language
    /// with only the helpers its materials use, no report; the fits and code go to
    /// `<opts.fits_dir>/<scene name>/`.
    pub fn scene(manifest: &Manifest, opts: &RunOptions) -> Result<Job> {
        let plan = scene::plan(manifest)?;
        Ok(Job {
            name: plan.scene.clone(),
            tables: plan
                .tables
                .iter()
                .map(|t| PlannedTable {
                    model: t.model,
                    ranges: t.ranges.clone(),
                    resolution: t.resolution.clone(),
                    used_by: t.used_by.clone(),
                })
                .collect(),
            fit: FitStage::OnePerTable {
                degrees: plan.fit.clone(),
                stress_points: opts.stress_points,
            },
            emit: EmitStage::OneFilePerLanguage {
                langs: opts.langs.clone(),
                helpers: plan.helper_names(),
                lut_resolution: opts.lut_resolution,
                command: opts.command.clone(),
            },
            report: None,
            data_dir: opts.data_dir.clone(),
            fits_dir: opts.fits_dir.join(&plan.scene),
            lut_dir: opts.lut_dir.clone(),
            quadrature: opts.quadrature.clone(),
            force: opts.force,
            refit: false,
            tables_only: false,
            anisotropic_fits: None,
        })
    }

    /// Nodes per axis: `two_d` for 2-D tables, `three_d` for 3-D ones (radiance-form tables:
    /// at most [`RUN_RESOLUTION_PAPER_RADIANCE`]); tables of more axes keep theirs.
    pub fn set_resolution(&mut self, two_d: usize, three_d: usize) {
        for t in &mut self.tables {
            let n = match (t.resolution.len(), t.model.is_radiance()) {
                (2, _) => two_d,
                (3, false) => three_d,
                (3, true) => three_d.min(RUN_RESOLUTION_PAPER_RADIANCE),
                _ => continue,
            };
            t.resolution.fill(n);
        }
    }

    /// Keeps only the tables of the models named (by their cache names,
    /// `ggx-dielectric-separable-radiance`), and the anisotropic fits if their model is named;
    /// refused for a name not in the job.
    pub fn only(&mut self, names: &[String]) -> Result<()> {
        let aniso = self
            .anisotropic_fits
            .as_ref()
            .map(|_| super::aniso::model().key());
        for m in names {
            if !self.tables.iter().any(|t| &t.model.key() == m) && aniso.as_ref() != Some(m) {
                let known: Vec<String> = self
                    .tables
                    .iter()
                    .map(|t| t.model.key())
                    .chain(aniso.clone())
                    .collect();
                return Err(Error::InvalidInput(format!(
                    "--models: '{m}' is not in the {}; choose from {}",
                    self.name,
                    known.join(", ")
                )));
            }
        }
        self.tables.retain(|t| names.contains(&t.model.key()));
        if aniso.is_some_and(|a| !names.contains(&a)) {
            self.anisotropic_fits = None;
        }
        Ok(())
    }

    /// The report on tiny grids (9² / 5³ tables, 3- and 5-per-axis LUTs, 2 sphere columns): for
    /// tests and trials.
    pub fn quick_report(&mut self) {
        if let Some(o) = &mut self.report {
            o.resolution_2d = 9;
            o.resolution_3d = 5;
            o.lut_2d = 5;
            o.lut_3d = 3;
            o.furnace_luts = vec![3];
            o.furnace_nodes = 9;
            o.furnace_f0_slices = 2;
            o.sphere_roughness = vec![0.3, 1.0];
            o.anisotropy = Some(crate::report::aniso::QUICK_RESOLUTION.to_vec());
        }
        if self.anisotropic_fits.is_some() {
            self.anisotropic_fits = Some(crate::report::aniso::QUICK_RESOLUTION.to_vec());
        }
    }

    /// The number of stages the job runs (1 tables only, 3 without the report, else 4).
    pub fn stages(&self) -> usize {
        if self.tables_only {
            1
        } else if self.report.is_none() {
            3
        } else {
            4
        }
    }

    /// The tables of the job, one line each: model, nodes, ranges, what reads it.
    pub fn human(&self) -> String {
        let mut s = format!("{}: {} table(s)\n", self.name, self.tables.len());
        for t in &self.tables {
            s.push_str(&format!(
                "  {:<38} {:>12}  {}  for {}\n",
                t.model,
                t.resolution
                    .iter()
                    .map(|n| n.to_string())
                    .collect::<Vec<_>>()
                    .join("x"),
                t.ranges
                    .iter()
                    .map(|(a, b)| format!("[{a:.4}, {b:.4}]"))
                    .collect::<Vec<_>>()
                    .join(" × "),
                if t.used_by.is_empty() {
                    "the report".to_string()
                } else {
                    t.used_by.join(", ")
                }
            ));
        }
        s
    }
}

/// The kinds of the registered material classes that read `model`'s table (in either Smith
/// form), in registry order.
fn classes_reading(model: ModelId) -> Vec<String> {
    material::classes()
        .iter()
        .filter(|c| {
            [SmithForm::HeightCorrelated, SmithForm::Separable]
                .into_iter()
                .any(|smith| c.tables(smith).iter().any(|t| t.model == model))
        })
        .map(|c| c.kind().to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_set_is_the_registry_s_at_full_size_over_default_domains() {
        let job = Job::default_set(Path::new("root"));
        let models: Vec<ModelId> = job.tables.iter().map(|t| t.model).collect();
        let mut want = bsdf::default_set();
        want.extend(PAPER_RADIANCE_MODELS);
        assert_eq!(models, want);
        for t in &job.tables {
            let axes = bsdf::get(t.model).unwrap().axes();
            let n = match (axes.len(), t.model.is_radiance()) {
                (2, _) => DEFAULT_RESOLUTION_2D,
                (_, false) => DEFAULT_RESOLUTION_3D,
                (_, true) => RUN_RESOLUTION_PAPER_RADIANCE,
            };
            assert_eq!(t.resolution, vec![n; axes.len()], "{}", t.model);
            let domain: Vec<(f64, f64)> = axes.iter().map(|a| a.default_range).collect();
            assert_eq!(t.ranges, domain, "{}", t.model);
        }
        let conductor = &job.tables[0];
        assert_eq!(conductor.model.key(), "ggx-conductor");
        // the conductor's table is read by conductors, thin dielectrics and glossy materials
        for kind in ["conductor", "thin-dielectric", "glossy"] {
            assert!(
                conductor.used_by.iter().any(|k| k == kind),
                "{:?}",
                conductor.used_by
            );
        }
        assert!(job.tables.iter().any(|t| t.used_by.is_empty()) && job.report.is_some());
        assert_eq!(job.stages(), 4);
        assert_eq!(
            job.fit,
            FitStage::Sweep { max_degree: None },
            "the default set sweeps"
        );
    }

    #[test]
    fn smaller_resolutions_keep_the_radiance_tables_at_most_32() {
        let mut job = Job::default_set(Path::new("root"));
        job.set_resolution(17, 9);
        job.only(&[
            "ggx-conductor".into(),
            "ggx-dielectric-separable".into(),
            "ggx-dielectric-separable-radiance".into(),
        ])
        .unwrap();
        let res: Vec<Vec<usize>> = job.tables.iter().map(|t| t.resolution.clone()).collect();
        assert_eq!(res, [vec![17; 2], vec![9; 3], vec![9; 3]]);
        job.set_resolution(17, 64);
        assert_eq!(job.tables[2].resolution, vec![32; 3]);
        let e = job.only(&["ggx-metal".into()]).unwrap_err().to_string();
        assert!(e.contains("'ggx-metal' is not in the default set; choose from ggx-conductor"));
    }

    #[test]
    fn the_anisotropic_fits_run_only_when_their_model_is_named() {
        let root = Path::new("root");
        let mut job = Job::default_set(root);
        assert_eq!(job.anisotropic_fits, Some(vec![16, 8, 16, 8]));
        job.only(&["ggx-conductor-aniso".into(), "eon".into()])
            .unwrap();
        assert_eq!(job.tables.len(), 1);
        assert!(job.anisotropic_fits.is_some());
        job.quick_report();
        assert_eq!(job.anisotropic_fits, Some(vec![5, 3, 5, 3]));
        let mut job = Job::default_set(root);
        job.only(&["eon".into()]).unwrap();
        assert_eq!(job.anisotropic_fits, None);
        let e = job.only(&["ggx-conductor-aniso".into()]).unwrap_err();
        assert!(e.to_string().contains("is not in the default set"), "{e}");
    }

    #[test]
    fn a_scene_job_is_its_plan() {
        let m = Manifest::parse(
            r#"{"name": "metals", "resolution": {"2d": 24}, "materials": [
                {"name": "gold", "kind": "conductor", "r": [0.2, 0.6]}]}"#,
            Path::new("metals.json"),
        )
        .unwrap();
        let opts = RunOptions {
            data_dir: "d".into(),
            fits_dir: "f".into(),
            lut_dir: "l".into(),
            force: false,
            quadrature: QuadratureSettings::default(),
            langs: vec![Lang::Rust],
            lut_resolution: 8,
            stress_points: 0,
            command: "c".into(),
        };
        let job = Job::scene(&m, &opts).unwrap();
        let plan = scene::plan(&m).unwrap();
        assert_eq!(job.tables.len(), plan.tables.len());
        assert_eq!(job.tables[0].ranges, plan.tables[0].ranges);
        assert_eq!(job.tables[0].used_by, ["gold"]);
        assert_eq!(job.fits_dir, Path::new("f").join("metals"));
        assert!(job.report.is_none() && job.stages() == 3);
        match &job.emit {
            EmitStage::OneFilePerLanguage { helpers, .. } => {
                assert_eq!(helpers, &plan.helper_names())
            }
            e => panic!("{e:?}"),
        }
    }
}
