//! `furnace eval --model`: E at arbitrary points by direct quadrature.

use super::EvalArgs;
use crate::bsdf::{self, albedo};
use crate::error::Result;
use crate::quadrature::RuleCache;
use crate::table::{io::write_atomic, points::read_points};
use rayon::prelude::*;

pub fn eval_cmd(args: &EvalArgs) -> Result<()> {
    let settings = args.quadrature.settings()?;
    let model = bsdf::find(&args.model, args.quadrature.model_options())?;
    let axes: Vec<String> = model.axes().iter().map(|a| a.name.clone()).collect();
    let ranges: Vec<(f64, f64)> = model.axes().iter().map(|a| a.valid_range).collect();
    let points = read_points(&args.input, &axes, &ranges)?;
    let cache = RuleCache::new(&settings);
    let pb = super::progress_bar(points.coords.len() as u64, &format!("eval {}", model.name()));
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
        model.name(),
        args.output.display(),
        if unconverged > 0 {
            format!("; warning: {unconverged} points did not reach the tolerance (see the err column)")
        } else {
            String::new()
        }
    );
    Ok(())
}
