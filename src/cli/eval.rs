//! `furnace eval --model`: E at arbitrary points by direct quadrature; `furnace eval --fit`: E
//! from a fit file's coefficients.

use super::EvalArgs;
use crate::bsdf::albedo;
use crate::error::{Error, Result};
use crate::fit::job::FitRecord;
use crate::quadrature::RuleCache;
use crate::table::{io::write_atomic, points::read_points};
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

/// E = P/Q (or P) of a fit file at the points of `--input`, which must lie in the fit's domain.
fn eval_fit(args: &EvalArgs, fit_path: &Path) -> Result<()> {
    let text = std::fs::read_to_string(fit_path).map_err(|e| Error::io(fit_path, e))?;
    let rec = FitRecord::from_json(&text).map_err(|m| Error::file(fit_path, m))?;
    let a = &rec.fit.approximant;
    let points = read_points(&args.input, &a.variables, &a.domain)?;
    if !rec.usable {
        eprintln!("warning: {}: {}", fit_path.display(), rec.verdict);
    }
    let mut out = points.header.join(",");
    out.push_str(",E\n");
    for (k, (raw, x)) in points.raw.iter().zip(&points.coords).enumerate() {
        let e = a.eval(x);
        if !e.is_finite() {
            return Err(Error::file(
                &args.input,
                format!(
                    "data row {}: the fit is not finite at {x:?} (a pole of its denominator); {}",
                    k + 1,
                    rec.verdict
                ),
            ));
        }
        out.push_str(&raw.join(","));
        out.push_str(&format!(",{e}\n"));
    }
    write_atomic(&args.output, out.as_bytes())?;
    eprintln!(
        "{} points of {} evaluated to {}",
        points.coords.len(),
        fit_path.display(),
        args.output.display()
    );
    Ok(())
}

fn eval_model(args: &EvalArgs, name: &str) -> Result<()> {
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
    write_atomic(&args.output, out.as_bytes())?;
    eprintln!(
        "{} points of {} evaluated to {}{}",
        estimates.len(),
        model.id().name(),
        args.output.display(),
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
