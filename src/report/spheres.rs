//! Furnace images like the paper's Figs. 2 and 4: rows of spheres of increasing roughness under a
//! uniform white environment, one row per compensation (none, LUT, fit, …).
//!
//! With an orthographic camera the sphere's normal at a pixel gives μ = n·v, and under a white
//! environment the radiance towards the camera is the directional albedo of the BSDF there: the
//! pixel is E_comp(r, μ), computed by the furnace quadrature ([`super::furnace`]) on a μ grid of
//! [`MU_SAMPLES`] nodes per sphere and interpolated linearly in μ (the compensation's albedo
//! itself — LUT, fit — is read at the pixel's exact μ). An energy-preserving BSDF vanishes into
//! the background; darkening is energy loss, a bright rim energy gain. Pixels are 2×2
//! supersampled against the background (which is the environment, E = 1).

use super::plot::{self, ColorScale, Draw, FONT};
use crate::material::furnace::{lobe_integrals_at, LobeIntegrals};
use crate::material::{CompensatedBsdf, Compensation};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// μ nodes per sphere at which the furnace quadrature is evaluated.
pub const MU_SAMPLES: usize = 65;

const CELL: u32 = 132;
const RADIUS: f64 = 60.0;
const LEFT: u32 = 300;
const TOP: u32 = 84;
const BOTTOM: u32 = 46;
const BAR: u32 = 160;

/// One row of spheres: its label and the furnace values at the pixels' μ, or why it is missing.
#[derive(Clone, Debug)]
pub struct SphereRow {
    pub label: String,
    /// Second line under the label (e.g. max |1 − E| of the row).
    pub note: String,
    /// One [`SphereColumn`] per roughness, or why the row is missing.
    pub columns: Result<Vec<SphereColumn>, String>,
}

/// The furnace value along μ for one sphere.
#[derive(Clone, Debug)]
pub struct SphereColumn {
    /// E_comp at the pixel μ, sampled finely enough for display (see [`PIXEL_SAMPLES`]).
    pub values: Vec<f64>,
}

/// Samples of E_comp per sphere, uniform in the pixel radius ρ ∈ [0, 1] (μ = √(1 − ρ²)): one per
/// half pixel of radius, so that linear interpolation between them is invisible.
pub const PIXEL_SAMPLES: usize = 2 * RADIUS as usize + 1;

impl SphereColumn {
    /// E_comp at radius fraction ρ.
    fn at(&self, rho: f64) -> f64 {
        let n = self.values.len();
        let t = rho.clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (t.floor() as usize).min(n - 2);
        let f = t - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }
}

/// What a sphere pixel shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Show {
    /// The albedo E itself, as grey (white background = the environment).
    Albedo,
    /// E − 1 on a diverging scale.
    Deviation,
}

/// A grid of spheres with row and column labels and a colour bar.
#[derive(Clone, Debug)]
pub struct SphereFigure {
    pub title: String,
    pub column_labels: Vec<String>,
    pub rows: Vec<SphereRow>,
    pub show: Show,
    pub scale: ColorScale,
    pub colorbar_label: String,
    pub caption: String,
}

/// Furnace values of `material` for spheres of roughness `roughness` under each compensation:
/// `[row][column]`. `point(r, μ)` is the point of the material's albedo axes at roughness r and
/// μ (F0 and any other axis held fixed). The lobe integrals are computed once on a μ grid of
/// [`MU_SAMPLES`] nodes per roughness and shared by every row.
pub fn sphere_columns(
    material: &dyn CompensatedBsdf,
    point: &dyn Fn(f64, f64) -> Vec<f64>,
    roughness: &[f64],
    compensations: &[Compensation],
) -> Vec<Vec<SphereColumn>> {
    let mus: Vec<f64> = (0..MU_SAMPLES)
        .map(|k| k as f64 / (MU_SAMPLES - 1) as f64)
        .collect();
    let nodes: Vec<Vec<f64>> = roughness
        .iter()
        .flat_map(|&r| mus.iter().map(move |&mu| point(r, mu)))
        .collect();
    let lobes = lobe_integrals_at(material, &nodes);
    let pixel_points: Vec<Vec<f64>> = roughness
        .iter()
        .flat_map(|&r| {
            (0..PIXEL_SAMPLES)
                .map(move |k| point(r, mu_of_rho(k as f64 / (PIXEL_SAMPLES - 1) as f64)))
        })
        .collect();
    compensations
        .iter()
        .map(|comp| {
            let prepared = material.prepare(comp, &pixel_points);
            roughness
                .iter()
                .enumerate()
                .map(|(c, _)| {
                    let node_lobes = &lobes[c * MU_SAMPLES..(c + 1) * MU_SAMPLES];
                    let values = (0..PIXEL_SAMPLES)
                        .map(|k| {
                            let x = &pixel_points[c * PIXEL_SAMPLES + k];
                            let mu = x[x.len() - 1];
                            let l = interpolate_lobes(node_lobes, mu);
                            material.albedo(&l.values, x, comp, &prepared)
                        })
                        .collect();
                    SphereColumn { values }
                })
                .collect()
        })
        .collect()
}

/// μ = n·v at radius fraction ρ of an orthographic sphere.
fn mu_of_rho(rho: f64) -> f64 {
    (1.0 - rho * rho).max(0.0).sqrt()
}

/// Lobe integrals at μ by linear interpolation between the uniform μ nodes.
fn interpolate_lobes(nodes: &[LobeIntegrals], mu: f64) -> LobeIntegrals {
    let n = nodes.len();
    let t = mu.clamp(0.0, 1.0) * (n - 1) as f64;
    let i = (t.floor() as usize).min(n - 2);
    let f = t - i as f64;
    let (a, b) = (&nodes[i], &nodes[i + 1]);
    let lerp = |x: f64, y: f64| x * (1.0 - f) + y * f;
    LobeIntegrals {
        values: a
            .values
            .iter()
            .zip(&b.values)
            .map(|(&x, &y)| lerp(x, y))
            .collect(),
        error: a.error.max(b.error),
        converged: a.converged && b.converged,
    }
}

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

impl Draw for SphereFigure {
    fn size(&self) -> (u32, u32) {
        let cols = self.column_labels.len().max(1) as u32;
        let rows = self.rows.len().max(1) as u32;
        (LEFT + cols * CELL + BAR, TOP + rows * CELL + BOTTOM)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> std::result::Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let (w, h) = self.size();
        let center = Pos::new(HPos::Center, VPos::Center);
        let left = Pos::new(HPos::Left, VPos::Center);
        let title = TextStyle::from((FONT, 22).into_font()).pos(center);
        let label = TextStyle::from((FONT, 16).into_font()).pos(center);
        let row_label = TextStyle::from((FONT, 16).into_font()).pos(left);
        let note = TextStyle::from((FONT, 14).into_font())
            .color(&RGBColor(80, 80, 80))
            .pos(left);
        let grid_w = w - LEFT - BAR;
        root.draw_text(&self.title, &title, ((LEFT + grid_w / 2) as i32, 22))
            .map_err(err)?;
        for (c, l) in self.column_labels.iter().enumerate() {
            let x = LEFT + c as u32 * CELL + CELL / 2;
            root.draw_text(l, &label, (x as i32, TOP as i32 - 18))
                .map_err(err)?;
        }
        let background = match self.show {
            Show::Albedo => 1.0,
            Show::Deviation => 0.0,
        };
        for (r, row) in self.rows.iter().enumerate() {
            let y0 = TOP + r as u32 * CELL;
            let cy = (y0 + CELL / 2) as i32;
            root.draw_text(&row.label, &row_label, (14, cy - 10))
                .map_err(err)?;
            root.draw_text(&row.note, &note, (14, cy + 12))
                .map_err(err)?;
            let columns = match &row.columns {
                Ok(c) => c,
                Err(why) => {
                    root.draw_text(why, &note, ((LEFT + 10) as i32, cy))
                        .map_err(err)?;
                    continue;
                }
            };
            for (c, col) in columns.iter().enumerate() {
                let cx = (LEFT + c as u32 * CELL + CELL / 2) as f64;
                let cyf = cy as f64;
                let reach = RADIUS.ceil() as i32 + 1;
                for py in -reach..=reach {
                    for px in -reach..=reach {
                        // 2×2 supersampling; outside the disc the sample sees the environment
                        let mut sum = 0.0;
                        for (sx, sy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                            let (dx, dy) = (
                                (px as f64 + sx - 0.5) / RADIUS,
                                (py as f64 + sy - 0.5) / RADIUS,
                            );
                            let rho = (dx * dx + dy * dy).sqrt();
                            sum += if rho < 1.0 {
                                let e = col.at(rho);
                                if self.show == Show::Deviation {
                                    e - 1.0
                                } else {
                                    e
                                }
                            } else {
                                background
                            };
                        }
                        let v = sum / 4.0;
                        if v != background {
                            root.draw_pixel(
                                ((cx as i32) + px, (cyf as i32) + py),
                                &self.scale.color(v),
                            )
                            .map_err(err)?;
                        }
                    }
                }
                // faint outline so that a sphere that vanishes (E = 1) can still be located
                root.draw(&Circle::new(
                    (cx as i32, cyf as i32),
                    RADIUS as i32 + 3,
                    RGBColor(215, 215, 215).stroke_width(1),
                ))
                .map_err(err)?;
            }
        }
        let caption = TextStyle::from((FONT, 14).into_font())
            .color(&RGBColor(60, 60, 60))
            .pos(left);
        root.draw_text(&self.caption, &caption, (14, (h - BOTTOM / 2) as i32))
            .map_err(err)?;
        let bar = root.clone().shrink(
            ((w - BAR) as i32, TOP as i32 - 40),
            (BAR, h - TOP - BOTTOM + 40),
        );
        plot::draw_colorbar(&bar, &self.scale, &self.colorbar_label)
    }
}
