//! The anisotropic conductor's section of `reports/README.md`: how far the isotropic shortcuts
//! renderers use are from the 4-D albedo E(r, aniso, μ, φ) of `ggx-conductor-aniso`, and the
//! white furnace test of the compensated anisotropic conductor (ρ_ss/E, Sforza & Pellacini 2022,
//! eqs. 7, 13 at F0 = 1) with the exact table, each shortcut and furnace's fits under the
//! budgets of 80 and 160 coefficients.
//!
//! The section reads its own small table ([`DEFAULT_RESOLUTION`], height-correlated G2, over the
//! model's default domain) through the report's table source, so the report stays fast: the
//! default 64 × 16 × 64 × 16 table of docs/anisotropy.md is not needed. A shortcut looks the
//! isotropic albedo up at an effective roughness r_eff = √α_eff (clamped to the table's r ≤ 1);
//! E_iso(r_eff, μ) is computed by quadrature of `ggx-conductor` at that point, i.e. the best an
//! isotropic table can do, so the differences are the shortcut's own error, not a LUT's.
//!
//! Written under `reports/anisotropy/`: `shortcuts.{png,svg}`, `section.md` and `summary.json`
//! (the digest of the inputs, so `furnace run` keeps an unchanged section as it is).
//!
//! The fits are the 4-D forms of a sweep ([`aniso_exponent_forms`]) fitted for minimax error
//! on a grid uniform in the fit variables r², aniso, √L(μ; α_o) and sin²φ
//! ([`fit_grid`], [`layer_points`]), whose values come from the model by quadrature: the nodes
//! of a table uniform in μ leave the grazing layer μ ≲ α_o unsampled at small r
//! (docs/anisotropy.md, "Fits on points that resolve the layer"). Each fit is measured at every
//! node of the section's table, points it was not fitted on.

use super::albedo::{Albedo, FitAlbedo, TableAlbedo};
use super::model::{fmt_e, furnace_axis, Reporter};
use super::plot::{self, ColorScale, Formats, HeatFigure, HeatPanel};
use crate::bsdf::{self, ModelId};
use crate::bsdf::{albedo, Model};
use crate::digest::sha256_hex;
use crate::error::{Error, Result};
use crate::fit::data::transformed_box;
use crate::fit::defaults::{aniso_exponent_forms, physics_transforms};
use crate::fit::metrics::{measure, Metrics};
use crate::fit::{fit_form, FitData, FitOptions, FitResult, Form, InputTransform, Objective};
use crate::material::anisotropic::{albedo_model, Compensated};
use crate::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at, FurnaceStats};
use crate::material::Compensation;
use crate::math::{anisotropic_alphas, SmithForm};
use crate::quadrature::{QuadratureSettings, RuleCache};
use crate::table::Table;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The section's folder under `reports/`.
pub const DIR: &str = "anisotropy";
/// Nodes of (r, aniso, mu, phi) of the section's table: 16 384 cells.
pub const DEFAULT_RESOLUTION: [usize; 4] = [16, 8, 16, 8];
/// The table of `furnace run --quick-report` (tests and trials).
pub const QUICK_RESOLUTION: [usize; 4] = [5, 3, 5, 3];
/// The budgets of the section's fits: under each, the fit with the lowest max at its points
/// among the rational [`SCENE_DEGREES`] and the largest of [`aniso_exponent_forms`] under it.
pub const FIT_BUDGETS: [usize; 2] = [80, 160];
/// Degrees of the rational `furnace run --scene` fits by default, one of the section's forms.
pub const SCENE_DEGREES: (u32, u32) = (3, 3);
/// The variables of the section's fits ([`physics_transforms`]), part of the section's digest.
pub const FIT_VARIABLES: &str = "r², aniso, √L(μ; α_o), α_o/α_t";
/// The furnace grid takes at most this many nodes of r and of μ (every aniso and φ node).
pub const FURNACE_NODES: usize = 9;
/// The Smith form of the section's tables.
pub const SMITH: SmithForm = SmithForm::HeightCorrelated;

/// An effective isotropic roughness a renderer looks its isotropic table up at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shortcut {
    /// α = √(α_t α_b).
    GeometricMean,
    /// α = √(α_t² cos²φ + α_b² sin²φ), the roughness projected on the azimuth of ωo
    /// (Heitz 2014, "Understanding the Masking-Shadowing Function", eq. 80).
    Projected,
    /// α = max(α_t, α_b).
    Larger,
}

impl Shortcut {
    pub const ALL: [Shortcut; 3] = [
        Shortcut::GeometricMean,
        Shortcut::Projected,
        Shortcut::Larger,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Shortcut::GeometricMean => "geometric mean √(α_t α_b)",
            Shortcut::Projected => "projected roughness of ωo √(α_t² cos²φ + α_b² sin²φ)",
            Shortcut::Larger => "larger roughness α_t",
        }
    }

    fn short(self) -> &'static str {
        match self {
            Shortcut::GeometricMean => "geometric mean",
            Shortcut::Projected => "projected",
            Shortcut::Larger => "larger α",
        }
    }

    /// The α of the lookup.
    pub fn alpha(self, alpha_t: f64, alpha_b: f64, phi: f64) -> f64 {
        match self {
            Shortcut::GeometricMean => (alpha_t * alpha_b).sqrt(),
            Shortcut::Projected => {
                let (s, c) = phi.sin_cos();
                (c * c * alpha_t * alpha_t + s * s * alpha_b * alpha_b).sqrt() // Heitz 2014, eq. 80
            }
            Shortcut::Larger => alpha_t.max(alpha_b),
        }
    }

    /// r of the isotropic lookup (α = r²), clamped to the isotropic table's edge r = 1 as a
    /// lookup would be (α_t exceeds 1 at high r and aniso).
    pub fn r_eff(self, r: f64, aniso: f64, phi: f64) -> f64 {
        let (alpha_t, alpha_b) = anisotropic_alphas(r, aniso);
        self.alpha(alpha_t, alpha_b, phi).sqrt().min(1.0)
    }
}

/// E_iso(r, μ) of `ggx-conductor` at the points a shortcut looks up, by quadrature.
struct Isotropic {
    values: BTreeMap<(u64, u64), f64>,
}

impl Isotropic {
    fn compute(pairs: Vec<(f64, f64)>) -> Result<Isotropic> {
        let mut pairs = pairs;
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        pairs.dedup();
        let model = bsdf::get(ModelId::ggx_conductor(SMITH))?;
        let settings = QuadratureSettings::default();
        let cache = RuleCache::new(&settings);
        let values: Vec<f64> = pairs
            .par_iter()
            .map(|&(r, mu)| bsdf::albedo(model.as_ref(), &[r, mu], &settings, &cache).value[0])
            .collect();
        Ok(Isotropic {
            values: pairs
                .iter()
                .zip(values)
                .map(|(&(r, mu), v)| ((r.to_bits(), mu.to_bits()), v))
                .collect(),
        })
    }

    fn get(&self, r: f64, mu: f64) -> f64 {
        self.values
            .get(&(r.to_bits(), mu.to_bits()))
            .copied()
            .unwrap_or(f64::NAN)
    }
}

/// A shortcut as the albedo source of a compensation: E_iso(r_eff(r, aniso, φ), μ).
struct ShortcutAlbedo<'a> {
    shortcut: Shortcut,
    iso: &'a Isotropic,
}

impl Albedo for ShortcutAlbedo<'_> {
    fn albedo(&self, x: &[f64]) -> f64 {
        self.iso.get(self.shortcut.r_eff(x[0], x[1], x[3]), x[2])
    }
    fn dim(&self) -> usize {
        4
    }
}

/// One shortcut's errors over the table's nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShortcutErrors {
    pub shortcut: String,
    pub max_abs: f64,
    /// (r, aniso, mu, phi) of the max.
    pub at: Vec<f64>,
    pub mean_abs: f64,
    /// Max over (r, μ) at each (aniso, φ) node: `[aniso index][phi index]`.
    pub max_by_aniso_phi: Vec<Vec<f64>>,
}

/// One albedo source of the furnace test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FurnaceVariant {
    pub name: String,
    pub stats: FurnaceStats,
}

/// A fit of the section: its form and its errors at its fitting points and at the table's nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitErrors {
    pub budget: usize,
    pub form: String,
    pub coefficients: usize,
    /// Max |fit − E| at the points it was fitted on.
    pub max_fitted: f64,
    /// Max and mean |fit − E| at the table's nodes, and (r, aniso, mu, phi) of the max.
    pub max_abs: f64,
    pub at: Vec<f64>,
    pub mean_abs: f64,
}

/// What the section computed (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AnisoSummary {
    pub model: String,
    pub resolution: String,
    pub shortcuts: Vec<ShortcutErrors>,
    pub furnace: Vec<FurnaceVariant>,
    pub furnace_points: usize,
    pub lobe_error: f64,
    /// Points the fits were fitted on ([`fit_grid`]) and their grid.
    pub fit_points: usize,
    pub fit_grid: [usize; 4],
    /// The certified fits, by budget.
    pub fits: Vec<FitErrors>,
    pub files: Vec<String>,
    pub inputs_sha256: String,
    /// SHA-256 of each written file, to tell an intact section from an edited one.
    pub outputs: Vec<(String, String)>,
}

/// Every node of `table` as a point, in the table's order.
fn node(table: &Table, idx: [usize; 4]) -> Vec<f64> {
    table
        .spec
        .axes
        .iter()
        .zip(idx)
        .map(|(a, i)| a.node(i))
        .collect()
}

/// Points per variable of the grid the section's fits are fitted on ([`layer_points`]): for a
/// table of n_r × n_a × n_μ × n_φ nodes, ⌈5n_r/2⌉ × ⌈3n_a/2⌉ × 3n_μ × ⌈3n_φ/2⌉ (16 × 8 × 16 × 8 →
/// 40 × 12 × 48 × 12, 276 480 points).
pub fn fit_grid(resolution: &[usize]) -> [usize; 4] {
    let n = |k: usize, num: usize, den: usize| (resolution[k] * num).div_ceil(den).max(2);
    [n(0, 5, 2), n(1, 3, 2), n(2, 3, 1), n(3, 3, 2)]
}

/// A grid of (r, aniso, μ, φ) over `domain` uniform in r², aniso, sin²φ and the layer variable
/// t of μ (`mu_layer`, the transform of variable 2: μ solved from t for each r, aniso, φ), `grid`
/// points per variable, row-major (φ fastest).
pub fn layer_points(
    grid: [usize; 4],
    domain: &[(f64, f64)],
    mu_layer: &InputTransform,
    t_range: (f64, f64),
) -> Vec<f64> {
    let step = |k: usize, i: usize| i as f64 / (grid[k] - 1) as f64;
    let lerp = |(lo, hi): (f64, f64), s: f64| lo + (hi - lo) * s;
    let (r2, s2) = (
        (domain[0].0.powi(2), domain[0].1.powi(2)),
        (domain[3].0.sin().powi(2), domain[3].1.sin().powi(2)),
    );
    let mut out = Vec::with_capacity(4 * grid.iter().product::<usize>());
    for i0 in 0..grid[0] {
        let r = lerp(r2, step(0, i0)).sqrt().clamp(domain[0].0, domain[0].1);
        for i1 in 0..grid[1] {
            let aniso = lerp(domain[1], step(1, i1));
            for i2 in 0..grid[2] {
                let t = lerp(t_range, step(2, i2));
                for i3 in 0..grid[3] {
                    let phi = lerp(s2, step(3, i3))
                        .sqrt()
                        .asin()
                        .clamp(domain[3].0, domain[3].1);
                    let mut x = [r, aniso, 0.0, phi];
                    x[2] = mu_layer.inverse(2, t, &x).clamp(domain[2].0, domain[2].1);
                    out.extend(x);
                }
            }
        }
    }
    out
}

/// A fit of the section and its errors at the table's nodes.
struct SectionFit {
    budget: usize,
    fit: FitResult,
    at_nodes: Metrics,
}

/// Fits the section's forms ([`FIT_BUDGETS`]) to `model` for minimax error on the
/// [`layer_points`] of [`fit_grid`] of `table`'s resolution and chooses one per budget, measured
/// at the table's nodes; fits that are not certified pole-free are left out.
fn fits(model: &dyn Model, table: &Table) -> Result<Vec<SectionFit>> {
    let names: Vec<String> = table.spec.axes.iter().map(|a| a.name.clone()).collect();
    let axes: Vec<Vec<f64>> = table.spec.axes.iter().map(|a| a.nodes()).collect();
    let at_nodes = FitData::from_grid(names.clone(), &axes, table.output(0).to_vec())?;
    let domain = at_nodes.domain.clone();
    // r², the layer of μ scaled by the projected roughness, α_o/α_t (docs/anisotropy.md, "Fits")
    let Some(transforms) = physics_transforms(&at_nodes, true) else {
        return Ok(Vec::new());
    };
    let t_box = transformed_box(&names, &domain, &transforms)?;
    let n: Vec<usize> = table.spec.axes.iter().map(|a| a.n).collect();
    let coords = layer_points(fit_grid(&n), &domain, &transforms[2], t_box[2]);
    let cache = RuleCache::new(&table.spec.quadrature);
    let values: Vec<f64> = coords
        .par_chunks(4)
        .map(|x| albedo(model, x, &table.spec.quadrature, &cache).value[0])
        .collect();
    let data = FitData::new(names, coords, values, domain)?;
    // the rational of the scene flow and, under each budget, the largest 4-D exponent form;
    // each fitted once
    let exponent_forms = aniso_exponent_forms(&transforms);
    let mut candidates = vec![Form::Rational {
        numerator_degree: SCENE_DEGREES.0,
        denominator_degree: SCENE_DEGREES.1,
    }];
    for budget in FIT_BUDGETS {
        if let Some(form) = exponent_forms
            .iter()
            .filter(|f| f.n_coefficients(4) <= budget)
            .max_by_key(|f| f.n_coefficients(4))
        {
            if !candidates.contains(form) {
                candidates.push(form.clone());
            }
        }
    }
    let mut fitted = Vec::new();
    for form in &candidates {
        let fit = fit_form(
            &data,
            &transforms,
            form,
            Objective::Minimax,
            &FitOptions::default(),
        )?;
        if fit.is_usable() {
            fitted.push(fit);
        }
    }
    // under each budget the fit with the lowest max at the points it was fitted on
    let mut out = Vec::new();
    for budget in FIT_BUDGETS {
        if let Some(fit) = fitted
            .iter()
            .filter(|f| f.n_coefficients <= budget)
            .min_by(|a, b| a.metrics.max_abs_error.total_cmp(&b.metrics.max_abs_error))
        {
            out.push(SectionFit {
                budget,
                fit: fit.clone(),
                at_nodes: measure(&fit.approximant, &at_nodes),
            });
        }
    }
    Ok(out)
}

impl Reporter<'_> {
    /// The section's markdown and the files it links (relative to `reports/`), regenerated, or
    /// kept when `reuse` and its inputs and files are unchanged. None when the options leave
    /// the section out.
    pub fn anisotropy_section(&self, reuse: bool) -> Result<Option<(String, Vec<String>)>> {
        let Some(resolution) = self.options.anisotropy.clone() else {
            return Ok(None);
        };
        let dir = self.options.reports_dir.join(DIR);
        let model = bsdf::get(albedo_model(SMITH))?;
        (self.progress())("anisotropy: table");
        let table = self.tables().table(model.as_ref(), &resolution)?;
        let digest = {
            let mut bytes: Vec<u8> = Vec::new();
            bytes.extend(crate::VERSION.as_bytes());
            bytes.extend(
                format!(
                    "{resolution:?} {FIT_BUDGETS:?} {SCENE_DEGREES:?} {:?} {} {FURNACE_NODES} {FIT_VARIABLES}",
                    fit_grid(&resolution),
                    crate::fit::FITTER_VERSION
                )
                .as_bytes(),
            );
            for v in table.output(0) {
                bytes.extend(v.to_le_bytes());
            }
            sha256_hex(&bytes)
        };
        if reuse {
            if let Some(kept) = self.kept_section(&dir, &digest) {
                return Ok(Some(kept));
            }
        }
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let n: Vec<usize> = table.spec.axes.iter().map(|a| a.n).collect();
        let values = table.output(0);
        let flat = |i: [usize; 4]| ((i[0] * n[1] + i[1]) * n[2] + i[2]) * n[3] + i[3];
        let all: Vec<[usize; 4]> = (0..values.len())
            .map(|mut k| {
                let mut i = [0; 4];
                for d in (0..4).rev() {
                    i[d] = k % n[d];
                    k /= n[d];
                }
                i
            })
            .collect();
        // the isotropic albedo at every lookup of every shortcut at every node
        (self.progress())("anisotropy: isotropic lookups");
        let mut pairs = Vec::new();
        for &i in &all {
            let x = node(&table, i);
            for s in Shortcut::ALL {
                pairs.push((s.r_eff(x[0], x[1], x[3]), x[2]));
            }
        }
        let iso = Isotropic::compute(pairs)?;
        let mut shortcuts = Vec::new();
        for s in Shortcut::ALL {
            let mut max_by = vec![vec![0.0f64; n[3]]; n[1]];
            let (mut worst, mut at, mut sum) = (0.0f64, node(&table, all[0]), 0.0);
            for &i in &all {
                let x = node(&table, i);
                let d = (values[flat(i)] - iso.get(s.r_eff(x[0], x[1], x[3]), x[2])).abs();
                sum += d;
                max_by[i[1]][i[3]] = max_by[i[1]][i[3]].max(d);
                if d > worst {
                    worst = d;
                    at = x;
                }
            }
            shortcuts.push(ShortcutErrors {
                shortcut: s.label().into(),
                max_abs: worst,
                at,
                mean_abs: sum / all.len() as f64,
                max_by_aniso_phi: max_by,
            });
        }
        // the figure over (aniso, φ)
        let half = |k: usize| {
            let a = &table.spec.axes[k];
            let h = 0.5 * (a.hi - a.lo) / (a.n - 1) as f64;
            (a.lo - h, a.hi + h)
        };
        let panels: Vec<HeatPanel> = shortcuts
            .iter()
            .zip(Shortcut::ALL)
            .map(|(e, s)| HeatPanel {
                title: s.short().to_string(),
                x_label: "φ (azimuth of ωo from the tangent)".into(),
                y_label: "aniso".into(),
                x_range: half(3),
                y_range: half(1),
                nx: n[3],
                ny: n[1],
                values: e.max_by_aniso_phi.iter().flatten().copied().collect(),
                mark: None,
            })
            .collect();
        let all_values: Vec<f64> = panels.iter().flat_map(|p| p.values.clone()).collect();
        let figure = HeatFigure {
            title: Some("max over (r, μ) of |E_aniso − E_iso(r_eff, μ)|, by shortcut".into()),
            panels,
            scale: ColorScale::log_for(&all_values, 6.0),
            colorbar_label: "|E_aniso − E_iso| (log scale)".into(),
            size: (1500, 520),
        };
        let written = plot::save(&figure, &dir.join("shortcuts"), Formats::PngAndSvg)?;
        let rel = |p: &Path| {
            p.strip_prefix(&self.options.reports_dir)
                .unwrap_or(p)
                .to_string_lossy()
                .replace('\\', "/")
        };
        let files: Vec<String> = written.iter().map(|p| rel(p)).collect();

        // the white furnace test of the compensated anisotropic conductor
        (self.progress())("anisotropy: fits");
        let fitted = fits(model.as_ref(), &table)?;
        (self.progress())("anisotropy: furnace");
        let material = Compensated { smith: SMITH };
        let (rs, mus) = (
            furnace_axis(n[0], FURNACE_NODES),
            furnace_axis(n[2], FURNACE_NODES),
        );
        let mut points = Vec::new();
        for &i0 in &rs {
            for i1 in 0..n[1] {
                for &i2 in &mus {
                    for i3 in 0..n[3] {
                        points.push(node(&table, [i0, i1, i2, i3]));
                    }
                }
            }
        }
        let lobes = lobe_integrals_at(&material, &points);
        let lobe_error = lobes.iter().map(|l| l.error).fold(0.0, f64::max);
        let exact = TableAlbedo::new(&table);
        let shortcut_sources: Vec<ShortcutAlbedo> = Shortcut::ALL
            .iter()
            .map(|&shortcut| ShortcutAlbedo {
                shortcut,
                iso: &iso,
            })
            .collect();
        let fit_sources = fitted
            .iter()
            .map(|f| FitAlbedo::new(&f.fit, &["r", "aniso", "mu", "phi"].map(String::from)))
            .collect::<Result<Vec<_>>>()?;
        let mut variants: Vec<(String, Compensation)> = vec![
            ("none".into(), Compensation::None),
            (
                format!("exact table {}", table.spec.resolution_name()),
                Compensation::With(vec![&exact as &dyn Albedo]),
            ),
        ];
        for (s, src) in Shortcut::ALL.iter().zip(&shortcut_sources) {
            variants.push((
                format!("isotropic, {}", s.short()),
                Compensation::With(vec![src as &dyn Albedo]),
            ));
        }
        for (f, src) in fitted.iter().zip(&fit_sources) {
            variants.push((
                format!(
                    "furnace fit ≤ {} ({} coefficients)",
                    f.budget, f.fit.n_coefficients
                ),
                Compensation::With(vec![src as &dyn Albedo]),
            ));
        }
        let furnace: Vec<FurnaceVariant> = variants
            .iter()
            .map(|(name, c)| FurnaceVariant {
                name: name.clone(),
                stats: furnace_stats(&points, &furnace_values(&material, &points, &lobes, c)),
            })
            .collect();
        let mut summary = AnisoSummary {
            model: albedo_model(SMITH).key(),
            resolution: table.spec.resolution_name(),
            shortcuts,
            furnace,
            furnace_points: points.len(),
            lobe_error,
            fit_points: fitted.first().map_or(0, |f| f.fit.metrics.n_points),
            fit_grid: fit_grid(&n),
            fits: fitted
                .iter()
                .map(|f| FitErrors {
                    budget: f.budget,
                    form: f.fit.form.label_with(&f.fit.approximant.variables),
                    coefficients: f.fit.n_coefficients,
                    max_fitted: f.fit.metrics.max_abs_error,
                    max_abs: f.at_nodes.max_abs_error,
                    at: f.at_nodes.max_abs_error_at.clone(),
                    mean_abs: f.at_nodes.mae,
                })
                .collect(),
            files: files.clone(),
            inputs_sha256: digest,
            outputs: Vec::new(),
        };
        let md = markdown(&summary, &n);
        crate::output::write(&dir.join("section.md"), md.as_bytes())?;
        for f in files.iter().cloned().chain([format!("{DIR}/section.md")]) {
            let p = self.options.reports_dir.join(&f);
            let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
            summary.outputs.push((f, sha256_hex(&bytes)));
        }
        let json = serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::file(dir.join("summary.json"), e.to_string()))?;
        crate::output::write(&dir.join("summary.json"), format!("{json}\n").as_bytes())?;
        Ok(Some((md, files)))
    }

    /// The written section, if its summary records `digest` and every file is intact.
    fn kept_section(&self, dir: &Path, digest: &str) -> Option<(String, Vec<String>)> {
        let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
        let s: AnisoSummary = serde_json::from_str(&text).ok()?;
        if s.inputs_sha256 != digest {
            return None;
        }
        for (f, sha) in &s.outputs {
            let bytes = std::fs::read(self.options.reports_dir.join(f)).ok()?;
            if &sha256_hex(&bytes) != sha {
                return None;
            }
        }
        let md = std::fs::read_to_string(dir.join("section.md")).ok()?;
        Some((md, s.files))
    }
}

fn point(x: &[f64]) -> String {
    format!(
        "r = {:.3}, aniso = {:.3}, μ = {:.3}, φ = {:.3}",
        x[0], x[1], x[2], x[3]
    )
}

/// The section's markdown (links relative to `reports/`).
fn markdown(s: &AnisoSummary, n: &[usize]) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Anisotropic conductor: the isotropic shortcuts\n");
    let _ = writeln!(
        md,
        "`{}` (height-correlated G2; OpenPBR's r and aniso, φ the azimuth of ωo from the tangent) on a {} table over r ∈ [0, 1], aniso ∈ [0, 0.95], μ ∈ [0, 1], φ ∈ [0, π/2] ({} cells). \
A renderer that compensates an anisotropic lobe with its isotropic table looks up E_iso(r_eff, μ) at an effective roughness r_eff = √α (clamped to r ≤ 1); E_iso is computed here by quadrature of `ggx-conductor` at that point, \
so the differences are the shortcut's own error, not a LUT's. Over every node of the table:\n",
        s.model,
        s.resolution,
        n.iter().product::<usize>()
    );
    let _ = writeln!(md, "| shortcut (α of the isotropic lookup) | max \\|E_aniso − E_iso\\| | at | mean \\|E_aniso − E_iso\\| |");
    let _ = writeln!(md, "| --- | ---: | --- | ---: |");
    for e in &s.shortcuts {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            e.shortcut,
            fmt_e(e.max_abs),
            point(&e.at),
            fmt_e(e.mean_abs)
        );
    }
    if let Some(png) = s.files.iter().find(|f| f.ends_with(".png")) {
        let svg = s
            .files
            .iter()
            .find(|f| f.ends_with(".svg"))
            .cloned()
            .unwrap_or_default();
        let _ = writeln!(
            md,
            "\nThe largest error over (r, μ) at each (aniso, φ) node, by shortcut:\n\n![isotropic shortcuts]({png}) ([SVG]({svg}))\n"
        );
    }
    let _ = writeln!(
        md,
        "White furnace test of the anisotropic conductor compensated with each albedo source (ρ_ss/E, Sforza & Pellacini 2022, eqs. 7, 13 at F0 = 1), at {} nodes \
(at most {FURNACE_NODES} of r and of μ, every aniso and φ node); the lobe's integral is the model's slope-space integrand at orders 16 and 24 (largest difference {}), not the table's refined estimate:\n",
        s.furnace_points,
        fmt_e(s.lobe_error)
    );
    let _ = writeln!(
        md,
        "| albedo source | max \\|1 − E\\| | at | mean \\|1 − E\\| |"
    );
    let _ = writeln!(md, "| --- | ---: | --- | ---: |");
    for v in &s.furnace {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            v.name,
            fmt_e(v.stats.max_deviation),
            point(&v.stats.at),
            fmt_e(v.stats.mean_deviation)
        );
    }
    let g = s.fit_grid;
    let _ = writeln!(
        md,
        "\nfurnace's fits: under each budget, of the rational 3/3 and the largest of a sweep's 4-D forms under it (rationals with degree caps on (r², aniso, √L(μ; α_o), α_o/α_t), \
`fit::defaults::ANISO_EXPONENT_FORMS`), the one with the lowest max at its points, each fitted for minimax error on {} points of a {} × {} × {} × {} grid uniform in r², aniso, √L(μ; α_o) and sin²φ \
(E there by quadrature: a grid uniform in μ would leave the grazing layer μ ≲ α_o unsampled at small r), each certified pole-free on the box, \
and measured at the {} nodes of the table above, which it was not fitted on:\n",
        s.fit_points,
        g[0],
        g[1],
        g[2],
        g[3],
        n.iter().product::<usize>()
    );
    if s.fits.is_empty() {
        let _ = writeln!(
            md,
            "No certified fit came out, so the furnace test has no fit row."
        );
    } else {
        let _ = writeln!(
            md,
            "| budget | form | coefficients | max at its points | max \\|fit − E\\| at the nodes | at | mean |"
        );
        let _ = writeln!(md, "| ---: | --- | ---: | ---: | ---: | --- | ---: |");
        for f in &s.fits {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} |",
                f.budget,
                f.form,
                f.coefficients,
                fmt_e(f.max_fitted),
                fmt_e(f.max_abs),
                point(&f.at),
                fmt_e(f.mean_abs)
            );
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_grid_is_uniform_in_the_fit_variables() {
        assert_eq!(fit_grid(&DEFAULT_RESOLUTION), [40, 12, 48, 12]);
        let names: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let domain = vec![
            (0.0, 1.0),
            (0.0, 0.95),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ];
        let data = FitData::new(names.clone(), vec![0.5; 4], vec![0.5], domain.clone()).unwrap();
        let transforms = physics_transforms(&data, true).unwrap();
        let t_box = transformed_box(&names, &domain, &transforms).unwrap();
        let grid = [4, 3, 5, 3];
        let points = layer_points(grid, &domain, &transforms[2], t_box[2]);
        assert_eq!(points.len(), 4 * 4 * 3 * 5 * 3);
        for (k, x) in points.chunks(4).enumerate() {
            let (i0, i1, i2, i3) = (k / 45, (k / 15) % 3, (k / 3) % 5, k % 3);
            assert!(x
                .iter()
                .zip(&domain)
                .all(|(v, (lo, hi))| v >= lo && v <= hi));
            assert!((x[0] * x[0] - i0 as f64 / 3.0).abs() < 1e-12, "{x:?}");
            assert!((x[1] - 0.95 * i1 as f64 / 2.0).abs() < 1e-12, "{x:?}");
            assert!(
                (x[3].sin().powi(2) - i3 as f64 / 2.0).abs() < 1e-12,
                "{x:?}"
            );
            // μ solved from the layer variable: t back from μ on the uniform grid (at r = 0
            // the layer has no width and every μ maps to one t)
            let (lo, hi) = t_box[2];
            let t = lo + (hi - lo) * i2 as f64 / 4.0;
            if i0 > 0 {
                // (t = √L: next to t = 0 a rounding of μ near 1e-19 moves t by 1e-9)
                let back = transforms[2].apply(2, x);
                assert!((back - t).abs() < 1e-8, "{x:?}: {t} {back}");
            }
        }
    }

    #[test]
    fn the_shortcuts_agree_when_isotropic_and_order_as_expected_otherwise() {
        for s in Shortcut::ALL {
            for r in [0.1, 0.5, 0.9] {
                for phi in [0.0, 0.4, 1.2] {
                    assert!((s.r_eff(r, 0.0, phi) - r).abs() < 1e-12, "{s:?}");
                }
            }
        }
        let (r, aniso) = (0.6, 0.7);
        let (at, ab) = anisotropic_alphas(r, aniso);
        let g = Shortcut::GeometricMean.r_eff(r, aniso, 0.3);
        let l = Shortcut::Larger.r_eff(r, aniso, 0.3);
        assert!((g * g - (at * ab).sqrt()).abs() < 1e-12 && (l * l - at).abs() < 1e-12);
        // projected: α_t along the tangent (φ = 0), α_b along the bitangent (φ = π/2)
        let p0 = Shortcut::Projected.r_eff(r, aniso, 0.0);
        let p1 = Shortcut::Projected.r_eff(r, aniso, std::f64::consts::FRAC_PI_2);
        assert!((p0 - l).abs() < 1e-12 && (p1 * p1 - ab).abs() < 1e-12);
        // clamped to the isotropic table's edge
        assert_eq!(Shortcut::Larger.r_eff(1.0, 0.95, 0.0), 1.0);
    }
}
