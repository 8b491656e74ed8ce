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
//! The fits are the best fits of the degree sweep `furnace run` makes of the model's table
//! (`fits/<model>/best-<N>.json`, [`crate::pipeline::aniso`]); the section reads them and
//! measures each at every node of its table. Their files are part of the section's digest.
use super::albedo::{Albedo, FitAlbedo, TableAlbedo};
use super::model::{fmt_e, furnace_axis, Reporter};
use super::plot::{self, ColorScale, Formats, HeatFigure, HeatPanel};
use crate::bsdf::{self, ModelId};
use crate::digest::sha256_hex;
use crate::error::{Error, Result};
use crate::fit::check::CheckSet;
use crate::fit::job::FitRecord;
use crate::fit::metrics::{measure, Metrics};
use crate::fit::FitData;
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

/// A fit of the section: its file, form, the points it was fitted on and its errors at the
/// off-grid check points and at the table's nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitErrors {
    pub budget: usize,
    /// Relative to the fits folder.
    pub file: String,
    pub form: String,
    pub coefficients: usize,
    /// How many points it was fitted on, and which.
    pub fitted_on: String,
    /// Max and mean |fit − E| at its table's off-grid check points (what they are).
    pub off_grid: Option<(f64, f64, String)>,
    /// Max and mean |fit − E| at the table's nodes, and (r, aniso, mu, phi) of the max.
    pub max_abs: f64,
    pub at: Vec<f64>,
    pub mean_abs: f64,
}

/// A LUT's errors at the off-grid check points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LutOffGrid {
    pub values: usize,
    pub points: usize,
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
    /// The section's table as a LUT (multilinear) at the model's off-grid check points: values
    /// stored, max and mean |LUT − E|, and (r, aniso, mu, phi) of the max.
    pub lut_off_grid: LutOffGrid,
    /// The fits, by budget.
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

/// A fit of the section: its file and its errors at the table's nodes.
struct SectionFit {
    budget: usize,
    /// Relative to the fits folder.
    file: String,
    record: FitRecord,
    at_nodes: Metrics,
}

/// The best fits `furnace run` wrote for the section's model (`<fits>/<model>/best-<N>.json`,
/// [`crate::pipeline::aniso`]) that are there, each measured at every node of `table`.
fn fits(fits_dir: &Path, table: &Table) -> Result<Vec<SectionFit>> {
    let names: Vec<String> = table.spec.axes.iter().map(|a| a.name.clone()).collect();
    let axes: Vec<Vec<f64>> = table.spec.axes.iter().map(|a| a.nodes()).collect();
    let at_nodes = FitData::from_grid(names, &axes, table.output(0).to_vec())?;
    let model = albedo_model(SMITH).key();
    let mut out = Vec::new();
    for budget in crate::fit::job::default_budgets(4) {
        let file = format!("{model}/best-{budget}.json");
        let path = fits_dir.join(&file);
        if !path.is_file() {
            continue;
        }
        let record = crate::fit::file::read(&path)?;
        out.push(SectionFit {
            budget,
            file,
            at_nodes: measure(&record.fit.approximant, &at_nodes),
            record,
        });
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
        let table = self
            .tables()
            .table(model.as_ref(), &resolution)
            .map_err(|e| e.for_option("--anisotropy"))?;
        let fitted = fits(&self.options.fits_dir, &table)?;
        let digest = {
            let mut bytes: Vec<u8> = Vec::new();
            bytes.extend(crate::VERSION.as_bytes());
            bytes.extend(
                format!(
                    "{resolution:?} {FURNACE_NODES} {} report {}",
                    crate::fit::check::CHECK_SET_VERSION,
                    crate::report::model::reuse::REPORT_REVISION
                )
                .as_bytes(),
            );
            for v in table.output(0) {
                bytes.extend(v.to_le_bytes());
            }
            for f in &fitted {
                bytes.extend(f.file.as_bytes());
                bytes.extend(f.record.to_json()?.as_bytes());
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
        // the table as a LUT at the check points the fit files are measured on
        (self.progress())("anisotropy: check points");
        let check = CheckSet::compute(model.as_ref(), &table.spec)?;
        let check_n = check.names.len();
        let (mut lut_max, mut lut_at, mut lut_sum) = (0.0f64, Vec::new(), 0.0);
        for (x, v) in check.coords.chunks(check_n).zip(&check.values) {
            let d = (exact.albedo(x) - v).abs();
            lut_sum += d;
            if d > lut_max || lut_at.is_empty() {
                lut_max = d;
                lut_at = x.to_vec();
            }
        }
        let lut_off_grid = LutOffGrid {
            values: values.len(),
            points: check.values.len(),
            max_abs: lut_max,
            at: lut_at,
            mean_abs: lut_sum / check.values.len().max(1) as f64,
        };
        let shortcut_sources: Vec<ShortcutAlbedo> = Shortcut::ALL
            .iter()
            .map(|&shortcut| ShortcutAlbedo {
                shortcut,
                iso: &iso,
            })
            .collect();
        let fit_sources = fitted
            .iter()
            .map(|f| {
                FitAlbedo::new(
                    &f.record.fit,
                    &["r", "aniso", "mu", "phi"].map(String::from),
                )
            })
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
                    f.budget, f.record.fit.n_coefficients
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
            lut_off_grid,
            fits: fitted
                .iter()
                .map(|f| FitErrors {
                    budget: f.budget,
                    file: f.file.clone(),
                    form: f
                        .record
                        .fit
                        .form
                        .label_with(&f.record.fit.approximant.variables),
                    coefficients: f.record.fit.n_coefficients,
                    fitted_on: format!(
                        "{} points: {}",
                        f.record.fitted_on.points, f.record.fitted_on.selection
                    ),
                    off_grid: f
                        .record
                        .off_grid
                        .as_ref()
                        .map(|o| (o.metrics.max_abs_error, o.metrics.mae, o.on.clone())),
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
    let _ = writeln!(
        md,
        "\nfurnace's fits: the best fits of the degree sweep `furnace run` makes of the model's 16 × 8 × 16 × 8 table (written to `fits/` with their code: Rust, WGSL, GLSL, HLSL, C/C++), \
fitted on the table's nodes and exact training points in the grazing and low-roughness layers, in the variables r², aniso, √L(μ; α_o), α_o/α_t; \
under each budget the lowest max error at the table's off-grid check points among the fits within 1.5× of the lowest MAE there, each certified pole-free on the box, \
and measured here at the {} nodes of the table above:\n",
        n.iter().product::<usize>()
    );
    if s.fits.is_empty() {
        let _ = writeln!(
            md,
            "No fit file is there (`furnace run` writes them), so the furnace test has no fit row."
        );
    } else {
        let _ = writeln!(
            md,
            "| budget | file | form | coefficients | fitted on | max / mean off grid | max \\|fit − E\\| at the nodes | at | mean |"
        );
        let _ = writeln!(
            md,
            "| ---: | --- | --- | ---: | --- | --- | ---: | --- | ---: |"
        );
        for f in &s.fits {
            let _ = writeln!(
                md,
                "| {} | `fits/{}` | {} | {} | {} | {} | {} | {} | {} |",
                f.budget,
                f.file,
                f.form,
                f.coefficients,
                f.fitted_on,
                f.off_grid.as_ref().map_or("–".into(), |(m, a, _)| format!(
                    "{} / {}",
                    fmt_e(*m),
                    fmt_e(*a)
                )),
                fmt_e(f.max_abs),
                point(&f.at),
                fmt_e(f.mean_abs)
            );
        }
        if let Some((_, _, on)) = s.fits.iter().find_map(|f| f.off_grid.as_ref()) {
            let _ = writeln!(md, "\nOff grid: {on}.");
        }
    }
    let l = &s.lut_off_grid;
    let _ = writeln!(
        md,
        "\nAt the {} check points the table above as a LUT (multilinear, {} values) errs by up to {} (mean {}), at {}.",
        l.points,
        l.values,
        fmt_e(l.max_abs),
        fmt_e(l.mean_abs),
        point(&l.at)
    );
    md
}

#[cfg(test)]
mod tests {
    use super::*;

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
