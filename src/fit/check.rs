//! Off-grid truth: a deterministic set of points between a table's nodes, with the model's
//! exact values there (direct quadrature, as `furnace eval --model` computes them), on which every
//! fit of the table is measured. A fit's headline errors are these, not the errors at the nodes it
//! was fitted to.
//!
//! The points ([`check_points`]), all inside the table's box:
//! - [`QUASI_POINTS`] of the R_d quasi-random sequence over the whole box (Roberts 2018,
//!   "The Unreasonable Effectiveness of Quasirandom Sequences": x_i = frac(½ + i·g^{−k}), g the
//!   positive root of g^{d+1} = g + 1);
//! - the layers where albedos vary fastest, [`LAYER_POINTS`] each: grazing angles (the first
//!   [`GRAZING_FRACTION`] of `mu`), low roughness (the first [`SMOOTH_FRACTION`] of `r`), their
//!   corner (μ clustered quadratically towards its low end) and, for `f0`, its first
//!   [`GRAZING_FRACTION`];
//! - every face of the box, [`FACE_POINTS`] each (one coordinate at its end, the others
//!   quasi-random).
//!
//! The set is cached next to its table (`<table stem>.check-v<version>.json`, under the
//! git-ignored `data/`), keyed by the table spec's content hash and [`CHECK_SET_VERSION`].

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use super::data::FitData;
use super::metrics::{measure, Metrics};
use super::result::Approximant;
use crate::bsdf::{albedo, Model};
use crate::error::{Error, Result};
use crate::quadrature::RuleCache;
use crate::table::TableSpec;

/// Version of the point set: a change to [`check_points`] bumps it, so cached sets are redone.
pub const CHECK_SET_VERSION: u32 = 1;
/// Quasi-random points over the whole box.
pub const QUASI_POINTS: usize = 16384;
/// Points in each fast-varying layer (grazing μ, low r, their corner, low F0).
pub const LAYER_POINTS: usize = 2048;
/// Points on each face of the box.
pub const FACE_POINTS: usize = 256;
/// Width of the grazing layer as a fraction of the `mu` range (μ < 0.05 on [0, 1]).
pub const GRAZING_FRACTION: f64 = 0.05;
/// Width of the low-roughness layer as a fraction of the `r` range (r < 0.15, α < 0.0225).
pub const SMOOTH_FRACTION: f64 = 0.15;

/// The positive root g of g^{d+1} = g + 1 (Roberts 2018): g = 1.618… (d = 1), 1.3247… (d = 2),
/// 1.2207… (d = 3). Newton from 2 converges monotonically.
fn generalised_golden_ratio(d: usize) -> f64 {
    let mut g = 2.0f64;
    for _ in 0..64 {
        let f = g.powi(d as i32 + 1) - g - 1.0;
        let df = (d as f64 + 1.0) * g.powi(d as i32) - 1.0;
        g -= f / df;
    }
    g
}

/// Point `i` of the R_d sequence in [0, 1)^d.
fn rd_point(i: usize, d: usize, out: &mut [f64]) {
    let g = generalised_golden_ratio(d);
    for (k, o) in out.iter_mut().enumerate().take(d) {
        let a = g.powi(-(k as i32 + 1));
        *o = (0.5 + a * i as f64).fract();
    }
}

/// A sub-box of the unit cube to fill: per axis `(lo, hi, clustered)`, or a fixed coordinate.
#[derive(Clone, Copy)]
enum Span {
    Range(f64, f64, bool),
    Fixed(f64),
}

/// `n` points of the R_d sequence (over the non-fixed axes) mapped into `spans` (unit
/// coordinates), then into the table box.
fn fill(spans: &[Span], n: usize, domain: &[(f64, f64)], out: &mut Vec<f64>) {
    fill_from(spans, 0, n, domain, out)
}

/// [`fill`] with points `start..start + n` of the sequence.
fn fill_from(spans: &[Span], start: usize, n: usize, domain: &[(f64, f64)], out: &mut Vec<f64>) {
    let free: Vec<usize> = (0..spans.len())
        .filter(|&k| matches!(spans[k], Span::Range(..)))
        .collect();
    let mut u = vec![0.0; free.len()];
    for i in start..start + n {
        if !free.is_empty() {
            rd_point(i, free.len(), &mut u);
        }
        for (k, s) in spans.iter().enumerate() {
            let unit = match *s {
                Span::Fixed(v) => v,
                Span::Range(lo, hi, clustered) => {
                    let j = free.iter().position(|&f| f == k).unwrap_or(0);
                    let t = if clustered { u[j] * u[j] } else { u[j] };
                    lo + (hi - lo) * t
                }
            };
            let (a, b) = domain[k];
            // the ends of a face are the box's exactly
            out.push(if unit <= 0.0 {
                a
            } else if unit >= 1.0 {
                b
            } else {
                a + (b - a) * unit
            });
        }
    }
}

/// The check points of a box (flat, `names.len()` coordinates per point; see the module docs).
pub fn check_points(names: &[String], domain: &[(f64, f64)]) -> Vec<f64> {
    let d = names.len();
    let find = |n: &str| names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let whole = vec![Span::Range(0.0, 1.0, false); d];
    let mut out = Vec::new();
    fill(&whole, QUASI_POINTS, domain, &mut out);
    let layer = |k: usize, width: f64, clustered: bool, spans: &mut Vec<Span>| {
        spans[k] = Span::Range(0.0, width, clustered);
    };
    let (mu, r, f0) = (find("mu"), find("r"), find("f0"));
    if let Some(m) = mu {
        let mut s = whole.clone();
        layer(m, GRAZING_FRACTION, false, &mut s);
        fill(&s, LAYER_POINTS, domain, &mut out);
    }
    if let Some(k) = r {
        let mut s = whole.clone();
        layer(k, SMOOTH_FRACTION, false, &mut s);
        fill(&s, LAYER_POINTS, domain, &mut out);
    }
    if let (Some(m), Some(k)) = (mu, r) {
        let mut s = whole.clone();
        layer(m, GRAZING_FRACTION, true, &mut s);
        layer(k, SMOOTH_FRACTION, false, &mut s);
        fill(&s, LAYER_POINTS, domain, &mut out);
    }
    if let Some(f) = f0 {
        let mut s = whole.clone();
        layer(f, GRAZING_FRACTION, false, &mut s);
        fill(&s, LAYER_POINTS, domain, &mut out);
    }
    for k in 0..d {
        for end in [0.0, 1.0] {
            let mut s = whole.clone();
            s[k] = Span::Fixed(end);
            fill(&s, FACE_POINTS, domain, &mut out);
        }
    }
    out
}

/// Version of the training set: a change to [`training_points`] bumps it.
pub const TRAINING_SET_VERSION: u32 = 2;
/// The share of the training points on each face of the box (1/64: 6 × 128 of 8 192 in 3-D).
pub const TRAINING_FACE_DIVISOR: usize = 64;
/// The training points are points [`TRAINING_START`]… of the R_d sequence, the check points
/// 0…[`QUASI_POINTS`] − 1 (in every sub-box): the two sets never share a point.
pub const TRAINING_START: usize = 1 << 24;

/// `n` training points of a box (flat, `names.len()` coordinates per point): exact values
/// there join a sweep's fitting nodes, so that the solver sees between the table's nodes where
/// albedos vary fastest. Disjoint from [`check_points`] (a later stretch of the same R_d
/// sequence, from [`TRAINING_START`]): a quarter over the whole box; with `mu`, three eighths in
/// its grazing layer over every r (μ clustered quadratically towards the low end); with `r`, an
/// eighth in the low-roughness layer; with both, a quarter in their corner (μ clustered); on
/// every face of the box, n/[`TRAINING_FACE_DIVISOR`] (one coordinate at its end, the others
/// quasi-random), where the check set has points too and the graded nodes leave the far ends
/// of the axes sparse. The shares of missing layers go to the whole box.
pub fn training_points(names: &[String], domain: &[(f64, f64)], n: usize) -> Vec<f64> {
    let d = names.len();
    let find = |x: &str| names.iter().position(|v| v.eq_ignore_ascii_case(x));
    let whole = vec![Span::Range(0.0, 1.0, false); d];
    let (mu, r) = (find("mu"), find("r"));
    let mut layers: Vec<(Vec<Span>, usize)> = Vec::new();
    if let Some(m) = mu {
        let mut s = whole.clone();
        s[m] = Span::Range(0.0, GRAZING_FRACTION, true);
        layers.push((s, 3 * n / 8));
    }
    if let Some(k) = r {
        let mut s = whole.clone();
        s[k] = Span::Range(0.0, SMOOTH_FRACTION, false);
        layers.push((s, n / 8));
    }
    if let (Some(m), Some(k)) = (mu, r) {
        let mut s = whole.clone();
        s[m] = Span::Range(0.0, GRAZING_FRACTION, true);
        s[k] = Span::Range(0.0, SMOOTH_FRACTION, false);
        layers.push((s, n / 4));
    }
    // faces only where a point on one has free coordinates, and never more than is left
    let left = n - layers.iter().map(|l| l.1).sum::<usize>();
    let per_face = if d >= 2 {
        (n / TRAINING_FACE_DIVISOR).min(left / (2 * d))
    } else {
        0
    };
    for k in 0..d {
        for end in [0.0, 1.0] {
            let mut s = whole.clone();
            s[k] = Span::Fixed(end);
            layers.push((s, per_face));
        }
    }
    let rest = n - layers.iter().map(|l| l.1).sum::<usize>();
    let mut out = Vec::with_capacity(n * d);
    fill_from(&whole, TRAINING_START, rest, domain, &mut out);
    for (spans, count) in &layers {
        fill_from(spans, TRAINING_START, *count, domain, &mut out);
    }
    out
}

/// The off-grid check set of one table: points, the model's values there, and what they are.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckSet {
    pub what: String,
    pub version: u32,
    pub model: String,
    /// [`TableSpec::content_hash`] of the table the set belongs to.
    pub table_content_hash: String,
    /// The output checked (`E`).
    pub channel: String,
    pub names: Vec<String>,
    pub domain: Vec<(f64, f64)>,
    /// `names.len()` coordinates per point.
    pub coords: Vec<f64>,
    pub values: Vec<f64>,
    /// Largest quadrature error estimate of the values.
    pub max_error_estimate: f64,
}

impl CheckSet {
    /// The model's values at [`check_points`] of `spec`'s box, by direct quadrature with the
    /// table's settings (output 0, `E`).
    pub fn compute(model: &dyn Model, spec: &TableSpec) -> Result<CheckSet> {
        CheckSet::compute_with(model, spec, None)
    }

    /// The model's values at `n` [`training_points`] of `spec`'s box, like [`CheckSet::compute`].
    pub fn compute_training(model: &dyn Model, spec: &TableSpec, n: usize) -> Result<CheckSet> {
        CheckSet::compute_with(model, spec, Some(n))
    }

    /// The check set, or with `training: Some(n)` the training set of `n` points.
    fn compute_with(
        model: &dyn Model,
        spec: &TableSpec,
        training: Option<usize>,
    ) -> Result<CheckSet> {
        let names: Vec<String> = spec.axes.iter().map(|a| a.name.clone()).collect();
        let domain: Vec<(f64, f64)> = spec.axes.iter().map(|a| (a.lo, a.hi)).collect();
        if let Some((a, _)) = spec
            .axes
            .iter()
            .zip(&domain)
            .find(|(_, (lo, hi))| !(hi > lo))
        {
            return Err(Error::InvalidInput(format!(
                "axis {} of the {} table is a single value [{}, {}]: an off-grid check set needs a box of positive width on every axis",
                a.name, spec.model, a.lo, a.hi
            )));
        }
        let coords = match training {
            Some(n) => training_points(&names, &domain, n),
            None => check_points(&names, &domain),
        };
        let d = names.len();
        let cache = RuleCache::new(&spec.quadrature);
        let estimates: Vec<(f64, f64)> = coords
            .par_chunks(d)
            .map(|x| {
                let e = albedo(model, x, &spec.quadrature, &cache);
                (e.value[0], e.error)
            })
            .collect();
        if let Some(i) = estimates.iter().position(|e| !e.0.is_finite()) {
            return Err(Error::InvalidInput(format!(
                "{} is not finite at the check point {:?}",
                spec.model,
                &coords[i * d..(i + 1) * d]
            )));
        }
        let (what, version) = match training {
            Some(_) => ("off-grid training points of the table with this content hash (disjoint from its check points), and the model's E there by direct quadrature (furnace eval --model); a sweep fits on them with the table's nodes", TRAINING_SET_VERSION),
            None => ("off-grid check points of the table with this content hash, and the model's E there by direct quadrature (furnace eval --model); every fit of the table is measured on them", CHECK_SET_VERSION),
        };
        Ok(CheckSet {
            what: what.into(),
            version,
            model: spec.model.clone(),
            table_content_hash: spec.content_hash(),
            channel: spec.outputs.first().cloned().unwrap_or_else(|| "E".into()),
            names,
            domain,
            values: estimates.iter().map(|e| e.0).collect(),
            max_error_estimate: estimates.iter().map(|e| e.1).fold(0.0, f64::max),
            coords,
        })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The points as fit data (for [`measure`]).
    pub fn data(&self) -> Result<FitData> {
        Ok(FitData::new(
            self.names.clone(),
            self.coords.clone(),
            self.values.clone(),
            self.domain.clone(),
        )?)
    }

    /// The points inside `bounds` (one `(lo, hi)` per variable), e.g. for a fit restricted to a
    /// sub-box; None if no point is inside.
    pub fn within(&self, bounds: &[(f64, f64)]) -> Option<CheckSet> {
        let d = self.names.len();
        let mut out = CheckSet {
            coords: Vec::new(),
            values: Vec::new(),
            domain: bounds.to_vec(),
            ..self.clone()
        };
        for (x, &y) in self.coords.chunks(d).zip(&self.values) {
            if x.iter().zip(bounds).all(|(v, (lo, hi))| v >= lo && v <= hi) {
                out.coords.extend_from_slice(x);
                out.values.push(y);
            }
        }
        (!out.is_empty()).then_some(out)
    }

    /// In words, for fit files: `25088 off-grid points (…)`.
    pub fn description(&self) -> String {
        format!(
            "{} off-grid points (check set v{}: quasi-random over the whole domain, the grazing, low-roughness and low-F0 layers and every face), exact values by quadrature (error estimate ≤ {:.1e})",
            self.len(),
            self.version,
            self.max_error_estimate
        )
    }
}

impl CheckSet {
    /// In words, for fit files, when the set is a training set ([`training_points`]).
    pub fn training_description(&self) -> String {
        format!(
            "{} exact off-grid training points (training set v{}, disjoint from the check set: quasi-random over the whole domain, the grazing and low-roughness layers, their corner and every face; error estimate ≤ {:.1e})",
            self.len(),
            self.version,
            self.max_error_estimate
        )
    }
}

/// Where the check set of the table at `stem` is cached.
pub fn check_path(stem: &Path) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(format!(".check-v{CHECK_SET_VERSION}.json"));
    PathBuf::from(s)
}

/// The check set of `spec` (whose table lives at `stem`): read from its cache file when that
/// belongs to the same spec and version, else computed and written there.
pub fn get_or_compute(model: &dyn Model, spec: &TableSpec, stem: &Path) -> Result<CheckSet> {
    let path = check_path(stem);
    if let Ok(text) = std::fs::read_to_string(&path) {
        if let Ok(set) = serde_json::from_str::<CheckSet>(&text) {
            if set.version == CHECK_SET_VERSION
                && set.table_content_hash == spec.content_hash()
                && set.values.len() * set.names.len() == set.coords.len()
            {
                return Ok(set);
            }
        }
    }
    let set = CheckSet::compute(model, spec)?;
    let json = serde_json::to_string(&set).map_err(|e| Error::file(&path, e.to_string()))?;
    crate::output::write(&path, format!("{json}\n").as_bytes())?;
    Ok(set)
}

/// Where the training set of `n` points of the table at `stem` is cached.
pub fn training_path(stem: &Path, n: usize) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(format!(".train-v{TRAINING_SET_VERSION}-{n}.json"));
    PathBuf::from(s)
}

/// The training set of `n` points of `spec` (whose table lives at `stem`): read from its
/// cache file when that belongs to the same spec and version, else computed and written there.
pub fn training_get_or_compute(
    model: &dyn Model,
    spec: &TableSpec,
    stem: &Path,
    n: usize,
) -> Result<CheckSet> {
    let path = training_path(stem, n);
    if let Ok(text) = std::fs::read_to_string(&path) {
        if let Ok(set) = serde_json::from_str::<CheckSet>(&text) {
            if set.version == TRAINING_SET_VERSION
                && set.table_content_hash == spec.content_hash()
                && set.values.len() == n
                && set.values.len() * set.names.len() == set.coords.len()
            {
                return Ok(set);
            }
        }
    }
    let set = CheckSet::compute_training(model, spec, n)?;
    let json = serde_json::to_string(&set).map_err(|e| Error::file(&path, e.to_string()))?;
    crate::output::write(&path, format!("{json}\n").as_bytes())?;
    Ok(set)
}

/// A fit's errors at the check points.
pub fn measure_on(approximant: &Approximant, check: &FitData) -> Metrics {
    measure(approximant, check)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_ratios_solve_their_equations() {
        assert!((generalised_golden_ratio(1) - (1.0 + 5f64.sqrt()) / 2.0).abs() < 1e-14);
        assert!((generalised_golden_ratio(2) - 1.324_717_957_244_746).abs() < 1e-14);
    }

    #[test]
    fn points_fill_the_box_its_layers_and_faces() {
        let names: Vec<String> = ["f0", "r", "mu"].iter().map(|s| s.to_string()).collect();
        let domain = vec![(0.0125, 0.25), (0.0, 1.0), (0.0, 1.0)];
        let p = check_points(&names, &domain);
        let n = p.len() / 3;
        assert_eq!(n, QUASI_POINTS + 4 * LAYER_POINTS + 6 * FACE_POINTS);
        assert!(n >= 20_000);
        assert!(p.chunks(3).all(|x| x
            .iter()
            .zip(&domain)
            .all(|(v, (lo, hi))| v >= lo && v <= hi)));
        // every face is hit exactly, and the grazing corner is sampled densely
        for k in 0..3 {
            for end in [domain[k].0, domain[k].1] {
                assert!(p.chunks(3).filter(|x| x[k] == end).count() >= FACE_POINTS);
            }
        }
        let corner = p.chunks(3).filter(|x| x[1] < 0.15 && x[2] < 1e-3).count();
        assert!(corner > 200, "{corner}");
        // deterministic
        assert_eq!(p, check_points(&names, &domain));
    }

    #[test]
    fn training_points_are_disjoint_from_the_check_points_and_inside_the_box() {
        let names: Vec<String> = ["f0", "r", "mu"].iter().map(|s| s.to_string()).collect();
        let domain = vec![(0.0125, 0.25), (0.0, 1.0), (0.0, 1.0)];
        let n = 4096;
        let t = training_points(&names, &domain, n);
        assert_eq!(t.len(), 3 * n);
        assert!(t.chunks(3).all(|x| x
            .iter()
            .zip(&domain)
            .all(|(v, (lo, hi))| v >= lo && v <= hi)));
        assert_eq!(t, training_points(&names, &domain, n));
        // no training point is a check point
        let key = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
        let check: std::collections::HashSet<Vec<u64>> =
            check_points(&names, &domain).chunks(3).map(key).collect();
        assert!(t.chunks(3).all(|x| !check.contains(&key(x))));
        // the layers: μ < 0.05 over every r (and deep in it), and the corner
        let grazing = t.chunks(3).filter(|x| x[2] < 0.05).count();
        assert!(grazing >= 5 * n / 8, "{grazing}");
        let deep_rough = t.chunks(3).filter(|x| x[2] < 0.005 && x[1] > 0.8).count();
        assert!(deep_rough > 50, "{deep_rough}");
        let corner = t.chunks(3).filter(|x| x[1] < 0.15 && x[2] < 1e-3).count();
        assert!(corner > 100, "{corner}");
        // every face, between the nodes a grid puts there
        for k in 0..3 {
            for end in [domain[k].0, domain[k].1] {
                let on = t.chunks(3).filter(|x| x[k] == end).count();
                assert!(on >= n / TRAINING_FACE_DIVISOR, "axis {k} at {end}: {on}");
            }
        }
        // data without the named layers: all over the box
        let xy: Vec<String> = ["x", "y"].iter().map(|s| s.to_string()).collect();
        assert_eq!(training_points(&xy, &[(0.0, 1.0); 2], 100).len(), 200);
    }

    #[test]
    fn a_model_check_set_matches_direct_quadrature_and_is_cached() {
        let model = crate::bsdf::find("oren-nayar-fon").unwrap();
        let spec = TableSpec::new(
            model.as_ref(),
            &[5, 5],
            crate::quadrature::QuadratureSettings::default(),
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("furnace-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let stem = dir.join("5x5");
        let set = get_or_compute(model.as_ref(), &spec, &stem).unwrap();
        assert!(set.len() >= 20_000);
        assert!(check_path(&stem).is_file());
        let again = get_or_compute(model.as_ref(), &spec, &stem).unwrap();
        assert_eq!(set, again);
        let x = &set.coords[..2];
        let cache = RuleCache::new(&spec.quadrature);
        let direct = albedo(model.as_ref(), x, &spec.quadrature, &cache).value[0];
        assert_eq!(direct, set.values[0]);
        // the training set: cached apart, exact values, recomputed for another size
        let train = training_get_or_compute(model.as_ref(), &spec, &stem, 64).unwrap();
        assert_eq!(train.len(), 64);
        assert!(training_path(&stem, 64).is_file());
        assert_eq!(
            train,
            training_get_or_compute(model.as_ref(), &spec, &stem, 64).unwrap()
        );
        let y = &train.coords[2..4];
        let direct = albedo(model.as_ref(), y, &spec.quadrature, &cache).value[0];
        assert_eq!(direct, train.values[1]);
        assert_eq!(
            training_get_or_compute(model.as_ref(), &spec, &stem, 32)
                .unwrap()
                .len(),
            32
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
