//! What a report reads: tables (through a [`TableProvider`]), fit files under `fits/<model>/`,
//! the paper's published fits, and benchmark CSV files. Nothing here draws or writes.
//!
//! # Fit files
//! Every `*.json` file under `fits/<model>/` (recursively, in sorted path order) that holds a
//! fit is a fit of that model: a fit file of `furnace fit` / `furnace run` (a
//! [`FitRecord`] or a bare [`FitResult`]), a JSON array of fit results or an object with a
//! `results` or `fits` array of them, or a sweep file (`sweep.json`: every fit of the sweep,
//! its pole certificate redone on load). The *chosen* fit, whose heat maps, slices and furnace
//! row the report shows, is `fits/<model>/default.json` if it exists; otherwise the sweep's
//! `best-<N>.json` with the smallest budget N that holds the paper's degree-3 rational (19
//! coefficients in 2-D → `best-20.json`, 39 in 3-D → `best-40.json`); otherwise the usable fit
//! (pole-free, finite) with the smallest maximum error among those with at most as many
//! coefficients as the paper's; otherwise the usable fit with the smallest maximum error. Files
//! that are not fits are listed in the report, never fatal (`sweep-inputs.json`, which records
//! what a sweep was made from, and `off-grid.json`, the best fits' and LUTs' off-grid errors, are
//! skipped silently).
//!
//! # Benchmark files
//! Every `*.csv` file in the benchmark folder (`reports/bench/`, written only by the benchmark
//! commands' `--output`) is one plot: optional comment lines `# title: …`, `# x: <label>` and
//! `# y: <label>` (a label ending in `(log)` asks for a log axis) and `# note: …` (how the
//! numbers were measured), then a header `series,<x name>,<y name>[,label]` and one row per
//! point (the optional label names the point, e.g. `degree 3`).

use super::albedo::{Albedo, FitAlbedo};
use crate::bsdf::{Model, ModelId};
use crate::error::{Error, Result};
use crate::fit::compare::PAPER_PAIRS;
use crate::fit::job::FitRecord;
use crate::fit::paper::PaperModel;
use crate::fit::{Approximant, CertifyOptions, FitData, FitResult, Form, Objective};
use crate::math::CompensatedSum;
use crate::table::Table;
use std::path::{Path, PathBuf};

/// Supplies tables (e.g. from the cache under `data/`, computing missing ones).
pub trait TableProvider {
    /// The table of `model` at `resolution` (one count per axis) over its default domain.
    fn table(&self, model: &dyn Model, resolution: &[usize]) -> Result<Table>;
}

/// A fit read from a file.
#[derive(Clone, Debug)]
pub struct LoadedFit {
    /// Path relative to the fits folder (for the report), with `#k` for the k-th of a list.
    pub source: String,
    pub fit: FitResult,
}

impl LoadedFit {
    /// "rational 3/3", "polynomial 5".
    pub fn short_form(&self) -> String {
        short_form(&self.fit.form)
    }
}

/// "rational 3/3", "polynomial 5".
pub fn short_form(form: &Form) -> String {
    match *form {
        Form::Polynomial { degree } => format!("polynomial {degree}"),
        Form::Rational {
            numerator_degree,
            denominator_degree,
        } => format!("rational {numerator_degree}/{denominator_degree}"),
        Form::Exponents { .. } => form.file_stem().replace('-', " "),
    }
}

/// Fits found for a model, and notes on files that were skipped.
#[derive(Clone, Debug, Default)]
pub struct FitFiles {
    pub fits: Vec<LoadedFit>,
    pub notes: Vec<String>,
    /// Index into `fits` of `default.json`, if there was one.
    pub default: Option<usize>,
}

fn json_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            json_files(&p, out)?;
        } else if p.extension().is_some_and(|e| e == "json") {
            out.push(p);
        }
    }
    Ok(())
}

/// Parses one fit file: a fit, an array of fits, or an object with a `results`/`fits` array.
pub fn parse_fit_file(text: &str) -> std::result::Result<Vec<FitResult>, String> {
    if let Ok(f) = FitResult::from_json(text) {
        return Ok(vec![f]);
    }
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let list = match &value {
        serde_json::Value::Array(a) => a.clone(),
        serde_json::Value::Object(o) => match o.get("results").or_else(|| o.get("fits")) {
            Some(serde_json::Value::Array(a)) => a.clone(),
            _ => {
                return Err(
                    "neither a fit result nor a list of them (no `results` or `fits` array)".into(),
                )
            }
        },
        _ => return Err("neither a fit result nor a list of them".into()),
    };
    list.iter()
        .enumerate()
        .map(|(k, v)| FitResult::from_json(&v.to_string()).map_err(|e| format!("entry {k}: {e}")))
        .collect()
}

/// The file `furnace run` writes beside a sweep to record its inputs (not a fit).
pub const SWEEP_INPUTS_FILE: &str = "sweep-inputs.json";

/// The file `furnace run` writes beside a sweep with the best fits' and the LUTs' errors at the
/// off-grid check points (not a fit).
pub const OFF_GRID_FILE: &str = "off-grid.json";

/// The fits of a sweep file (`sweep.json`: summary `rows` and the approximants in `fits`), each
/// re-assessed on `data` — its pole certificate redone, not read from the file — with the
/// errors its row records on the table it was fitted to.
pub fn parse_sweep_file(text: &str, data: &FitData) -> std::result::Result<Vec<FitResult>, String> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let (Some(rows), Some(fits)) = (
        value.get("rows").and_then(|v| v.as_array()),
        value.get("fits").and_then(|v| v.as_array()),
    ) else {
        return Err("not a sweep file (no `rows` and `fits` arrays)".into());
    };
    if rows.len() != fits.len() {
        return Err(format!("{} rows but {} fits", rows.len(), fits.len()));
    }
    let mut out = Vec::with_capacity(fits.len());
    for (k, (row, fit)) in rows.iter().zip(fits).enumerate() {
        let approximant: Approximant =
            serde_json::from_value(fit.clone()).map_err(|e| format!("fit {k}: {e}"))?;
        approximant
            .validate()
            .map_err(|e| format!("fit {k}: {e}"))?;
        let form = match &approximant.denominator {
            None => Form::Polynomial {
                degree: approximant.numerator.degree(),
            },
            Some(q) => Form::Rational {
                numerator_degree: approximant.numerator.degree(),
                denominator_degree: q.degree(),
            },
        };
        let objective: Objective = row
            .get("objective")
            .and_then(|o| serde_json::from_value(o.clone()).ok())
            .unwrap_or_default();
        let mut result = FitResult::assess(
            form,
            approximant,
            data,
            objective,
            None,
            &CertifyOptions::default(),
        )
        .map_err(|e| format!("fit {k}: {e}"))?;
        // "as fitted": what the sweep measured on its own (full-size) table
        let number = |key: &str| row.get(key).and_then(|v| v.as_f64());
        if let Some(v) = number("mae") {
            result.metrics.mae = v;
        }
        if let Some(v) = number("rmse") {
            result.metrics.rmse = v;
        }
        if let Some(v) = number("max_abs_error") {
            result.metrics.max_abs_error = v;
        }
        if let Some(v) = number("max_rel_error") {
            result.metrics.max_rel_error = v;
        }
        out.push(result);
    }
    Ok(out)
}

/// Reads every fit of a model under `dir` (missing folder: no fits, no error): fit files
/// written by `furnace fit` / `furnace run` (a fit record or a bare fit result), lists of fit
/// results, and sweep files (`sweep.json`, assessed on `data`). A sweep's fit that is also in a
/// `best-<N>.json` of the same folder is listed once, under the best file's name.
pub fn load_fits(dir: &Path, data: &FitData) -> Result<FitFiles> {
    let mut out = FitFiles::default();
    if !dir.is_dir() {
        return Ok(out);
    }
    let mut files = Vec::new();
    json_files(dir, &mut files)?;
    let mut sweeps: Vec<(String, Vec<FitResult>)> = Vec::new();
    for path in files {
        let rel = path
            .strip_prefix(dir)
            .unwrap_or(&path)
            .to_string_lossy()
            .replace('\\', "/");
        if path
            .file_name()
            .is_some_and(|n| n == SWEEP_INPUTS_FILE || n == OFF_GRID_FILE)
        {
            continue;
        }
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        if let Ok(rec) = FitRecord::from_json(&text) {
            if rel == "default.json" {
                out.default = Some(out.fits.len());
            }
            out.fits.push(LoadedFit {
                source: rel,
                fit: rec.fit,
            });
            continue;
        }
        if let Ok(fits) = parse_sweep_file(&text, data) {
            sweeps.push((rel, fits));
            continue;
        }
        match parse_fit_file(&text) {
            Ok(fits) => {
                let many = fits.len() > 1;
                for (k, fit) in fits.into_iter().enumerate() {
                    if rel == "default.json" && !many {
                        out.default = Some(out.fits.len());
                    }
                    let source = if many {
                        format!("{rel}#{k}")
                    } else {
                        rel.clone()
                    };
                    out.fits.push(LoadedFit { source, fit });
                }
            }
            Err(e) => out.notes.push(format!("skipped `{rel}`: {e}")),
        }
    }
    for (rel, fits) in sweeps {
        let folder = rel.rsplit_once('/').map_or("", |(d, _)| d);
        for (k, fit) in fits.into_iter().enumerate() {
            let listed = out.fits.iter().any(|f| {
                f.source.rsplit_once('/').map_or("", |(d, _)| d) == folder
                    && f.fit.approximant == fit.approximant
            });
            if !listed {
                out.fits.push(LoadedFit {
                    source: format!("{rel}#{k}"),
                    fit,
                });
            }
        }
    }
    Ok(out)
}

/// Coefficients of the paper's degree-3 rational: 19 in 2-D, 39 in 3-D.
pub fn paper_coefficients(dim: usize) -> usize {
    if dim <= 2 {
        19
    } else {
        39
    }
}

/// The budget of `best-<N>.json`, if `source` is such a file at the top of the fits folder.
pub fn best_budget(source: &str) -> Option<usize> {
    source
        .strip_prefix("best-")?
        .strip_suffix(".json")?
        .parse()
        .ok()
}

/// The chosen fit (see the module docs), as an index into `files.fits`.
pub fn choose_fit(files: &FitFiles, dim: usize, measured: &[Measured]) -> Option<usize> {
    if files.default.is_some() {
        return files.default;
    }
    let budget = paper_coefficients(dim);
    // the sweep's best within the smallest budget that holds the paper's fit
    let best_file = files
        .fits
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            best_budget(&f.source)
                .filter(|&b| b >= budget && f.fit.is_usable())
                .map(|b| (b, k))
        })
        .min();
    if let Some((_, k)) = best_file {
        return Some(k);
    }
    let best = |within: bool| {
        files
            .fits
            .iter()
            .enumerate()
            .filter(|(k, f)| {
                f.fit.is_usable()
                    && measured[*k].max_abs.is_finite()
                    && (!within || f.fit.n_coefficients <= budget)
            })
            .min_by(|(a, _), (b, _)| {
                measured[*a]
                    .max_abs
                    .total_cmp(&measured[*b].max_abs)
                    .then(a.cmp(b))
            })
            .map(|(k, _)| k)
    };
    best(true).or_else(|| best(false))
}

/// Error of an albedo source against a table, measured at every node.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measured {
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub mae: f64,
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub max_abs: f64,
    /// Where the largest error is (table axes).
    pub max_abs_at: Vec<f64>,
    /// max |f − E|/|E| over nodes with |E| ≥ 1e-6.
    #[serde(with = "crate::fit::metrics::finite_or_string")]
    pub max_rel: f64,
    pub points: usize,
}

/// Measures `source` at every node of `table` (sequential, compensated sums: reproducible).
/// Non-finite values make every statistic infinite.
pub fn measure(source: &dyn Albedo, table: &Table) -> Measured {
    let spec = &table.spec;
    let mut x = vec![0.0; spec.axes.len()];
    let mut sum = CompensatedSum::default();
    let mut m = Measured {
        mae: 0.0,
        max_abs: 0.0,
        max_abs_at: vec![],
        max_rel: 0.0,
        points: table.cells(),
    };
    let mut bad = false;
    for (cell, &y) in table.output(0).iter().enumerate() {
        spec.point(cell, &mut x);
        let e = (source.albedo(&x) - y).abs();
        if !e.is_finite() {
            bad = true;
            continue;
        }
        sum.add(e);
        if e > m.max_abs || m.max_abs_at.is_empty() {
            m.max_abs = e;
            m.max_abs_at = x.clone();
        }
        if y.abs() >= crate::fit::metrics::RELATIVE_ERROR_FLOOR {
            m.max_rel = m.max_rel.max(e / y.abs());
        }
    }
    m.mae = sum.value() / table.cells().max(1) as f64;
    if bad {
        m.mae = f64::INFINITY;
        m.max_abs = f64::INFINITY;
        m.max_rel = f64::INFINITY;
    }
    m
}

/// The paper's fit of a furnace model, if it has one: which published table, and the furnace
/// model in the paper's convention (radiance-form transmission for dielectrics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperLink {
    pub paper: PaperModel,
    /// Stem of the paper's coefficient and table files (`conductors`, …).
    pub stem: &'static str,
    /// The model whose table the paper's fit approximates.
    pub model: ModelId,
}

/// The paper's fit of `model` (one of [`PAPER_PAIRS`]), if any. The paper uses the separable
/// Smith G and tabulates transmission in radiance form.
pub fn paper_link(model: ModelId) -> Option<PaperLink> {
    PAPER_PAIRS
        .iter()
        .find(|p| p.model == model.energy_form())
        .map(|p| PaperLink {
            paper: p.paper,
            stem: p.paper_name,
            model: p.table_model(),
        })
}

/// The paper's published fit as a [`FitResult`] measured on its own 32-point table (so its
/// `metrics` are the paper's own numbers), from `paper_dir`.
pub fn load_paper_fit(paper_dir: &Path, link: &PaperLink) -> Result<FitResult> {
    let coefficients = paper_dir
        .join("coefficients")
        .join(format!("{}.csv", link.stem));
    let table = paper_dir.join("tables").join(format!("{}.csv", link.stem));
    let data = crate::fit::paper::load_table(&table, link.paper)?;
    Ok(crate::fit::paper::published_fit(
        &coefficients,
        link.paper,
        &data,
    )?)
}

/// A fit as an albedo source for a model with axes `axes`.
pub fn fit_albedo(fit: &FitResult, axes: &[String]) -> Result<FitAlbedo> {
    FitAlbedo::new(fit, axes)
}

/// One benchmark plot read from a CSV file.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchPlot {
    pub stem: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_log: bool,
    pub y_log: bool,
    /// (series, x, y) in file order.
    pub rows: Vec<(String, f64, f64)>,
    /// One label per row (e.g. "order 12", "degree 3"), empty if the file has no label column.
    pub labels: Vec<String>,
    /// `# note:` lines: how and where the numbers were measured.
    pub notes: Vec<String>,
}

impl BenchPlot {
    /// An empty plot to fill.
    pub fn new(
        stem: &str,
        title: &str,
        x_label: &str,
        x_log: bool,
        y_label: &str,
        y_log: bool,
    ) -> BenchPlot {
        BenchPlot {
            stem: stem.into(),
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_log,
            y_log,
            rows: Vec::new(),
            labels: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// Adds a point with a label.
    pub fn push(&mut self, series: &str, x: f64, y: f64, label: &str) {
        self.rows.push((series.into(), x, y));
        self.labels.push(label.into());
    }

    fn has_labels(&self) -> bool {
        self.labels.iter().any(|l| !l.is_empty())
    }

    /// The CSV form [`parse_bench_csv`] reads (for benchmark commands to write).
    pub fn to_csv(&self) -> String {
        let log = |l: &str, on: bool| {
            if on {
                format!("{l} (log)")
            } else {
                l.to_string()
            }
        };
        let clean = |s: &str| s.replace([',', '\n'], ";");
        let mut s = format!(
            "# title: {}\n# x: {}\n# y: {}\n",
            self.title,
            log(&self.x_label, self.x_log),
            log(&self.y_label, self.y_log)
        );
        for n in &self.notes {
            s.push_str(&format!("# note: {}\n", n.replace('\n', " ")));
        }
        let labelled = self.has_labels();
        s.push_str(if labelled {
            "series,x,y,label\n"
        } else {
            "series,x,y\n"
        });
        for (k, (series, x, y)) in self.rows.iter().enumerate() {
            s.push_str(&format!("{},{x},{y}", clean(series)));
            if labelled {
                s.push_str(&format!(
                    ",{}",
                    clean(self.labels.get(k).map_or("", |l| l.as_str()))
                ));
            }
            s.push('\n');
        }
        s
    }
}

/// Parses a benchmark CSV (see the module docs).
pub fn parse_bench_csv(stem: &str, text: &str) -> std::result::Result<BenchPlot, String> {
    let mut plot = BenchPlot::new(stem, &stem.replace(['-', '_'], " "), "", false, "", false);
    let mut header: Option<Vec<String>> = None;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            let c = c.trim();
            if let Some(t) = c.strip_prefix("title:") {
                plot.title = t.trim().into();
            } else if let Some(t) = c.strip_prefix("x:") {
                plot.x_label = t.trim().into();
            } else if let Some(t) = c.strip_prefix("y:") {
                plot.y_label = t.trim().into();
            } else if let Some(t) = c.strip_prefix("note:") {
                plot.notes.push(t.trim().into());
            }
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(|s| s.trim()).collect();
        let Some(h) = &header else {
            if cells.len() != 3 && cells.len() != 4 {
                return Err(format!("line {}: the header must have three columns (series,x,y) or four (series,x,y,label), found {}", n + 1, cells.len()));
            }
            header = Some(cells.iter().map(|s| s.to_string()).collect());
            continue;
        };
        if cells.len() != h.len() {
            return Err(format!(
                "line {}: expected {} values, found {}",
                n + 1,
                h.len(),
                cells.len()
            ));
        }
        let num = |s: &str, what: &str| -> std::result::Result<f64, String> {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("line {}: {what} '{s}' is not a finite number", n + 1))
        };
        plot.push(
            cells[0],
            num(cells[1], "x")?,
            num(cells[2], "y")?,
            cells.get(3).copied().unwrap_or(""),
        );
    }
    let header = header.ok_or("no header line (series,x,y)")?;
    if plot.x_label.is_empty() {
        plot.x_label = header[1].clone();
    }
    if plot.y_label.is_empty() {
        plot.y_label = header[2].clone();
    }
    for (label, log) in [
        (&mut plot.x_label, &mut plot.x_log),
        (&mut plot.y_label, &mut plot.y_log),
    ] {
        if let Some(l) = label.strip_suffix("(log)") {
            *label = l.trim().to_string();
            *log = true;
        }
    }
    if plot.rows.is_empty() {
        return Err("no data rows".into());
    }
    Ok(plot)
}

/// Reads every `*.csv` in `dir` (sorted); missing folder → none. Unreadable files become notes.
pub fn load_bench(dir: &Path) -> Result<(Vec<BenchPlot>, Vec<String>)> {
    let mut plots = Vec::new();
    let mut notes = Vec::new();
    if !dir.is_dir() {
        return Ok((plots, notes));
    }
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    paths.sort();
    for p in paths {
        let stem = p
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
        match parse_bench_csv(&stem, &text) {
            Ok(b) => plots.push(b),
            Err(e) => notes.push(format!(
                "skipped `{}`: {e}",
                p.file_name()
                    .map(|s| s.to_string_lossy().to_string())
                    .unwrap_or_default()
            )),
        }
    }
    Ok((plots, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_csv_parses_labels_and_log_axes() {
        let text = "# title: Evaluation cost\n# x: ns per call (log)\n# y: max error (log)\nseries,ns,err\nfit a,1.5,1e-3\nLUT,2,2e-4\n";
        let b = parse_bench_csv("eval", text).unwrap();
        assert_eq!(b.title, "Evaluation cost");
        assert_eq!(
            (b.x_label.as_str(), b.x_log, b.y_log),
            ("ns per call", true, true)
        );
        assert_eq!(
            b.rows,
            vec![("fit a".into(), 1.5, 1e-3), ("LUT".into(), 2.0, 2e-4)]
        );
        let b = parse_bench_csv("t", "series,order,seconds\na,1,2\n").unwrap();
        assert_eq!(
            (b.x_label.as_str(), b.y_label.as_str(), b.x_log),
            ("order", "seconds", false)
        );
        assert!(parse_bench_csv("t", "series,x,y\na,1,nan\n")
            .unwrap_err()
            .contains("line 2"));
        assert!(parse_bench_csv("t", "series,x\n").is_err());
        let b = parse_bench_csv("eval", text).unwrap();
        assert_eq!(parse_bench_csv("eval", &b.to_csv()).unwrap(), b);
        // labels and notes round-trip
        let mut b = BenchPlot::new("fit", "Fit time", "s", true, "max error", true);
        b.notes.push("2 cores, load average 3.1".into());
        b.push("rational", 0.5, 1e-3, "degree 3");
        b.push("rational, sqrt", 1.5, 2e-4, "degree 4");
        let back = parse_bench_csv("fit", &b.to_csv()).unwrap();
        assert_eq!(back.labels, vec!["degree 3", "degree 4"]);
        assert_eq!(back.rows[1].0, "rational; sqrt");
        assert_eq!(back.notes, b.notes);
        assert!(parse_bench_csv("t", "series,x,y,label\na,1,2\n")
            .unwrap_err()
            .contains("expected 4"));
    }

    #[test]
    fn fit_files_may_hold_lists() {
        assert!(parse_fit_file("{\"results\": []}").unwrap().is_empty());
        assert!(parse_fit_file("[1]").unwrap_err().contains("entry 0"));
        assert!(parse_fit_file("{\"x\": 1}").is_err());
    }
}
