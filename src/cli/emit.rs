//! `furnace emit` and `furnace stress`: thin wrappers over [`crate::emit`].

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use crate::emit::file::{emit_fit_file, EmitFileOptions};
use crate::emit::generate::{albedo_function_name, EvalForm, FormChoice};
use crate::emit::stress::{stress, StressOptions, DEFAULT_POINTS};
use crate::emit::{self, parse_langs, Lang};
use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::output::Target;

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
    /// Output formats: rust, wgsl, glsl, hlsl, cpp (a C/C++/CUDA header), lut, all (or a
    /// comma-separated list).
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
    /// one fit and one of rust, wgsl, glsl, hlsl, cpp.
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
            "--output writes one file: give one --fit and one of --lang rust, wgsl, glsl, hlsl or cpp".into(),
        ));
    }
    // an unwritable output is refused before the stress tests and LUT tables are computed
    if let Some(t) = &target {
        t.check("--output")?;
        let fits: Vec<(&Path, &str)> = args.fit.iter().map(|f| (f.as_path(), "--fit")).collect();
        t.check_not_input(&fits, "--output")?;
    }
    if langs.contains(&Lang::Lut) {
        crate::output::check_dir_creatable(&args.lut_dir, "--lut-dir")?;
    }
    // with the code on standard output, the notes go to standard error; the first failed
    // write to standard output is kept and returned
    let to_stdout = target.as_ref().is_some_and(Target::is_stdout);
    let mut failed: Option<Error> = None;
    let mut log = |line: &str| {
        if to_stdout {
            eprintln!("{line}")
        } else if failed.is_none() {
            failed = outln!("{line}").err();
        }
    };
    for path in &args.fit {
        let options = EmitFileOptions {
            langs: langs.clone(),
            lang_arg: args.lang.clone(),
            form: args.form.choice(),
            suffix: args.suffix.clone(),
            data_dir: args.data_dir.clone(),
            lut_dir: args.lut_dir.clone(),
            lut_resolution: args.lut_resolution,
            force: args.force,
        };
        for w in emit_fit_file(path, &options, target.as_ref(), &mut log)? {
            match &target {
                Some(t) => log(&format!("wrote {}", t.describe())),
                None => log(&format!("wrote {}", w.display())),
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

/// `furnace stress`: exit status 1 if the test fails.
pub fn stress_cmd(args: &StressArgs) -> Result<()> {
    crate::emit::stress::check_points(args.points, "--points")?;
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
    out!("{}", report.render())?;
    if args.points < DEFAULT_POINTS {
        outln!(
            "note: {} random points are fewer than the {DEFAULT_POINTS} that emit and run test before writing code; this verdict is not theirs",
            args.points
        )?;
    }
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
