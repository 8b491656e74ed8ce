//! `furnace bench eval`: what a renderer pays per albedo evaluation, in time and error, for each
//! emitted fit and for multilinear LUTs of 16², 32², 64² (or 16³, 32³) nodes.
//!
//! Error: the emitted f32 code (the [`Compiled`] program, bit-identical to the emitted Rust —
//! checked here by checksum) and the LUTs (f32 values, multilinear interpolation in f32) against
//! an accurate reference table whose nodes mostly fall between LUT nodes (257² / 33³ by default).
//!
//! Time: the emitted Rust itself, compiled. A throw-away crate is written to a temporary folder
//! (the emitted `.rs` files `include!`d unchanged, a LUT sampler, the points and LUT values as
//! raw f32), built with `cargo build --release`, and run; it reports the best of several passes
//! over 2²⁰ random points, in two ways: the call inlined into a loop summing the results (the
//! compiler may vectorise it), and one call at a time through a function pointer (no inlining,
//! no vectorisation). Results depend on the machine; the EON paper's 20.8 ns for approximate EON
//! (its Table 1, one CPU core) is the point of comparison.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::generate::{albedo_function_name, choose_form, domain_f32, EvalForm, FormChoice};
use super::ir::{Arith, Compiled, Program};
use super::lut::Lut;
use super::{lut_spec, rust::Rust, Emitter, SourceFit, Unit};
use crate::error::{Error, Result};
use crate::fit::data::SplitMix64;
use crate::fit::job::FitRecord;
use crate::progress::Quiet;
use crate::table::get_or_tabulate;
use crate::table::Table;

/// The timing crate's folder, removed when this is dropped — on success and on every error
/// alike — unless it is to be kept.
struct WorkDir {
    path: PathBuf,
    keep: bool,
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

impl WorkDir {
    fn path(&self) -> &Path {
        &self.path
    }
}

/// Settings of the benchmark.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub data_dir: PathBuf,
    /// Nodes per axis of the reference table.
    pub reference_2d: usize,
    pub reference_3d: usize,
    pub lut_sizes_2d: Vec<usize>,
    pub lut_sizes_3d: Vec<usize>,
    /// Random points per timing pass.
    pub points: usize,
    /// Timing passes (the best is kept).
    pub passes: usize,
    /// The cargo to build the timing crate with.
    pub cargo: String,
    /// Keep the timing crate (its folder is printed) instead of deleting it.
    pub keep: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            data_dir: "data".into(),
            reference_2d: 257,
            reference_3d: 33,
            lut_sizes_2d: vec![16, 32, 64],
            lut_sizes_3d: vec![16, 32],
            points: 1 << 20,
            passes: 7,
            cargo: std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()),
            keep: false,
        }
    }
}

/// One line of the benchmark table.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BenchRow {
    pub model: String,
    pub what: String,
    pub bytes: usize,
    /// ns per evaluation, inlined loop.
    pub ns_inlined: f64,
    /// ns per evaluation, one call at a time through a function pointer.
    pub ns_call: f64,
    pub max_error: f64,
    pub mean_error: f64,
    pub reference: String,
}

/// One thing to time and measure.
enum Case {
    Fit {
        module: String,
        function: String,
        compiled: Compiled,
    },
    Lut {
        lut: Lut,
    },
}

struct Job {
    model: String,
    what: String,
    bytes: usize,
    dims: usize,
    points_file: usize,
    case: Case,
    max_error: f64,
    mean_error: f64,
    reference: String,
}

fn errors_at_nodes(
    reference: &Table,
    output: &str,
    mut eval: impl FnMut(&[f32]) -> f32,
) -> Result<(f64, f64)> {
    let o = reference.output_index(output).ok_or_else(|| {
        Error::InvalidInput(format!("the reference table has no output '{output}'"))
    })?;
    let d = reference.spec.axes.len();
    let mut x = vec![0.0; d];
    let mut x32 = vec![0.0f32; d];
    let mut sum = crate::math::CompensatedSum::default();
    let mut max = 0.0f64;
    for (cell, &y) in reference.output(o).iter().enumerate() {
        reference.spec.point(cell, &mut x);
        for k in 0..d {
            x32[k] = x[k] as f32;
        }
        let e = (eval(&x32) as f64 - y).abs();
        sum.add(e);
        max = max.max(e);
    }
    Ok((max, sum.value() / reference.cells().max(1) as f64))
}

fn random_points(domain: &[(f32, f32)], n: usize, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64(seed);
    let mut out = Vec::with_capacity(n * domain.len());
    for _ in 0..n {
        for &(lo, hi) in domain {
            out.push((lo as f64 + (hi as f64 - lo as f64) * rng.next_f64()) as f32);
        }
    }
    out
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The LUT sampler of the timing crate: the same operations, in the same order, as
/// [`super::lut::Sampler::sample`], specialised to 2 and 3 axes.
const HARNESS_LUT: &str = r#"
pub struct Lut { lo: [f32; 3], scale: [f32; 3], n: [usize; 3], stride: [usize; 3], data: Vec<f32> }
impl Lut {
    pub fn new(axes: &[(f32, f32, usize)], data: Vec<f32>) -> Lut {
        let d = axes.len();
        let mut l = Lut { lo: [0.0; 3], scale: [0.0; 3], n: [2; 3], stride: [1; 3], data };
        for k in 0..d { l.lo[k] = axes[k].0; l.scale[k] = axes[k].1; l.n[k] = axes[k].2; }
        for k in (0..d.saturating_sub(1)).rev() { l.stride[k] = l.stride[k + 1] * l.n[k + 1]; }
        l
    }
    #[inline]
    fn cell(&self, k: usize, x: f32) -> (usize, f32) {
        let u = ((x - self.lo[k]) * self.scale[k]).max(0.0).min((self.n[k] - 1) as f32);
        let i = (u as usize).min(self.n[k] - 2);
        (i, u - i as f32)
    }
    #[inline]
    pub fn sample2(&self, x0: f32, x1: f32) -> f32 {
        let (i0, f0) = self.cell(0, x0);
        let (i1, f1) = self.cell(1, x1);
        let b = i0 * self.stride[0] + i1;
        let (c00, c01) = (self.data[b], self.data[b + 1]);
        let (c10, c11) = (self.data[b + self.stride[0]], self.data[b + self.stride[0] + 1]);
        let v0 = c00 + f0 * (c10 - c00);
        let v1 = c01 + f0 * (c11 - c01);
        v0 + f1 * (v1 - v0)
    }
    #[inline]
    pub fn sample3(&self, x0: f32, x1: f32, x2: f32) -> f32 {
        let (i0, f0) = self.cell(0, x0);
        let (i1, f1) = self.cell(1, x1);
        let (i2, f2) = self.cell(2, x2);
        let b = i0 * self.stride[0] + i1 * self.stride[1] + i2;
        let (s0, s1) = (self.stride[0], self.stride[1]);
        let c = |o: usize| self.data[b + o];
        let (c000, c001, c010, c011) = (c(0), c(1), c(s1), c(s1 + 1));
        let (c100, c101, c110, c111) = (c(s0), c(s0 + 1), c(s0 + s1), c(s0 + s1 + 1));
        let (a00, a01, a10, a11) = (c000 + f0 * (c100 - c000), c001 + f0 * (c101 - c001), c010 + f0 * (c110 - c010), c011 + f0 * (c111 - c011));
        let (b0, b1) = (a00 + f1 * (a10 - a00), a01 + f1 * (a11 - a01));
        b0 + f2 * (b1 - b0)
    }
}
pub fn read_f32(path: &str) -> Vec<f32> {
    std::fs::read(path).expect("harness input").chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}
pub fn best<F: FnMut() -> f64>(passes: usize, mut f: F) -> (f64, f64) {
    let mut sum = f(); // warm-up
    let mut best = f64::INFINITY;
    for _ in 0..passes {
        let t = std::time::Instant::now();
        sum = std::hint::black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, sum)
}
"#;

/// Runs the benchmark for the given fit files.
pub fn bench_eval(
    fits: &[(PathBuf, FitRecord)],
    opts: &BenchOptions,
    log: &dyn Fn(&str),
) -> Result<Vec<BenchRow>> {
    if fits.is_empty() {
        return Err(Error::InvalidInput(
            "no fit files given; pass --fit fits/<model>/<form>.json (one or more)".into(),
        ));
    }
    if opts.points == 0 || opts.passes == 0 {
        return Err(Error::InvalidInput(
            "--points and --passes must be positive".into(),
        ));
    }
    super::stress::check_points(opts.points, "--points")?;
    let work = WorkDir {
        path: std::env::temp_dir().join(format!("furnace-bench-eval-{}", std::process::id())),
        keep: opts.keep,
    };
    let work = work.path();
    let src_dir = work.join("src");
    std::fs::create_dir_all(&src_dir).map_err(|e| Error::io(&src_dir, e))?;
    let mut jobs = Vec::new();
    let mut modules = String::new();
    let mut point_sets: Vec<Vec<f32>> = Vec::new();
    for (i, (path, file)) in fits.iter().enumerate() {
        let d = file.fit.approximant.variables.len();
        if !(2..=3).contains(&d) {
            return Err(Error::file(
                path,
                format!("bench eval handles fits of 2 or 3 variables, this one has {d}"),
            ));
        }
        let n_ref = if d == 2 {
            opts.reference_2d
        } else {
            opts.reference_3d
        };
        let (model, ref_spec) = lut_spec(file, n_ref).map_err(|e| {
            e.for_option(if d == 2 {
                "--reference-2d"
            } else {
                "--reference-3d"
            })
        })?;
        let src = SourceFit::new(path, file.clone(), None)?;
        let subject = src.subject();
        let output = src.output().to_string();
        log(&format!(
            "{subject}: reference table {} …",
            ref_spec.resolution_name()
        ));
        let reference =
            get_or_tabulate(model.as_ref(), &ref_spec, &opts.data_dir, false, &Quiet)?.table;
        let reference_name = format!(
            "{} {}",
            reference.spec.model,
            reference.spec.resolution_name()
        );
        // the fit, exactly as emitted (the form that passes the stress test)
        let name = albedo_function_name(&subject, &output);
        let (_, emitted) = super::build_unit(
            "bench",
            "FURNACE_BENCH",
            std::slice::from_ref(&src),
            "furnace bench eval",
            &super::EmitOptions::default(),
        )?;
        let report = &emitted[0].form;
        let points_file = point_sets.len();
        point_sets.push(random_points(
            &domain_f32(&file.fit),
            opts.points,
            0xBE7C_0000 + i as u64,
        ));
        // every form, the emitted one first, so its cost can be weighed against its stability
        let mut forms = vec![report.form];
        forms.extend(EvalForm::ALL.iter().copied().filter(|&f| f != report.form));
        for form in forms {
            let module = format!("fit_{i}_{}", form.name());
            let (function, _) = choose_form(&name, &[], &file.fit, FormChoice::Force(form))?;
            let unit = Unit {
                stem: module.clone(),
                program: Program {
                    functions: vec![function.clone()],
                },
                ..Unit::default()
            };
            let code = Rust.produce(&unit)?;
            std::fs::write(src_dir.join(&code[0].file_name), &code[0].bytes)
                .map_err(|e| Error::io(&src_dir, e))?;
            writeln!(
                modules,
                "#[allow(dead_code)] mod {module} {{ include!(\"{module}.rs\"); }}"
            )
            .ok();
            let compiled = Compiled::new(
                &Program {
                    functions: vec![function],
                },
                &name,
            )
            .map_err(|e| Error::InvalidInput(e.to_string()))?;
            let mut regs = Vec::new();
            let (max_e, mean_e) = errors_at_nodes(&reference, &output, |x| {
                compiled.eval_f32(x, Arith::Ieee, &mut regs)
            })?;
            let f32_diff = report
                .candidates
                .iter()
                .find(|(f, _)| *f == form)
                .map_or(f64::NAN, |(_, a)| a.max_diff());
            let status = if form == report.form {
                "emitted".to_string()
            } else {
                format!("not emitted; f32 Δ {f32_diff:.1e}")
            };
            jobs.push(Job {
                model: subject.clone(),
                what: format!(
                    "fit {} {}, {} form ({status})",
                    file.fit
                        .form
                        .label()
                        .replace("rational of degree ", "rational "),
                    name.trim_end_matches("_albedo"),
                    form.name()
                ),
                bytes: 4 * file.fit.n_coefficients,
                dims: d,
                points_file,
                case: Case::Fit {
                    module,
                    function: name.clone(),
                    compiled,
                },
                max_error: max_e,
                mean_error: mean_e,
                reference: reference_name.clone(),
            });
        }
        let sizes = if d == 2 {
            &opts.lut_sizes_2d
        } else {
            &opts.lut_sizes_3d
        };
        for &n in sizes {
            let (model, spec) = lut_spec(file, n)?;
            log(&format!("{subject}: LUT {} …", spec.resolution_name()));
            let table =
                get_or_tabulate(model.as_ref(), &spec, &opts.data_dir, false, &Quiet)?.table;
            let lut = Lut::from_table(&table, &output, spec.resolution_name())?;
            let sampler = lut.sampler_f32();
            let (max_e, mean_e) = errors_at_nodes(&reference, &output, |x| sampler.sample(x))?;
            jobs.push(Job {
                model: subject.clone(),
                what: format!(
                    "{} LUT {}, f32",
                    if d == 2 { "bilinear" } else { "trilinear" },
                    spec.resolution_name()
                ),
                bytes: 4 * lut.cells(),
                dims: d,
                points_file,
                case: Case::Lut { lut },
                max_error: max_e,
                mean_error: mean_e,
                reference: reference_name.clone(),
            });
        }
    }
    // timing crate
    for (k, pts) in point_sets.iter().enumerate() {
        let p = work.join(format!("points_{k}.f32"));
        std::fs::write(&p, f32_bytes(pts)).map_err(|e| Error::io(&p, e))?;
    }
    let mut main = String::new();
    main.push_str("// furnace bench eval: timing harness (generated)\n#![allow(clippy::all)]\n");
    main.push_str(&modules);
    main.push_str(HARNESS_LUT);
    writeln!(main, "fn main() {{\n    let dir = std::env::args().nth(1).expect(\"data folder\");\n    let passes: usize = {};", opts.passes).ok();
    let mut expected = Vec::new();
    for (j, job) in jobs.iter().enumerate() {
        let d = job.dims;
        let args = |p: &str| {
            (0..d)
                .map(|k| format!("{p}[{d} * i + {k}]"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        writeln!(main, "    {{\n        let pts = read_f32(&format!(\"{{dir}}/points_{}.f32\"));\n        let n = pts.len() / {d};", job.points_file).ok();
        let floats = vec!["f32"; d].join(", ");
        let (inlined, pointer) = match &job.case {
            Case::Fit { module, function, .. } => (
                format!("{module}::{function}({})", args("pts")),
                format!("let g: fn({floats}) -> f32 = std::hint::black_box({module}::{function});\n        let call = |i: usize| g({});", args("pts")),
            ),
            Case::Lut { lut } => {
                let p = work.join(format!("lut_{j}.f32"));
                std::fs::write(&p, f32_bytes(&lut.values_f32())).map_err(|e| Error::io(&p, e))?;
                let axes = lut
                    .axes
                    .iter()
                    .map(|a| format!("({:?}f32, {:?}f32, {})", a.lo as f32, ((a.n - 1) as f64 / (a.hi - a.lo)) as f32, a.n))
                    .collect::<Vec<_>>()
                    .join(", ");
                writeln!(main, "        let lut = Lut::new(&[{axes}], read_f32(&format!(\"{{dir}}/lut_{j}.f32\")));").ok();
                (
                    format!("lut.sample{d}({})", args("pts")),
                    format!("let g: fn(&Lut, {floats}) -> f32 = std::hint::black_box(Lut::sample{d});\n        let call = |i: usize| g(&lut, {});", args("pts")),
                )
            }
        };
        writeln!(
            main,
            "        let (t1, sum) = best(passes, || {{ let mut s = 0.0f64; for i in 0..n {{ s += {inlined} as f64; }} s }});\n        \
             {pointer}\n        \
             let (t2, _) = best(passes, || {{ let mut s = 0.0f64; for i in 0..n {{ s += call(i) as f64; }} s }});\n        \
             println!(\"{j}\\t{{}}\\t{{}}\\t{{:e}}\", t1 * 1e9 / n as f64, t2 * 1e9 / n as f64, sum);\n    }}"
        )
        .ok();
        // the checksum the harness must reproduce: f32 outputs summed in f64 in point order
        let pts = &point_sets[job.points_file];
        let mut sum = 0.0f64;
        match &job.case {
            Case::Fit { compiled, .. } => {
                let mut regs = Vec::new();
                for x in pts.chunks_exact(d) {
                    sum += compiled.eval_f32(x, Arith::Ieee, &mut regs) as f64;
                }
            }
            Case::Lut { lut } => {
                let s = lut.sampler_f32();
                for x in pts.chunks_exact(d) {
                    sum += s.sample(x) as f64;
                }
            }
        }
        expected.push(sum);
    }
    main.push_str("}\n");
    std::fs::write(src_dir.join("main.rs"), main).map_err(|e| Error::io(&src_dir, e))?;
    let manifest = "[package]\nname = \"furnace-bench-eval\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n[workspace]\n\n[profile.release]\nopt-level = 3\ncodegen-units = 1\ndebug = false\n";
    std::fs::write(work.join("Cargo.toml"), manifest).map_err(|e| Error::io(work, e))?;
    log(&format!(
        "building the timing crate in {} …",
        work.display()
    ));
    let status = Command::new(&opts.cargo)
        .args(["build", "--release", "--quiet", "--offline", "--manifest-path"])
        .arg(work.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", work.join("target"))
        .env_remove("RUSTFLAGS")
        .status()
        .map_err(|e| {
            Error::InvalidInput(format!(
                "cannot run '{}' ({e}): bench eval times the emitted Rust by compiling it, so it needs cargo on PATH (or set CARGO)",
                opts.cargo
            ))
        })?;
    if !status.success() {
        return Err(Error::InvalidInput(format!("the timing crate in {} did not build ({status}); the emitted Rust should always compile — please report this", work.display())));
    }
    let exe = work.join("target/release/furnace-bench-eval");
    let out = Command::new(&exe)
        .arg(work)
        .output()
        .map_err(|e| Error::io(&exe, e))?;
    if !out.status.success() {
        return Err(Error::InvalidInput(format!(
            "the timing run failed: {}",
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let mut rows = Vec::new();
    for line in text.lines() {
        let f: Vec<&str> = line.split('\t').collect();
        let parse = |s: &str| {
            s.parse::<f64>()
                .map_err(|_| Error::InvalidInput(format!("unexpected timing output line '{line}'")))
        };
        let [j, t1, t2, sum] = f.as_slice() else {
            return Err(Error::InvalidInput(format!(
                "unexpected timing output line '{line}'"
            )));
        };
        let j: usize = j
            .parse()
            .map_err(|_| Error::InvalidInput(format!("unexpected timing output line '{line}'")))?;
        let job = jobs.get(j).ok_or_else(|| {
            Error::InvalidInput(format!("unexpected timing output line '{line}'"))
        })?;
        let (sum, want) = (parse(sum)?, expected[j]);
        if sum.to_bits() != want.to_bits() {
            return Err(Error::InvalidInput(format!(
                "{}: the compiled code summed to {sum:e} but the f32 model of the same operations to {want:e}; the emitted code and its checks disagree — please report this",
                job.what
            )));
        }
        rows.push(BenchRow {
            model: job.model.clone(),
            what: job.what.clone(),
            bytes: job.bytes,
            ns_inlined: parse(t1)?,
            ns_call: parse(t2)?,
            max_error: job.max_error,
            mean_error: job.mean_error,
            reference: job.reference.clone(),
        });
    }
    if rows.len() != jobs.len() {
        return Err(Error::InvalidInput(format!(
            "the timing run reported {} of {} cases",
            rows.len(),
            jobs.len()
        )));
    }
    if opts.keep {
        log(&format!("timing crate kept in {}", work.display()));
    }
    Ok(rows)
}

/// The benchmark table as text.
pub fn render(rows: &[BenchRow]) -> String {
    let mut s = format!(
        "{:<20} {:<82} {:>7} {:>10} {:>8} {:>9} {:>9}\n",
        "model", "evaluation (f32)", "bytes", "ns inlined", "ns call", "max |ΔE|", "mean |ΔE|"
    );
    for r in rows {
        s.push_str(&format!(
            "{:<20} {:<82} {:>7} {:>10.2} {:>8.2} {:>9.2e} {:>9.2e}\n",
            r.model, r.what, r.bytes, r.ns_inlined, r.ns_call, r.max_error, r.mean_error
        ));
    }
    let mut refs: Vec<&str> = rows.iter().map(|r| r.reference.as_str()).collect();
    refs.dedup();
    s.push_str(&format!(
        "errors: at every node of an accurate table of the same model and domain ({}); f32 LUT values, multilinear in f32\n",
        refs.join(", ")
    ));
    s.push_str("times: best pass over random points; 'inlined' = call inlined in a summing loop (may vectorise), 'call' = through a function pointer\n");
    s.push_str("for comparison: approximate EON, 20.8 ns per evaluation on one CPU core (EON paper, Table 1; another machine)\n");
    s
}
