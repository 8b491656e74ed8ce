//! Emitters: fits → source a renderer includes as it is (Rust, WGSL, GLSL), and tables → LUTs.
//!
//! Data flow: fit file ([`fitfile`]) → one shared generator ([`generate`], [`helpers`]) → a
//! language-neutral [`ir::Program`] → an [`Emitter`] per output format producing bytes
//! ([`rust`], [`wgsl`], [`glsl`], [`lut`]) → [`write_artifacts`] (temp file + rename, nothing
//! half-written). The same program, flattened ([`ir::Compiled`]), is what the f32 checks
//! ([`stress`]) execute, so what is measured is what is emitted.
//!
//! ```
//! use furnace::emit::{build_unit, fitfile::FitFile, generate::FormChoice, Emitter, SourceFit};
//! use furnace::fit::{fit_polynomial, FitData, InputTransform, Objective, PolynomialOptions};
//! let ax: Vec<f64> = (0..9).map(|i| i as f64 / 8.0).collect();
//! let vals = ax.iter().flat_map(|&r| ax.iter().map(move |&m| 1.0 - 0.3 * r * (1.0 - m))).collect();
//! let data = FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
//! let fit = fit_polynomial(&data, &[InputTransform::Identity; 2], 2, Objective::LeastSquares,
//!                          &PolynomialOptions::default()).unwrap();
//! let src = SourceFit::new("example.json", FitFile::new("ggx-conductor", "E", None, fit), None).unwrap();
//! let (unit, _) = build_unit("example", "FURNACE_EXAMPLE", &[src], "furnace emit --fit example.json", FormChoice::Auto, None).unwrap();
//! let wgsl = furnace::emit::wgsl::Wgsl.produce(&unit).unwrap();
//! assert!(String::from_utf8_lossy(&wgsl[0].bytes).contains("fn ggx_conductor_albedo(r: f32, mu: f32) -> f32"));
//! ```

pub mod bench;
pub mod fitfile;
pub mod generate;
pub mod glsl;
pub mod helpers;
pub mod ir;
pub mod lut;
pub mod rust;
pub mod source;
pub mod stress;
pub mod wgsl;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::table::Table;
use fitfile::FitFile;
use generate::{albedo_function_name, choose_form, FormChoice, FormReport};

/// One output format. Implementations only produce bytes; [`write_artifacts`] writes them.
pub trait Emitter {
    /// The name `--lang` uses.
    fn lang(&self) -> &'static str;
    /// The files of `unit` in this format.
    fn produce(&self, unit: &Unit) -> Result<Vec<Artifact>>;
}

/// Where an artifact belongs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// Next to the fit file (source code).
    Code,
    /// Under the LUT folder (`data/lut/` by default).
    Lut,
}

/// One output file: a name relative to its place, and its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Artifact {
    pub file_name: String,
    pub bytes: Vec<u8>,
    pub place: Place,
}

impl Artifact {
    pub fn code(file_name: String, text: String) -> Artifact {
        Artifact {
            file_name,
            bytes: text.into_bytes(),
            place: Place::Code,
        }
    }
}

/// What one emitted file holds.
#[derive(Clone, Debug, Default)]
pub struct Unit {
    /// File name without extension (`rational-3`).
    pub stem: String,
    /// File-level comment lines.
    pub header: Vec<String>,
    /// GLSL include-guard macro.
    pub guard: String,
    pub program: ir::Program,
    /// Tables for the LUT emitter.
    pub luts: Vec<lut::Lut>,
}

/// Output formats `--lang` accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lang {
    Rust,
    Wgsl,
    Glsl,
    Lut,
}

pub const LANG_CHOICES: &str = "rust, wgsl, glsl, lut, all (or a comma-separated list)";

/// Parses `rust`, `wgsl,glsl`, `all`, …
pub fn parse_langs(text: &str) -> Result<Vec<Lang>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim) {
        let add: &[Lang] = match part.to_ascii_lowercase().as_str() {
            "rust" | "rs" => &[Lang::Rust],
            "wgsl" => &[Lang::Wgsl],
            "glsl" => &[Lang::Glsl],
            "lut" => &[Lang::Lut],
            "all" => &[Lang::Rust, Lang::Wgsl, Lang::Glsl, Lang::Lut],
            other => {
                return Err(Error::InvalidInput(format!(
                    "unknown language '{other}' for --lang; choose from {LANG_CHOICES}"
                )));
            }
        };
        for l in add {
            if !out.contains(l) {
                out.push(*l);
            }
        }
    }
    Ok(out)
}

/// The emitter of a language.
pub fn emitter(lang: Lang) -> Box<dyn Emitter> {
    match lang {
        Lang::Rust => Box::new(rust::Rust),
        Lang::Wgsl => Box::new(wgsl::Wgsl),
        Lang::Glsl => Box::new(glsl::Glsl),
        Lang::Lut => Box::new(lut::LutEmitter),
    }
}

/// A fit to emit: its file, the proved lower bound of |Q|, and (optionally) the table it was
/// fitted to, on which the f32 code's error is then measured.
#[derive(Clone, Debug)]
pub struct SourceFit {
    /// How the header names the fit file.
    pub path: PathBuf,
    pub file: FitFile,
    pub q_min: Option<f64>,
    pub table: Option<Table>,
}

impl SourceFit {
    /// Certifies the denominator (refusing the fit otherwise) and attaches the table.
    pub fn new(path: impl Into<PathBuf>, file: FitFile, table: Option<Table>) -> Result<SourceFit> {
        let path = path.into();
        if let Some(t) = &file.table {
            if t.spec.transmission() == Some(crate::bsdf::Transmission::Radiance) {
                return Err(Error::file(
                    &path,
                    "fit of a radiance-form transmission table (values above 1): the emitted albedo clamps to [0, 1]; fit the energy-form table (the default) instead",
                ));
            }
        }
        let q_min = file.certify(&path)?;
        Ok(SourceFit {
            path,
            file,
            q_min,
            table,
        })
    }
}

/// Error of the emitted f32 code and of the f64 fit at a table's nodes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TableAccuracy {
    pub points: usize,
    pub f64_mae: f64,
    pub f64_max: f64,
    pub f32_mae: f64,
    pub f32_max: f64,
}

/// What was emitted for one fit, with the numbers its header states.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EmittedFit {
    pub model: String,
    pub function: String,
    pub params: Vec<String>,
    pub fit_hash: String,
    pub n_coefficients: usize,
    pub form: FormReport,
    pub table: Option<TableAccuracy>,
    pub q_min: Option<f64>,
}

/// Measures the IEEE f32 evaluation of `compiled` and the f64 fit at every node of `table`.
pub fn table_accuracy(
    compiled: &ir::Compiled,
    file: &FitFile,
    table: &Table,
) -> Result<TableAccuracy> {
    let o = table.output_index(&file.output).ok_or_else(|| {
        Error::InvalidInput(format!(
            "the table of {} has no output '{}' (it has {})",
            table.spec.model,
            file.output,
            table.spec.outputs.join(", ")
        ))
    })?;
    let d = table.spec.axes.len();
    if d != compiled.n_params() {
        return Err(Error::InvalidInput(format!(
            "the fit has {} variables but its table has {d} axes; the fit file's table reference is wrong",
            compiled.n_params()
        )));
    }
    let values = table.output(o);
    let (mut s64, mut s32) = (
        crate::math::CompensatedSum::default(),
        crate::math::CompensatedSum::default(),
    );
    let (mut m64, mut m32) = (0.0f64, 0.0f64);
    let mut x = vec![0.0; d];
    let mut x32 = vec![0.0f32; d];
    let mut regs = Vec::new();
    for (cell, &y) in values.iter().enumerate() {
        table.spec.point(cell, &mut x);
        for k in 0..d {
            x32[k] = x[k] as f32;
        }
        let e64 = (file.fit.eval(&x).clamp(0.0, 1.0) - y).abs();
        let e32 = (compiled.eval_f32(&x32, ir::Arith::Ieee, &mut regs) as f64 - y).abs();
        s64.add(e64);
        s32.add(e32);
        m64 = m64.max(e64);
        m32 = m32.max(e32);
    }
    let n = values.len().max(1) as f64;
    Ok(TableAccuracy {
        points: values.len(),
        f64_mae: s64.value() / n,
        f64_max: m64,
        f32_mae: s32.value() / n,
        f32_max: m32,
    })
}

fn model_summary(model: &str) -> Option<String> {
    crate::bsdf::find(model).ok().map(|m| m.summary())
}

fn fmt_domain(lo: f64, hi: f64) -> String {
    format!("[{lo}, {hi}]")
}

/// The documentation block of an albedo function: model, variables, domain, form, measured errors, f32
/// bounds and provenance.
fn albedo_doc(
    src: &SourceFit,
    name: &str,
    params: &[String],
    hash: &str,
    report: &FormReport,
    table: Option<&TableAccuracy>,
) -> Vec<String> {
    let f = &src.file;
    let a = &f.fit.approximant;
    let mut doc = vec![format!(
        "{name}({}): directional albedo {} of {}.",
        params.join(", "),
        f.output,
        f.model
    )];
    if let Some(s) = model_summary(&f.model) {
        doc.push(format!("Model: {s}."));
    }
    let den = a.denominator.as_ref().map_or(0, |q| q.coefficients.len());
    let counts = if den > 0 {
        format!(
            "numerator {}, denominator {} with constant term 1",
            a.numerator.coefficients.len(),
            den.saturating_sub(1)
        )
    } else {
        format!("{} monomials", a.numerator.coefficients.len())
    };
    let origin = match &f.fit.solver {
        Some(sv) => format!(
            "{} objective, {}",
            serde_json::to_value(f.fit.objective)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            sv.method
        ),
        None => "coefficients not fitted by furnace (e.g. published ones)".to_string(),
    };
    doc.push(format!(
        "Fit: {}, {} coefficients ({counts}); {origin}.",
        f.fit.form.label(),
        f.fit.n_coefficients
    ));
    doc.push(format!(
        "Source: {} (furnace {}), fit SHA-256 {hash}.",
        src.path.display(),
        f.tool_version
    ));
    doc.push("Arguments, transform t, fitted domain (arguments are clamped to it):".into());
    for (k, p) in params.iter().enumerate() {
        let (lo, hi) = a.domain[k];
        let tr = match a.transforms[k] {
            crate::fit::InputTransform::Identity => format!("t = {p}"),
            t => format!("t = {}", t.formula(k, params)),
        };
        doc.push(format!("  {p}: {tr}, {}", fmt_domain(lo, hi)));
    }
    doc.extend(report.explain());
    let m = &f.fit.metrics;
    doc.push(format!("Error of the f64 fit on its {} data points: MAE {:.2e}, max {:.2e} (recorded by the fitter).", m.n_points, m.mae, m.max_abs_error));
    let acc = report.chosen();
    match table {
        Some(t) => doc.push(format!(
            "Error at the {} nodes of its table (output clamp applied): f64 MAE {:.2e}, max {:.2e}; this f32 code MAE {:.2e}, max {:.2e}.",
            t.points, t.f64_mae, t.f64_max, t.f32_mae, t.f32_max
        )),
        None => doc.push(format!(
            "Error of this f32 code on the same data: MAE ≤ {:.2e} + {:.1e}, max ≤ {:.2e} + {:.1e} (the f64 errors plus max |f32 − f64|; the table was not at hand to measure it).",
            m.mae,
            acc.max_diff(),
            m.max_abs_error,
            acc.max_diff()
        )),
    }
    doc.push(format!(
        "f32 − f64 on {} grid points: max {:.1e} (every op rounded, as this Rust), {:.1e} (fused multiply–add), {:.1e} (GPU ÷/sqrt error); first-order bound {:.1e}.",
        acc.points, acc.max_diff_ieee, acc.max_diff_fused, acc.max_diff_gpu, acc.max_bound
    ));
    if acc.max_overshoot > 0.0 {
        doc.push(format!(
            "Output clamped to [0, 1]; the f64 fit leaves that range by up to {:.1e} on the grid.",
            acc.max_overshoot
        ));
    } else {
        doc.push("Output clamped to [0, 1] (the fit stays inside on the grid).".into());
    }
    match src.q_min {
        Some(q) => doc.push(format!("Denominator proved ≥ {q:.3e} on the domain (Bernstein certificate), so the division is safe.")),
        None => doc.push("Polynomial: no division.".into()),
    }
    doc
}

/// Builds one emitted file's program: an albedo function per fit (in the given order) and the
/// helpers they support. `command` is the command line that regenerates the file.
/// `helper_filter`: names of the helpers to keep (None keeps every helper the fits support).
pub fn build_unit(
    stem: &str,
    guard: &str,
    fits: &[SourceFit],
    command: &str,
    choice: FormChoice,
    helper_filter: Option<&[String]>,
) -> Result<(Unit, Vec<EmittedFit>)> {
    if fits.is_empty() {
        return Err(Error::InvalidInput("nothing to emit: no fits given".into()));
    }
    let mut program = ir::Program::default();
    let mut emitted = Vec::new();
    let mut refs = Vec::new();
    for src in fits {
        let f = &src.file;
        let name = albedo_function_name(&f.model, &f.output);
        if program.function(&name).is_some() {
            return Err(Error::InvalidInput(format!(
                "two fits of {} ({}) in one file would both define {name}; emit them into separate files",
                f.model, f.output
            )));
        }
        let hash = f.fit_hash()?;
        let (function, report) = choose_form(&name, &[], &f.fit, choice)?;
        let compiled = ir::Compiled::new(
            &ir::Program {
                functions: vec![function.clone()],
            },
            &name,
        )
        .map_err(|e| Error::InvalidInput(e.to_string()))?;
        let table = match &src.table {
            Some(t) => Some(table_accuracy(&compiled, f, t)?),
            None => None,
        };
        let mut function = function;
        function.doc = albedo_doc(src, &name, &function.params, &hash, &report, table.as_ref());
        refs.push(helpers::AlbedoRef {
            model: f.model.clone(),
            id: match &f.table {
                Some(t) => t.spec.model_id().ok(),
                None => crate::bsdf::lookup(&f.model).ok(),
            },
            function: name.clone(),
            params: function.params.clone(),
        });
        emitted.push(EmittedFit {
            model: f.model.clone(),
            function: name,
            params: function.params.clone(),
            fit_hash: hash,
            n_coefficients: f.fit.n_coefficients,
            form: report,
            table,
            q_min: src.q_min,
        });
        program.functions.push(function);
    }
    let mut helper_fns = helpers::helpers(&refs);
    if let Some(keep) = helper_filter {
        helper_fns.retain(|f| keep.contains(&f.name));
    }
    let mut names: Vec<String> = program.functions.iter().map(|f| f.name.clone()).collect();
    names.extend(helper_fns.iter().map(|f| f.name.clone()));
    program.functions.extend(helper_fns);
    // every name resolves (a generator bug would show here, not in a renderer)
    for f in &program.functions {
        ir::Compiled::new(&program, &f.name).map_err(|e| Error::InvalidInput(e.to_string()))?;
    }
    let header = vec![
        format!("Generated by furnace {} — do not edit; regenerate with:", crate::VERSION),
        format!("  {command}"),
        format!("Functions: {}.", names.join(", ")),
        "All arithmetic is f32. Each function states its domain, evaluation form and measured errors.".into(),
        "Helpers: Sforza & Pellacini 2022, \"Enforcing Energy Preservation in Microfacet Models\" (eqs. 13, 18, 19).".into(),
    ];
    Ok((
        Unit {
            stem: stem.into(),
            header,
            guard: guard.into(),
            program,
            luts: vec![],
        },
        emitted,
    ))
}

/// A GLSL include-guard macro from free text: `FURNACE_<TEXT>_GLSL`.
pub fn guard_macro(text: &str) -> String {
    format!(
        "FURNACE_{}_GLSL",
        generate::ident(text).to_ascii_uppercase()
    )
}

/// Writes every artifact atomically: code under `code_dir`, LUTs under `lut_dir`. All bytes
/// are produced before this is called, so a failing emitter writes nothing.
pub fn write_artifacts(
    artifacts: &[Artifact],
    code_dir: &Path,
    lut_dir: &Path,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for a in artifacts {
        let dir = match a.place {
            Place::Code => code_dir,
            Place::Lut => lut_dir,
        };
        let path = dir.join(&a.file_name);
        crate::table::io::write_atomic(&path, &a.bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// The table spec a fit's LUT is computed from: the fit's table spec (or, without one, the
/// model's spec over the fit's domain) with `n` nodes per axis.
pub fn lut_spec(
    file: &FitFile,
    n: usize,
) -> Result<(Arc<dyn crate::bsdf::Model>, crate::table::TableSpec)> {
    let model = match &file.table {
        Some(t) => t.spec.model_id(),
        None => crate::bsdf::lookup(&file.model),
    }
    .and_then(crate::bsdf::get)
    .map_err(|e| {
        Error::InvalidInput(format!(
            "cannot make a LUT for this fit: {e}; LUTs are tabulated from a furnace model"
        ))
    })?;
    let spec = match &file.table {
        Some(t) => {
            let mut spec = t.spec.clone();
            for a in &mut spec.axes {
                a.n = n;
            }
            spec.validate()?;
            spec
        }
        None => crate::table::TableSpec::with_ranges(
            model.as_ref(),
            &vec![n; file.fit.approximant.domain.len()],
            &file.fit.approximant.domain,
            crate::quadrature::QuadratureSettings::default(),
        )?,
    };
    Ok((model, spec))
}

/// The LUT of a fit's table at `n` nodes per axis (tabulated, or read from the cache under
/// `data_dir`), compared — if the fit's table is at hand and finer than the LUT — with the
/// emitted f32 fit at that table's nodes.
pub fn lut_for_fit(src: &SourceFit, n: usize, data_dir: &Path, force: bool) -> Result<lut::Lut> {
    let (model, spec) = lut_spec(&src.file, n)?;
    if spec.cells() > lut::MAX_LUT_CELLS {
        return Err(Error::InvalidInput(format!(
            "a {} LUT has {} cells, over the limit of {}; choose a smaller --lut-resolution",
            spec.resolution_name(),
            spec.cells(),
            lut::MAX_LUT_CELLS
        )));
    }
    let (table, _, _) = lut::tabulate_cached(model.as_ref(), &spec, data_dir, force)?;
    let stem = crate::table::io::table_stem(Path::new(""), model.as_ref(), &spec);
    let mut l = lut::Lut::from_table(
        &table,
        &src.file.output,
        stem.to_string_lossy().replace('\\', "/"),
    )?;
    // compare only against a finer table: at the LUT's own nodes its error is zero
    if let Some(reference) = src
        .table
        .as_ref()
        .filter(|t| t.spec.axes.iter().zip(&l.axes).all(|(r, a)| r.n > a.n))
    {
        l.comparison = Some(lut::compare(&l, reference, &src.file)?);
    }
    Ok(l)
}
