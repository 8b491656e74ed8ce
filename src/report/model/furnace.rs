//! The white furnace test of one material in a section (no compensation, exact table, LUTs,
//! fits, the paper's fit) and its sphere images.

use super::data::ModelData;
use super::nodes::{furnace_axis, slice_indices};
use super::{FurnaceRow, FurnaceVariant, Reporter};
use crate::error::Result;
use crate::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at};
use crate::material::{CompensatedBsdf, Compensation};
use crate::report::albedo::Albedo;
use crate::report::plot::{self, ColorScale, Formats};
use crate::report::spheres::{sphere_columns, Show, SphereFigure, SphereRow};
use std::path::Path;
use std::rc::Rc;

impl Reporter<'_> {
    /// Furnace points of a material: table nodes of its albedo model (see [`furnace_axis`]).
    pub(super) fn furnace_points(&self, data: &ModelData) -> Vec<Vec<f64>> {
        let axes = &data.table.spec.axes;
        let dims = axes.len();
        let per_axis: Vec<Vec<usize>> = axes
            .iter()
            .enumerate()
            .map(|(d, a)| {
                if dims == 3 && d == 0 {
                    slice_indices(a.n, self.options.furnace_f0_slices)
                } else {
                    furnace_axis(a.n, self.options.furnace_nodes)
                }
            })
            .collect();
        let mut points = vec![vec![]];
        for (d, idx) in per_axis.iter().enumerate() {
            points = points
                .into_iter()
                .flat_map(|p: Vec<f64>| {
                    idx.iter().map(move |&i| {
                        let mut q = p.clone();
                        q.push(axes[d].node(i));
                        q
                    })
                })
                .collect();
        }
        points
    }

    /// The point of `data`'s axes at roughness `r` and cosine `mu` for the sphere images: `f0` at
    /// [`ReportOptions::sphere_f0`], any other axis at the middle of its table's range.
    pub(super) fn sphere_point(&self, data: &ModelData, r: f64, mu: f64) -> Vec<f64> {
        data.table
            .spec
            .axes
            .iter()
            .map(|a| match a.name.as_str() {
                "r" => r,
                "mu" => mu,
                "f0" => self.options.sphere_f0,
                _ => 0.5 * (a.lo + a.hi),
            })
            .collect()
    }

    /// The furnace test of one material (none, exact table, LUT, fit, paper fit) and its spheres.
    pub(super) fn furnace_row(
        &self,
        material: &dyn CompensatedBsdf,
        dir: &Path,
    ) -> Result<FurnaceRow> {
        let albedos = material.albedos();
        let data = self.data(albedos[0])?;
        let others: Vec<Rc<ModelData>> = albedos[1..]
            .iter()
            .map(|&m| self.data(m))
            .collect::<Result<_>>()?;
        let points = self.furnace_points(&data);
        let lobes = lobe_integrals_at(material, &points);
        let quadrature_error = lobes.iter().map(|l| l.error).fold(0.0, f64::max);
        let unconverged = lobes.iter().filter(|l| !l.converged).count();

        let lut_name = |n: usize| {
            format!(
                "LUT {} ({})",
                vec![n.to_string(); data.dims()].join("×"),
                if data.dims() == 2 {
                    "bilinear"
                } else {
                    "trilinear"
                }
            )
        };
        // the same kind of source for the primary albedo and every other one
        let sources = |pick: &dyn for<'d> Fn(&'d ModelData) -> Option<&'d dyn Albedo>| {
            std::iter::once(&data)
                .chain(&others)
                .map(|d| pick(d))
                .collect::<Option<Vec<&dyn Albedo>>>()
        };
        let mut variants: Vec<(String, std::result::Result<Compensation, String>, String)> =
            Vec::new();
        variants.push((
            "no compensation".into(),
            Ok(Compensation::None),
            "single-scattering BSDF".into(),
        ));
        variants.push((
            format!("exact table ({})", data.table.spec.resolution_name()),
            Ok(Compensation::With(
                sources(&|d| Some(&d.exact)).expect("every table is loaded"),
            )),
            "the furnace points are table nodes".into(),
        ));
        // the LUT of the sphere images, then every other size, by nodes per axis
        let main_lut = data.lut_per_axis();
        let mut lut_sizes = vec![main_lut];
        lut_sizes.extend(self.options.furnace_luts.iter().filter(|&&n| n != main_lut));
        lut_sizes.sort_unstable();
        lut_sizes.dedup();
        for &n in &lut_sizes {
            variants.push((
                lut_name(n),
                Ok(Compensation::With(
                    sources(&|d| d.lut_of(n).map(|l| l as _)).expect("every LUT is loaded"),
                )),
                "multilinear in the tabulated values at its nodes".into(),
            ));
        }
        let chosen = sources(&|d| d.chosen_albedo.as_ref().map(|a| a as _));
        let fit_variant = match (&data.chosen_albedo, data.chosen, chosen) {
            (Some(_), Some(k), Some(s)) => {
                let mut note = data.fits.fits[k].short_form();
                for (j, o) in others.iter().enumerate() {
                    let ok = o.chosen.expect("a chosen albedo has a chosen fit");
                    note.push_str(&format!(
                        " + {} {}",
                        material.albedo_role(j + 1),
                        o.fits.fits[ok].short_form()
                    ));
                }
                Ok((Compensation::With(s), note))
            }
            (Some(_), Some(_), None) => {
                let missing = others
                    .iter()
                    .find(|o| o.chosen_albedo.is_none())
                    .expect("only another albedo can lack its fit");
                Err(format!(
                    "needs a fit of {} too: run `furnace fit --model {} --sweep` first",
                    missing.name, missing.name
                ))
            }
            _ => Err(format!(
                "no fit of {}: run `furnace fit --model {} --sweep` first",
                data.name,
                data.model.id().name()
            )),
        };
        match fit_variant {
            Ok((c, note)) => variants.push(("furnace fit".into(), Ok(c), note)),
            Err(e) => variants.push(("furnace fit".into(), Err(e.clone()), e)),
        }
        // every budget of the sweep (`best-<N>.json` of each albedo the material reads)
        for &(b, k) in &data.budgets {
            let name = format!("best-{b}");
            match sources(&|d| d.budget_albedo(b).map(|a| a as _)) {
                Some(s) => {
                    let f = &data.fits.fits[k];
                    let note = format!(
                        "`best-{b}.json`: {}, {} coefficients",
                        f.short_form(),
                        f.fit.n_coefficients
                    );
                    variants.push((name, Ok(Compensation::With(s)), note));
                }
                None => {
                    let missing = others
                        .iter()
                        .find(|o| o.budget_albedo(b).is_none())
                        .map_or(data.name.as_str(), |o| o.name.as_str());
                    let e = format!("no `best-{b}.json` of {missing}");
                    variants.push((name, Err(e.clone()), e));
                }
            }
        }
        if data.paper.is_some() {
            let v = match sources(&|d| d.paper.as_ref().map(|p| &p.1 as _)) {
                Some(s) => Ok(Compensation::With(s)),
                None => {
                    let j = others.iter().position(|o| o.paper.is_none()).unwrap_or(0);
                    Err(format!(
                        "needs the paper's {} fit too",
                        material.albedo_role(j + 1)
                    ))
                }
            };
            variants.push((
                "paper's fit".into(),
                v,
                "Sforza & Pellacini 2022, Appendix A".into(),
            ));
        }

        let mut out = Vec::new();
        for (name, comp, note) in &variants {
            let stats = comp
                .as_ref()
                .ok()
                .map(|c| furnace_stats(&points, &furnace_values(material, &points, &lobes, c)));
            out.push(FurnaceVariant {
                name: name.clone(),
                stats,
                note: match comp {
                    Ok(_) => note.clone(),
                    Err(e) => e.clone(),
                },
            });
        }

        // spheres: none, the report's LUT, the chosen fit (and the paper's fit)
        let sphere_lut = lut_name(main_lut);
        let sphere_rows: Vec<&(String, std::result::Result<Compensation, String>, String)> =
            variants
                .iter()
                .filter(|v| {
                    !v.0.starts_with("exact table")
                        && !v.0.starts_with("best-")
                        && (!v.0.starts_with("LUT") || v.0 == sphere_lut)
                })
                .collect();
        let comps: Vec<Compensation> = sphere_rows
            .iter()
            .filter_map(|v| v.1.as_ref().ok().cloned())
            .collect();
        let point = |r: f64, mu: f64| self.sphere_point(&data, r, mu);
        let mut columns =
            sphere_columns(material, &point, &self.options.sphere_roughness, &comps).into_iter();
        let rows: Vec<SphereRow> = sphere_rows
            .iter()
            .map(|v| {
                let cols = match &v.1 {
                    Ok(_) => Ok(columns
                        .next()
                        .expect("one column set per available compensation")),
                    Err(e) => Err(format!("not available: {e}")),
                };
                let note = match &cols {
                    Ok(c) => format!(
                        "max |1 − E| = {}",
                        plot::format_number(
                            c.iter()
                                .flat_map(|s| s.values.iter())
                                .map(|e| (1.0 - e).abs())
                                .fold(0.0, f64::max)
                        )
                    ),
                    Err(_) => String::new(),
                };
                SphereRow {
                    label: v.0.clone(),
                    note,
                    columns: cols,
                }
            })
            .collect();
        let f0 = material.fixed_f0().or_else(|| {
            data.axes
                .iter()
                .any(|a| a == "f0")
                .then_some(self.options.sphere_f0)
        });
        let f0_text = match f0 {
            Some(f0) => format!(", F0 = {}", plot::format_number(f0)),
            None => String::new(),
        };
        let column_labels: Vec<String> = self
            .options
            .sphere_roughness
            .iter()
            .map(|r| format!("r = {}", plot::format_number(*r)))
            .collect();
        let caption = "Orthographic view of spheres under a uniform white environment: pixel = albedo E of the BSDF at μ = n·v (computed by quadrature). Faint circles outline the spheres.".to_string();
        let dev_caption = "Pixel = E − 1 of the compensated BSDF on a symmetric log colour scale (|E − 1| below the bar's smallest tick is white). Faint circles outline the spheres.".to_string();
        let albedo_fig = SphereFigure {
            title: format!("White furnace: {}{f0_text}", material.label()),
            column_labels: column_labels.clone(),
            rows: rows.clone(),
            show: Show::Albedo,
            scale: ColorScale::Gray { lo: 0.0, hi: 1.0 },
            colorbar_label: "E (pixel value, linear; shown sRGB)".into(),
            caption: caption.clone(),
        };
        let mut images = Vec::new();
        let stem = dir.join(format!("furnace-{}", material.id()));
        images.extend(plot::save(&albedo_fig, &stem, Formats::Png)?);
        let compensated: Vec<SphereRow> = rows
            .into_iter()
            .filter(|r| r.label != "no compensation")
            .collect();
        let deviations: Vec<f64> = compensated
            .iter()
            .filter_map(|r| r.columns.as_ref().ok())
            .flat_map(|c| c.iter().flat_map(|s| s.values.iter().map(|e| e - 1.0)))
            .collect();
        let dev_fig = SphereFigure {
            title: format!(
                "White furnace, E − 1 of the compensated BSDFs: {}{f0_text}",
                material.label()
            ),
            column_labels,
            rows: compensated,
            show: Show::Deviation,
            scale: ColorScale::signed_log_for(&deviations, 4.0),
            colorbar_label: "E − 1 (red: energy gain, blue: loss)".into(),
            caption: dev_caption,
        };
        images.extend(plot::save(
            &dev_fig,
            &dir.join(format!("furnace-{}-deviation", material.id())),
            Formats::Png,
        )?);
        let images = images
            .iter()
            .map(|p| {
                p.strip_prefix(&self.options.reports_dir)
                    .unwrap_or(p)
                    .to_string_lossy()
                    .replace('\\', "/")
            })
            .collect();
        Ok(FurnaceRow {
            material: material.label(),
            id: material.id(),
            points: points.len(),
            quadrature_error,
            unconverged,
            variants: out,
            images,
        })
    }
}
