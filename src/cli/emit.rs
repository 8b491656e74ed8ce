//! `furnace emit` and `furnace stress`: thin wrappers over [`crate::emit`].

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use crate::emit::fitfile::FitFile;
use crate::emit::generate::{EvalForm, FormChoice};
use crate::emit::stress::{stress, StressOptions, DEFAULT_POINTS};
use crate::emit::{self, build_unit, parse_langs, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::table::io;

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormArg {
    /// The cheapest form that is stable in f32 (monomial, shifted, Bernstein).
    Auto,
    /// Horner in the fit's own variables and coefficients.
    Monomial,
    /// Horner in variables shifted and scaled to [-1, 1].
    Shifted,
    /// Tensor-product Bernstein form on the domain box.
    Bernstein,
}

impl FormArg {
    pub fn choice(self) -> FormChoice {
        match self {
            FormArg::Auto => FormChoice::Auto,
            FormArg::Monomial => FormChoice::Force(EvalForm::Monomial),
            FormArg::Shifted => FormChoice::Force(EvalForm::Shifted),
            FormArg::Bernstein => FormChoice::Force(EvalForm::Bernstein),
        }
    }
}

#[derive(Args, Debug)]
pub struct EmitArgs {
    /// Fit file(s) to emit (e.g. fits/ggx-conductor/rational-3.json); output goes next to each.
    #[arg(long, required = true)]
    pub fit: Vec<PathBuf>,
    /// Output formats: rust, wgsl, glsl, lut, all (or a comma-separated list).
    #[arg(long)]
    pub lang: String,
    /// Evaluation form of the polynomials.
    #[arg(long, value_enum, default_value_t = FormArg::Auto)]
    pub form: FormArg,
    /// Folder of the table cache (where fit files' tables are looked up and LUT tables cached).
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Folder for LUTs.
    #[arg(long, default_value = "data/lut")]
    pub lut_dir: PathBuf,
    /// Nodes per axis of LUTs (`--lang lut`).
    #[arg(long, default_value_t = 32)]
    pub lut_resolution: usize,
    /// Recompute LUT tables even when cached.
    #[arg(long)]
    pub force: bool,
}

#[derive(Args, Debug)]
pub struct StressArgs {
    /// Fit file to test.
    #[arg(long)]
    pub fit: PathBuf,
    /// Random points (edge points are added).
    #[arg(long, default_value_t = DEFAULT_POINTS)]
    pub points: usize,
    /// Seed of the random points.
    #[arg(long, default_value_t = StressOptions::default().seed)]
    pub seed: u64,
    /// Evaluation form (as `furnace emit --form`).
    #[arg(long, value_enum, default_value_t = FormArg::Auto)]
    pub form: FormArg,
}

/// The table a fit file refers to, if it is still in the cache.
pub fn referenced_table(file: &FitFile) -> Result<Option<crate::table::Table>> {
    let Some(t) = &file.table else {
        return Ok(None);
    };
    if t.spec.content_hash() != t.content_hash {
        return Err(Error::InvalidInput(format!(
            "the fit file's table reference is inconsistent (hash {} does not match its spec); re-create the fit",
            t.content_hash
        )));
    }
    io::load_cached(&t.spec, &t.stem)
}

/// `furnace emit`.
pub fn emit_cmd(args: &EmitArgs) -> Result<()> {
    let langs = parse_langs(&args.lang)?;
    if args.lut_resolution < 2 {
        return Err(Error::InvalidInput(format!(
            "--lut-resolution {} is too small: a LUT needs at least 2 nodes per axis",
            args.lut_resolution
        )));
    }
    for path in &args.fit {
        emit_one(path, &langs, args)?;
    }
    Ok(())
}

fn emit_one(path: &Path, langs: &[Lang], args: &EmitArgs) -> Result<()> {
    for w in emit_files(path, langs, args, &mut |line| println!("{line}"))? {
        println!("wrote {}", w.display());
    }
    Ok(())
}

/// Emits one fit file in `langs` (source next to it, LUTs under `args.lut_dir`); `log` gets the
/// accuracy lines `furnace emit` prints. Returns the files written.
pub fn emit_files(
    path: &Path,
    langs: &[Lang],
    args: &EmitArgs,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>> {
    let file = FitFile::read(path)?;
    let table = referenced_table(&file)?;
    if file.table.is_some() && table.is_none() {
        log(&format!("note: the table of {} is not in the cache; the header bounds the f32 error instead of measuring it", path.display()));
    }
    let src = SourceFit::new(path, file, table)?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| Error::file(path, "a fit file needs a file name"))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let command = format!("furnace emit --fit {} --lang {}", path.display(), args.lang);
    let guard = emit::guard_macro(&format!("{} {stem}", src.file.model));
    let (mut unit, emitted) = build_unit(
        &stem,
        &guard,
        std::slice::from_ref(&src),
        &command,
        args.form.choice(),
        None,
    )?;
    if langs.contains(&Lang::Lut) {
        unit.luts.push(emit::lut_for_fit(
            &src,
            args.lut_resolution,
            &args.data_dir,
            args.force,
        )?);
    }
    // every byte is produced before anything is written
    let mut artifacts = Vec::new();
    for &lang in langs {
        artifacts.extend(emit::emitter(lang).produce(&unit)?);
    }
    let written = emit::write_artifacts(&artifacts, &dir, &args.lut_dir)?;
    for e in &emitted {
        let acc = e.form.chosen();
        log(&format!(
            "{}: {:?} form, {} coefficients; f32 − f64 max {:.1e} (IEEE) / {:.1e} (FMA) / {:.1e} (GPU model), bound {:.1e}",
            e.function, e.form.form, e.n_coefficients, acc.max_diff_ieee, acc.max_diff_fused, acc.max_diff_gpu, acc.max_bound
        ));
        if let Some(t) = &e.table {
            log(&format!(
                "    on its table ({} nodes): f64 MAE {:.2e} max {:.2e}; f32 MAE {:.2e} max {:.2e}",
                t.points, t.f64_mae, t.f64_max, t.f32_mae, t.f32_max
            ));
        }
    }
    for l in &unit.luts {
        if let Some(c) = &l.comparison {
            log(&format!(
                "LUT {} ({} B f32, {} B f16) vs fit ({} B) at the {} nodes of the {}: LUT f32 MAE {:.2e} max {:.2e}, f16 MAE {:.2e} max {:.2e}; fit MAE {:.2e} max {:.2e}",
                l.stem,
                4 * l.cells(),
                2 * l.cells(),
                c.fit_bytes.unwrap_or(0),
                c.points,
                c.reference,
                c.lut_f32_mae,
                c.lut_f32_max,
                c.lut_f16_mae,
                c.lut_f16_max,
                c.fit_f32_mae.unwrap_or(f64::NAN),
                c.fit_f32_max.unwrap_or(f64::NAN)
            ));
        }
    }
    Ok(written)
}

/// `furnace stress`: exit status 1 if the test fails.
pub fn stress_cmd(args: &StressArgs) -> Result<()> {
    let file = FitFile::read(&args.fit)?;
    let report = stress(
        &file,
        &StressOptions {
            random_points: args.points,
            seed: args.seed,
            form: args.form.choice(),
        },
    )?;
    print!("{}", report.render());
    if report.passed() {
        Ok(())
    } else {
        Err(Error::InvalidInput(format!(
            "stress test of {} failed ({} problem(s), listed above)",
            args.fit.display(),
            report.failures.len()
        )))
    }
}
