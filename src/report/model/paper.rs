//! The comparison of furnace's fit with the paper's published fit, and its markdown table.

use super::data::{fit_row, ModelData};
use super::{fmt_e, PaperRow, Reporter};
use crate::bsdf::ModelId;
use crate::error::{Error, Result};
use crate::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at};
use crate::material::{compensated_for, Compensation};
use crate::report::albedo::Albedo;
use crate::report::inputs::{self};
use std::cell::RefCell;
use std::fmt::Write as _;
use std::rc::Rc;

impl Reporter<'_> {
    /// The paper comparison: both fits measured on the furnace table in the paper's convention,
    /// with their furnace max |1 − E|.
    pub(super) fn paper_row(&self, id: ModelId, link: inputs::PaperLink) -> Result<PaperRow> {
        let name = id.key();
        let data = self.data(link.model)?;
        let mut notes = Vec::new();
        let (paper_fit, _, paper_measured) = data
            .paper
            .as_ref()
            .ok_or_else(|| Error::InvalidInput(format!("{name}: the paper's fit did not load")))?;
        let material = compensated_for(link.model).into_iter().next();
        let others: Vec<Rc<ModelData>> = match &material {
            Some(m) => m.albedos()[1..]
                .iter()
                .map(|&o| self.data(o))
                .collect::<Result<_>>()?,
            None => Vec::new(),
        };
        // the lobe integrals do not depend on the compensation: computed once for both fits
        let points = self.furnace_points(&data);
        let lobes: RefCell<Option<Vec<_>>> = RefCell::new(None);
        let furnace_of = |sources: Vec<&dyn Albedo>| -> Option<f64> {
            let m = material.as_deref()?;
            let mut lobes = lobes.borrow_mut();
            let lobes = lobes.get_or_insert_with(|| lobe_integrals_at(m, &points));
            let values = furnace_values(m, &points, lobes, &Compensation::With(sources));
            Some(furnace_stats(&points, &values).max_deviation)
        };
        let other_sources = |pick: &dyn for<'d> Fn(&'d ModelData) -> Option<&'d dyn Albedo>| {
            others
                .iter()
                .map(|d| pick(d))
                .collect::<Option<Vec<&dyn Albedo>>>()
        };
        let paper_fit_furnace = match other_sources(&|d| d.paper.as_ref().map(|p| &p.1 as _)) {
            Some(rest) => {
                let mut s: Vec<&dyn Albedo> = vec![&data.paper.as_ref().expect("checked").1];
                s.extend(rest);
                furnace_of(s)
            }
            None => None,
        };
        let (furnace_fit, furnace_fit_furnace) = match (data.chosen, &data.chosen_albedo) {
            (Some(k), Some(f)) => {
                let ff = match other_sources(&|d| d.chosen_albedo.as_ref().map(|a| a as _)) {
                    Some(rest) => {
                        let mut s: Vec<&dyn Albedo> = vec![f];
                        s.extend(rest);
                        furnace_of(s)
                    }
                    None => {
                        let m = material.as_deref().expect("others come from a material");
                        let j = others
                            .iter()
                            .position(|o| o.chosen_albedo.is_none())
                            .unwrap_or(0);
                        notes.push(format!(
                            "the furnace number of furnace's {} fit needs a {} fit too",
                            m.albedo_role(0),
                            m.albedo_role(j + 1)
                        ));
                        None
                    }
                };
                (Some(data.fit_row(k)), ff)
            }
            _ => {
                notes.push(format!(
                    "no furnace fit of {}: run `furnace fit --model {}{} --sweep` first",
                    data.name,
                    name,
                    if link.model.is_radiance() {
                        " --transmission radiance"
                    } else {
                        ""
                    }
                ));
                (None, None)
            }
        };
        Ok(PaperRow {
            paper_table: link.stem.to_string(),
            convention_model: data.name.clone(),
            resolution: data.table.spec.resolution_name(),
            furnace_fit,
            furnace_fit_furnace,
            paper_fit: fit_row("paper", paper_fit, paper_measured),
            paper_fit_furnace,
            notes,
        })
    }
}

/// The side-by-side table of furnace's fit and the paper's published fit.
pub fn paper_table_markdown(rows: &[PaperRow]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "| paper table | measured on | fit | form | coefficients | MAE | max error | furnace max \\|1 − E\\| |");
    let _ = writeln!(md, "| --- | --- | --- | --- | ---: | ---: | ---: | ---: |");
    for p in rows {
        let on = format!("`{}` {}", p.convention_model, p.resolution);
        match &p.furnace_fit {
            Some(f) => {
                let _ = writeln!(
                    md,
                    "| {} | {on} | furnace (`{}`) | {} | {} | {} | {} | {} |",
                    p.paper_table,
                    f.source,
                    f.form,
                    f.n_coefficients,
                    fmt_e(f.measured.mae),
                    fmt_e(f.measured.max_abs),
                    p.furnace_fit_furnace.map_or("–".into(), fmt_e)
                );
            }
            None => {
                let _ = writeln!(
                    md,
                    "| {} | {on} | furnace | no fit yet | | | | |",
                    p.paper_table
                );
            }
        }
        let f = &p.paper_fit;
        let _ = writeln!(
            md,
            "| {} | {on} | paper (published) | {} | {} | {} | {} | {} |",
            p.paper_table,
            f.form,
            f.n_coefficients,
            fmt_e(f.measured.mae),
            fmt_e(f.measured.max_abs),
            p.paper_fit_furnace.map_or("–".into(), fmt_e)
        );
    }
    md.trim_end().to_string()
}
