//! The f32 stress test of an emitted albedo function: the exact operation sequence the emitted
//! code performs ([`Compiled`], the same program the printers print) is run in f32 at random
//! points of the domain and at edge points — both ends of every axis, the f32 neighbours of the
//! ends, tiny and subnormal inputs, and out-of-range inputs (negative, above the domain, ±∞) that
//! the code must clamp — under three rounding models (each operation rounded once, as the
//! emitted Rust; fused multiply–adds; GPU-allowed ÷ and sqrt errors), and compared with the f64
//! fit at the same (clamped) input.
//!
//! It fails if any output or the unclamped quotient is NaN/∞, any output is outside
//! [0, 1 + 1e-6], any difference exceeds [`MAX_ABS_DIFF`], or the denominator is not proved
//! pole-free. It reports the largest absolute and relative differences, the smallest |Q| met
//! (and the proved lower bound), the condition numbers of P and Q in the evaluated form, and the
//! largest first-order rounding-error bound.

use rayon::prelude::*;
use serde::Serialize;

use super::generate::{
    choose_form, condition, form_polynomials, form_variables, references, EvalForm, FormChoice,
};
use super::ir::{Arith, Compiled, Program, BLOCK};
use crate::error::{Error, Result};
use crate::fit::data::{SplitMix64, MAX_DIM};
use crate::fit::{CertifyOptions, FitResult, PoleVerdict};
use crate::table::MAX_TABLE_BYTES;

/// Largest |f32 − f64| allowed.
pub const MAX_ABS_DIFF: f64 = 1e-5;
/// Outputs must lie in [0, 1 + OUTPUT_SLACK].
pub const OUTPUT_SLACK: f64 = 1e-6;
/// Relative differences are taken where the reference is at least this (relative error of an
/// albedo near 0, e.g. glossy at F0 = 0, carries no information).
pub const RELATIVE_FLOOR: f64 = 1e-3;
/// Random points per combination of edge values on a face or edge line of the domain.
pub const EDGE_REPEATS: usize = 16;
/// Default number of random points: 10⁶, enough to meet the rare f32 cancellations.
pub const DEFAULT_POINTS: usize = 1_000_000;
/// Most random points of a stress test or of a timing pass of `bench eval`: their f32
/// coordinates (up to [`MAX_DIM`] per point, held twice while the point list is assembled)
/// stay within the memory limit of a table, [`MAX_TABLE_BYTES`] (8 GiB / 32 B = 2²⁸ points).
pub const MAX_POINTS: usize = (MAX_TABLE_BYTES / (2 * 4 * MAX_DIM as u128)) as usize;

/// Refuses, before anything is allocated, more random points than [`MAX_POINTS`]; `option`
/// names the option that gave them (`--points`, `--stress-points`).
pub fn check_points(n: usize, option: &str) -> Result<()> {
    if n <= MAX_POINTS {
        Ok(())
    } else {
        Err(Error::InvalidInput(format!(
            "{option} {n} is above the limit of {MAX_POINTS} random points (their coordinates would need more than {}); give a smaller number",
            crate::error::human_bytes(MAX_TABLE_BYTES)
        )))
    }
}

/// Stress-test settings.
#[derive(Clone, Debug)]
pub struct StressOptions {
    pub random_points: usize,
    pub seed: u64,
    pub form: FormChoice,
    /// Also measure the condition numbers of P and Q and the first-order error bound at every
    /// point (reported, not tested: `furnace stress` shows them, the emit gate skips them).
    pub diagnostics: bool,
}

impl Default for StressOptions {
    fn default() -> Self {
        StressOptions {
            random_points: DEFAULT_POINTS,
            seed: 0x5EED_F00D,
            form: FormChoice::Auto,
            diagnostics: true,
        }
    }
}

/// Differences of one rounding model.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ModeStats {
    pub max_abs_diff: f64,
    pub max_abs_diff_at: Vec<f32>,
    pub max_rel_diff: f64,
    pub non_finite: usize,
    pub out_of_range: usize,
}

/// What the stress test found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StressReport {
    pub function: String,
    pub form: EvalForm,
    pub random_points: usize,
    pub edge_points: usize,
    /// Seed of the random points (and of the GPU rounding model's error directions).
    pub seed: u64,
    /// Each operation rounded once (the emitted Rust on a CPU).
    pub ieee: ModeStats,
    /// Multiply–adds fused.
    pub fused: ModeStats,
    /// Fused, with GPU-allowed ÷ and sqrt errors.
    pub gpu: ModeStats,
    /// Smallest |Q| computed in f32 at the test points (None for a polynomial).
    pub min_abs_q: Option<f64>,
    /// The proved lower bound of |Q| on the domain, if the certificate succeeded.
    pub q_lower_bound: Option<f64>,
    pub pole_verdict: String,
    /// Largest condition number Σ|c m|/|P| of P (and Q) in the evaluated form.
    pub max_condition_p: f64,
    pub max_condition_q: Option<f64>,
    /// Largest first-order bound on |f32 − f64| of the unclamped value.
    pub max_error_bound: f64,
    /// Largest distance of the f64 fit outside [0, 1] (hidden by the output clamp).
    pub max_overshoot: f64,
    /// Why it failed; empty if it passed.
    pub failures: Vec<String>,
}

impl StressReport {
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }

    /// A human-readable report.
    pub fn render(&self) -> String {
        let mut s = format!(
            "{} ({:?} form): {} random + {} edge points, 3 rounding models\n",
            self.function, self.form, self.random_points, self.edge_points
        );
        s.push_str(&format!(
            "  {:<34} {:>12} {:>12} {:>9} {:>12}\n",
            "rounding model", "max |Δ|", "max rel Δ", "NaN/inf", "out of range"
        ));
        for (name, m) in [
            ("each op rounded (emitted Rust)", &self.ieee),
            ("fused multiply-add", &self.fused),
            ("GPU ÷/sqrt error", &self.gpu),
        ] {
            s.push_str(&format!(
                "  {:<34} {:>12.3e} {:>12.3e} {:>9} {:>12}\n",
                name, m.max_abs_diff, m.max_rel_diff, m.non_finite, m.out_of_range
            ));
        }
        s.push_str(&format!(
            "  worst point (IEEE): {:?}\n",
            self.ieee.max_abs_diff_at
        ));
        match (self.min_abs_q, self.q_lower_bound) {
            (Some(q), Some(b)) => s.push_str(&format!(
                "  min |Q| at the points {q:.4e}; proved ≥ {b:.4e} on the domain\n"
            )),
            (Some(q), None) => s.push_str(&format!(
                "  min |Q| at the points {q:.4e}; NOT proved pole-free: {}\n",
                self.pole_verdict
            )),
            _ => s.push_str("  polynomial: no denominator\n"),
        }
        if self.max_condition_p > 0.0 {
            s.push_str(&format!(
            "  condition number of P {:.3e}{}; first-order f32 error bound {:.3e} (= {:.0} u, u = 2^-24)\n",
            self.max_condition_p,
            self.max_condition_q.map(|q| format!(", of Q {q:.3e}")).unwrap_or_default(),
            self.max_error_bound,
            self.max_error_bound * (1u64 << 24) as f64
        ));
        }
        if self.max_overshoot > 0.0 {
            s.push_str(&format!("  note: the f64 fit leaves [0, 1] by up to {:.3e}; the emitted output clamp removes it\n", self.max_overshoot));
        }
        if self.passed() {
            s.push_str(&format!("PASS: no NaN/inf, outputs in [0, 1 + {OUTPUT_SLACK:.0e}], max |f32 − f64| ≤ {MAX_ABS_DIFF:.0e}\n"));
        } else {
            for f in &self.failures {
                s.push_str(&format!("FAIL: {f}\n"));
            }
        }
        s
    }
}

/// Values of one axis that stress its ends: the ends, their f32 neighbours, tiny and subnormal
/// offsets, and inputs outside the domain (which must clamp).
pub fn edge_values(lo: f32, hi: f32) -> Vec<f32> {
    let mut v = vec![
        lo,
        hi,
        lo.next_up(),
        hi.next_down(),
        0.5 * (lo + hi),
        -0.0,
        0.0,
    ];
    for tiny in [1e-45f32, 1e-40, 1e-30, 1e-20, 1e-10] {
        v.push(lo + tiny);
        v.push(tiny);
        v.push(-tiny);
    }
    v.extend([
        lo.next_down(),
        hi.next_up(),
        lo - 1.0,
        hi + 1.0,
        2.0 * hi + 1.0,
        -1.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        f32::MIN,
    ]);
    v.sort_by(f32::total_cmp);
    v.dedup_by(|a, b| a.to_bits() == b.to_bits());
    v
}

/// Every combination of edge values of all axes (the box's corners, seen from every side), and
/// for every proper subset of axes, every combination of edge values on it with the other axes
/// random (`per_face` points each): faces in 2-D; faces and edge lines in 3-D, where a rational's
/// denominator is often smallest.
fn edge_points(domain: &[(f32, f32)], rng: &mut SplitMix64, per_face: usize) -> Vec<f32> {
    let d = domain.len();
    let lists: Vec<Vec<f32>> = domain.iter().map(|&(lo, hi)| edge_values(lo, hi)).collect();
    let mut out = Vec::new();
    for subset in 1..(1usize << d) {
        let fixed: Vec<usize> = (0..d).filter(|k| subset >> k & 1 == 1).collect();
        let repeats = if fixed.len() == d { 1 } else { per_face };
        let combos: usize = fixed.iter().map(|&k| lists[k].len()).product();
        for idx in 0..combos {
            let mut x = vec![0.0f32; d];
            let mut rest = idx;
            for &k in fixed.iter().rev() {
                x[k] = lists[k][rest % lists[k].len()];
                rest /= lists[k].len();
            }
            for _ in 0..repeats {
                for (j, &(lo, hi)) in domain.iter().enumerate() {
                    if subset >> j & 1 == 0 {
                        x[j] = uniform(rng, lo, hi);
                    }
                }
                out.extend_from_slice(&x);
            }
        }
    }
    out
}

fn uniform(rng: &mut SplitMix64, lo: f32, hi: f32) -> f32 {
    (lo as f64 + (hi as f64 - lo as f64) * rng.next_f64()) as f32
}

#[derive(Clone, Default)]
struct Partial {
    modes: [ModeStats; 3],
    min_q: f64,
    cond_p: f64,
    cond_q: f64,
    bound: f64,
    overshoot: f64,
}

fn merge(a: &mut ModeStats, b: ModeStats) {
    if b.max_abs_diff > a.max_abs_diff
        || (a.max_abs_diff_at.is_empty() && !b.max_abs_diff_at.is_empty())
    {
        a.max_abs_diff = b.max_abs_diff;
        a.max_abs_diff_at = b.max_abs_diff_at;
    }
    a.max_rel_diff = a.max_rel_diff.max(b.max_rel_diff);
    a.non_finite += b.non_finite;
    a.out_of_range += b.out_of_range;
}

/// Runs the stress test on `fit`, with the albedo function `name` the emitters would write for it
/// (in the form `opts.form` picks).
pub fn stress(fit: &FitResult, name: &str, opts: &StressOptions) -> Result<StressReport> {
    check_points(opts.random_points, "--points")?;
    let name = name.to_string();
    let (function, form) = match opts.form {
        FormChoice::Force(form) => (
            super::generate::albedo_function(&name, vec![], fit, form)?,
            form,
        ),
        FormChoice::Auto => {
            let (function, report) = choose_form(&name, &[], fit, opts.form)?;
            (function, report.form)
        }
    };
    let program = Program {
        functions: vec![function],
    };
    let compiled =
        Compiled::new(&program, &name).map_err(|e| Error::InvalidInput(e.to_string()))?;
    // the quotient the emitted code evaluates: one over the product of the denominators where a
    // structured form's terms cancel (generate::one_quotient), else the first term's
    let evaluated = super::generate::one_quotient(fit);
    let (p_poly, q_poly) = form_polynomials(evaluated.as_ref().unwrap_or(fit), form)?;
    let domain = super::generate::domain_f32(fit);
    let d = domain.len();

    let mut rng = SplitMix64(opts.seed);
    let edges = edge_points(&domain, &mut rng, EDGE_REPEATS);
    let n_edges = edges.len() / d;
    let mut random = Vec::with_capacity(opts.random_points * d);
    for _ in 0..opts.random_points {
        for &(lo, hi) in &domain {
            random.push(uniform(&mut rng, lo, hi));
        }
    }
    let points: Vec<f32> = edges.into_iter().chain(random).collect();
    let e_reg = compiled.register("e").expect("albedo functions bind e");
    let q_reg = compiled.register("q");
    let result = compiled.results()[0];

    const CHUNK: usize = 4096;
    let n = points.len() / d;
    let parts: Vec<Partial> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut part = Partial {
                min_q: f64::INFINITY,
                ..Default::default()
            };
            let mut regs = Vec::new();
            let mut bregs = Vec::new();
            let end = ((c + 1) * CHUNK).min(n);
            for b0 in (c * CHUNK..end).step_by(BLOCK) {
                let b1 = (b0 + BLOCK).min(end);
                let xs = &points[b0 * d..b1 * d];
                let seeds: Vec<u64> = (b0..b1).map(|i| i as u64 ^ opts.seed).collect();
                let refs = references(fit, d, xs);
                for &(_, raw) in &refs {
                    part.overshoot = part.overshoot.max(raw - 1.0).max(-raw);
                }
                for (m, arith) in [Arith::Ieee, Arith::Fused, Arith::Gpu { seed: 0 }]
                    .into_iter()
                    .enumerate()
                {
                    compiled.eval_block(xs, arith, &seeds, &mut regs);
                    let st = &mut part.modes[m];
                    for (j, &(refv, _)) in refs.iter().enumerate() {
                        let x = &xs[j * d..(j + 1) * d];
                        let out = regs[result * BLOCK + j];
                        let e = regs[e_reg * BLOCK + j];
                        if !out.is_finite() || !e.is_finite() {
                            st.non_finite += 1;
                            if st.max_abs_diff_at.is_empty() {
                                st.max_abs_diff_at = x.to_vec();
                            }
                            st.max_abs_diff = f64::INFINITY;
                            continue;
                        }
                        if !(out >= 0.0 && (out as f64) <= 1.0 + OUTPUT_SLACK) {
                            st.out_of_range += 1;
                        }
                        let diff = (out as f64 - refv).abs();
                        if diff > st.max_abs_diff || st.max_abs_diff_at.is_empty() {
                            st.max_abs_diff = st.max_abs_diff.max(diff);
                            st.max_abs_diff_at = x.to_vec();
                        }
                        if refv.abs() >= RELATIVE_FLOOR {
                            st.max_rel_diff = st.max_rel_diff.max(diff / refv.abs());
                        }
                        if m == 0 {
                            if let Some(q) = q_reg {
                                part.min_q = part.min_q.min((regs[q * BLOCK + j] as f64).abs());
                            }
                        }
                    }
                }
                if !opts.diagnostics {
                    continue;
                }
                for x in xs.chunks_exact(d) {
                    compiled.eval_bound(x, &mut bregs);
                    part.bound = part.bound.max(bregs[e_reg].1);
                    let xv: Vec<f64> = x.iter().map(|&v| v as f64).collect();
                    if let Ok(v) = form_variables(fit, form, &xv) {
                        part.cond_p = part.cond_p.max(condition(&p_poly, &v));
                        if let Some(q) = &q_poly {
                            part.cond_q = part.cond_q.max(condition(q, &v));
                        }
                    }
                }
            }
            part
        })
        .collect();
    let mut total = Partial {
        min_q: f64::INFINITY,
        ..Default::default()
    };
    for p in parts {
        for (a, b) in total.modes.iter_mut().zip(p.modes) {
            merge(a, b);
        }
        total.min_q = total.min_q.min(p.min_q);
        total.cond_p = total.cond_p.max(p.cond_p);
        total.cond_q = total.cond_q.max(p.cond_q);
        total.bound = total.bound.max(p.bound);
        total.overshoot = total.overshoot.max(p.overshoot);
    }
    // each Q_k of a structured fit, or the one quotient's denominator Π_k Q_k where the emitted
    // code evaluates that (positive where every Q_k is: its certificate states the product's bound)
    let verdict = evaluated
        .as_ref()
        .unwrap_or(fit)
        .approximant
        .certify_poles(&CertifyOptions::default());
    let q_lower_bound = match verdict {
        PoleVerdict::Certified {
            min_lower_bound, ..
        } => Some(min_lower_bound),
        _ => None,
    };
    let pole_verdict = match &verdict {
        PoleVerdict::Certified {
            min_lower_bound,
            boxes,
        } => format!("certified: Q ≥ {min_lower_bound:.4e} ({boxes} boxes)"),
        PoleVerdict::PoleFound { at } => format!("pole found near {at:?}"),
        PoleVerdict::Undecided { reason, .. } => format!("undecided: {reason}"),
        PoleVerdict::NoDenominator => "no denominator".into(),
    };
    let [ieee, fused, gpu] = total.modes;
    let mut failures = Vec::new();
    if !verdict.is_certified() {
        failures.push(format!("the denominator is not proved pole-free ({pole_verdict}); refit with a certified denominator"));
    }
    for (name, m) in [
        ("each-op-rounded", &ieee),
        ("fused multiply-add", &fused),
        ("GPU ÷/sqrt", &gpu),
    ] {
        if m.non_finite > 0 {
            failures.push(format!(
                "{} NaN/inf values in the {name} model (first at {:?})",
                m.non_finite, m.max_abs_diff_at
            ));
        }
        if m.out_of_range > 0 {
            failures.push(format!(
                "{} outputs outside [0, 1 + {OUTPUT_SLACK:.0e}] in the {name} model",
                m.out_of_range
            ));
        }
        if m.non_finite == 0 && m.max_abs_diff > MAX_ABS_DIFF {
            let fix = if form == EvalForm::Bernstein {
                "refit so the denominator stays further from zero (a larger denominator margin or a lower degree)"
            } else {
                "try --form bernstein, or refit so the denominator stays further from zero"
            };
            failures.push(format!(
                "max |f32 − f64| {:.3e} > {MAX_ABS_DIFF:.0e} in the {name} model at {:?}; {fix}",
                m.max_abs_diff, m.max_abs_diff_at
            ));
        }
    }
    Ok(StressReport {
        function: name,
        form,
        random_points: opts.random_points,
        edge_points: n_edges,
        seed: opts.seed,
        ieee,
        fused,
        gpu,
        min_abs_q: q_poly.as_ref().map(|_| total.min_q),
        q_lower_bound,
        pole_verdict,
        max_condition_p: total.cond_p,
        max_condition_q: q_poly.as_ref().map(|_| total.cond_q),
        max_error_bound: total.bound,
        max_overshoot: total.overshoot,
        failures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_random_points_than_the_memory_limit_allows_are_refused_naming_the_option() {
        assert_eq!(MAX_POINTS, 1 << 28);
        assert!(check_points(MAX_POINTS, "--points").is_ok());
        for n in [MAX_POINTS + 1, 1_000_000_000_000, usize::MAX] {
            let e = check_points(n, "--points").unwrap_err().to_string();
            assert!(e.starts_with(&format!("--points {n} is above the limit of {MAX_POINTS}")));
            assert!(
                e.contains("8.0 GiB") && e.contains("give a smaller number"),
                "{e}"
            );
        }
        let e = crate::emit::check_stress_points(usize::MAX).unwrap_err();
        assert!(e.to_string().starts_with("--stress-points "), "{e}");
        // the stress test itself refuses before allocating its points
        let fit = crate::fit::file::read(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fits/ggx-conductor/best-20.json"
        )))
        .unwrap()
        .fit;
        let opts = StressOptions {
            random_points: usize::MAX,
            ..StressOptions::default()
        };
        assert!(stress(&fit, "e", &opts).is_err());
    }
}
