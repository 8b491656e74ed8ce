//! `reports/README.md`: the summary tables (per model, the best fits against the LUTs off the
//! grid, furnace against the paper, the white furnace test), the run-time-against-error plots
//! from the benchmark files, and every model's section, assembled from the `summary.json` and `section.md` each model's report wrote.

use super::inputs::{load_bench, BenchPlot};
use super::model::{fmt_e, paper_table_markdown, ModelSummary, Reporter};
use super::offgrid::{OffGridSummary, LUT_TO_BEAT};
use super::plot::{self, color, Axis, Chart, Figure, Formats, LegendAt, Series, Style};
use crate::bsdf::ModelId;
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What a report run produced.
#[derive(Clone, Debug)]
pub struct ReportOutcome {
    /// The sections of the models asked for, in order (regenerated, or kept when reused).
    pub regenerated: Vec<ModelSummary>,
    /// Models whose sections were kept because their inputs had not changed.
    pub reused: Vec<String>,
    /// Every file the README links (relative to `reports/`).
    pub linked: Vec<String>,
    pub readme: PathBuf,
}

/// Files a model's report owns in its folder: figures, images and the two text files.
fn owned(p: &Path) -> bool {
    matches!(p.extension().and_then(|e| e.to_str()), Some("png" | "svg"))
        || matches!(
            p.file_name().and_then(|e| e.to_str()),
            Some("section.md" | "summary.json")
        )
}

/// Removes files of `dir` that a model report owns but did not write this time (stale figures
/// of a fit that is gone), so that the folder holds exactly what the README links.
fn remove_stale(dir: &Path, keep: &[PathBuf]) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_file() && owned(&p) && !keep.iter().any(|k| k == &p) {
            std::fs::remove_file(&p).map_err(|err| Error::io(&p, err))?;
        }
    }
    Ok(())
}

impl Reporter<'_> {
    /// Regenerates the sections of `models` (the default set, [`crate::bsdf::default_set`], if
    /// `None`), the benchmark
    /// plots, and `reports/README.md`.
    pub fn generate(&self, models: Option<&[ModelId]>) -> Result<ReportOutcome> {
        self.generate_each(models, false, &mut |_, _| {})
    }

    /// [`Reporter::generate`], calling `done(k, model)` after the k-th section (from 0). With
    /// `reuse`, a section whose inputs are unchanged and whose files are intact is kept as it is
    /// ([`Reporter::reusable_section`]) — it would come out byte for byte the same.
    pub fn generate_each(
        &self,
        models: Option<&[ModelId]>,
        reuse: bool,
        done: &mut dyn FnMut(usize, &str),
    ) -> Result<ReportOutcome> {
        let default_set = crate::bsdf::default_set();
        let targets = models.unwrap_or(&default_set);
        for &m in targets {
            crate::bsdf::get(m)?;
        }
        let mut regenerated = Vec::new();
        let mut reused = Vec::new();
        for (k, &m) in targets.iter().enumerate() {
            let kept = if reuse {
                self.reusable_section(m)?
            } else {
                None
            };
            if kept.is_some() {
                reused.push(m.key());
            }
            let s = match kept {
                Some(s) => s,
                None => self.report_model(m)?,
            };
            let dir = self.options.reports_dir.join(m.key());
            let mut keep: Vec<PathBuf> = s
                .files
                .iter()
                .map(|f| self.options.reports_dir.join(f))
                .collect();
            keep.push(dir.join("section.md"));
            keep.push(dir.join("summary.json"));
            remove_stale(&dir, &keep)?;
            regenerated.push(s);
            done(k, &m.key());
        }
        // the README lists the default set, then any other model that has a section
        let mut order: Vec<String> = default_set.iter().map(|m| m.key()).collect();
        for m in targets {
            if !order.contains(&m.key()) {
                order.push(m.key());
            }
        }
        let anisotropy = self.anisotropy_section(reuse)?;
        let (readme, linked) = self.assemble(&order, anisotropy.as_ref())?;
        Ok(ReportOutcome {
            regenerated,
            reused,
            linked,
            readme,
        })
    }

    fn load_summary(&self, model: &str) -> Result<Option<(ModelSummary, String)>> {
        let dir = self.options.reports_dir.join(model);
        let (json, md) = (dir.join("summary.json"), dir.join("section.md"));
        if !json.is_file() || !md.is_file() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&json).map_err(|e| Error::io(&json, e))?;
        let summary: ModelSummary = serde_json::from_str(&text).map_err(|e| {
            Error::file(
                &json,
                format!(
                    "not a report summary ({e}); regenerate with `furnace report --model {model}`"
                ),
            )
        })?;
        let section = std::fs::read_to_string(&md).map_err(|e| Error::io(&md, e))?;
        Ok(Some((summary, section)))
    }

    /// Writes `reports/README.md` from the models' summaries and sections; returns its path and
    /// the files it links.
    fn assemble(
        &self,
        order: &[String],
        anisotropy: Option<&(String, Vec<String>)>,
    ) -> Result<(PathBuf, Vec<String>)> {
        let mut sections: Vec<(String, Option<(ModelSummary, String)>)> = Vec::new();
        for m in order {
            sections.push((m.clone(), self.load_summary(m)?));
        }
        let mut linked: Vec<String> = Vec::new();
        let mut md = String::new();
        let _ = writeln!(md, "# furnace error reports\n");
        let _ = writeln!(
            md,
            "Generated by furnace {} — by `furnace run` (which keeps a model's section when its inputs have not changed) or by `furnace report` \
(everything; one model's section with `furnace report --model <name>`). Every number here is computed from the tables under `data/`, the fits under `fits/` \
and the paper's published coefficients, except the run times, which are read from the benchmark files under `{}/`: only the benchmark commands \
(`furnace bench … --output`) write those, and neither `furnace run` nor `furnace report` measures or rewrites them, so that re-running the pipeline \
gives the same bytes.\n",
            crate::VERSION,
            display_rel(&self.options.bench_dir)
        );
        let _ = writeln!(md, "- [Summary](#summary)\n- [Off-grid errors: fits against LUTs](#off-grid-errors-fits-against-luts)\n- [Furnace and the paper, side by side](#furnace-and-the-paper-side-by-side)\n- [White furnace test](#white-furnace-test)\n{}- [Run time against error](#run-time-against-error)\n- [Models](#models): {}\n",
            if anisotropy.is_some() { "- [Anisotropic conductor: the isotropic shortcuts](#anisotropic-conductor-the-isotropic-shortcuts)\n" } else { "" },
            order.iter().map(|m| format!("[{m}](#{})", anchor(m))).collect::<Vec<_>>().join(", "));

        // Summary
        let _ = writeln!(md, "## Summary\n");
        let _ = writeln!(md, "Errors of the chosen fit against the model's table (at every node); furnace: max |1 − E| of the BSDF compensated with that fit.\n");
        let _ = writeln!(md, "| model | table | fits found | chosen fit | coefficients | MAE | max error | max rel. error | furnace max \\|1 − E\\| |");
        let _ = writeln!(
            md,
            "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |"
        );
        for (m, s) in &sections {
            let Some((s, _)) = s else {
                let _ = writeln!(md, "| [{m}](#{}) | not generated: run `furnace report --model {m}` | | | | | | | |", anchor(m));
                continue;
            };
            let furnace = s
                .furnace
                .first()
                .and_then(|r| r.variants.iter().find(|v| v.name == "furnace fit"))
                .and_then(|v| v.stats.as_ref())
                .map(|st| fmt_e(st.max_deviation));
            match s.chosen.and_then(|k| s.fits.get(k)) {
                Some(f) => {
                    let _ = writeln!(
                        md,
                        "| [{m}](#{}) | {} | {} | `{}` {} | {} | {} | {} | {} | {} |",
                        anchor(m),
                        s.resolution,
                        s.fits.len(),
                        f.source,
                        f.form,
                        f.n_coefficients,
                        fmt_e(f.measured.mae),
                        fmt_e(f.measured.max_abs),
                        fmt_e(f.measured.max_rel),
                        furnace.unwrap_or_else(|| "–".into())
                    );
                }
                None => {
                    let _ = writeln!(md, "| [{m}](#{}) | {} | {} | none: run `furnace fit --model {m} --sweep` | | | | | |", anchor(m), s.resolution, s.fits.len());
                }
            }
        }
        md.push('\n');

        // Off-grid: best fits next to the LUTs
        let _ = writeln!(md, "## Off-grid errors: fits against LUTs\n");
        let with_off_grid: Vec<(&String, &OffGridSummary)> = sections
            .iter()
            .filter_map(|(m, s)| {
                s.as_ref()
                    .and_then(|(s, _)| s.off_grid.as_ref().map(|o| (m, o)))
            })
            .collect();
        if with_off_grid.is_empty() {
            let _ = writeln!(md, "No off-grid errors yet: `furnace run` measures every best fit and the 16/32/64-per-axis LUTs at each model's check points (`fits/<model>/off-grid.json`).\n");
        } else {
            let _ = writeln!(
                md,
                "Max error / MAE at each model's off-grid check points (quasi-random over the whole domain plus the grazing, low-roughness and low-F0 layers and every face; exact values by quadrature), of each `best-<N>.json` and of multilinear LUTs of 16, 32 and 64 nodes per axis (f64 values) at the same points. \
**Bold**: a best fit that loses to the {n}-per-axis LUT on max error or MAE. Each model's section plots every form family of the sweep against the LUTs.\n",
                n = LUT_TO_BEAT
            );
            let mut budgets: Vec<usize> = with_off_grid
                .iter()
                .flat_map(|(_, o)| o.best.iter().map(|b| b.budget))
                .collect();
            budgets.sort_unstable();
            budgets.dedup();
            let mut luts: Vec<usize> = with_off_grid
                .iter()
                .flat_map(|(_, o)| o.luts.iter().map(|l| l.per_axis))
                .collect();
            luts.sort_unstable();
            luts.dedup();
            let _ = writeln!(
                md,
                "| model | {} | {} |",
                budgets
                    .iter()
                    .map(|b| format!("best-{b}"))
                    .collect::<Vec<_>>()
                    .join(" | "),
                luts.iter()
                    .map(|n| format!("LUT {n}"))
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
            let _ = writeln!(
                md,
                "| --- |{}",
                " ---: |".repeat(budgets.len() + luts.len())
            );
            for (m, o) in &with_off_grid {
                let mut cells: Vec<String> = budgets
                    .iter()
                    .map(|&b| {
                        o.best
                            .iter()
                            .find(|e| e.budget == b)
                            .map_or("–".into(), |e| {
                                let text = format!(
                                    "{} / {} ({})",
                                    fmt_e(e.max_abs_error),
                                    fmt_e(e.mae),
                                    e.n_coefficients
                                );
                                if o.loses(e) {
                                    format!("**{text}**")
                                } else {
                                    text
                                }
                            })
                    })
                    .collect();
                cells.extend(luts.iter().map(|&n| {
                    o.luts
                        .iter()
                        .find(|l| l.per_axis == n)
                        .map_or("–".into(), |l| {
                            format!(
                                "{} / {} ({})",
                                fmt_e(l.errors.max_abs_error),
                                fmt_e(l.errors.mae),
                                l.values
                            )
                        })
                }));
                let _ = writeln!(md, "| [{m}](#{}) | {} |", anchor(m), cells.join(" | "));
            }
            let _ = writeln!(
                md,
                "\nIn parentheses: stored values (coefficients of the fit, nodes of the LUT).\n"
            );
        }

        // Paper side by side
        let _ = writeln!(md, "## Furnace and the paper, side by side\n");
        let paper_rows: Vec<_> = sections
            .iter()
            .filter_map(|(_, s)| s.as_ref())
            .filter_map(|(s, _)| s.paper.clone())
            .collect();
        if paper_rows.is_empty() {
            let _ = writeln!(md, "No paper comparison: the paper's coefficients were not found (pass `--paper-dir <dsforza96/energy-preservation resources>` or set `FURNACE_PAPER_DATA`), or the separable models' sections are not generated yet.\n");
        } else {
            let _ = writeln!(
                md,
                "Sforza & Pellacini 2022 publish degree-3 rationals for four tables (separable Smith G; dielectric transmission in radiance form). Both fits are measured here on the same furnace table in the paper's convention, at every node; \
the furnace column is max |1 − E| of the BSDF compensated with each fit (glossy: with the same source's conductor fit for E_ss).\n"
            );
            let _ = writeln!(md, "{}\n", paper_table_markdown(&paper_rows));
            for p in &paper_rows {
                for n in &p.notes {
                    let _ = writeln!(md, "- {}: {n}", p.paper_table);
                }
            }
            md.push('\n');
        }

        // White furnace
        let _ = writeln!(md, "## White furnace test\n");
        let _ = writeln!(
            md,
            "Albedo of the energy-compensated BSDF under a uniform white environment, integrated by quadrature of the compensated BSDF over incident directions (not by re-reading the albedo it is compensated with): \
max |1 − E| over the table nodes tested (1 = energy preserved). Compensations follow the paper: conductor ρ_ss/E (eqs. 7–9, 13 with F0 = 1), glossy ρ_ss/E_ss + (1 − E_spec)ρ_diff (eqs. 16–18), \
thin and thick dielectrics (ρ_R + ρ_T)/E (§3.4, eq. 19); rough diffuse is Fujii's Oren–Nayar with the EON multiple-scattering lobe built from E.\n"
        );
        let mut columns: Vec<String> = Vec::new();
        for (_, s) in sections
            .iter()
            .filter_map(|(m, s)| s.as_ref().map(|s| (m, s)))
        {
            for row in &s.0.furnace {
                for v in &row.variants {
                    let key = variant_key(&v.name);
                    if !columns.contains(&key) {
                        columns.push(key);
                    }
                }
            }
        }
        if columns.is_empty() {
            let _ = writeln!(md, "No furnace results yet: generate the sections of the GGX and rough-diffuse models.\n");
        } else {
            let _ = writeln!(
                md,
                "| material | compensation table of | {} |",
                columns.join(" | ")
            );
            let _ = writeln!(md, "| --- | --- |{}", " ---: |".repeat(columns.len()));
            for (m, s) in &sections {
                let Some((s, _)) = s else { continue };
                for row in &s.furnace {
                    let mut cells: BTreeMap<String, String> = BTreeMap::new();
                    for v in &row.variants {
                        cells.insert(
                            variant_key(&v.name),
                            v.stats
                                .as_ref()
                                .map_or("–".into(), |st| fmt_e(st.max_deviation)),
                        );
                    }
                    let _ = writeln!(
                        md,
                        "| {} | [{m}](#{}) | {} |",
                        row.material,
                        anchor(m),
                        columns
                            .iter()
                            .map(|c| cells.get(c).cloned().unwrap_or_else(|| "–".into()))
                            .collect::<Vec<_>>()
                            .join(" | ")
                    );
                }
            }
            let _ = writeln!(md, "\nLUT and table sizes are given in each model's section. Rows of spheres of increasing roughness (the paper's Figs. 2 and 4):\n");
            for (_, s) in &sections {
                let Some((s, _)) = s else { continue };
                for row in &s.furnace {
                    if let Some(img) = row.images.first() {
                        let _ = writeln!(md, "![white furnace: {}]({img})\n", row.material);
                        linked.push(img.clone());
                    }
                }
            }
        }

        // the anisotropic conductor
        if let Some((section, files)) = anisotropy {
            md.push_str(section.trim_end());
            md.push_str("\n\n");
            linked.extend(files.iter().cloned());
        }

        // Benchmarks
        let _ = writeln!(md, "## Run time against error\n");
        let (plots, notes) = load_bench(&self.options.bench_dir)?;
        let bench_dir = self.options.reports_dir.join("benchmarks");
        let mut bench_files = Vec::new();
        if plots.is_empty() {
            let dir = display_rel(&self.options.bench_dir);
            let _ = writeln!(
                md,
                "No benchmark data in `{dir}`. The benchmark commands write one CSV per plot there: \
`furnace bench tabulate --output {dir}/tabulate.csv` (tabulation time against quadrature error), \
`furnace bench fit --output {dir}/fit.csv` (fit time against error per degree), \
`furnace bench eval --fit … --output {dir}/eval.csv` (evaluation cost against error for fits and LUTs).\n"
            );
        }
        for n in &notes {
            let _ = writeln!(md, "- {n}");
        }
        for b in &plots {
            let written = plot::save(
                &bench_figure(b),
                &bench_dir.join(&b.stem),
                Formats::PngAndSvg,
            )?;
            let rel: Vec<String> = written
                .iter()
                .map(|p| {
                    p.strip_prefix(&self.options.reports_dir)
                        .unwrap_or(p)
                        .to_string_lossy()
                        .replace('\\', "/")
                })
                .collect();
            let _ = writeln!(md, "### {}\n", b.title);
            let _ = writeln!(md, "![{}]({}) ([SVG]({}))\n", b.title, rel[0], rel[1]);
            for n in &b.notes {
                let _ = writeln!(md, "{n}\n");
            }
            let labelled = b.labels.iter().any(|l| !l.is_empty());
            let cell = |t: &str| t.replace('|', "\\|");
            let _ = writeln!(
                md,
                "Source: `{}/{}.csv`.\n",
                display_rel(&self.options.bench_dir),
                b.stem
            );
            if labelled {
                let _ = writeln!(
                    md,
                    "| series | point | {} | {} |\n| --- | --- | ---: | ---: |",
                    cell(&b.x_label),
                    cell(&b.y_label)
                );
            } else {
                let _ = writeln!(
                    md,
                    "| series | {} | {} |\n| --- | ---: | ---: |",
                    cell(&b.x_label),
                    cell(&b.y_label)
                );
            }
            for (k, (s, x, y)) in b.rows.iter().enumerate() {
                let (x, y) = (plot::format_number(*x), plot::format_number(*y));
                if labelled {
                    let _ = writeln!(
                        md,
                        "| {} | {} | {x} | {y} |",
                        cell(s),
                        cell(b.labels.get(k).map_or("", |l| l.as_str()))
                    );
                } else {
                    let _ = writeln!(md, "| {} | {x} | {y} |", cell(s));
                }
            }
            md.push('\n');
            linked.extend(rel);
            bench_files.extend(written);
        }
        remove_stale(&bench_dir, &bench_files)?;

        // Models
        let _ = writeln!(md, "## Models\n");
        for (m, s) in &sections {
            match s {
                Some((s, section)) => {
                    md.push_str(section.trim_end());
                    md.push_str("\n\n");
                    linked.extend(s.files.iter().cloned());
                }
                None => {
                    let _ = writeln!(
                        md,
                        "### {m}\n\nNot generated yet: run `furnace report --model {m}`.\n"
                    );
                }
            }
        }
        linked.sort();
        linked.dedup();
        let path = self.options.reports_dir.join("README.md");
        crate::output::write(&path, format!("{}\n", md.trim_end()).as_bytes())?;
        Ok((path, linked))
    }
}

/// Column key of a furnace variant: a LUT by its nodes per axis ("LUT 32×32 (bilinear)" →
/// "LUT 32"), a table without its size.
fn variant_key(name: &str) -> String {
    if let Some(rest) = name.strip_prefix("LUT ") {
        // "LUT 16×16 (bilinear)" → "LUT 16"
        let n: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        format!("LUT {n}")
    } else if name.starts_with("exact table") {
        "exact table".into()
    } else {
        name.to_string()
    }
}

/// GitHub's heading anchor of a model name (lower case, already hyphenated).
fn anchor(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == '-' || *c == '_')
        .collect()
}

fn display_rel(p: &Path) -> String {
    p.to_string_lossy().replace('\\', "/")
}

/// One benchmark table as a chart: one line per series, sorted by x.
pub fn bench_figure(b: &BenchPlot) -> Figure {
    let mut names: Vec<&str> = Vec::new();
    for (s, _, _) in &b.rows {
        if !names.contains(&s.as_str()) {
            names.push(s);
        }
    }
    let series = names
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let mut pts: Vec<(f64, f64)> = b
                .rows
                .iter()
                .filter(|r| r.0 == *n)
                .map(|r| (r.1, r.2))
                .collect();
            pts.sort_by(|a, c| a.0.total_cmp(&c.0));
            Series::new(n, pts, color(k), Style::LinePoints)
        })
        .collect();
    let axis = |label: &str, log: bool| {
        if log {
            Axis::log(label)
        } else {
            Axis::linear(label)
        }
    };
    Figure {
        title: None,
        charts: vec![Chart {
            title: b.title.clone(),
            x: axis(&b.x_label, b.x_log),
            y: axis(&b.y_label, b.y_log),
            legend_room: 0.06 * names.len() as f64,
            series,
            legend: LegendAt::UpperRight,
        }],
        size: (900, 600),
    }
}
