//! `furnace emit` and `furnace stress`: thin wrappers over [`crate::emit`].

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use crate::emit::generate::{albedo_function_name, EvalForm, FormChoice};
use crate::emit::stress::{stress, StressOptions, DEFAULT_POINTS};
use crate::emit::{self, build_unit, parse_langs, EmitOptions, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::fit::job::FitRecord;
use crate::output::Target;
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
    /// Fit file(s) to emit (e.g. fits/ggx-conductor/best-40.json); output goes next to each.
    #[arg(long, required = true)]
    pub fit: Vec<PathBuf>,
    /// Output formats: rust, wgsl, glsl, lut, all (or a comma-separated list).
    #[arg(long)]
    pub lang: String,
    /// Evaluation form of the polynomials.
    #[arg(long, value_enum, default_value_t = FormArg::Auto)]
    pub form: FormArg,
    /// Appended to every emitted function name (e.g. `_best20`), so several fits of one model
    /// (different budgets) can be included in one shader.
    #[arg(long, default_value = "")]
    pub suffix: String,
    /// Write the one emitted file here instead of next to the fit (`-`: standard output); needs
    /// one fit and one of rust, wgsl, glsl.
    #[arg(long)]
    pub output: Option<PathBuf>,
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

/// The table a fit file refers to, if it is still in the cache: at the stem the file records,
/// or where the same table lives under `data_dir`.
pub fn referenced_table(file: &FitRecord, data_dir: &Path) -> Result<Option<crate::table::Table>> {
    let Some(t) = file.table.as_ref().filter(|t| t.is_current()) else {
        return Ok(None);
    };
    if let Some(table) = io::load_cached(&t.spec, &t.stem)? {
        return Ok(Some(table));
    }
    let Ok(model) = t.spec.model_id().and_then(crate::bsdf::get) else {
        return Ok(None);
    };
    let stem = io::table_stem(data_dir, model.as_ref(), &t.spec);
    io::load_cached(&t.spec, &stem)
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
    emit::check_suffix(&args.suffix)?;
    let target = args.output.as_deref().map(Target::from_arg);
    if target.is_some() && (args.fit.len() != 1 || langs.len() != 1 || langs[0] == Lang::Lut) {
        return Err(Error::InvalidInput(
            "--output writes one file: give one --fit and one of --lang rust, wgsl or glsl".into(),
        ));
    }
    // with the code on standard output, the notes go to standard error
    let to_stdout = target.as_ref().is_some_and(Target::is_stdout);
    let mut log = |line: &str| {
        if to_stdout {
            eprintln!("{line}")
        } else {
            println!("{line}")
        }
    };
    for path in &args.fit {
        for w in emit_files(path, &langs, args, target.as_ref(), &mut log)? {
            match &target {
                Some(t) => log(&format!("wrote {}", t.describe())),
                None => log(&format!("wrote {}", w.display())),
            }
        }
    }
    Ok(())
}

/// Emits one fit file in `langs` (source next to it, or to `target`; LUTs under
/// `args.lut_dir`); `log` gets the accuracy lines `furnace emit` prints. Returns the files
/// written (`-` for standard output).
pub fn emit_files(
    path: &Path,
    langs: &[Lang],
    args: &EmitArgs,
    target: Option<&Target>,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>> {
    let file = fitfile::read(path)?;
    let table = referenced_table(&file, &args.data_dir)?;
    match &file.table {
        Some(t) if !t.is_current() => log(&format!("note: the table of {} was computed by another version of the quadrature engine; the header states the fit's error on its data plus the f32 bound instead of measuring the code on the table", path.display())),
        Some(_) if table.is_none() => log(&format!("note: the table of {} is not in the cache; the header states the fit's error on its data plus the f32 bound instead of measuring the code on the table", path.display())),
        _ => {}
    }
    let src = SourceFit::new(path, file, table)?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| Error::file(path, "a fit file needs a file name"))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut command = format!("furnace emit --fit {} --lang {}", path.display(), args.lang);
    if !args.suffix.is_empty() {
        command.push_str(&format!(" --suffix {}", args.suffix));
    }
    let guard = emit::guard_macro(&format!("{} {stem}{}", src.subject(), args.suffix));
    let opts = EmitOptions {
        form: args.form.choice(),
        suffix: args.suffix.clone(),
        ..EmitOptions::default()
    };
    let (mut unit, emitted) =
        build_unit(&stem, &guard, std::slice::from_ref(&src), &command, &opts)?;
    if langs.contains(&Lang::Lut) {
        unit.luts.push(emit::lut_for_fit(
            &src,
            &unit,
            &emitted[0].function,
            args.lut_resolution,
            &args.data_dir,
            args.force,
        )?);
    }
    // every byte is produced (and every shader validated) before anything is written
    let mut artifacts = Vec::new();
    for &lang in langs {
        artifacts.extend(emit::emitter(lang).produce(&unit)?);
    }
    let written = match target {
        Some(t) => {
            t.write(&artifacts[0].bytes)?;
            vec![match t {
                Target::Stdout => PathBuf::from("-"),
                Target::File(p) => p.clone(),
            }]
        }
        None => emit::write_artifacts(&artifacts, &dir, &args.lut_dir)?,
    };
    for e in &emitted {
        let st = &e.stress;
        log(&format!(
            "{}: {:?} form, {} coefficients; f32 − f64 at {} stress points max {:.1e} (IEEE) / {:.1e} (FMA) / {:.1e} (GPU model); bound {:.1e} over the whole domain",
            e.function, e.form.form, e.n_coefficients, st.random_points + st.edge_points, st.max_diff_ieee, st.max_diff_fused, st.max_diff_gpu, e.bound.max_error
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
    let file = fitfile::read(&args.fit)?;
    let name = albedo_function_name(&fitfile::subject_name(&file), &file.source.channel);
    let report = stress(
        &file.fit,
        &name,
        &StressOptions {
            random_points: args.points,
            seed: args.seed,
            form: args.form.choice(),
            diagnostics: true,
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
