//! Emitters: fits → source a renderer includes as it is (Rust, WGSL, GLSL, HLSL, C/C++), and
//! tables → LUTs.
//!
//! Data flow: fit file ([`crate::fit::file`]) → one shared generator ([`generate`],
//! [`helpers`]) → a language-neutral [`ir::Program`] → an [`Emitter`] per output format producing
//! bytes ([`rust`], [`wgsl`], [`glsl`], [`hlsl`], [`cpp`], [`lut`]; WGSL and GLSL are validated by
//! naga before they are returned, [`validate`]; the tests compile all five with real compilers) → [`write_artifacts`] ([`crate::output`]: nothing half-written).
//! The same program, flattened ([`ir::Compiled`]), is what the f32 checks execute, so what is
//! measured is what is emitted: every fit must pass the stress test ([`stress`]) before it is
//! emitted, and its header states the stress test's numbers and a bound over the whole domain
//! ([`bound`]).
//!
//! ```
//! use furnace::emit::{build_unit, EmitOptions, Emitter, SourceFit};
//! use furnace::fit::{fit_polynomial, FitData, InputTransform, Objective, PolynomialOptions};
//! use furnace::fit::job::FitRecord;
//! use furnace::fit::source::{FitInput, FittedOn, Source};
//! let ax: Vec<f64> = (0..9).map(|i| i as f64 / 8.0).collect();
//! let vals = ax.iter().flat_map(|&r| ax.iter().map(move |&m| 1.0 - 0.3 * r * (1.0 - m))).collect();
//! let data = FitData::from_grid(vec!["r".into(), "mu".into()], &[ax.clone(), ax], vals).unwrap();
//! let fit = fit_polynomial(&data, &[InputTransform::Identity; 2], 2, Objective::LeastSquares,
//!                          &PolynomialOptions::default()).unwrap();
//! let source = Source { kind: "csv".into(), model: None, path: Some("example.csv".into()),
//!     content_hash: String::new(), resolution: None, channel: "E".into(), points: 81,
//!     restricted_to: None };
//! let input = FitInput { data, source, grid: None, table: None };
//! let record = FitRecord::new(fit, &input, FittedOn { points: 81, selection: "all points".into() });
//! let src = SourceFit::new("example.json", record, None).unwrap();
//! let (unit, _) = build_unit("example", "FURNACE_EXAMPLE", &[src], "furnace emit --fit example.json",
//!                            &EmitOptions::default()).unwrap();
//! let wgsl = furnace::emit::wgsl::Wgsl.produce(&unit).unwrap();
//! assert!(String::from_utf8_lossy(&wgsl[0].bytes).contains("fn example_albedo(r: f32, mu: f32) -> f32"));
//! ```

pub mod ascii;
pub mod bench;
pub mod bound;
pub mod cpp;
pub mod file;
pub mod generate;
pub mod glsl;
pub mod helpers;
pub mod hlsl;
pub mod ir;
pub mod lut;
pub mod rust;
pub mod source;
pub mod stress;
pub mod validate;
pub mod wgsl;

use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::fit::job::FitRecord;
use crate::table::Table;
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
    Hlsl,
    /// C99 / C++ / CUDA header.
    Cpp,
    Lut,
}

impl Lang {
    /// Every source language, in the order `all` lists them (LUTs are not source).
    pub const SOURCE: [Lang; 5] = [Lang::Rust, Lang::Wgsl, Lang::Glsl, Lang::Hlsl, Lang::Cpp];
}

pub const LANG_CHOICES: &str =
    "rust, wgsl, glsl, hlsl, cpp (C/C++/CUDA header), lut, all (or a comma-separated list)";

/// Parses `rust`, `wgsl,glsl`, `all`, …
pub fn parse_langs(text: &str) -> Result<Vec<Lang>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim) {
        let add: &[Lang] = match part.to_ascii_lowercase().as_str() {
            "rust" | "rs" => &[Lang::Rust],
            "wgsl" => &[Lang::Wgsl],
            "glsl" => &[Lang::Glsl],
            "hlsl" => &[Lang::Hlsl],
            "cpp" | "c++" | "c" | "cuda" => &[Lang::Cpp],
            "lut" => &[Lang::Lut],
            "all" => &[
                Lang::Rust,
                Lang::Wgsl,
                Lang::Glsl,
                Lang::Hlsl,
                Lang::Cpp,
                Lang::Lut,
            ],
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
        Lang::Hlsl => Box::new(hlsl::Hlsl),
        Lang::Cpp => Box::new(cpp::Cpp),
        Lang::Lut => Box::new(lut::LutEmitter),
    }
}

/// A fit to emit: its file, the proved lower bound of |Q|, and (optionally) the table it was
/// fitted to, on which the f32 code's error is then measured.
#[derive(Clone, Debug)]
pub struct SourceFit {
    /// How the header names the fit file.
    pub path: PathBuf,
    pub record: FitRecord,
    pub q_min: Option<f64>,
    pub table: Option<Table>,
    /// A user's table the fit was made from (no furnace table): its points, on which the f32
    /// code's error is measured as on a furnace table's nodes.
    pub points: Option<UserPoints>,
}

/// The points of a user's table: how the header names it, the coordinates (row-major, in the
/// fit's variable order) and the values.
#[derive(Clone, Debug)]
pub struct UserPoints {
    pub name: String,
    pub coords: Vec<f64>,
    pub values: Vec<f64>,
}

impl SourceFit {
    /// Checks the record against itself, its table and its model ([`crate::fit::file::check`]),
    /// certifies the denominator (refusing the fit otherwise) and attaches the table.
    pub fn new(
        path: impl Into<PathBuf>,
        record: FitRecord,
        table: Option<Table>,
    ) -> Result<SourceFit> {
        let path = path.into();
        fitfile::check(&record).map_err(|m| Error::file(&path, m))?;
        if let Some(t) = &record.table {
            if t.spec.transmission() == Some(crate::bsdf::Transmission::Radiance) {
                return Err(Error::file(
                    &path,
                    "fit of a radiance-form transmission table (values above 1): the emitted albedo clamps to [0, 1]; fit the energy-form table (the default) instead",
                ));
            }
        }
        let q_min = fitfile::certify(&record, &path)?;
        Ok(SourceFit {
            path,
            record,
            q_min,
            table,
            points: None,
        })
    }

    /// Attaches a user table's points (see [`SourceFit::points`]).
    pub fn with_points(mut self, points: Option<UserPoints>) -> SourceFit {
        self.points = points;
        self
    }

    /// The model (or user table) the emitted functions are named after.
    pub fn subject(&self) -> String {
        fitfile::subject_name(&self.record)
    }

    /// The fitted output (`E`, `E_R`, `E_T`).
    pub fn output(&self) -> &str {
        &self.record.source.channel
    }
}

/// Error of the emitted f32 code and of the f64 fit at a table's nodes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TableAccuracy {
    /// How the header names the table (`data/ggx-conductor/1024x1024`).
    pub table: String,
    pub points: usize,
    pub f64_mae: f64,
    pub f64_max: f64,
    pub f32_mae: f64,
    pub f32_max: f64,
}

/// What the stress test measured on the emitted code (see [`stress`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StressSummary {
    pub random_points: usize,
    pub edge_points: usize,
    pub seed: u64,
    /// max |f32 − f64| with every operation rounded once, with multiply–adds fused, and with
    /// GPU ÷/sqrt errors.
    pub max_diff_ieee: f64,
    pub max_diff_fused: f64,
    pub max_diff_gpu: f64,
}

impl StressSummary {
    pub fn max_diff(&self) -> f64 {
        self.max_diff_ieee
            .max(self.max_diff_fused)
            .max(self.max_diff_gpu)
    }
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
    /// The stress test of the emitted form, which it passed.
    pub stress: StressSummary,
    /// The rigorous bound on |f32 − f64| over every input.
    pub bound: bound::Bound,
    pub table: Option<TableAccuracy>,
    pub q_min: Option<f64>,
}

/// Most a fit may leave [0, 1] (measured on the form-choice grid) and still be emitted: the
/// emitted output is clamped to [0, 1], which hides a fit's small overshoot near the corners
/// (the published conductor fit: 2.5e-2) but would replace a function that is not an albedo
/// (a radiance-form dielectric table reaches E ≈ 7).
pub const MAX_OVERSHOOT: f64 = 0.1;

/// How [`build_unit`] emits.
#[derive(Clone, Debug)]
pub struct EmitOptions {
    pub form: FormChoice,
    /// Names of the helpers to keep, before the suffix (None keeps every helper the fits support).
    pub helpers: Option<Vec<String>>,
    /// Appended to every function name (`_best20`), so several budgets of one model can live in
    /// one shader; empty for none. Letters, digits and `_` only.
    pub suffix: String,
    /// Random points of the stress test every emitted fit must pass (edge points are added);
    /// at least [`stress::DEFAULT_POINTS`].
    pub stress_points: usize,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            form: FormChoice::Auto,
            helpers: None,
            suffix: String::new(),
            stress_points: stress::DEFAULT_POINTS,
        }
    }
}

/// Checks a name suffix: empty, or letters, digits and `_` (it is appended to identifiers).
pub fn check_suffix(suffix: &str) -> Result<()> {
    if suffix
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_')
    {
        Ok(())
    } else {
        Err(Error::InvalidInput(format!(
            "--suffix '{suffix}': use letters, digits and _ only (it is appended to function names, e.g. _best20)"
        )))
    }
}

/// The stress test of emitted code uses at least [`stress::DEFAULT_POINTS`] random points (rare
/// bad points are met only among many), besides the edges, and at most [`stress::MAX_POINTS`].
pub fn check_stress_points(n: usize) -> Result<()> {
    if n >= stress::DEFAULT_POINTS {
        stress::check_points(n, "--stress-points")
    } else {
        Err(Error::InvalidInput(format!(
            "--stress-points {n}: emitted code is stress-tested at at least {} random points (and the edges); give a larger number",
            stress::DEFAULT_POINTS
        )))
    }
}

/// Table nodes per work item of [`table_accuracy`].
const ACCURACY_CHUNK: usize = 1 << 14;

/// Error sums and maxima of one chunk of table nodes.
#[derive(Default)]
struct ChunkAccuracy {
    s64: crate::math::CompensatedSum,
    s32: crate::math::CompensatedSum,
    m64: f64,
    m32: f64,
}

/// Measures the IEEE f32 evaluation of `compiled` and the f64 fit at every node of `table`
/// (in parallel over fixed chunks of nodes, so the result does not depend on the thread count).
pub fn table_accuracy(
    compiled: &ir::Compiled,
    record: &FitRecord,
    table: &Table,
) -> Result<TableAccuracy> {
    let output = &record.source.channel;
    let o = table.output_index(output).ok_or_else(|| {
        Error::InvalidInput(format!(
            "the table of {} has no output '{}' (it has {})",
            table.spec.model,
            output,
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
    // fixed chunks, each summed in order and the chunks combined in order: the same bits for
    // any number of threads
    let chunks: Vec<ChunkAccuracy> = values
        .par_chunks(ACCURACY_CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut acc = ChunkAccuracy::default();
            let mut x = vec![0.0; d * chunk.len()];
            let mut x32 = vec![0.0f32; d * chunk.len()];
            for (i, p) in x.chunks_exact_mut(d.max(1)).enumerate() {
                table.spec.point(c * ACCURACY_CHUNK + i, p);
            }
            for (a, &b) in x32.iter_mut().zip(&x) {
                *a = b as f32;
            }
            let mut f64s = vec![0.0f64; chunk.len()];
            record.fit.approximant.eval_many(d, &x, &mut f64s);
            let mut f32s = vec![0.0f32; chunk.len()];
            compiled.eval_f32_points(&x32, ir::Arith::Ieee, &mut f32s, &mut Vec::new());
            for ((&y, &v64), &v32) in chunk.iter().zip(&f64s).zip(&f32s) {
                let e64 = (v64.clamp(0.0, 1.0) - y).abs();
                let e32 = (v32 as f64 - y).abs();
                acc.s64.add(e64);
                acc.s32.add(e32);
                acc.m64 = acc.m64.max(e64);
                acc.m32 = acc.m32.max(e32);
            }
            acc
        })
        .collect();
    let (mut s64, mut s32) = (
        crate::math::CompensatedSum::default(),
        crate::math::CompensatedSum::default(),
    );
    let (mut m64, mut m32) = (0.0f64, 0.0f64);
    for c in &chunks {
        s64.add(c.s64.value());
        s32.add(c.s32.value());
        m64 = m64.max(c.m64);
        m32 = m32.max(c.m32);
    }
    let n = values.len().max(1) as f64;
    Ok(TableAccuracy {
        table: record.table.as_ref().map_or_else(
            || table.spec.model.clone(),
            |t| t.stem.display().to_string(),
        ),
        points: values.len(),
        f64_mae: s64.value() / n,
        f64_max: m64,
        f32_mae: s32.value() / n,
        f32_max: m32,
    })
}

/// [`table_accuracy`] at a user table's points (in order, on one thread: user tables are small).
pub fn points_accuracy(
    compiled: &ir::Compiled,
    record: &FitRecord,
    points: &UserPoints,
) -> TableAccuracy {
    let d = compiled.n_params();
    let mut acc = ChunkAccuracy::default();
    let mut x32 = vec![0.0f32; d];
    let mut regs = Vec::new();
    for (x, &y) in points.coords.chunks_exact(d).zip(&points.values) {
        for k in 0..d {
            x32[k] = x[k] as f32;
        }
        let e64 = (record.fit.eval(x).clamp(0.0, 1.0) - y).abs();
        let e32 = (compiled.eval_f32(&x32, ir::Arith::Ieee, &mut regs) as f64 - y).abs();
        acc.s64.add(e64);
        acc.s32.add(e32);
        acc.m64 = acc.m64.max(e64);
        acc.m32 = acc.m32.max(e32);
    }
    let n = points.values.len().max(1) as f64;
    TableAccuracy {
        table: points.name.clone(),
        points: points.values.len(),
        f64_mae: acc.s64.value() / n,
        f64_max: acc.m64,
        f32_mae: acc.s32.value() / n,
        f32_max: acc.m32,
    }
}

/// The lines saying what each argument means: its model's description, the unit, the fitted
/// domain (inputs are clamped to it) and the input transform.
fn argument_doc(src: &SourceFit, params: &[String]) -> Vec<String> {
    let a = &src.record.fit.approximant;
    let model = src
        .record
        .source
        .model
        .as_deref()
        .and_then(|m| crate::bsdf::find(m).ok());
    let axes = model.as_ref().map(|m| m.axes()).unwrap_or_default();
    let mut doc = vec![
        "Arguments (f32, dimensionless; an input outside its fitted domain is clamped to it):"
            .to_string(),
    ];
    for (k, p) in params.iter().enumerate() {
        let (lo, hi) = a.domain[k];
        let meaning = match axes.get(k) {
            Some(ax) => ax.description.clone(),
            None => format!(
                "axis '{}' of the fitted table{}",
                a.variables[k],
                src.record
                    .source
                    .path
                    .as_deref()
                    .map_or(String::new(), |p| format!(" {p}"))
            ),
        };
        let tr = match a.transforms[k] {
            crate::fit::InputTransform::Identity => String::new(),
            t => format!("; evaluated in t = {}", t.formula(k, params)),
        };
        doc.push(format!("  {p}: {meaning}; fitted domain [{lo}, {hi}]{tr}."));
    }
    doc
}

/// The documentation block of an albedo function: its arguments, fit, source, evaluation form
/// and every measured error, with the bound.
fn albedo_doc(src: &SourceFit, name: &str, params: &[String], e: &EmittedFit) -> Vec<String> {
    let r = &src.record;
    let a = &r.fit.approximant;
    let subject = src.subject();
    let mut doc = vec![format!(
        "{name}({}): directional albedo {} of {subject}.",
        params.join(", "),
        src.output(),
    )];
    match r.source.model.as_deref().and_then(model_summary) {
        Some(s) => doc.push(format!("Model: {s}.")),
        None => doc.push(format!(
            "Fitted to a user's table ({}).",
            r.source.path.as_deref().unwrap_or("no file recorded")
        )),
    }
    doc.extend(argument_doc(src, params));
    let den = a.denominator.as_ref().map_or(0, |q| q.coefficients.len());
    let counts = if a.is_structured() {
        format!(
            "{} terms (factor, numerator and denominator of each), denominator constants 1 not counted",
            a.terms.len() + 1
        )
    } else if den > 0 {
        format!(
            "numerator {}, denominator {} with constant term 1",
            a.numerator.coefficients.len(),
            den.saturating_sub(1)
        )
    } else {
        format!("{} monomials", a.numerator.coefficients.len())
    };
    let origin = match &r.fit.solver {
        Some(sv) => format!(
            "{} objective, {}",
            serde_json::to_value(r.fit.objective)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            sv.method
        ),
        None => "coefficients not fitted by furnace (e.g. published ones)".to_string(),
    };
    doc.push(format!(
        "Fit: {}, {} coefficients ({counts}); {origin}.",
        r.fit.form.label(),
        r.fit.n_coefficients
    ));
    doc.push(format!(
        "Source: {} (furnace {}), fit SHA-256 {}.",
        src.path.display(),
        r.tool_version,
        e.fit_hash
    ));
    doc.extend(e.form.explain());
    if generate::one_quotient(&r.fit).is_some() {
        doc.push(format!(
            "Its {} terms cancel (sum of |term| up to {:.0}x the albedo on the measurement grid), so they are evaluated as one quotient over the product of their denominators, multiplied out in f64.",
            a.terms.len() + 1,
            generate::term_cancellation(&r.fit)
        ));
    }
    let m = &r.fit.metrics;
    doc.push(format!(
        "Error of the f64 fit on its {} data points: MAE {:.2e}, max {:.2e} (recorded by the fitter).",
        m.n_points, m.mae, m.max_abs_error
    ));
    if let Some(o) = &r.off_grid {
        doc.push(format!(
            "Error of the f64 fit between the nodes, at {} off-grid check points (exact values by quadrature; `off_grid` of the fit file): MAE {:.2e}, max {:.2e}.",
            o.metrics.n_points, o.metrics.mae, o.metrics.max_abs_error
        ));
    }
    let st = &e.stress;
    doc.push(format!(
        "f32 - f64, measured at the stress test's {} random + {} edge points (`furnace stress`, seed {:#x}): max {:.2e} (every op rounded, as this Rust), {:.2e} (fused multiply-add), {:.2e} (GPU division/sqrt error).",
        st.random_points, st.edge_points, st.seed, st.max_diff_ieee, st.max_diff_fused, st.max_diff_gpu
    ));
    let proved = e.bound.max_error.is_finite();
    doc.push(if proved {
        format!(
            "Bound: |f32 - f64| <= {:.2e} for every input, in all three rounding models (interval error analysis over the whole domain, {} boxes).",
            e.bound.max_error, e.bound.boxes
        )
    } else {
        format!(
            "Bound: none proved; the interval error analysis over the whole domain ({} boxes) gives no finite bound for this form and its input transforms, so the stress test above is the measure of |f32 - f64|.",
            e.bound.boxes
        )
    });
    match &e.table {
        Some(t) => doc.push(format!(
            "Error at the {} {} of its table {} (output clamp applied): f64 MAE {:.2e}, max {:.2e}; this f32 code MAE {:.2e}, max {:.2e}.",
            t.points, if src.table.is_none() { "points" } else { "nodes" }, t.table, t.f64_mae, t.f64_max, t.f32_mae, t.f32_max
        )),
        None if proved => doc.push(format!(
            "Error of this f32 code on the fit's data: max <= {:.2e} + {:.2e} (the f64 max plus the bound; the table was not at hand to measure it).",
            m.max_abs_error, e.bound.max_error
        )),
        None => doc.push(format!(
            "Error of this f32 code on the fit's data: not measured (the table was not at hand); the f64 fit's max is {:.2e}.",
            m.max_abs_error
        )),
    }
    let acc = e.form.chosen();
    if acc.max_overshoot > 0.0 {
        doc.push(format!(
            "Output clamped to [0, 1]; the f64 fit leaves that range by up to {:.1e} on the measurement grid.",
            acc.max_overshoot
        ));
    } else {
        doc.push("Output clamped to [0, 1] (the fit stays inside on the measurement grid).".into());
    }
    match src.q_min {
        Some(q) => doc.push(format!("Denominator proved >= {q:.3e} on the domain (Bernstein certificate), so the division is safe.")),
        None => doc.push("Polynomial: no division.".into()),
    }
    doc
}

fn model_summary(model: &str) -> Option<String> {
    crate::bsdf::find(model).ok().map(|m| m.summary())
}

/// The emitted form of fit `fit` (albedo function `name`): the form `choice` picks if its f32
/// code passes the stress test at `stress_points` random points and the edges; with
/// [`FormChoice::Auto`], else the other forms in order of their measured accuracy. Every emit
/// goes through this gate; the error, if none passes, gives each form's worst difference.
pub fn stress_gate(
    fit: &crate::fit::FitResult,
    name: &str,
    choice: FormChoice,
    stress_points: usize,
) -> std::result::Result<(ir::Function, FormReport, stress::StressReport), String> {
    let (function, report) = choose_form(name, &[], fit, choice).map_err(|e| e.to_string())?;
    let mut order = vec![report.form];
    if choice == FormChoice::Auto {
        let mut rest: Vec<&(generate::EvalForm, generate::F32Accuracy)> = report
            .candidates
            .iter()
            .filter(|(f, _)| *f != report.form)
            .collect();
        rest.sort_by(|a, b| a.1.max_diff().total_cmp(&b.1.max_diff()));
        order.extend(rest.into_iter().map(|(f, _)| *f));
    }
    let mut failures = Vec::new();
    let mut worst: Option<(f64, Vec<f32>)> = None;
    for form in order {
        let st = stress::stress(
            fit,
            name,
            &stress::StressOptions {
                random_points: stress_points,
                form: FormChoice::Force(form),
                diagnostics: false,
                ..Default::default()
            },
        )
        .map_err(|e| e.to_string())?;
        if st.passed() {
            let function = if form == report.form {
                function
            } else {
                generate::albedo_function(name, vec![], fit, form).map_err(|e| e.to_string())?
            };
            let report = FormReport {
                form,
                forced: report.forced,
                stress_fallback: form != report.form,
                ..report
            };
            return Ok((function, report, st));
        }
        let modes = [&st.ieee, &st.fused, &st.gpu];
        let bad = modes
            .iter()
            .max_by(|a, b| a.max_abs_diff.total_cmp(&b.max_abs_diff))
            .expect("three rounding models");
        let what = match (
            bad.non_finite,
            modes.iter().map(|m| m.out_of_range).sum::<usize>(),
        ) {
            (n, _) if n > 0 => format!("{n} NaN/inf values"),
            (_, n) if n > 0 && bad.max_abs_diff <= stress::MAX_ABS_DIFF => {
                format!("{n} outputs outside [0, 1]")
            }
            _ => format!("max |f32 − f64| {:.2e}", bad.max_abs_diff),
        };
        failures.push(format!("{} form {what}", form.name()));
        if worst.as_ref().is_none_or(|w| bad.max_abs_diff > w.0) {
            worst = Some((bad.max_abs_diff, bad.max_abs_diff_at.clone()));
        }
    }
    let at = worst.map_or(String::new(), |(_, x)| {
        format!(
            " (worst at {} = {x:?})",
            fit.approximant.variables.join(", ")
        )
    });
    Err(format!(
        "the f32 code fails the stress test at {stress_points} random points and the edges (limit |f32 − f64| ≤ {:.0e}): {}{at}",
        stress::MAX_ABS_DIFF,
        failures.join(", "),
    ))
}

/// [`stress_gate`] for a fit to emit; the error names the file and the fix.
fn gated_form(
    src: &SourceFit,
    name: &str,
    opts: &EmitOptions,
) -> Result<(ir::Function, FormReport, stress::StressReport)> {
    stress_gate(&src.record.fit, name, opts.form, opts.stress_points).map_err(|why| {
        Error::file(
            &src.path,
            format!(
                "{why}, so it is not emitted; refit so the denominator stays further from zero (a lower degree, a polynomial, or `furnace run --scene`, which tries larger denominator margins), and check with `furnace stress --fit {}`",
                src.path.display()
            ),
        )
    })
}

/// Builds one emitted file's program: an albedo function per fit (in the given order) and the
/// helpers they support. Every fit must pass the f32 stress test ([`gated_form`]) and its
/// arguments must be distinct identifiers. `command` is the command line that regenerates the
/// file.
pub fn build_unit(
    stem: &str,
    guard: &str,
    fits: &[SourceFit],
    command: &str,
    opts: &EmitOptions,
) -> Result<(Unit, Vec<EmittedFit>)> {
    if fits.is_empty() {
        return Err(Error::InvalidInput("nothing to emit: no fits given".into()));
    }
    check_suffix(&opts.suffix)?;
    check_stress_points(opts.stress_points)?;
    let mut program = ir::Program::default();
    let mut emitted = Vec::new();
    let mut refs = Vec::new();
    for src in fits {
        let r = &src.record;
        let subject = src.subject();
        let name = format!(
            "{}{}",
            albedo_function_name(&subject, src.output()),
            opts.suffix
        );
        if program.function(&name).is_some() {
            return Err(Error::InvalidInput(format!(
                "two fits of {subject} ({}) in one file would both define {name}; emit them into separate files or give them name suffixes",
                src.output()
            )));
        }
        let vars = &r.fit.approximant.variables;
        for (i, v) in vars.iter().enumerate() {
            if let Some(w) = vars[..i]
                .iter()
                .find(|w| generate::ident(w) == generate::ident(v))
            {
                return Err(Error::file(
                    &src.path,
                    format!("the variables '{w}' and '{v}' would both be the argument '{}' of the emitted function; rename one (the fit's variables must be distinct identifiers)", generate::ident(v)),
                ));
            }
        }
        let hash = fitfile::fit_hash(r)?;
        let (mut function, report, st) = gated_form(src, &name, opts)?;
        let overshoot = report.chosen().max_overshoot;
        if overshoot > MAX_OVERSHOOT {
            return Err(Error::file(
                &src.path,
                format!(
                    "the fit's values leave [0, 1] by up to {overshoot:.2e} on its domain, so the albedo the code clamps to [0, 1] is not the fitted function; fit a directional albedo (for a dielectric, the energy-form table, not the radiance form) — it is not emitted"
                ),
            ));
        }
        let single = ir::Program {
            functions: vec![function.clone()],
        };
        let compiled =
            ir::Compiled::new(&single, &name).map_err(|e| Error::InvalidInput(e.to_string()))?;
        let table = match (&src.table, &src.points) {
            (Some(t), _) => Some(table_accuracy(&compiled, r, t)?),
            (None, Some(p)) => Some(points_accuracy(&compiled, r, p)),
            (None, None) => None,
        };
        let bound =
            bound::albedo_bound(&single, &name, &r.fit, &generate::transformed_lets(&r.fit));
        let e = EmittedFit {
            model: subject.clone(),
            function: name.clone(),
            params: function.params.clone(),
            fit_hash: hash,
            n_coefficients: r.fit.n_coefficients,
            form: report,
            stress: StressSummary {
                random_points: st.random_points,
                edge_points: st.edge_points,
                seed: st.seed,
                max_diff_ieee: st.ieee.max_abs_diff,
                max_diff_fused: st.fused.max_abs_diff,
                max_diff_gpu: st.gpu.max_abs_diff,
            },
            bound,
            table,
            q_min: src.q_min,
        };
        function.doc = albedo_doc(src, &name, &function.params, &e);
        refs.push(helpers::AlbedoRef {
            id: match &r.table {
                Some(t) => t.spec.model_id().ok(),
                None => r
                    .source
                    .model
                    .as_deref()
                    .and_then(|m| crate::bsdf::lookup(m).ok()),
            },
            model: subject,
            function: name,
            params: function.params.clone(),
        });
        emitted.push(e);
        program.functions.push(function);
    }
    let mut helper_fns = helpers::helpers(&refs, &opts.suffix);
    if let Some(keep) = &opts.helpers {
        helper_fns.retain(|f| keep.iter().any(|k| f.name == format!("{k}{}", opts.suffix)));
    }
    let mut names: Vec<String> = program.functions.iter().map(|f| f.name.clone()).collect();
    names.extend(helper_fns.iter().map(|f| f.name.clone()));
    program.functions.extend(helper_fns);
    // every name resolves (a generator bug would show here, not in a renderer)
    for f in &program.functions {
        ir::Compiled::new(&program, &f.name).map_err(|e| Error::InvalidInput(e.to_string()))?;
    }
    let header = vec![
        format!("Generated by furnace {} -- do not edit; regenerate with:", crate::VERSION),
        format!("  {command}"),
        format!("Functions: {}.", names.join(", ")),
        "All arithmetic is f32. Each function states what its arguments mean, its domain, evaluation form, measured errors and error bound.".into(),
        "Helpers: Sforza & Pellacini 2022, \"Enforcing Energy Preservation in Microfacet Models\" (eqs. 13, 18, 19).".into(),
    ];
    let mut header = header;
    if names.iter().any(|n| n.contains("_kulla_conty_")) {
        header.push("Kulla-Conty helpers: Kulla & Conty 2017, \"Revisiting Physically Based Shading at Imageworks\".".into());
    }
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
        crate::output::write(&path, &a.bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// The table spec a fit's LUT is computed from: the fit's table spec (or, without one, the
/// model's spec over the fit's domain) with `n` nodes per axis.
pub fn lut_spec(
    file: &FitRecord,
    n: usize,
) -> Result<(Arc<dyn crate::bsdf::Model>, crate::table::TableSpec)> {
    let model = match (&file.table, &file.source.model) {
        (Some(t), _) => t.spec.model_id(),
        (None, Some(m)) => crate::bsdf::lookup(m),
        (None, None) => {
            return Err(Error::InvalidInput(
                "cannot make a LUT for a fit of a user's table: LUTs are tabulated from a furnace model".into(),
            ))
        }
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
/// emitted f32 albedo function `emitted` (of `unit`) at that table's nodes.
pub fn lut_for_fit(
    src: &SourceFit,
    unit: &Unit,
    emitted: &str,
    n: usize,
    data_dir: &Path,
    force: bool,
) -> Result<lut::Lut> {
    let (model, spec) = lut_spec(&src.record, n).map_err(|e| e.for_option("--lut-resolution"))?;
    if spec.cells() > lut::MAX_LUT_CELLS {
        return Err(Error::InvalidInput(format!(
            "a {} LUT has {} cells, over the limit of {}; choose a smaller --lut-resolution",
            spec.resolution_name(),
            spec.cells(),
            lut::MAX_LUT_CELLS
        )));
    }
    let table = crate::table::get_or_tabulate(
        model.as_ref(),
        &spec,
        data_dir,
        force,
        &crate::progress::Quiet,
    )?
    .table;
    let stem = crate::table::io::table_stem(Path::new(""), model.as_ref(), &spec);
    let mut stem = stem.to_string_lossy().replace('\\', "/");
    // one LUT per output: the LUTs of a model's other outputs (a dielectric's E_R, the split
    // sum's A and B) live beside E's under their own names
    if src.output() != "E" {
        stem.push_str(&format!("-{}", src.output()));
    }
    let mut l = lut::Lut::from_table(&table, src.output(), stem)?;
    // compare only against a finer table: at the LUT's own nodes its error is zero
    if let Some(reference) = src
        .table
        .as_ref()
        .filter(|t| t.spec.axes.iter().zip(&l.axes).all(|(r, a)| r.n > a.n))
    {
        let compiled = ir::Compiled::new(&unit.program, emitted)
            .map_err(|e| Error::InvalidInput(e.to_string()))?;
        l.comparison = Some(lut::compare(
            &l,
            reference,
            emitted,
            &compiled,
            src.record.fit.n_coefficients,
        )?);
    }
    Ok(l)
}
