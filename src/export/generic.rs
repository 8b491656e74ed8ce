//! The generic export: any model (albedos, their averages, split-sum terms, Fresnel averages)
//! on a grid of its default domain, as furnace's own table files — `<stem>.exr` (one f32
//! channel per output plus `err`, one image n_last wide), `<stem>.f64` (the exact values,
//! little-endian, each output in turn, then the error estimates) and `<stem>.json` (tool,
//! version, model, its definition, axes and node placement, layout, quadrature settings and the
//! error summary with the largest estimate). The layout is that of `furnace tabulate`
//! (docs/quadrature.md#tables).

use super::{model_definition, report, Compute, Export, Files};
use crate::bsdf::Model;
use crate::error::{Error, Result};
use crate::table::TableSpec;
use std::path::{Path, PathBuf};

/// The stem of `output` (`lut.exr` → `lut`).
pub fn stem(output: &Path) -> Result<PathBuf> {
    if output.extension().is_some_and(|e| e == "exr") {
        Ok(output.with_extension(""))
    } else {
        Err(Error::InvalidInput(format!(
            "--output {}: the generic format writes an EXR with its .f64 and .json beside it; give a path ending in .exr",
            output.display()
        )))
    }
}

/// The generic export of `model` at `resolution` (one count per axis) to `output` (`….exr`).
pub fn export(
    compute: &Compute,
    model: &dyn Model,
    resolution: &[usize],
    output: &Path,
) -> Result<Export> {
    let stem = stem(output)?;
    let spec = TableSpec::new(model, resolution, compute.quadrature.clone())?;
    super::check_paths(&crate::table::io::files(&stem), None)?;
    let (table, seconds) = compute.table(model.id(), spec.axes)?;
    let (m, definition) = (model, model_definition(model));
    Ok(Export {
        tables: vec![report(&m.id().key(), definition.clone(), &table, seconds)],
        files: Files::Table(Box::new(table), stem, definition),
        replaceable: None,
    })
}
