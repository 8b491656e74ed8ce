//! A section's markdown (`reports/<model>/section.md`).

use super::data::ModelData;
use super::format::fmt_point;
use super::{fmt_e, fmt_f, paper_table_markdown, ModelSummary, Reporter};
use crate::report::inputs::short_form;
use crate::report::offgrid::{self, OffGridSummary, SweepPoint};
use std::fmt::Write as _;

impl Reporter<'_> {
    pub(super) fn section_markdown(&self, data: &ModelData, s: &ModelSummary) -> String {
        let mut md = String::new();
        let name = &s.model;
        let _ = writeln!(md, "### {name}\n");
        let _ = writeln!(md, "{}.\n", s.description.trim_end_matches('.'));
        let _ = writeln!(
            md,
            "Table: {} nodes over the default domain, largest per-cell quadrature error estimate {}; fits are measured against it at every node.\n",
            s.resolution,
            fmt_e(s.table_max_error_estimate)
        );
        let link = |f: &str| format!("{name}/{f}");
        let has = |f: &str| s.files.iter().any(|x| *x == link(f));

        let _ = writeln!(md, "#### Error against number of coefficients\n");
        if data.fits.fits.is_empty() {
            let _ = writeln!(
                md,
                "No fits found under `fits/{}/`: run `furnace fit --model {} --sweep` first.\n",
                data.model.id().key(),
                data.model.id().name()
            );
        }
        for n in &data.fits.notes {
            let _ = writeln!(md, "- {n}");
        }
        if !data.fits.notes.is_empty() {
            md.push('\n');
        }
        if has("error-vs-coefficients.png") {
            let _ = writeln!(
                md,
                "![{name}: MAE and max error against number of coefficients]({}) ([SVG]({}))\n",
                link("error-vs-coefficients.png"),
                link("error-vs-coefficients.svg")
            );
        }
        if !s.fits.is_empty() || data.paper.is_some() {
            let _ = writeln!(md, "| fit | form | coefficients | MAE | max error | max rel. error | pole-free | as fitted: MAE / max |");
            let _ = writeln!(
                md,
                "| --- | --- | ---: | ---: | ---: | ---: | :---: | ---: |"
            );
            let mut order: Vec<usize> = (0..s.fits.len()).collect();
            order.sort_by(|&a, &b| {
                (
                    s.fits[a].form.starts_with("rational"),
                    s.fits[a].n_coefficients,
                    &s.fits[a].source,
                )
                    .cmp(&(
                        s.fits[b].form.starts_with("rational"),
                        s.fits[b].n_coefficients,
                        &s.fits[b].source,
                    ))
            });
            for k in order {
                let f = &s.fits[k];
                let chosen = if s.chosen == Some(k) {
                    " **(chosen)**"
                } else {
                    ""
                };
                let _ = writeln!(
                    md,
                    "| `{}`{chosen} | {} | {} | {} | {} | {} | {} | {} / {} |",
                    f.source,
                    f.form,
                    f.n_coefficients,
                    fmt_e(f.measured.mae),
                    fmt_e(f.measured.max_abs),
                    fmt_e(f.measured.max_rel),
                    if f.usable { "yes" } else { "no" },
                    fmt_e(f.reported_mae),
                    fmt_e(f.reported_max)
                );
            }
            if let Some((fit, _, m)) = &data.paper {
                let _ = writeln!(
                    md,
                    "| paper (published) | {} | {} | {} | {} | {} | {} | {} / {} |",
                    short_form(&fit.form),
                    fit.n_coefficients,
                    fmt_e(m.mae),
                    fmt_e(m.max_abs),
                    fmt_e(m.max_rel),
                    if fit.is_usable() { "yes" } else { "no" },
                    fmt_e(fit.metrics.mae),
                    fmt_e(fit.metrics.max_abs_error)
                );
            }
            let _ = writeln!(md, "\n\"As fitted\" is what the fit file records (on the data it was fitted to; for the paper, its own 32-point table).\n");
        }

        if let Some(og) = &s.off_grid {
            let _ = writeln!(md, "#### Off-grid errors: fits against LUTs\n");
            let _ = writeln!(
                md,
                "Every fit of the sweep and the multilinear LUTs of the same model, measured at the same points against the exact values: {}.\n",
                og.check_set
            );
            if has("off-grid.png") {
                let _ = writeln!(
                    md,
                    "![{name}: off-grid error against stored values]({}) ([SVG]({}))\n",
                    link("off-grid.png"),
                    link("off-grid.svg")
                );
            }
            md.push_str(&offgrid_markdown(og, &data.sweep_points, data.dims()));
        }

        let _ = writeln!(md, "#### Error of the chosen fit over the domain\n");
        if has("heatmap-abs.png") {
            let _ = writeln!(
                md,
                "![{name}: |fit − table|]({}) ([SVG]({}))\n",
                link("heatmap-abs.png"),
                link("heatmap-abs.svg")
            );
            let _ = writeln!(
                md,
                "![{name}: fit − table]({}) ([SVG]({}))\n",
                link("heatmap-signed.png"),
                link("heatmap-signed.svg")
            );
        } else {
            let _ = writeln!(
                md,
                "No chosen fit yet (run `furnace fit --model {} --sweep` first).\n",
                data.model.id().name()
            );
        }
        let _ = writeln!(md, "#### Slices E(μ) at several r\n");
        if has("slices.png") {
            let _ = writeln!(
                md,
                "![{name}: E(μ) slices]({}) ([SVG]({}))\n",
                link("slices.png"),
                link("slices.svg")
            );
        }

        if let Some(p) = &s.paper {
            let _ = writeln!(
                md,
                "#### Against the paper's published fit (`{}`)\n",
                p.paper_table
            );
            let _ = writeln!(md, "{}\n", paper_table_markdown(std::slice::from_ref(p)));
            for n in &p.notes {
                let _ = writeln!(md, "- {n}");
            }
            if !p.notes.is_empty() {
                md.push('\n');
            }
        }

        if !s.furnace.is_empty() {
            let _ = writeln!(md, "#### White furnace test\n");
            let _ = writeln!(md, "max |1 − E| of the energy-compensated BSDF, E integrated by quadrature of the BSDF over incident directions (`furnace::material::furnace`), at table nodes.\n");
            for row in &s.furnace {
                let _ = writeln!(
                    md,
                    "**{}** ({} points; quadrature error estimate ≤ {}{})\n",
                    row.material,
                    row.points,
                    fmt_e(row.quadrature_error),
                    if row.unconverged > 0 {
                        format!(", {} points unconverged", row.unconverged)
                    } else {
                        String::new()
                    }
                );
                let _ = writeln!(md, "| compensation | max \\|1 − E\\| | at | mean \\|1 − E\\| | E range | albedo source |");
                let _ = writeln!(md, "| --- | ---: | --- | ---: | --- | --- |");
                for v in &row.variants {
                    match &v.stats {
                        Some(st) => {
                            let _ = writeln!(
                                md,
                                "| {} | {} | {} | {} | [{}, {}] | {} |",
                                v.name,
                                fmt_e(st.max_deviation),
                                fmt_point(&st.at, &data_axes_for(&row.id, &data.axes)),
                                fmt_e(st.mean_deviation),
                                fmt_f(st.min_albedo),
                                fmt_f(st.max_albedo),
                                v.note
                            );
                        }
                        None => {
                            let _ = writeln!(md, "| {} | – | | | | {} |", v.name, v.note);
                        }
                    }
                }
                md.push('\n');
                for img in &row.images {
                    let _ = writeln!(md, "![{}]({img})\n", row.material);
                }
            }
        }
        md
    }
}

/// The off-grid tables of a section: the best fits and the LUTs (with the flag of a best fit
/// that loses to the [`offgrid::LUT_TO_BEAT`]-per-axis LUT), then the lowest max error of every
/// form family within each budget.
fn offgrid_markdown(og: &OffGridSummary, points: &[SweepPoint], dims: usize) -> String {
    let mut md = String::new();
    let losing: Vec<usize> = og
        .best
        .iter()
        .filter(|b| og.loses(b))
        .map(|b| b.budget)
        .collect();
    let _ = writeln!(
        md,
        "| albedo source | form | stored values | max error | MAE |"
    );
    let _ = writeln!(md, "| --- | --- | ---: | ---: | ---: |");
    for b in &og.best {
        let flag = if losing.contains(&b.budget) {
            format!(" (loses to the LUT {})", offgrid::LUT_TO_BEAT)
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| `{}`{flag} | {} | {} | {} | {} |",
            b.file,
            b.form,
            b.n_coefficients,
            fmt_e(b.max_abs_error),
            fmt_e(b.mae)
        );
    }
    for l in &og.luts {
        let _ = writeln!(
            md,
            "| LUT {} | {} | {} | {} | {} |",
            vec![l.per_axis.to_string(); dims].join("×"),
            if dims == 2 { "bilinear" } else { "trilinear" },
            l.values,
            fmt_e(l.errors.max_abs_error),
            fmt_e(l.errors.mae)
        );
    }
    md.push('\n');
    let families = offgrid::families(points);
    if !families.is_empty() {
        let budgets = crate::fit::job::default_budgets(dims);
        let _ = writeln!(
            md,
            "Lowest off-grid max error of each form family of the sweep within each budget (max / MAE, coefficients):\n"
        );
        let _ = writeln!(
            md,
            "| form family | {} |",
            budgets
                .iter()
                .map(|b| format!("≤ {b}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(md, "| --- |{}", " ---: |".repeat(budgets.len()));
        for f in &families {
            let cells: Vec<String> = budgets
                .iter()
                .map(|&b| {
                    offgrid::lowest_max_within(points, f, b).map_or("–".into(), |p| {
                        format!(
                            "{} / {} ({})",
                            fmt_e(p.max_abs_error),
                            fmt_e(p.mae),
                            p.n_coefficients
                        )
                    })
                })
                .collect();
            let _ = writeln!(md, "| {f} | {} |", cells.join(" | "));
        }
        md.push('\n');
    }
    md
}

/// Axis names for a furnace row (its albedo model's).
fn data_axes_for(_id: &str, axes: &[String]) -> Vec<String> {
    axes.to_vec()
}
