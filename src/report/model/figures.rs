//! A section's figures: Fig. 3 (error against number of coefficients), the off-grid chart, the
//! error heat maps and the E(μ) slices of the chosen fit.

use super::data::ModelData;
use super::nodes::slice_indices;
use super::Reporter;
use crate::error::Result;
use crate::report::albedo::Albedo;
use crate::report::inputs::Measured;
use crate::report::offgrid::{self, SweepPoint};
use crate::report::plot::{
    self, color, Axis, Chart, ColorScale, Figure, Formats, HeatFigure, HeatPanel, LegendAt, Marker,
    Series, Style,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

impl Reporter<'_> {
    /// Paper's Fig. 3: MAE and max error against number of coefficients.
    pub(super) fn fig_error_vs_coefficients(
        &self,
        data: &ModelData,
        stem: &Path,
    ) -> Result<Vec<PathBuf>> {
        if data.fits.fits.is_empty() && data.paper.is_none() {
            return Ok(vec![]);
        }
        // best (lowest MAE) fit per (kind, coefficient count)
        let mut best: BTreeMap<(bool, usize), usize> = BTreeMap::new();
        for (k, f) in data.fits.fits.iter().enumerate() {
            let rational = matches!(f.fit.form, crate::fit::Form::Rational { .. });
            let e = best.entry((rational, f.fit.n_coefficients)).or_insert(k);
            if data.measured[k].mae < data.measured[*e].mae {
                *e = k;
            }
        }
        let max_n = data
            .fits
            .fits
            .iter()
            .map(|f| f.fit.n_coefficients)
            .chain(data.paper.iter().map(|p| p.0.n_coefficients))
            .max()
            .unwrap_or(1);
        let chart = |title: &str, y_label: &str, pick: &dyn Fn(&Measured) -> f64| {
            let mut series = Vec::new();
            for (rational, name, c, marker) in [
                (false, "polynomial", 0, Marker::Circle),
                (true, "rational", 1, Marker::Square),
            ] {
                let pts: Vec<(f64, f64)> = best
                    .iter()
                    .filter(|((r, _), _)| *r == rational)
                    .map(|((_, n), &k)| (*n as f64, pick(&data.measured[k])))
                    .collect();
                if !pts.is_empty() {
                    series.push(Series::new(name, pts, color(c), Style::LinePoints).marker(marker));
                }
            }
            if let Some(k) = data.chosen {
                let f = &data.fits.fits[k];
                series.push(
                    Series::new(
                        &format!("chosen: {}", f.short_form()),
                        vec![(f.fit.n_coefficients as f64, pick(&data.measured[k]))],
                        color(2),
                        Style::Points,
                    )
                    .marker(Marker::Triangle),
                );
            }
            if let Some((fit, _, m)) = &data.paper {
                series.push(
                    Series::new(
                        "paper's published fit (rational 3/3)",
                        vec![(fit.n_coefficients as f64, pick(m))],
                        color(3),
                        Style::Points,
                    )
                    .marker(Marker::Cross),
                );
            }
            let room = legend_room(&series);
            Chart {
                title: title.into(),
                x: Axis::linear("number of coefficients")
                    .with_range(0.0, max_n as f64 * 1.08 + 2.0),
                y: Axis::log(y_label),
                series,
                legend: LegendAt::UpperRight,
                legend_room: room,
            }
        };
        let fig = Figure {
            title: Some(format!(
                "{}: error against number of coefficients (on the {} table)",
                data.name,
                data.table.spec.resolution_name()
            )),
            charts: vec![
                chart("mean absolute error", "MAE of E", &|m: &Measured| m.mae),
                chart(
                    "maximum absolute error",
                    "max |fit − table|",
                    &|m: &Measured| m.max_abs,
                ),
            ],
            size: (1300, 560),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }

    /// Error against stored values at the off-grid check points: the lower envelope of every
    /// form family of the sweep, the `best-<N>.json` fits and the 16/32/64-per-axis LUTs, max
    /// error and MAE side by side.
    pub(super) fn fig_off_grid(&self, data: &ModelData, stem: &Path) -> Result<Vec<PathBuf>> {
        let Some(og) = &data.off_grid else {
            return Ok(vec![]);
        };
        let points = &data.sweep_points;
        let families = offgrid::families(points);
        let markers = [Marker::Circle, Marker::Square, Marker::Cross];
        let chart = |title: &str,
                     y_label: &str,
                     fit: &dyn Fn(&SweepPoint) -> f64,
                     lut: &dyn Fn(&offgrid::PointErrors) -> f64,
                     best: &dyn Fn(&offgrid::BudgetErrors) -> f64| {
            let mut series = Vec::new();
            for (c, family) in families.iter().enumerate() {
                let pts = offgrid::envelope(points, family, fit);
                if !pts.is_empty() {
                    series.push(
                        Series::new(
                            &format!("{family} (best of the sweep)"),
                            pts,
                            color(c),
                            Style::LinePoints,
                        )
                        .marker(markers[c % markers.len()]),
                    );
                }
            }
            if !og.best.is_empty() {
                series.push(
                    Series::new(
                        "best-<N>.json",
                        og.best
                            .iter()
                            .map(|b| (b.n_coefficients as f64, best(b)))
                            .collect(),
                        color(families.len()),
                        Style::Points,
                    )
                    .marker(Marker::Triangle),
                );
            }
            if !og.luts.is_empty() {
                series.push(
                    Series::new(
                        &format!(
                            "LUT {} per axis ({})",
                            og.luts
                                .iter()
                                .map(|l| l.per_axis.to_string())
                                .collect::<Vec<_>>()
                                .join("/"),
                            if data.dims() == 2 {
                                "bilinear"
                            } else {
                                "trilinear"
                            }
                        ),
                        og.luts
                            .iter()
                            .map(|l| (l.values as f64, lut(&l.errors)))
                            .collect(),
                        RGBColorKey::black(),
                        Style::LinePoints,
                    )
                    .marker(Marker::Square),
                );
            }
            let room = legend_room(&series);
            Chart {
                title: title.into(),
                x: Axis::log("stored values (fit: coefficients; LUT: nodes)"),
                y: Axis::log(y_label),
                series,
                legend: LegendAt::UpperRight,
                legend_room: room,
            }
        };
        let fig = Figure {
            title: Some(format!(
                "{}: error against stored values at {} off-grid points",
                data.name,
                og.check_set.split(" off-grid").next().unwrap_or("the")
            )),
            charts: vec![
                chart(
                    "maximum absolute error",
                    "max |E − exact|",
                    &|p| p.max_abs_error,
                    &|e| e.max_abs_error,
                    &|b| b.max_abs_error,
                ),
                chart(
                    "mean absolute error",
                    "MAE of E",
                    &|p| p.mae,
                    &|e| e.mae,
                    &|b| b.mae,
                ),
            ],
            size: (1300, 560),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }

    /// Heat maps of the chosen fit's error: |fit − table| (log) and fit − table (signed).
    pub(super) fn fig_heatmaps(&self, data: &ModelData, dir: &Path) -> Result<Vec<PathBuf>> {
        let (Some(k), Some(fit)) = (data.chosen, &data.chosen_albedo) else {
            return Ok(vec![]);
        };
        let form = data.fits.fits[k].short_form();
        let t = &data.table;
        let axes = &t.spec.axes;
        let dims = axes.len();
        let (ra, ma) = (&axes[dims - 2], &axes[dims - 1]);
        let slices: Vec<usize> = if dims == 3 {
            slice_indices(axes[0].n, 3)
        } else {
            vec![0]
        };
        const MAX_CELLS: usize = 128;
        let (br, bm) = (ra.n.div_ceil(MAX_CELLS), ma.n.div_ceil(MAX_CELLS));
        let (ny, nx) = (ra.n.div_ceil(br), ma.n.div_ceil(bm));
        let mut abs_panels = Vec::new();
        let mut signed_panels = Vec::new();
        let mut all_abs = Vec::new();
        for &s in &slices {
            // signed error with the largest magnitude in each display block (max-pooling keeps peaks)
            let mut cells = vec![0.0f64; nx * ny];
            let mut worst = (0.0f64, (0.0, 0.0));
            let mut x = vec![0.0; dims];
            for i in 0..ra.n {
                for j in 0..ma.n {
                    let cell = (s * ra.n + i) * ma.n + j;
                    t.spec.point(cell, &mut x);
                    let e = fit.albedo(&x) - t.output(0)[cell];
                    let c = &mut cells[(i / br) * nx + j / bm];
                    if e.abs() > c.abs() {
                        *c = e;
                    }
                    if e.abs() > worst.0 {
                        worst = (e.abs(), (x[dims - 1], x[dims - 2]));
                    }
                }
            }
            let title = if dims == 3 {
                format!(
                    "{} = {}",
                    axes[0].name,
                    plot::format_number(axes[0].node(s))
                )
            } else {
                data.name.clone()
            };
            let half_r = 0.5 * (ra.hi - ra.lo) / (ra.n - 1) as f64 * br as f64;
            let half_m = 0.5 * (ma.hi - ma.lo) / (ma.n - 1) as f64 * bm as f64;
            let mark = Some((
                worst.1,
                format!(
                    "max {} at μ = {}, r = {}",
                    plot::format_number(worst.0),
                    plot::format_number(worst.1 .0),
                    plot::format_number(worst.1 .1)
                ),
            ));
            let panel = |values: Vec<f64>| HeatPanel {
                title: title.clone(),
                x_label: "μ = cos θo".into(),
                y_label: "r = √α".into(),
                x_range: (ma.lo - half_m, ma.lo - half_m + 2.0 * half_m * nx as f64),
                y_range: (ra.lo - half_r, ra.lo - half_r + 2.0 * half_r * ny as f64),
                nx,
                ny,
                values,
                mark: mark.clone(),
            };
            all_abs.extend(cells.iter().map(|v| v.abs()));
            abs_panels.push(panel(cells.iter().map(|v| v.abs()).collect()));
            signed_panels.push(panel(cells));
        }
        let width = (150 + 520 * slices.len() as u32).max(1000);
        let mut out = Vec::new();
        let abs = HeatFigure {
            title: Some(format!(
                "|fit − table| of the chosen fit ({form}, {} coefficients)",
                data.fits.fits[k].fit.n_coefficients
            )),
            panels: abs_panels,
            scale: ColorScale::log_for(&all_abs, 6.0),
            colorbar_label: "|fit − table| (log scale)".into(),
            size: (width, 580),
        };
        out.extend(plot::save(
            &abs,
            &dir.join("heatmap-abs"),
            Formats::PngAndSvg,
        )?);
        let signed_values: Vec<f64> = signed_panels
            .iter()
            .flat_map(|p| p.values.iter().copied())
            .collect();
        let signed = HeatFigure {
            title: Some(format!(
                "fit − table of the chosen fit ({form}; red: fit too high, blue: too low)"
            )),
            scale: ColorScale::signed_for(&signed_values),
            panels: signed_panels,
            colorbar_label: "fit − table".into(),
            size: (width, 580),
        };
        out.extend(plot::save(
            &signed,
            &dir.join("heatmap-signed"),
            Formats::PngAndSvg,
        )?);
        Ok(out)
    }

    /// E(μ) at several r: table, chosen fit, paper's fit; and their differences.
    pub(super) fn fig_slices(&self, data: &ModelData, stem: &Path) -> Result<Vec<PathBuf>> {
        let t = &data.table;
        let axes = &t.spec.axes;
        let dims = axes.len();
        let (ra, ma) = (&axes[dims - 2], &axes[dims - 1]);
        let f0_index = if dims == 3 {
            nearest_node(&axes[0], self.options.sphere_f0)
        } else {
            0
        };
        let rs: Vec<usize> = [0.1, 0.3, 0.6, 1.0]
            .iter()
            .map(|&r| nearest_node(ra, r))
            .collect();
        let fit = data.chosen.zip(data.chosen_albedo.as_ref());
        let paper = data.paper.as_ref().map(|p| &p.1);
        let mut left = Vec::new();
        let mut right = Vec::new();
        let marker_stride = (ma.n / 16).max(1);
        for (c, &i) in rs.iter().enumerate() {
            let r = ra.node(i);
            let point = |j: usize| -> Vec<f64> {
                let mu = ma.node(j);
                if dims == 3 {
                    vec![axes[0].node(f0_index), r, mu]
                } else {
                    vec![r, mu]
                }
            };
            let cell = |j: usize| (f0_index * ra.n + i) * ma.n + j;
            let table: Vec<(f64, f64)> = (0..ma.n)
                .map(|j| (ma.node(j), t.output(0)[cell(j)]))
                .collect();
            left.push(Series::new(
                &format!("r = {}", plot::format_number(r)),
                table,
                color(c),
                Style::Line,
            ));
            if let Some((_, f)) = fit {
                left.push(Series::new(
                    "",
                    (0..ma.n)
                        .map(|j| (ma.node(j), f.albedo(&point(j))))
                        .collect(),
                    color(c),
                    Style::Dashed,
                ));
                right.push(Series::new(
                    &format!("fit, r = {}", plot::format_number(r)),
                    (0..ma.n)
                        .map(|j| (ma.node(j), f.albedo(&point(j)) - t.output(0)[cell(j)]))
                        .collect(),
                    color(c),
                    Style::Line,
                ));
            }
            if let Some(p) = paper {
                left.push(
                    Series::new(
                        "",
                        (0..ma.n)
                            .step_by(marker_stride)
                            .map(|j| (ma.node(j), p.albedo(&point(j))))
                            .collect(),
                        color(c),
                        Style::Points,
                    )
                    .marker(Marker::Cross),
                );
                right.push(Series::new(
                    &format!("paper, r = {}", plot::format_number(r)),
                    (0..ma.n)
                        .map(|j| (ma.node(j), p.albedo(&point(j)) - t.output(0)[cell(j)]))
                        .collect(),
                    color(c),
                    Style::Dashed,
                ));
            }
        }
        let key = RGBColorKey::black();
        left.push(Series::new(
            &format!("table ({})", t.spec.resolution_name()),
            vec![],
            key,
            Style::Line,
        ));
        if let Some((k, _)) = fit {
            left.push(Series::new(
                &format!("fit: {}", data.fits.fits[k].short_form()),
                vec![],
                key,
                Style::Dashed,
            ));
        }
        if paper.is_some() {
            left.push(Series::new("paper's fit", vec![], key, Style::Points).marker(Marker::Cross));
        }
        let f0_text = if dims == 3 {
            format!(
                " at {} = {}",
                axes[0].name,
                plot::format_number(axes[0].node(f0_index))
            )
        } else {
            String::new()
        };
        let y_label = offset_nearly_constant(&mut left)
            .map_or("directional albedo E".to_string(), |c| {
                format!("E − {} (E is nearly constant)", plot::format_number(c))
            });
        let mut charts = vec![Chart {
            title: format!("E(μ){f0_text}"),
            x: Axis::linear("μ = cos θo").with_range(0.0, 1.0),
            y: Axis::linear(&y_label),
            legend_room: 0.0,
            series: left,
            legend: LegendAt::Right,
        }];
        if !right.is_empty() {
            let what = match (fit.is_some(), paper.is_some()) {
                (true, true) => "solid: chosen fit, dashed: paper's fit",
                (true, false) => "chosen fit",
                _ => "paper's fit",
            };
            charts.push(Chart {
                title: format!("fit − table{f0_text} ({what})"),
                x: Axis::linear("μ = cos θo").with_range(0.0, 1.0),
                y: Axis::linear("E(fit) − E(table)"),
                legend_room: 0.0,
                series: right,
                legend: LegendAt::Right,
            });
        }
        let width = if charts.len() == 2 { 1600 } else { 860 };
        let fig = Figure {
            title: Some(format!("{}: slices of E at several r", data.name)),
            charts,
            size: (width, 620),
        };
        plot::save(&fig, stem, Formats::PngAndSvg)
    }
}

/// Relative spread below which the values of a chart are shown as offsets from a constant: tick
/// labels of 3 significant digits could not tell them apart (EON's albedo is 1 to 1e-9).
const NEARLY_CONSTANT: f64 = 1e-4;

/// If every y value of `series` lies within [`NEARLY_CONSTANT`]·max(1, |y|) of the others,
/// subtracts their midpoint (rounded to 3 significant digits) and returns it.
fn offset_nearly_constant(series: &mut [Series]) -> Option<f64> {
    let ys = series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
        (lo.min(y), hi.max(y))
    });
    if !(lo.is_finite() && hi.is_finite()) || hi - lo >= NEARLY_CONSTANT * hi.abs().max(1.0) {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    let c: f64 = plot::format_number(mid).parse().unwrap_or(mid);
    for s in series.iter_mut() {
        for p in &mut s.points {
            p.1 -= c;
        }
    }
    Some(c)
}

/// Node index of `axis` nearest to `v`.
fn nearest_node(axis: &crate::table::GridAxis, v: f64) -> usize {
    let t = ((v - axis.lo) / (axis.hi - axis.lo)).clamp(0.0, 1.0) * (axis.n - 1) as f64;
    t.round() as usize
}

/// Room to leave for a legend of the chart's labelled series (fraction of the y span).
fn legend_room(series: &[Series]) -> f64 {
    0.09 * series.iter().filter(|s| !s.label.is_empty()).count() as f64
}

/// Plain black for style keys in legends.
struct RGBColorKey;
impl RGBColorKey {
    pub(super) fn black() -> plotters::style::RGBColor {
        plotters::style::RGBColor(0, 0, 0)
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearly_constant_values_are_shown_as_offsets() {
        let key = RGBColorKey::black();
        let mut s = vec![
            Series::new(
                "a",
                vec![(0.0, 1.0 + 1e-9), (1.0, 1.0 - 2e-9)],
                key,
                Style::Line,
            ),
            Series::new("key", vec![], key, Style::Line),
        ];
        assert_eq!(offset_nearly_constant(&mut s), Some(1.0));
        assert!((s[0].points[1].1 + 2e-9).abs() < 1e-15);
        let mut s = vec![Series::new(
            "a",
            vec![(0.0, 0.3), (1.0, 0.9)],
            key,
            Style::Line,
        )];
        assert_eq!(offset_nearly_constant(&mut s), None);
        assert_eq!(s[0].points[0].1, 0.3);
    }
}
