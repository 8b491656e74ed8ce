//! `furnace eval --model`: E at arbitrary points by direct quadrature; `furnace eval --fit`: E
//! from a fit file's coefficients, as the emitted code computes it.

use super::EvalArgs;
use crate::bsdf::albedo;
use crate::emit::generate::clamped;
use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::output::Target;
use crate::quadrature::RuleCache;
use crate::table::points::read_points;
use rayon::prelude::*;
use std::path::Path;

pub fn eval_cmd(args: &EvalArgs) -> Result<()> {
    match (&args.model, &args.fit) {
        (Some(model), None) => eval_model(args, model),
        (None, Some(fit)) => eval_fit(args, fit),
        _ => Err(Error::InvalidInput(
            "give exactly one of --model and --fit".into(),
        )),
    }
}

/// A fit file's value at the points of `--input`: the fit is read and checked, and its
/// denominator proved pole-free, exactly as `furnace emit` does (refused otherwise); the value
/// is the emitted code's function in f64 (inputs clamped to the domain, output to [0, 1]), or
/// with `--raw` the approximant itself at points inside the domain.
fn eval_fit(args: &EvalArgs, fit_path: &Path) -> Result<()> {
    let target = Target::from_arg(&args.output);
    target.check("--output")?;
    target.check_not_input(
        &[(fit_path, "--fit"), (args.input.as_path(), "--input")],
        "--output",
    )?;
    let checked = fitfile::load(fit_path)?;
    let rec = &checked.record;
    let a = &rec.fit.approximant;
    let ranges: Vec<(f64, f64)> = if args.raw {
        a.domain.clone()
    } else {
        vec![(f64::NEG_INFINITY, f64::INFINITY); a.domain.len()]
    };
    let points = read_points(&args.input, &a.variables, &ranges)?;
    let mut out = points.header.join(",");
    out.push_str(&format!(",{}\n", rec.source.channel));
    let mut outside = 0;
    for (k, (raw, x)) in points.raw.iter().zip(&points.coords).enumerate() {
        outside += usize::from(
            x.iter()
                .zip(&a.domain)
                .any(|(v, (lo, hi))| v < lo || v > hi),
        );
        let e = if args.raw {
            a.eval(x)
        } else {
            clamped(&rec.fit, x).0
        };
        if !e.is_finite() {
            return Err(Error::file(
                &args.input,
                format!("data row {}: the fit is not finite at {x:?}", k + 1),
            ));
        }
        out.push_str(&raw.join(","));
        out.push_str(&format!(",{e}\n"));
    }
    target.write(out.as_bytes())?;
    eprintln!(
        "{} points of {} evaluated to {} ({}){}",
        points.coords.len(),
        fit_path.display(),
        target.describe(),
        if args.raw {
            "the raw approximant"
        } else {
            "inputs clamped to the fit's domain and output to [0, 1], as the emitted code"
        },
        if outside > 0 {
            format!(
                "; {outside} {} outside the domain {} and {} clamped into it",
                if outside == 1 {
                    "point lies"
                } else {
                    "points lie"
                },
                a.variables
                    .iter()
                    .zip(&a.domain)
                    .map(|(v, (lo, hi))| format!("{v} in [{lo}, {hi}]"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if outside == 1 { "was" } else { "were" }
            )
        } else {
            String::new()
        }
    );
    Ok(())
}

fn eval_model(args: &EvalArgs, name: &str) -> Result<()> {
    // an unwritable output is refused before the quadrature, not after it
    let target = Target::from_arg(&args.output);
    target.check("--output")?;
    target.check_not_input(&[(args.input.as_path(), "--input")], "--output")?;
    let settings = args.quadrature.settings()?;
    let model = args.quadrature.model(name)?;
    let axes: Vec<String> = model.axes().iter().map(|a| a.name.clone()).collect();
    let ranges: Vec<(f64, f64)> = model.axes().iter().map(|a| a.valid_range).collect();
    let points = read_points(&args.input, &axes, &ranges)?;
    let cache = RuleCache::new(&settings);
    let pb = super::progress_bar(
        points.coords.len() as u64,
        &format!("eval {}", model.id().name()),
    );
    let estimates: Vec<_> = points
        .coords
        .par_iter()
        .map(|x| {
            let e = albedo(model.as_ref(), x, &settings, &cache);
            pb.inc(1);
            e
        })
        .collect();
    pb.finish_and_clear();
    let outputs = model.outputs();
    let mut out = points.header.join(",");
    for o in &outputs {
        out.push(',');
        out.push_str(o);
    }
    out.push_str(",err\n");
    let mut unconverged = 0;
    for (raw, e) in points.raw.iter().zip(&estimates) {
        out.push_str(&raw.join(","));
        for v in &e.value[..outputs.len()] {
            out.push_str(&format!(",{v:.15e}"));
        }
        out.push_str(&format!(",{:.3e}\n", e.error));
        unconverged += usize::from(!e.converged);
    }
    target.write(out.as_bytes())?;
    eprintln!(
        "{} points of {} evaluated to {}{}",
        estimates.len(),
        model.id().name(),
        target.describe(),
        if unconverged > 0 {
            format!(
                "; warning: {unconverged} points did not reach the tolerance (see the err column)"
            )
        } else {
            String::new()
        }
    );
    Ok(())
}
