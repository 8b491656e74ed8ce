//! Scene manifests: the materials a scene uses → only the tables, parameter ranges, fits and
//! emitted functions it needs.
//!
//! ```json
//! { "name": "showroom",
//!   "materials": [
//!     { "name": "gold",  "kind": "conductor",  "r": [0.2, 0.6] },
//!     { "name": "glass", "kind": "dielectric", "r": [0.0, 0.3], "ior": [1.45, 1.55] } ] }
//! ```
//!
//! A material's `kind` is a registered material class ([`crate::material`]: `conductor`,
//! `glossy`, `thin-dielectric`, `dielectric`, `rough-diffuse`, or one a program registers),
//! which says which albedo tables it reads and which helper functions are emitted for them.
//!
//! Ranges: `r` ∈ [0, 1] is the tables' `r` axis (α = r² for GGX; the FON roughness for
//! rough-diffuse), or `alpha` (converted by r = √α); `ior` ≥ 1 is converted to
//! F0 = ((η − 1)/(η + 1))² (the normal-incidence Fresnel reflectance) on the tables' `f0` axes;
//! `aniso` is the `aniso` axis of an anisotropic conductor (OpenPBR's, α_b/α_t = 1 − aniso).
//! Missing ranges, and every other axis, mean the model's default domain. One
//! number instead of a pair means a fixed value, widened to [`MIN_RANGE_WIDTH`]. Materials that
//! share a model share one table over the union of their ranges; μ always spans [0, 1].
//! A scene of conductors, thin dielectrics and rough-diffuse materials needs no 3-D table.
//!
//! This module parses and plans ([`plan`] → [`Plan`]); [`crate::pipeline::Job::scene`] makes a
//! plan a job of the pipeline: tables, fits and the emitted files.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::bsdf::{self, AxisSpec, ModelId};
use crate::emit;
use crate::error::{Error, Result};
use crate::material::{self, Helper};
use crate::math::SmithForm;

/// A fixed value (one number, or lo = hi) is widened to a range of this width (in table-axis
/// units), centred on it and kept inside the axis' valid range: a table needs lo < hi, and a fit
/// over a slightly wider range than used is harmless.
pub const MIN_RANGE_WIDTH: f64 = 0.02;

/// Default nodes per axis of tables (`furnace tabulate`, `furnace run`, scenes): the paper's
/// 1024² and 128³ (in a scene, narrower domains make the same node count denser).
pub const DEFAULT_RESOLUTION_2D: usize = 1024;
pub const DEFAULT_RESOLUTION_3D: usize = 128;

/// A range in the manifest: `[lo, hi]` or one number.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RangeSpec {
    Pair([f64; 2]),
    Value(f64),
}

/// One material entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub name: String,
    /// A registered material class ([`crate::material::find`]; checked with a clear error, so
    /// kept as text here).
    pub kind: String,
    #[serde(default)]
    pub r: Option<RangeSpec>,
    #[serde(default)]
    pub alpha: Option<RangeSpec>,
    #[serde(default)]
    pub ior: Option<RangeSpec>,
    /// OpenPBR's anisotropy, α_b/α_t = 1 − aniso (an `aniso` axis: anisotropic conductors).
    #[serde(default)]
    pub aniso: Option<RangeSpec>,
}

/// Table resolutions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Resolution {
    #[serde(rename = "2d", default = "default_2d")]
    pub two_d: usize,
    #[serde(rename = "3d", default = "default_3d")]
    pub three_d: usize,
    /// Nodes of each axis of a 4-D table (r, aniso, mu, phi); absent: the model's default
    /// resolution (64 × 16 × 64 × 16 for `ggx-conductor-aniso`).
    #[serde(rename = "4d", default)]
    pub four_d: Option<Vec<usize>>,
}

fn default_2d() -> usize {
    DEFAULT_RESOLUTION_2D
}
fn default_3d() -> usize {
    DEFAULT_RESOLUTION_3D
}

impl Default for Resolution {
    fn default() -> Self {
        Resolution {
            two_d: DEFAULT_RESOLUTION_2D,
            three_d: DEFAULT_RESOLUTION_3D,
            four_d: None,
        }
    }
}

/// Degrees of the rational fits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSettings {
    #[serde(default = "three")]
    pub numerator_degree: u32,
    #[serde(default = "three")]
    pub denominator_degree: u32,
}

fn three() -> u32 {
    3
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            numerator_degree: 3,
            denominator_degree: 3,
        }
    }
}

/// A scene manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Names the output files (`fits/<name>/<name>.rs`, …): letters, digits, `-`, `_`.
    pub name: String,
    pub materials: Vec<Material>,
    /// Smith masking–shadowing form of the GGX tables (`separable`: G1·G1, the paper's renderer).
    #[serde(default)]
    pub smith: SmithForm,
    #[serde(default)]
    pub resolution: Resolution,
    #[serde(default)]
    pub fit: FitSettings,
}

impl Manifest {
    /// Parses a manifest (`path` only names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Manifest> {
        let m: Manifest = serde_json::from_str(text).map_err(|e| {
            Error::file(
                path,
                format!("invalid scene manifest: {e}; expected {{\"name\": …, \"materials\": [{{\"name\": …, \"kind\": …, \"r\": [lo, hi], \"ior\": [lo, hi]}}]}} (see docs/scenes.md)"),
            )
        })?;
        m.validate().map_err(|e| Error::file(path, e))?;
        Ok(m)
    }

    pub fn read(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Manifest::parse(&text, path)
    }

    fn validate(&self) -> std::result::Result<(), String> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(format!("scene name '{}' must be non-empty letters, digits, '-' or '_' (it names the output files)", self.name));
        }
        if self.materials.is_empty() {
            return Err("the scene lists no materials; add at least one".into());
        }
        for (what, n) in [
            ("2d", self.resolution.two_d),
            ("3d", self.resolution.three_d),
        ] {
            if n < 2 {
                return Err(format!(
                    "resolution.{what} = {n}: a table needs at least 2 nodes per axis"
                ));
            }
        }
        if let Some(n) = &self.resolution.four_d {
            if n.len() != 4 || n.iter().any(|&k| k < 2) {
                return Err(format!(
                    "resolution.4d = {n:?}: give the nodes of the four axes (r, aniso, mu, phi), each at least 2, e.g. [16, 8, 16, 8]"
                ));
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            if m.name.trim().is_empty() {
                return Err(format!(
                    "material {} has an empty name; name every material",
                    i + 1
                ));
            }
            if let Some(j) = self.materials[..i].iter().position(|o| o.name == m.name) {
                return Err(format!(
                    "materials {} and {} are both named '{}'; a renderer looks materials up by name, so give each its own",
                    j + 1,
                    i + 1,
                    m.name
                ));
            }
            material_needs(m, self.smith)?;
        }
        Ok(())
    }
}

/// (lo, hi) of a range spec, checked against `valid`; a single value is widened.
fn resolve(
    material: &str,
    field: &str,
    spec: &RangeSpec,
    valid: (f64, f64),
) -> std::result::Result<(f64, f64), String> {
    let (lo, hi) = match *spec {
        RangeSpec::Pair([lo, hi]) => (lo, hi),
        RangeSpec::Value(v) => (v, v),
    };
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(format!(
            "material '{material}': {field} range [{lo}, {hi}] is not finite"
        ));
    }
    if lo > hi {
        return Err(format!("material '{material}': {field} range [{lo}, {hi}] is inverted; write it as [{hi}, {lo}]"));
    }
    if lo < valid.0 || hi > valid.1 {
        return Err(format!(
            "material '{material}': {field} range [{lo}, {hi}] leaves the valid range [{}, {}]",
            valid.0, valid.1
        ));
    }
    Ok((lo, hi))
}

/// Widens a single value (lo = hi) to [`MIN_RANGE_WIDTH`] inside `valid`; proper ranges are
/// kept as given.
fn widen((lo, hi): (f64, f64), valid: (f64, f64)) -> (f64, f64) {
    if hi > lo {
        return (lo, hi);
    }
    let c = 0.5 * (lo + hi);
    let half = 0.5 * MIN_RANGE_WIDTH;
    let (mut a, mut b) = (c - half, c + half);
    if a < valid.0 {
        b += valid.0 - a;
        a = valid.0;
    }
    if b > valid.1 {
        a -= b - valid.1;
        b = valid.1;
    }
    (a.max(valid.0), b.min(valid.1))
}

/// F0 of a relative IOR η ≥ 1: ((η − 1)/(η + 1))² (Fresnel at normal incidence).
pub fn f0_from_ior(eta: f64) -> f64 {
    let x = (eta - 1.0) / (eta + 1.0);
    x * x
}

/// Largest IOR a manifest may give: F0(η) must stay within the dielectric tables' valid f0 ≤ 0.99.
pub const MAX_IOR: f64 = 398.0;

/// What one material needs: (model, ranges per axis, helpers of that model).
type Need = (ModelId, Vec<(f64, f64)>, Vec<Helper>);

fn material_needs(m: &Material, smith: SmithForm) -> std::result::Result<Vec<Need>, String> {
    let class = material::find(&m.kind).map_err(|_| {
        format!(
            "material '{}': unknown kind '{}'; known kinds: {}",
            m.name,
            m.kind,
            material::known_kinds()
        )
    })?;
    if m.r.is_some() && m.alpha.is_some() {
        return Err(format!(
            "material '{}': give either r or alpha, not both (α = r²)",
            m.name
        ));
    }
    let tables = class.tables(smith);
    let axes: Vec<Vec<AxisSpec>> = tables
        .iter()
        .map(|t| bsdf::get(t.model).map(|model| model.axes()))
        .collect::<Result<_>>()
        .map_err(|e| format!("material '{}': {e}", m.name))?;
    let axis = |name: &str| axes.iter().flatten().find(|a| a.name == name);
    let absent = |field: &str, what: &str| {
        format!(
            "material '{}': a {} has no {what} axis; remove '{field}'",
            m.name,
            class.noun()
        )
    };
    let r = match (axis("r"), &m.r, &m.alpha) {
        (None, Some(_), _) => return Err(absent("r", "r")),
        (None, None, Some(_)) => return Err(absent("alpha", "r")),
        (None, None, None) => None,
        (Some(a), Some(r), _) => Some(widen(
            resolve(&m.name, "r", r, a.valid_range)?,
            a.valid_range,
        )),
        (Some(a), None, Some(alpha)) => {
            if let Some(what) = class.r_is_not_alpha() {
                return Err(format!(
                    "material '{}': {} takes r ({what}), not alpha",
                    m.name,
                    class.kind()
                ));
            }
            let (v0, v1) = a.valid_range;
            let (lo, hi) = resolve(&m.name, "alpha", alpha, (v0 * v0, v1 * v1))?;
            Some(widen((lo.sqrt(), hi.sqrt()), a.valid_range))
        }
        (Some(a), None, None) => Some(a.default_range),
    };
    let aniso = match (axis("aniso"), &m.aniso) {
        (None, Some(_)) => return Err(absent("aniso", "anisotropy")),
        (Some(a), Some(spec)) => Some(widen(
            resolve(&m.name, "aniso", spec, a.valid_range)?,
            a.valid_range,
        )),
        (_, None) => None,
    };
    if m.ior.is_some() && axis("f0").is_none() {
        return Err(format!(
            "material '{}': a {} has no IOR axis (its F0 is applied at render time); remove 'ior'",
            m.name,
            class.noun()
        ));
    }
    let f0 = |a: &AxisSpec| -> std::result::Result<(f64, f64), String> {
        match &m.ior {
            None => Ok(a.default_range),
            Some(spec) => {
                let (lo, hi) = resolve(&m.name, "ior", spec, (1.0, MAX_IOR))?;
                let range = (f0_from_ior(lo), f0_from_ior(hi).min(a.valid_range.1));
                Ok(widen(range, a.valid_range))
            }
        }
    };
    tables
        .into_iter()
        .zip(&axes)
        .map(|(t, axes)| {
            let ranges = axes
                .iter()
                .map(|a| match a.name.as_str() {
                    "r" => Ok(r.unwrap_or(a.default_range)),
                    "f0" => f0(a),
                    "aniso" => Ok(aniso.unwrap_or(a.default_range)),
                    _ => Ok(a.default_range),
                })
                .collect::<std::result::Result<_, String>>()?;
            Ok((
                t.model,
                ranges,
                t.helpers.into_iter().map(|u| u.helper).collect(),
            ))
        })
        .collect()
}

/// One table (and fit) a scene needs.
#[derive(Clone, Debug, PartialEq)]
pub struct TableNeed {
    pub model: ModelId,
    /// Union of the materials' ranges, one per axis.
    pub ranges: Vec<(f64, f64)>,
    pub resolution: Vec<usize>,
    /// Materials that need it.
    pub used_by: Vec<String>,
    helpers: Vec<Helper>,
}

/// Everything a scene needs, in a fixed order (by model name).
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub scene: String,
    pub tables: Vec<TableNeed>,
    pub fit: FitSettings,
}

impl Plan {
    /// Names of the helper functions to emit.
    pub fn helper_names(&self) -> Vec<String> {
        self.tables
            .iter()
            .flat_map(|t| {
                t.helpers
                    .iter()
                    .flat_map(|&h| emit::helpers::helper_names(t.model, h))
            })
            .collect()
    }
}

/// Works out the tables, ranges and helpers of a manifest.
pub fn plan(m: &Manifest) -> Result<Plan> {
    m.validate().map_err(Error::InvalidInput)?;
    let mut by_model: BTreeMap<String, TableNeed> = BTreeMap::new(); // by key: a fixed order
    for mat in &m.materials {
        for (model, ranges, helpers) in material_needs(mat, m.smith).map_err(Error::InvalidInput)? {
            let dims = ranges.len();
            let resolution = match dims {
                0..=2 => vec![m.resolution.two_d; dims],
                3 => vec![m.resolution.three_d; dims],
                _ => match &m.resolution.four_d {
                    Some(n) if n.len() == dims => n.clone(),
                    _ => bsdf::get(model)?.default_resolution(),
                },
            };
            let entry = by_model.entry(model.key()).or_insert_with(|| TableNeed {
                model,
                ranges: ranges.clone(),
                resolution,
                used_by: vec![],
                helpers: vec![],
            });
            for (have, new) in entry.ranges.iter_mut().zip(&ranges) {
                have.0 = have.0.min(new.0);
                have.1 = have.1.max(new.1);
            }
            if !entry.used_by.contains(&mat.name) {
                entry.used_by.push(mat.name.clone());
            }
            for h in helpers {
                if !entry.helpers.contains(&h) {
                    entry.helpers.push(h);
                }
            }
        }
    }
    let mut tables: Vec<TableNeed> = by_model.into_values().collect();
    for t in &mut tables {
        t.helpers.sort();
    }
    Ok(Plan {
        scene: m.name.clone(),
        tables,
        fit: m.fit.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn manifest(text: &str) -> Result<Manifest> {
        Manifest::parse(text, Path::new("scene.json"))
    }

    #[test]
    fn conductor_only_scene_needs_no_3d_table() {
        let m = manifest(
            r#"{"name": "metals", "materials": [
            {"name": "gold", "kind": "conductor", "r": [0.2, 0.6]},
            {"name": "steel", "kind": "conductor", "alpha": [0.01, 0.09]},
            {"name": "window", "kind": "thin-dielectric", "r": 0.1}]}"#,
        )
        .unwrap();
        let p = plan(&m).unwrap();
        assert_eq!(p.tables.len(), 1, "{p:?}");
        let t = &p.tables[0];
        assert_eq!(t.model.key(), "ggx-conductor");
        assert_eq!(t.resolution, vec![DEFAULT_RESOLUTION_2D; 2]);
        // union of [0.2, 0.6], √[0.01, 0.09] = [0.1, 0.3] and 0.1 widened to [0.09, 0.11]
        assert!(
            (t.ranges[0].0 - 0.09).abs() < 1e-12 && (t.ranges[0].1 - 0.6).abs() < 1e-12,
            "{:?}",
            t.ranges
        );
        assert_eq!(t.ranges[1], (0.0, 1.0));
        assert_eq!(
            p.helper_names(),
            vec![
                "ggx_conductor_turquin_scale",
                "ggx_conductor_turquin_scale_rgb",
                "ggx_conductor_kulla_conty_lobe",
                "ggx_conductor_kulla_conty_color",
                "ggx_conductor_kulla_conty_color_rgb",
                "ggx_conductor_kulla_conty_diffuse_weight",
                "ggx_conductor_normalization"
            ]
        );
    }

    #[test]
    fn dielectric_and_glossy_scene_plans_3d_tables_over_ior_ranges() {
        let m = manifest(
            r#"{"name": "mixed", "smith": "separable", "materials": [
            {"name": "glass", "kind": "dielectric", "r": [0.0, 0.3], "ior": [1.45, 1.55]},
            {"name": "plastic", "kind": "glossy", "ior": 1.5},
            {"name": "clay", "kind": "rough-diffuse"}]}"#,
        )
        .unwrap();
        let p = plan(&m).unwrap();
        let models: Vec<String> = p.tables.iter().map(|t| t.model.key()).collect();
        assert_eq!(
            models,
            [
                "ggx-conductor-separable",
                "ggx-dielectric-inv-separable",
                "ggx-dielectric-separable",
                "ggx-glossy-separable",
                "oren-nayar-fon"
            ]
        );
        let glass = &p.tables[2];
        assert!(
            (glass.ranges[0].0 - f0_from_ior(1.45)).abs() < 1e-15
                && (glass.ranges[0].1 - f0_from_ior(1.55)).abs() < 1e-15
        );
        assert_eq!(glass.resolution, vec![DEFAULT_RESOLUTION_3D; 3]);
        let plastic = &p.tables[3];
        assert!(
            (plastic.ranges[0].1 - plastic.ranges[0].0 - MIN_RANGE_WIDTH).abs() < 1e-12,
            "{:?}",
            plastic.ranges
        );
        let h = p.helper_names();
        assert!(
            h.contains(&"ggx_dielectric_separable_sided_normalization".to_string()),
            "{h:?}"
        );
        assert!(h.contains(&"ggx_glossy_separable_diffuse_weight".to_string()));
        assert!(
            !h.iter().any(|n| n.contains("turquin")),
            "no conductor material, no Turquin scale: {h:?}"
        );
    }

    #[test]
    fn an_anisotropic_conductor_plans_a_4d_table_over_its_ranges() {
        let m = manifest(
            r#"{"name": "brushed", "resolution": {"4d": [8, 4, 8, 4]}, "materials": [
            {"name": "steel", "kind": "anisotropic-conductor", "r": [0.3, 0.6], "aniso": [0.2, 0.8]},
            {"name": "alu", "kind": "anisotropic-conductor", "r": 0.5, "aniso": 0.9}]}"#,
        )
        .unwrap();
        let p = plan(&m).unwrap();
        assert_eq!(p.tables.len(), 1, "{p:?}");
        let t = &p.tables[0];
        assert_eq!(t.model.key(), "ggx-conductor-aniso");
        assert_eq!(t.resolution, [8, 4, 8, 4]);
        let want = [
            (0.3, 0.6),
            (0.2, 0.91),
            (0.0, 1.0),
            (0.0, std::f64::consts::FRAC_PI_2),
        ];
        for (got, want) in t.ranges.iter().zip(want) {
            assert!(
                (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
                "{:?}",
                t.ranges
            );
        }
        assert_eq!(
            p.helper_names(),
            [
                "ggx_conductor_aniso_direction_albedo",
                "ggx_conductor_aniso_turquin_scale",
                "ggx_conductor_aniso_turquin_scale_rgb"
            ]
        );
        // without resolution.4d: the model's default resolution
        let m = manifest(
            r#"{"name": "b", "smith": "separable", "materials": [{"name": "s", "kind": "anisotropic-conductor"}]}"#,
        )
        .unwrap();
        let t = &plan(&m).unwrap().tables[0];
        assert_eq!(t.model.key(), "ggx-conductor-aniso-separable");
        assert_eq!(t.resolution, [64, 16, 64, 16]);
        assert_eq!(t.ranges[1], (0.0, 0.95));
    }

    #[test]
    fn bad_manifests_are_refused_with_the_fix() {
        let cases = [
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "velvet"}]}"#,
                "unknown kind 'velvet'; known kinds: conductor",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "r": [0.6, 0.2]}]}"#,
                "is inverted; write it as [0.2, 0.6]",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "dielectric", "ior": [1.6, 1.4]}]}"#,
                "ior range [1.6, 1.4] is inverted",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "glossy", "ior": [0.5, 1.4]}]}"#,
                "leaves the valid range [1, 398]",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "r": [0.0, 1.5]}]}"#,
                "leaves the valid range [0, 1]",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "ior": 1.5}]}"#,
                "remove 'ior'",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "r": 0.5, "alpha": 0.25}]}"#,
                "either r or alpha",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "roughness": 0.5}]}"#,
                "unknown field `roughness`",
            ),
            (r#"{"name": "x", "materials": []}"#, "lists no materials"),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "anisotropic-conductor", "aniso": [0.5, 1.0]}]}"#,
                "aniso range [0.5, 1] leaves the valid range [0, 0.99]",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "anisotropic-conductor", "aniso": [0.8, 0.2]}]}"#,
                "aniso range [0.8, 0.2] is inverted",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "anisotropic-conductor", "alpha": 0.2}]}"#,
                "anisotropic-conductor takes r (OpenPBR's roughness",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor", "aniso": 0.5}]}"#,
                "a conductor has no anisotropy axis; remove 'aniso'",
            ),
            (
                r#"{"name": "x", "resolution": {"4d": [8, 8, 1]}, "materials": [{"name": "a", "kind": "anisotropic-conductor"}]}"#,
                "resolution.4d = [8, 8, 1]: give the nodes of the four axes",
            ),
            (
                r#"{"name": "x", "materials": [{"name": "a", "kind": "conductor"}, {"name": "a", "kind": "rough-diffuse"}]}"#,
                "materials 1 and 2 are both named 'a'",
            ),
            (
                r#"{"name": "../x", "materials": [{"name": "a", "kind": "conductor"}]}"#,
                "scene name",
            ),
        ];
        for (text, want) in cases {
            let e = manifest(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text}\n→ {e}\nwanted: {want}");
            assert!(e.starts_with("scene.json"), "{e}");
        }
    }
}
