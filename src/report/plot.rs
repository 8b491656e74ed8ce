//! Plotting helpers on plotters: line/point charts (linear or log axes) in side-by-side panels,
//! heat maps with a labelled colour bar, each written as PNG (for viewing) and SVG (for papers).
//!
//! Text uses the embedded DejaVu Sans ([`ensure_font`]); no system font is needed. Output is
//! deterministic (no timestamps in either format) and written through [`crate::output`] (PNG with
//! [`crate::output::write_with`], as plotters encodes it to a file itself).
//!
//! Log axes are drawn as linear axes over log10 of the data with tick labels 10^v, so that every
//! chart has one coordinate type; values ≤ 0 cannot be shown on a log axis and are left out (the
//! caller says so in the caption if it matters).

use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// Registers DejaVu Sans as plotters' "sans-serif" once per process (plotters' ab_glyph text has
/// no font until one is registered; the machine has no system fonts).
pub fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans font is valid"));
        plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans Bold font is valid"));
    });
}

/// Font family registered by [`ensure_font`].
pub const FONT: &str = "sans-serif";

/// A qualitative palette (Tableau 10), colour-blind friendlier than primaries.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Palette colour `k` (wrapping).
pub fn color(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// How an axis maps data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Linear,
    Log10,
}

/// One axis of a chart.
#[derive(Clone, Debug)]
pub struct Axis {
    pub label: String,
    pub scale: Scale,
    /// Data range; `None` for the data's extent (padded a little).
    pub range: Option<(f64, f64)>,
}

impl Axis {
    pub fn linear(label: &str) -> Axis {
        Axis {
            label: label.into(),
            scale: Scale::Linear,
            range: None,
        }
    }
    pub fn log(label: &str) -> Axis {
        Axis {
            label: label.into(),
            scale: Scale::Log10,
            range: None,
        }
    }
    pub fn with_range(mut self, lo: f64, hi: f64) -> Axis {
        self.range = Some((lo, hi));
        self
    }
    fn map(&self, v: f64) -> Option<f64> {
        match self.scale {
            Scale::Linear => v.is_finite().then_some(v),
            Scale::Log10 => (v > 0.0 && v.is_finite()).then(|| v.log10()),
        }
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    Line,
    Dashed,
    Points,
    LinePoints,
}

/// Marker of a point series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Marker {
    Circle,
    Square,
    Triangle,
    Cross,
}

/// One labelled series of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: RGBColor,
    pub style: Style,
    pub marker: Marker,
}

impl Series {
    pub fn new(label: &str, points: Vec<(f64, f64)>, color: RGBColor, style: Style) -> Series {
        Series {
            label: label.into(),
            points,
            color,
            style,
            marker: Marker::Circle,
        }
    }
    pub fn marker(mut self, marker: Marker) -> Series {
        self.marker = marker;
        self
    }
}

/// Where a chart's legend goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LegendAt {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
    /// Outside the plot, in a column to its right (for charts whose data fill the whole area).
    Right,
}

/// Width of the legend column of [`LegendAt::Right`].
const LEGEND_COLUMN: u32 = 200;

/// One chart: axes, series and a legend.
#[derive(Clone, Debug)]
pub struct Chart {
    pub title: String,
    pub x: Axis,
    pub y: Axis,
    pub series: Vec<Series>,
    pub legend: LegendAt,
    /// Extra room (fraction of the y span) added on the legend's side so that it covers no data.
    pub legend_room: f64,
}

/// A figure of one or more charts side by side under an optional title.
#[derive(Clone, Debug)]
pub struct Figure {
    pub title: Option<String>,
    pub charts: Vec<Chart>,
    pub size: (u32, u32),
}

/// Text sizes (px) for figures about 1000 px wide.
const TITLE_SIZE: u32 = 22;
const CAPTION_SIZE: u32 = 18;
const LABEL_SIZE: u32 = 15;
const DESC_SIZE: u32 = 16;
const LEGEND_SIZE: u32 = 14;

/// A drawing error as text: the I/O message inside plotters' nested error (e.g. "No space left
/// on device (os error 28)") when there is one, else the whole debug form.
fn plot_err<E: std::fmt::Debug>(e: E) -> String {
    let d = format!("{e:?}");
    for key in ["error: \"", "message: \""] {
        if let Some(start) = d.find(key).map(|i| i + key.len()) {
            if let Some(len) = d[start..].find('"') {
                return d[start..start + len].to_string();
            }
        }
    }
    d
}

/// "1e-3", "3.2e-4", "0.5", "19": a compact number for tick labels and tables (three significant
/// digits; never "NaN").
pub fn format_number(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return "–".into();
    }
    let a = v.abs();
    if (0.0095..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        return if s == "-0" { "0".into() } else { s };
    }
    format!("{v:.1e}").replace(".0e", "e")
}

/// Tick label of a log axis at log10 value `v`.
fn log_tick(v: f64) -> String {
    format_number(10f64.powf(v))
}

/// Range of the mapped data of an axis, padded; falls back to [0, 1].
fn axis_range(axis: &Axis, values: impl Iterator<Item = f64>) -> (f64, f64) {
    if let Some((lo, hi)) = axis.range {
        if let (Some(a), Some(b)) = (axis.map(lo), axis.map(hi)) {
            return (a, b);
        }
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter_map(|v| axis.map(v)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        return match axis.scale {
            Scale::Log10 => ((lo - 0.5).floor(), (hi + 0.5).ceil()),
            Scale::Linear => {
                let pad = lo.abs().max(1e-3) * 0.1;
                (lo - pad, hi + pad)
            }
        };
    }
    let pad = if axis.scale == Scale::Log10 {
        0.15
    } else {
        0.05 * (hi - lo)
    };
    match axis.scale {
        // decades: snap outwards so that the end ticks are powers of ten
        Scale::Log10 => ((lo - pad).floor(), (hi + pad).ceil()),
        Scale::Linear => (lo - pad, hi + pad),
    }
}

fn draw_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    chart: &Chart,
) -> std::result::Result<(), String> {
    if chart.legend == LegendAt::Right {
        let (w, _) = area.dim_in_pixel();
        let (plot_area, legend_area) = area.split_horizontally(w.saturating_sub(LEGEND_COLUMN));
        draw_chart_inner(&plot_area, chart)?;
        return draw_legend_column(&legend_area, &chart.series);
    }
    draw_chart_inner(area, chart)
}

/// A legend drawn by hand in its own area: one row per labelled series.
fn draw_legend_column<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    series: &[Series],
) -> std::result::Result<(), String> {
    const ROW: i32 = 22;
    let text = TextStyle::from((FONT, LEGEND_SIZE).into_font()).pos(
        plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Left,
            plotters::style::text_anchor::VPos::Center,
        ),
    );
    let mut y = 64;
    for s in series.iter().filter(|s| !s.label.is_empty()) {
        let line = s.color.stroke_width(2);
        let (x0, xm) = (6, 18);
        match s.style {
            Style::Line | Style::LinePoints => area
                .draw(&PathElement::new(vec![(x0, y), (x0 + 24, y)], line))
                .map_err(plot_err)?,
            Style::Dashed => {
                area.draw(&PathElement::new(vec![(x0, y), (x0 + 9, y)], line))
                    .map_err(plot_err)?;
                area.draw(&PathElement::new(vec![(x0 + 15, y), (x0 + 24, y)], line))
                    .map_err(plot_err)?;
            }
            Style::Points => {}
        }
        if matches!(s.style, Style::Points | Style::LinePoints) {
            let c = s.color;
            match s.marker {
                Marker::Circle => area
                    .draw(&Circle::new((xm, y), MARKER, c.filled()))
                    .map_err(plot_err)?,
                Marker::Square => area
                    .draw(&Rectangle::new(
                        [(xm - MARKER, y - MARKER), (xm + MARKER, y + MARKER)],
                        c.filled(),
                    ))
                    .map_err(plot_err)?,
                Marker::Triangle => area
                    .draw(&Polygon::new(
                        vec![
                            (xm, y - MARKER - 1),
                            (xm - MARKER - 1, y + MARKER),
                            (xm + MARKER + 1, y + MARKER),
                        ],
                        c.filled(),
                    ))
                    .map_err(plot_err)?,
                Marker::Cross => area
                    .draw(&PathElement::new(
                        CROSS
                            .iter()
                            .map(|&(dx, dy)| (xm + dx, y + dy))
                            .collect::<Vec<_>>(),
                        c.stroke_width(3),
                    ))
                    .map_err(plot_err)?,
            }
        }
        area.draw_text(&s.label, &text, (x0 + 32, y))
            .map_err(plot_err)?;
        y += ROW;
    }
    Ok(())
}

fn draw_chart_inner<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    chart: &Chart,
) -> std::result::Result<(), String> {
    let xs = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1));
    let (x0, x1) = axis_range(&chart.x, xs);
    let (mut y0, mut y1) = axis_range(&chart.y, ys);
    let room = chart.legend_room * (y1 - y0);
    match chart.legend {
        LegendAt::LowerLeft | LegendAt::LowerRight => y0 -= room,
        LegendAt::UpperLeft | LegendAt::UpperRight => y1 += room,
        LegendAt::Right => {}
    }
    let mut cc = ChartBuilder::on(area)
        .caption(&chart.title, (FONT, CAPTION_SIZE))
        .margin(12)
        .margin_right(24)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err)?;
    // ticks at rounding noise around zero read as 0
    let snap = |v: f64, span: f64| if v.abs() < 1e-9 * span { 0.0 } else { v };
    let x_fmt = |v: &f64| {
        if chart.x.scale == Scale::Log10 {
            log_tick(*v)
        } else {
            format_number(snap(*v, x1 - x0))
        }
    };
    let y_fmt = |v: &f64| {
        if chart.y.scale == Scale::Log10 {
            log_tick(*v)
        } else {
            format_number(snap(*v, y1 - y0))
        }
    };
    let decades = |lo: f64, hi: f64| ((hi - lo).round() as usize + 1).clamp(2, 12);
    let mut mesh = cc.configure_mesh();
    mesh.x_desc(chart.x.label.as_str())
        .y_desc(chart.y.label.as_str())
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT, LABEL_SIZE))
        .axis_desc_style((FONT, DESC_SIZE))
        .light_line_style(RGBColor(238, 238, 238))
        .max_light_lines(4);
    if chart.x.scale == Scale::Log10 {
        mesh.x_labels(decades(x0, x1));
    }
    if chart.y.scale == Scale::Log10 {
        mesh.y_labels(decades(y0, y1));
    }
    mesh.draw().map_err(plot_err)?;
    for s in &chart.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter_map(|&(x, y)| Some((chart.x.map(x)?, chart.y.map(y)?)))
            .collect();
        // a series without points still gets its legend entry (used for style keys)
        let c = s.color;
        let line = c.stroke_width(2);
        let has_line = matches!(s.style, Style::Line | Style::LinePoints | Style::Dashed);
        let has_points = matches!(s.style, Style::Points | Style::LinePoints);
        let label = s.label.as_str();
        let labelled = !label.is_empty();
        // Shapes are in pixels relative to their anchor, so one expression serves the data
        // points and the legend glyph.
        macro_rules! draw_with {
            ($shape:expr) => {{
                if has_line {
                    let anno = if s.style == Style::Dashed {
                        cc.draw_series(DashedLineSeries::new(pts.clone(), 8, 5, line))
                            .map_err(plot_err)?
                    } else {
                        cc.draw_series(LineSeries::new(pts.clone(), line))
                            .map_err(plot_err)?
                    };
                    if labelled && has_points {
                        anno.label(label).legend(move |(x, y)| {
                            EmptyElement::at((x + 12, y))
                                + PathElement::new(vec![(-12, 0), (12, 0)], line)
                                + $shape
                        });
                    } else if labelled && s.style == Style::Dashed {
                        anno.label(label).legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + PathElement::new(vec![(0, 0), (9, 0)], line)
                                + PathElement::new(vec![(15, 0), (24, 0)], line)
                        });
                    } else if labelled {
                        anno.label(label).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 24, y)], line)
                        });
                    }
                }
                if has_points {
                    let anno = cc
                        .draw_series(pts.iter().map(|&p| EmptyElement::at(p) + $shape))
                        .map_err(plot_err)?;
                    if labelled && !has_line {
                        anno.label(label)
                            .legend(move |(x, y)| EmptyElement::at((x + 12, y)) + $shape);
                    }
                }
            }};
        }
        match s.marker {
            Marker::Circle => draw_with!(Circle::new((0, 0), MARKER, c.filled())),
            Marker::Square => draw_with!(Rectangle::new(
                [(-MARKER, -MARKER), (MARKER, MARKER)],
                c.filled()
            )),
            Marker::Triangle => draw_with!(Polygon::new(
                vec![
                    (0, -MARKER - 1),
                    (-MARKER - 1, MARKER),
                    (MARKER + 1, MARKER)
                ],
                c.filled()
            )),
            Marker::Cross => draw_with!(PathElement::new(CROSS.to_vec(), c.stroke_width(3))),
        }
    }
    let pos = match chart.legend {
        LegendAt::UpperRight => SeriesLabelPosition::UpperRight,
        LegendAt::UpperLeft => SeriesLabelPosition::UpperLeft,
        LegendAt::LowerRight => SeriesLabelPosition::LowerRight,
        LegendAt::LowerLeft | LegendAt::Right => SeriesLabelPosition::LowerLeft,
    };
    if chart.legend != LegendAt::Right && chart.series.iter().any(|s| !s.label.is_empty()) {
        cc.configure_series_labels()
            .position(pos)
            .background_style(WHITE.mix(0.88))
            .border_style(RGBColor(120, 120, 120))
            .label_font((FONT, LEGEND_SIZE))
            .margin(8)
            .draw()
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Marker radius in pixels.
const MARKER: i32 = 5;
/// An "X" as one polyline through its centre (relative pixels).
const CROSS: [(i32, i32); 5] = [(-6, -6), (6, 6), (0, 0), (-6, 6), (6, -6)];

/// Splits `root` under a title (if any) into `n` equal panels side by side.
fn panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: Option<&str>,
    n: usize,
) -> std::result::Result<Vec<DrawingArea<DB, Shift>>, String> {
    root.fill(&WHITE).map_err(plot_err)?;
    let body = match title {
        Some(t) => {
            let (top, body) = root.split_vertically(TITLE_SIZE as i32 + 18);
            top.draw_text(
                t,
                &TextStyle::from((FONT, TITLE_SIZE).into_font()).pos(
                    plotters::style::text_anchor::Pos::new(
                        plotters::style::text_anchor::HPos::Center,
                        plotters::style::text_anchor::VPos::Center,
                    ),
                ),
                (
                    top.dim_in_pixel().0 as i32 / 2,
                    (TITLE_SIZE as i32 + 18) / 2,
                ),
            )
            .map_err(plot_err)?;
            body
        }
        None => root.clone(),
    };
    Ok(body.split_evenly((1, n.max(1))))
}

/// Something drawable on any plotters backend.
pub trait Draw {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> std::result::Result<(), String>;
}

impl Draw for Figure {
    fn size(&self) -> (u32, u32) {
        self.size
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> std::result::Result<(), String> {
        let areas = panels(root, self.title.as_deref(), self.charts.len())?;
        for (a, c) in areas.iter().zip(&self.charts) {
            draw_chart(a, c)?;
        }
        Ok(())
    }
}

/// Which files [`save`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Formats {
    PngAndSvg,
    Png,
}

/// Writes `<stem>.png` (and `<stem>.svg`) atomically; returns the paths written.
pub fn save(d: &impl Draw, stem: &Path, formats: Formats) -> Result<Vec<PathBuf>> {
    ensure_font();
    let png = stem.with_extension("png");
    // plotters picks the encoder from the extension: the temporary file must end in .png
    crate::output::write_with(&png, ".png", |tmp| {
        let drawn = {
            let root = CrispText(BitMapBackend::new(tmp, d.size())).into_drawing_area();
            d.draw(&root).and_then(|_| root.present().map_err(plot_err))
        };
        // the backend writes the file again when it is dropped unpresented: the writer removes
        // the temporary file only after this returns
        drawn.map_err(|e| Error::file(&png, format!("cannot write the figure: {e}")))
    })?;
    let mut written = vec![png];
    if formats == Formats::PngAndSvg {
        let svg_path = stem.with_extension("svg");
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, d.size()).into_drawing_area();
            d.draw(&root)
                .and_then(|_| root.present().map_err(plot_err))
                .map_err(|e| Error::file(&svg_path, format!("cannot draw the figure: {e}")))?;
        }
        crate::output::write(&svg_path, svg.as_bytes())?;
        written.push(svg_path);
    }
    Ok(written)
}

/// A colour scale of a heat map or colour bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColorScale {
    /// Viridis over log10 of values in [lo, hi] (values ≤ lo get the lowest colour).
    Log { lo: f64, hi: f64 },
    /// Diverging blue–white–red over [−max, max].
    Signed { max: f64 },
    /// Viridis over [lo, hi].
    Linear { lo: f64, hi: f64 },
    /// Grey levels: the value is a linear radiance in [lo, hi], shown sRGB-encoded (as a
    /// renderer would display it), clamped at both ends.
    Gray { lo: f64, hi: f64 },
    /// Diverging over sign(v)·log10(|v|/floor) for |v| in [floor, max] (|v| ≤ floor is white):
    /// small and large deviations in one picture.
    SignedLog { floor: f64, max: f64 },
}

/// sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn srgb_encode(v: f64) -> f64 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Viridis, 9 control points (matplotlib's viridis at t = k/8), linear between them.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (72, 40, 120),
    (62, 73, 137),
    (49, 104, 142),
    (38, 130, 142),
    (31, 158, 137),
    (53, 183, 121),
    (110, 206, 88),
    (253, 231, 37),
];

/// Diverging (ColorBrewer RdBu, reversed so that negative is blue) at t = −1, −0.5, 0, 0.5, 1.
const DIVERGING: [(u8, u8, u8); 5] = [
    (5, 48, 97),
    (67, 147, 195),
    (247, 247, 247),
    (214, 96, 77),
    (103, 0, 31),
];

fn ramp(stops: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (stops.len() - 1) as f64;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (stops[i], stops[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

impl ColorScale {
    /// Position in [0, 1] of value `v`.
    pub fn position(&self, v: f64) -> f64 {
        match *self {
            ColorScale::Log { lo, hi } => {
                if !(v > lo) {
                    return 0.0;
                }
                ((v.log10() - lo.log10()) / (hi.log10() - lo.log10())).clamp(0.0, 1.0)
            }
            ColorScale::Signed { max } => (0.5 + 0.5 * v / max).clamp(0.0, 1.0),
            ColorScale::SignedLog { floor, max } => {
                if !(v.abs() > floor) {
                    return 0.5;
                }
                let t = ((v.abs() / floor).log10() / (max / floor).log10()).clamp(0.0, 1.0);
                0.5 + 0.5 * t * v.signum()
            }
            ColorScale::Linear { lo, hi } | ColorScale::Gray { lo, hi } => {
                ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
            }
        }
    }

    pub fn color(&self, v: f64) -> RGBColor {
        match self {
            ColorScale::Signed { .. } | ColorScale::SignedLog { .. } => {
                ramp(&DIVERGING, self.position(v))
            }
            ColorScale::Gray { lo, hi } => {
                let g = (255.0 * srgb_encode(lo + (hi - lo) * self.position(v))).round() as u8;
                RGBColor(g, g, g)
            }
            _ => ramp(&VIRIDIS, self.position(v)),
        }
    }

    /// The colour bar's axis: (lo, hi) in bar coordinates, and whether they are log10 (for
    /// [`ColorScale::SignedLog`] the bar runs over the colour position −1…1).
    fn bar_range(&self) -> (f64, f64, bool) {
        match *self {
            ColorScale::SignedLog { .. } => (-1.0, 1.0, false),
            ColorScale::Log { lo, hi } => (lo.log10(), hi.log10(), true),
            ColorScale::Signed { max } => (-max, max, false),
            ColorScale::Linear { lo, hi } | ColorScale::Gray { lo, hi } => (lo, hi, false),
        }
    }

    /// A log scale spanning the positive finite `values` (at most `decades` decades below the
    /// maximum), snapped to powers of ten.
    pub fn log_for(values: &[f64], decades: f64) -> ColorScale {
        let hi = values
            .iter()
            .copied()
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold(0.0, f64::max);
        if hi <= 0.0 {
            return ColorScale::Log {
                lo: 1e-16,
                hi: 1e-15,
            };
        }
        let hi_exp = hi.log10().ceil();
        let lo_pos = values
            .iter()
            .copied()
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold(f64::INFINITY, f64::min);
        let lo_exp = lo_pos
            .log10()
            .floor()
            .max(hi_exp - decades)
            .min(hi_exp - 1.0);
        ColorScale::Log {
            lo: 10f64.powf(lo_exp),
            hi: 10f64.powf(hi_exp),
        }
    }

    /// A signed log scale from the largest |value| down `decades` decades (at least 1e-9).
    pub fn signed_log_for(values: &[f64], decades: f64) -> ColorScale {
        let m = values
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, |a: f64, v| a.max(v.abs()));
        let max = if m > 0.0 {
            10f64.powf(m.log10().ceil())
        } else {
            1.0
        };
        ColorScale::SignedLog {
            floor: (max / 10f64.powf(decades)).max(1e-9),
            max,
        }
    }

    /// The value at bar coordinate `u` (inverse of the bar's mapping).
    fn bar_value(&self, u: f64) -> f64 {
        match *self {
            ColorScale::Log { .. } => 10f64.powf(u),
            ColorScale::SignedLog { floor, max } => {
                if u.abs() < 1e-12 {
                    0.0
                } else {
                    u.signum() * floor * (max / floor).powf(u.abs())
                }
            }
            _ => u,
        }
    }

    /// A symmetric scale covering the largest |value|.
    pub fn signed_for(values: &[f64]) -> ColorScale {
        let m = values
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, |a: f64, v| a.max(v.abs()));
        ColorScale::Signed {
            max: if m > 0.0 { m } else { 1.0 },
        }
    }
}

/// One heat-map panel: `values[j * nx + i]` at x cell i, y cell j (cells span the ranges evenly).
#[derive(Clone, Debug)]
pub struct HeatPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
    pub nx: usize,
    pub ny: usize,
    pub values: Vec<f64>,
    /// Optional marker (data coordinates) with its legend text, e.g. the worst point.
    pub mark: Option<((f64, f64), String)>,
}

/// Heat-map panels side by side sharing one colour scale and bar.
#[derive(Clone, Debug)]
pub struct HeatFigure {
    pub title: Option<String>,
    pub panels: Vec<HeatPanel>,
    pub scale: ColorScale,
    pub colorbar_label: String,
    pub size: (u32, u32),
}

/// Width of the colour-bar column in pixels.
const BAR_COLUMN: u32 = 150;

fn draw_heat_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &HeatPanel,
    scale: &ColorScale,
) -> std::result::Result<(), String> {
    // the title drawn apart, so that the max-error marker on the top row (which reaches above
    // the cells) has room below it
    let area = area
        .titled(&p.title, (FONT, CAPTION_SIZE))
        .map_err(plot_err)?;
    let mut cc = ChartBuilder::on(&area)
        .margin(12)
        .margin_top(16)
        .margin_right(18)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(p.x_range.0..p.x_range.1, p.y_range.0..p.y_range.1)
        .map_err(plot_err)?;
    let dx = (p.x_range.1 - p.x_range.0) / p.nx as f64;
    let dy = (p.y_range.1 - p.y_range.0) / p.ny as f64;
    cc.draw_series((0..p.ny).flat_map(|j| {
        (0..p.nx).map(move |i| {
            let v = p.values[j * p.nx + i];
            let (x0, y0) = (p.x_range.0 + i as f64 * dx, p.y_range.0 + j as f64 * dy);
            Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], scale.color(v).filled())
        })
    }))
    .map_err(plot_err)?;
    let fmt = |v: &f64| format_number(*v);
    cc.configure_mesh()
        .disable_mesh()
        .x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .x_label_formatter(&fmt)
        .y_label_formatter(&fmt)
        .label_style((FONT, LABEL_SIZE))
        .axis_desc_style((FONT, DESC_SIZE))
        .draw()
        .map_err(plot_err)?;
    if let Some((at, text)) = &p.mark {
        let halo = RGBColor(255, 255, 255).stroke_width(6);
        let ink = RGBColor(0, 0, 0).stroke_width(3);
        cc.draw_series(std::iter::once(
            EmptyElement::at(*at) + PathElement::new(CROSS.to_vec(), halo),
        ))
        .map_err(plot_err)?;
        cc.draw_series(std::iter::once(
            EmptyElement::at(*at) + PathElement::new(CROSS.to_vec(), ink),
        ))
        .map_err(plot_err)?
        .label(text.as_str())
        .legend(move |(x, y)| {
            EmptyElement::at((x + 10, y)) + PathElement::new(CROSS.to_vec(), ink)
        });
        cc.configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(120, 120, 120))
            .label_font((FONT, LEGEND_SIZE))
            .draw()
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Draws a vertical colour bar for `scale` with its label.
pub fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &ColorScale,
    label: &str,
) -> std::result::Result<(), String> {
    let (lo, hi, log) = scale.bar_range();
    let mut cc = ChartBuilder::on(area)
        .margin_top(48)
        .margin_bottom(60)
        .margin_left(6)
        .margin_right(8)
        .y_label_area_size(0)
        .right_y_label_area_size(100)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(plot_err)?
        .set_secondary_coord(0.0..1.0, lo..hi);
    const STEPS: usize = 128;
    let step = (hi - lo) / STEPS as f64;
    cc.draw_series((0..STEPS).map(|k| {
        let v0 = lo + k as f64 * step;
        let value = scale.bar_value(v0 + 0.5 * step);
        Rectangle::new([(0.0, v0), (1.0, v0 + step)], scale.color(value).filled())
    }))
    .map_err(plot_err)?;
    cc.draw_series(std::iter::once(Rectangle::new(
        [(0.0, lo), (1.0, hi)],
        RGBColor(90, 90, 90).stroke_width(1),
    )))
    .map_err(plot_err)?;
    // a leading space keeps the tick mark from reading as a minus sign
    let fmt = |v: &f64| {
        let v = if v.abs() < 1e-9 * (hi - lo) { 0.0 } else { *v }; // rounding noise at the centre
        format!(" {}", format_number(scale.bar_value(v)))
    };
    let n_labels = match *scale {
        _ if log => ((hi - lo).round() as usize + 1).clamp(2, 12),
        // ticks at ±floor·10^k: u = k/decades
        ColorScale::SignedLog { floor, max } => 2 * ((max / floor).log10().round() as usize) + 1,
        _ => 7,
    };
    cc.configure_secondary_axes()
        .y_desc(label)
        .y_label_formatter(&fmt)
        .y_labels(n_labels)
        .label_style((FONT, LABEL_SIZE))
        .axis_desc_style((FONT, DESC_SIZE))
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

impl Draw for HeatFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> std::result::Result<(), String> {
        root.fill(&WHITE).map_err(plot_err)?;
        let (w, _) = root.dim_in_pixel();
        let (body, bar) = root.split_horizontally(w.saturating_sub(BAR_COLUMN));
        let areas = panels(&body, self.title.as_deref(), self.panels.len())?;
        for (a, p) in areas.iter().zip(&self.panels) {
            draw_heat_panel(a, p, &self.scale)?;
        }
        let bar = if self.title.is_some() {
            bar.split_vertically(TITLE_SIZE as i32 + 18).1
        } else {
            bar
        };
        draw_colorbar(&bar, &self.scale, &self.colorbar_label)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn drawing_errors_show_the_io_message() {
        // what plotters' nested error prints as Debug when the disk is full
        struct Raw(&'static str);
        impl std::fmt::Debug for Raw {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.0)
            }
        }
        let e = Raw("BackendError(DrawingError(ImageError(IoError(Custom { kind: Other, error: \"No space left on device (os error 28)\" }))))");
        assert_eq!(super::plot_err(e), "No space left on device (os error 28)");
        assert_eq!(super::plot_err(7), "7");
    }

    use super::*;

    #[test]
    fn number_format_is_compact_and_never_nan() {
        assert_eq!(format_number(0.0), "0");
        assert_eq!(format_number(1e-3), "1e-3");
        assert_eq!(format_number(3.2e-4), "3.2e-4");
        assert_eq!(format_number(0.5), "0.5");
        assert_eq!(format_number(19.0), "19");
        assert_eq!(format_number(f64::NAN), "–");
    }

    #[test]
    fn color_scales_hit_their_ends() {
        let s = ColorScale::Log { lo: 1e-6, hi: 1e-2 };
        assert_eq!(s.position(1e-7), 0.0);
        assert!((s.position(1e-4) - 0.5).abs() < 1e-12);
        assert_eq!(s.position(1.0), 1.0);
        assert_eq!(s.color(1e-2), RGBColor(253, 231, 37));
        let d = ColorScale::Signed { max: 2.0 };
        assert_eq!(d.color(0.0), RGBColor(247, 247, 247));
        assert_eq!(d.color(-5.0), RGBColor(5, 48, 97));
        let l = ColorScale::log_for(&[0.0, 3e-5, 0.02], 4.0);
        assert_eq!(l, ColorScale::Log { lo: 1e-5, hi: 0.1 });
    }
}

/// A backend wrapper whose text rendering places glyphs at their fractional advance plus their
/// left side bearing. plotters 0.3.7's ab_glyph text drops the bearing and truncates each glyph's
/// advance to whole pixels, which at 14–16 px spaces letters unevenly ("LU T32" for "LUT 32");
/// everything else (layout estimates, anchors, rotation) is plotters' own.
pub struct CrispText<B: DrawingBackend>(pub B);

mod crisp {
    use super::CrispText;
    use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
    use plotters::prelude::DrawingBackend;
    use plotters_backend::text_anchor::{HPos, VPos};
    use plotters_backend::{
        BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind, FontStyle,
    };

    impl<B: DrawingBackend> DrawingBackend for CrispText<B> {
        type ErrorType = B::ErrorType;
        fn get_size(&self) -> (u32, u32) {
            self.0.get_size()
        }
        fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.ensure_prepared()
        }
        fn present(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.present()
        }
        fn draw_pixel(
            &mut self,
            p: BackendCoord,
            c: BackendColor,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.draw_pixel(p, c)
        }
        fn draw_line<S: BackendStyle>(
            &mut self,
            a: BackendCoord,
            b: BackendCoord,
            s: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.draw_line(a, b, s)
        }
        fn draw_rect<S: BackendStyle>(
            &mut self,
            a: BackendCoord,
            b: BackendCoord,
            s: &S,
            fill: bool,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.draw_rect(a, b, s, fill)
        }
        fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
            &mut self,
            path: I,
            s: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.draw_path(path, s)
        }
        fn draw_circle<S: BackendStyle>(
            &mut self,
            c: BackendCoord,
            r: u32,
            s: &S,
            fill: bool,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.draw_circle(c, r, s, fill)
        }
        fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
            &mut self,
            v: I,
            s: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.fill_polygon(v, s)
        }
        fn blit_bitmap(
            &mut self,
            pos: BackendCoord,
            size: (u32, u32),
            src: &[u8],
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.0.blit_bitmap(pos, size, src)
        }
        fn estimate_text_size<T: BackendTextStyle>(
            &self,
            text: &str,
            style: &T,
        ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
            self.0.estimate_text_size(text, style)
        }

        fn draw_text<T: BackendTextStyle>(
            &mut self,
            text: &str,
            style: &T,
            pos: BackendCoord,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            let color = style.color();
            if color.alpha == 0.0 {
                return Ok(());
            }
            // the same box, anchor and transform as plotters' default draw_text
            let ((min_x, min_y), (max_x, max_y)) = style
                .layout_box(text)
                .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
            let (width, height) = (max_x - min_x, max_y - min_y);
            let dx = match style.anchor().h_pos {
                HPos::Left => 0,
                HPos::Right => -width,
                HPos::Center => -width / 2,
            };
            let dy = match style.anchor().v_pos {
                VPos::Top => 0,
                VPos::Center => -height / 2,
                VPos::Bottom => -height,
            };
            let bytes = match style.style() {
                FontStyle::Bold => dejavu::sans::bold(),
                _ => dejavu::sans::regular(),
            };
            let font = FontRef::try_from_slice(bytes)
                .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
            let size = style.size() as f32;
            let scaled = font.as_scaled(PxScale::from(size));
            let trans = style.transform();
            let (w, h) = self.get_size();
            // plotters' convention: the baseline sits at size/2 below the top of the box
            let baseline = size / 2.0;
            let mut pen = 0.0f32;
            let mut prev = None;
            for ch in text.chars() {
                let id = scaled.glyph_id(ch);
                if let Some(p) = prev {
                    pen += scaled.kern(p, id);
                }
                prev = Some(id);
                let glyph =
                    id.with_scale_and_position(PxScale::from(size), ab_glyph::point(pen, baseline));
                pen += scaled.h_advance(id);
                let Some(outline) = font.outline_glyph(glyph) else {
                    continue;
                };
                let bounds = outline.px_bounds();
                let mut pixels = Vec::new();
                outline.draw(|x, y, c| {
                    pixels.push((
                        bounds.min.x as i32 + x as i32,
                        bounds.min.y as i32 + y as i32,
                        c,
                    ))
                });
                for (x, y, c) in pixels {
                    if c <= 0.0 {
                        continue;
                    }
                    let (x, y) = trans.transform(x + dx - min_x, y + dy - min_y);
                    let (x, y) = (pos.0 + x, pos.1 + y);
                    if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                        self.0.draw_pixel(
                            (x, y),
                            BackendColor {
                                alpha: color.alpha * c.min(1.0) as f64,
                                rgb: color.rgb,
                            },
                        )?;
                    }
                }
            }
            Ok(())
        }
    }
}
