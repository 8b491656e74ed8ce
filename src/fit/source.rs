//! Where fit data comes from: a furnace table (computed or cached), or a user's table in CSV,
//! EXR or JSON, turned into [`FitData`] with a record of its provenance ([`Source`]).
//!
//! User file formats (`furnace fit --table FILE`):
//! - **furnace table**: a table stem (`data/<model>/<res>`), or its `.json` sidecar; values are
//!   the exact f64 file checked against the sidecar ([`io::load_any`]).
//! - **CSV**: a header naming the variables (1–3 columns, any names) and a value column (`E`
//!   unless `channel` says otherwise), one point per row; points may be scattered. The domain is
//!   the points' bounding box unless `axes` gives `name=lo:hi`.
//! - **EXR**: furnace's layout (see [`crate::table`]): one image `n_last` wide and the product
//!   of the other counts tall, row = flattened index of the other axes, one f32 channel per
//!   output. The axes come from a furnace sidecar next to the file (`<stem>.json`) or from
//!   `axes` (`name=lo:hi[:n]`, nodes lo + (hi − lo)·i/(n − 1), endpoints included).
//! - **JSON grid**: `{"axes": [{"name": "r", "nodes": [...]}, ...], "values": [...]}`, values
//!   row-major with the last axis fastest.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::data::{FitData, MAX_DIM, MAX_VALUE};
use crate::error::{Error, Result};
use crate::table::io::{self, Sidecar};
use crate::table::{GridAxis, Table, TableSpec};

/// The furnace table a fit was fitted to: enough to find it in the cache or compute it again
/// (at any size, for LUTs), and to measure emitted code on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableRef {
    /// The cached table's path without extension (see `table::io::table_stem`).
    pub stem: PathBuf,
    /// Its content hash (the cache key: [`TableSpec::content_hash`]).
    pub content_hash: String,
    /// Everything that determines its values.
    pub spec: TableSpec,
}

impl TableRef {
    pub fn new(stem: &Path, spec: &TableSpec) -> TableRef {
        TableRef {
            stem: stem.to_path_buf(),
            content_hash: spec.content_hash(),
            spec: spec.clone(),
        }
    }

    /// Whether this furnace computes the same table from the spec: the content hash covers the
    /// quadrature engine's version, so a table of another engine version is not the one fitted.
    pub fn is_current(&self) -> bool {
        self.spec.content_hash() == self.content_hash
    }
}

/// Refuse user tables with more points than this before allocating their coordinates
/// (the same limit as point files).
pub const MAX_FIT_POINTS: usize = crate::table::points::MAX_POINTS;

/// Provenance of fitted data, recorded in every fit file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Source {
    /// `furnace_table`, `csv`, `exr`, `json_grid` or `paper_table`.
    pub kind: String,
    /// The furnace model the table was computed from, if any.
    pub model: Option<String>,
    /// The file read, if the data came from a file given by the user.
    pub path: Option<String>,
    /// The table's content hash (furnace tables: the cache key of its spec, see
    /// [`crate::table::TableSpec::content_hash`]; files: SHA-256 of the file's bytes).
    pub content_hash: String,
    /// Nodes per axis for grids; None for scattered points.
    pub resolution: Option<Vec<usize>>,
    /// The output that was fitted (`E`, `E_R`, `E_T`, or an EXR/CSV column name).
    pub channel: String,
    /// Number of data points (table nodes or CSV rows) used: inside `restricted_to`, if set.
    pub points: usize,
    /// The sub-box of the table's domain the fit was restricted to (`--domain`), if any.
    pub restricted_to: Option<Vec<(f64, f64)>>,
}

/// Data to fit and where it came from. `grid` holds the axis nodes when the data is a tensor
/// grid (then it can be downsampled node-wise).
#[derive(Clone, Debug)]
pub struct FitInput {
    pub data: FitData,
    pub source: Source,
    pub grid: Option<Vec<Vec<f64>>>,
    /// The furnace table the data is, if it is one (carried into the fit file).
    pub table: Option<TableRef>,
}

/// How a fit's data was reduced before solving (metrics are always on all points).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedOn {
    /// Points the solver saw.
    pub points: usize,
    /// In words: all points, which nodes of a grid, or which random subset.
    pub selection: String,
}

/// Node indices 0 = i_0 < i_1 < … < i_{m−1} = n − 1, i_j = round(j (n − 1)/(m − 1)): an
/// (almost) even subset of a grid axis that keeps both endpoints.
pub fn even_indices(n: usize, m: usize) -> Vec<usize> {
    if m >= n || n < 2 {
        return (0..n).collect();
    }
    let m = m.max(2);
    (0..m)
        .map(|j| ((j * (n - 1)) as f64 / (m - 1) as f64).round() as usize)
        .collect()
}

/// Node indices 0 = i_0 < i_1 < … < i_{m−1} = n − 1 graded towards the axis's low end:
/// i_j = round((n − 1)·(j/(m − 1))^p), raised where needed to stay strictly increasing and
/// lowered to leave room for the indices after it. p = 1 is [`even_indices`]; p > 1 keeps
/// every node of the first cells (where an albedo's grazing or low-roughness layer is) and
/// thins the rest.
pub fn graded_indices(n: usize, m: usize, p: f64) -> Vec<usize> {
    if m >= n || n < 2 {
        return (0..n).collect();
    }
    if !(p.is_finite() && p > 1.0) {
        return even_indices(n, m);
    }
    let m = m.max(2);
    let mut out: Vec<usize> = Vec::with_capacity(m);
    for j in 0..m {
        let t = j as f64 / (m - 1) as f64;
        let mut i = ((n - 1) as f64 * t.powf(p)).round() as usize;
        if let Some(&last) = out.last() {
            i = i.max(last + 1);
        }
        out.push(i.min(n - m + j));
    }
    out
}

impl FitInput {
    /// Variable names.
    pub fn names(&self) -> &[String] {
        &self.data.names
    }

    /// The data inside a sub-box (`name=lo:hi` for some variables; the others keep their
    /// domain), whose domain becomes the fit's domain: poles are excluded and metrics measured
    /// there only. E.g. r ≥ 0.035, μ ≥ 0.02, where the paper's tables start, leaves out the
    /// corner r = μ = 0 at which albedos are discontinuous.
    pub fn restrict(&self, bounds: &[AxisDecl]) -> Result<FitInput> {
        let d = self.data.dim();
        let mut domain = self.data.domain.clone();
        for b in bounds {
            let k = self
                .data
                .names
                .iter()
                .position(|n| *n == b.name)
                .ok_or_else(|| {
                    Error::InvalidInput(format!(
                        "--domain names '{}', which is not a variable of the data ({})",
                        b.name,
                        self.data.names.join(", ")
                    ))
                })?;
            let (lo, hi) = self.data.domain[k];
            if b.lo < lo || b.hi > hi {
                return Err(Error::InvalidInput(format!(
                    "--domain {}={}:{} reaches outside the data's domain [{lo}, {hi}]; give a sub-box",
                    b.name, b.lo, b.hi
                )));
            }
            domain[k] = (b.lo, b.hi);
        }
        let inside = |x: &[f64]| {
            x.iter()
                .zip(&domain)
                .all(|(v, (lo, hi))| v >= lo && v <= hi)
        };
        let (mut coords, mut values) = (Vec::new(), Vec::new());
        for i in 0..self.data.len() {
            if inside(self.data.point(i)) {
                coords.extend_from_slice(self.data.point(i));
                values.push(self.data.values[i]);
            }
        }
        if values.is_empty() {
            return Err(Error::InvalidInput(
                "--domain leaves no data point; widen it".into(),
            ));
        }
        let grid = self.grid.as_ref().map(|axes| {
            axes.iter()
                .zip(&domain)
                .map(|(a, (lo, hi))| {
                    a.iter()
                        .copied()
                        .filter(|v| v >= lo && v <= hi)
                        .collect::<Vec<f64>>()
                })
                .collect::<Vec<_>>()
        });
        let data = FitData::new(self.data.names.clone(), coords, values, domain.clone())?;
        let mut source = self.source.clone();
        source.points = data.len();
        source.restricted_to = Some(domain);
        debug_assert!(grid
            .as_ref()
            .is_none_or(
                |g| g.iter().map(Vec::len).product::<usize>() == data.len() && g.len() == d
            ));
        Ok(FitInput {
            data,
            source,
            grid,
            table: self.table.clone(),
        })
    }

    /// At most `max_points` of the data for solving, deterministically: a grid keeps an even
    /// subset of nodes per axis ([`even_indices`], endpoints kept, the same count on every axis
    /// that has more than that), scattered data a pseudo-random subset
    /// ([`FitData::subsample`]). `None`: the data is already small enough.
    pub fn reduced(&self, max_points: usize) -> Result<Option<(FitData, FittedOn)>> {
        self.reduced_graded(max_points, &[])
    }

    /// [`FitInput::reduced`] with the nodes of a grid's axis k graded towards its low end by
    /// the exponent `grading[k]` ([`graded_indices`]; 1 or a missing entry: even). Scattered
    /// data ignores the grading.
    pub fn reduced_graded(
        &self,
        max_points: usize,
        grading: &[f64],
    ) -> Result<Option<(FitData, FittedOn)>> {
        let n = self.data.len();
        if max_points == 0 || n <= max_points {
            return Ok(None);
        }
        let Some(axes) = &self.grid else {
            let sub = self.data.subsample(max_points)?;
            let on = FittedOn {
                points: sub.len(),
                selection: format!("deterministic pseudo-random subset of {} of the {n} points (SplitMix64 selection sampling)", sub.len()),
            };
            return Ok(Some((sub, on)));
        };
        // largest per-axis cap m with Π min(n_k, m) ≤ max_points
        let counts: Vec<usize> = axes.iter().map(Vec::len).collect();
        let total = |m: usize| counts.iter().map(|&c| c.min(m)).product::<usize>();
        let mut m = counts.iter().copied().max().unwrap_or(2);
        while m > 2 && total(m) > max_points {
            m -= 1;
        }
        let power = |k: usize| grading.get(k).copied().unwrap_or(1.0);
        let picks: Vec<Vec<usize>> = counts
            .iter()
            .enumerate()
            .map(|(k, &c)| graded_indices(c, m, power(k)))
            .collect();
        let sub_axes: Vec<Vec<f64>> = picks
            .iter()
            .zip(axes)
            .map(|(p, a)| p.iter().map(|&i| a[i]).collect())
            .collect();
        let d = counts.len();
        let sub_n: usize = picks.iter().map(Vec::len).product();
        let mut values = Vec::with_capacity(sub_n);
        let mut idx = vec![0usize; d];
        for _ in 0..sub_n {
            let mut flat = 0;
            for k in 0..d {
                flat = flat * counts[k] + picks[k][idx[k]];
            }
            values.push(self.data.values[flat]);
            for k in (0..d).rev() {
                idx[k] += 1;
                if idx[k] < picks[k].len() {
                    break;
                }
                idx[k] = 0;
            }
        }
        let mut sub = FitData::from_grid(self.data.names.clone(), &sub_axes, values)?;
        sub.domain = self.data.domain.clone();
        let shape = picks
            .iter()
            .map(|p| p.len().to_string())
            .collect::<Vec<_>>()
            .join("x");
        let nodes = counts
            .iter()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join("x");
        let graded: Vec<String> = (0..d)
            .filter(|&k| power(k) > 1.0 && counts[k] > m)
            .map(|k| format!("{} ^{}", self.data.names[k], power(k)))
            .collect();
        let selection = if graded.is_empty() {
            format!("table downsampled to {shape} of its {nodes} nodes: node indices round(j·(n−1)/(m−1)) on each axis, endpoints kept")
        } else {
            format!(
                "table downsampled to {shape} of its {nodes} nodes: node indices round((n−1)·(j/(m−1))^p) on each axis, graded towards the low end ({}; p = 1 elsewhere), endpoints kept",
                graded.join(", ")
            )
        };
        let on = FittedOn {
            points: sub.len(),
            selection,
        };
        Ok(Some((sub, on)))
    }
}

/// The `channel` output of a furnace table as fit data.
pub fn from_table(table: &Table, channel: &str, stem: Option<&Path>) -> Result<FitInput> {
    let o = table.output_index(channel).ok_or_else(|| {
        Error::InvalidInput(format!(
            "table of {} has no output '{channel}'; its outputs are {} (choose one with --channel)",
            table.spec.model,
            table.spec.outputs.join(", ")
        ))
    })?;
    let axes: Vec<Vec<f64>> = table.spec.axes.iter().map(GridAxis::nodes).collect();
    let names = table.spec.axes.iter().map(|a| a.name.clone()).collect();
    let values = table.output(o).to_vec();
    check_values(
        &values,
        |i| format!("cell {i}"),
        &stem
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from(&table.spec.model)),
    )?;
    let mut data = FitData::from_grid(names, &axes, values)?;
    data.domain = table.spec.axes.iter().map(|a| (a.lo, a.hi)).collect();
    data.validate()?;
    Ok(FitInput {
        source: Source {
            kind: "furnace_table".into(),
            model: Some(table.spec.model.clone()),
            path: stem.map(|p| p.display().to_string()),
            content_hash: table.spec.content_hash(),
            resolution: Some(table.spec.axes.iter().map(|a| a.n).collect()),
            channel: channel.into(),
            points: data.len(),
            restricted_to: None,
        },
        data,
        grid: Some(axes),
        table: stem.map(|p| TableRef::new(p, &table.spec)),
    })
}

/// A user-declared axis: `name=lo:hi` or `name=lo:hi:n`.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisDecl {
    pub name: String,
    pub lo: f64,
    pub hi: f64,
    pub n: Option<usize>,
}

/// Parses `r=0:1,mu=0:1` / `f0=0.0125:0.25:32,r=0:1:32,mu=0:1:32`.
pub fn parse_axes(text: &str) -> Result<Vec<AxisDecl>> {
    let bad = |part: &str, why: &str| {
        Error::InvalidInput(format!("--axes '{text}': '{part}' {why}; write name=lo:hi or name=lo:hi:n, comma separated (e.g. r=0:1,mu=0:1)"))
    };
    let mut out: Vec<AxisDecl> = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, range) = part
            .split_once('=')
            .ok_or_else(|| bad(part, "has no '='"))?;
        let name = name.trim();
        if name.is_empty() {
            return Err(bad(part, "has no axis name"));
        }
        if out.iter().any(|a| a.name == name) {
            return Err(bad(part, "repeats an axis"));
        }
        let fields: Vec<&str> = range.split(':').map(str::trim).collect();
        if !(2..=3).contains(&fields.len()) {
            return Err(bad(part, "needs 2 or 3 ':'-separated fields"));
        }
        let num = |s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(part, "has a bound that is not a finite number"))
        };
        let (lo, hi) = (num(fields[0])?, num(fields[1])?);
        if !(lo < hi) {
            return Err(bad(part, "needs lo < hi"));
        }
        let n = match fields.get(2) {
            Some(s) => Some(
                s.parse::<usize>()
                    .ok()
                    .filter(|&n| n >= 2)
                    .ok_or_else(|| bad(part, "needs a node count n ≥ 2"))?,
            ),
            None => None,
        };
        out.push(AxisDecl {
            name: name.to_string(),
            lo,
            hi,
            n,
        });
    }
    if out.is_empty() || out.len() > MAX_DIM {
        return Err(Error::InvalidInput(format!(
            "--axes '{text}' declares {} axes; a fit needs 1 to {MAX_DIM}",
            out.len()
        )));
    }
    Ok(out)
}

/// Options for reading a user's table.
#[derive(Clone, Debug, Default)]
pub struct UserTableOptions {
    /// The value column / channel / output to fit (default `E`).
    pub channel: Option<String>,
    /// Axes for an EXR without sidecar, or the domain of CSV points.
    pub axes: Option<Vec<AxisDecl>>,
}

fn sha256_file(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    Ok(crate::digest::sha256_hex(&bytes))
}

/// Rejects NaN / infinite values and values beyond ±[`MAX_VALUE`], naming the first one.
fn check_values(values: &[f64], name: impl Fn(usize) -> String, path: &Path) -> Result<()> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(Error::file(
            path,
            format!(
                "{} is {}, not a finite number; repair or drop it before fitting",
                name(i),
                values[i]
            ),
        ));
    }
    if let Some(i) = values.iter().position(|v| v.abs() > MAX_VALUE) {
        return Err(Error::file(path, too_large(&name(i), values[i])));
    }
    Ok(())
}

/// Why a value beyond ±[`MAX_VALUE`] is refused, and the fix.
fn too_large(what: &str, value: f64) -> String {
    format!("{what} is {value:e}, beyond the largest magnitude a fit accepts, ±{MAX_VALUE:e}: the squared errors of such values overflow f64; rescale the values (e.g. divide them by their largest magnitude) before fitting")
}

fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Reads a user's table (see the module docs for the formats).
pub fn load_user_table(path: &Path, opts: &UserTableOptions) -> Result<FitInput> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("csv") => load_csv(path, opts),
        Some("exr") => load_exr(path, opts),
        Some("json") => {
            let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
            if serde_json::from_str::<Sidecar>(&text).is_ok() {
                load_furnace(&path.with_extension(""), opts)
            } else {
                load_json_grid(path, &text, opts)
            }
        }
        Some("f64") => load_furnace(&path.with_extension(""), opts),
        _ if with_ext(path, "json").exists() => load_furnace(path, opts),
        _ => Err(Error::file(
            path,
            "not a table furnace can read: give a furnace table stem or .json sidecar, a .csv with a header (variables and E), an .exr, or a .json grid",
        )),
    }
}

fn load_furnace(stem: &Path, opts: &UserTableOptions) -> Result<FitInput> {
    let table = io::load_any(stem)?;
    from_table(&table, opts.channel.as_deref().unwrap_or("E"), Some(stem))
}

fn load_csv(path: &Path, opts: &UserTableOptions) -> Result<FitInput> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let channel = opts.channel.clone().unwrap_or_else(|| "E".into());
    let (names, coords, values) =
        parse_csv_table(&text, &channel).map_err(|m| Error::file(path, m))?;
    let d = names.len();
    let n = values.len();
    let domain: Vec<(f64, f64)> = match &opts.axes {
        Some(decl) => names
            .iter()
            .map(|name| {
                decl.iter().find(|a| &a.name == name).map(|a| (a.lo, a.hi)).ok_or_else(|| {
                    Error::InvalidInput(format!("--axes does not give the domain of column '{name}'; declare every variable or none"))
                })
            })
            .collect::<Result<_>>()?,
        None => (0..d)
            .map(|k| coords.iter().skip(k).step_by(d).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x))))
            .collect(),
    };
    if let Some(decl) = &opts.axes {
        if let Some(extra) = decl.iter().find(|a| !names.contains(&a.name)) {
            return Err(Error::InvalidInput(format!(
                "--axes names '{}', which is not a column of {}",
                extra.name,
                path.display()
            )));
        }
        for i in 0..n {
            for k in 0..d {
                let x = coords[i * d + k];
                let (lo, hi) = domain[k];
                if x < lo || x > hi {
                    return Err(Error::file(path, format!("row {}, column '{}': {x} is outside the domain [{lo}, {hi}] given by --axes", i + 2, names[k])));
                }
            }
        }
    }
    let data = FitData::new(names, coords, values, domain)
        .map_err(|e| Error::file(path, e.to_string()))?;
    Ok(FitInput {
        source: Source {
            kind: "csv".into(),
            model: None,
            path: Some(path.display().to_string()),
            content_hash: sha256_file(path)?,
            resolution: None,
            channel,
            points: n,
            restricted_to: None,
        },
        data,
        grid: None,
        table: None,
    })
}

/// Variable names, row-major coordinates and values of a CSV table.
pub type CsvTable = (Vec<String>, Vec<f64>, Vec<f64>);

/// Parses a CSV table: header = variables + the value column `channel`. Errors name the row
/// (1-based, header = row 1) and the column.
pub fn parse_csv_table(text: &str, channel: &str) -> std::result::Result<CsvTable, String> {
    let text = crate::table::points::strip_bom(text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, head)) = lines.next() else {
        return Err(format!("empty file; expected a header naming the variables and the value column '{channel}', e.g. r,mu,{channel}"));
    };
    let header: Vec<String> = head.split(',').map(|s| s.trim().to_string()).collect();
    for (c, name) in header.iter().enumerate() {
        if name.is_empty() {
            return Err(format!("header column {} has no name", c + 1));
        }
        if header[..c].contains(name) {
            return Err(format!("column '{name}' appears twice in the header"));
        }
    }
    let vcol = header.iter().position(|h| h == channel).ok_or_else(|| {
        format!("the header ({}) has no value column '{channel}'; add it or choose the column with --channel", header.join(","))
    })?;
    let vars: Vec<usize> = (0..header.len()).filter(|&c| c != vcol).collect();
    if vars.is_empty() || vars.len() > MAX_DIM {
        return Err(format!(
            "{} variable columns besides '{channel}'; a fit needs 1 to {MAX_DIM}",
            vars.len()
        ));
    }
    let names: Vec<String> = vars.iter().map(|&c| header[c].clone()).collect();
    let (mut coords, mut values) = (Vec::new(), Vec::new());
    for (line_no, line) in lines {
        if values.len() >= MAX_FIT_POINTS {
            return Err(format!(
                "more than {MAX_FIT_POINTS} rows; subsample the table first"
            ));
        }
        let row = line_no + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != header.len() {
            return Err(format!(
                "row {row}: {} values for {} columns",
                cells.len(),
                header.len()
            ));
        }
        let num = |c: usize| -> std::result::Result<f64, String> {
            let v: f64 = cells[c].parse().map_err(|_| {
                format!(
                    "row {row}, column '{}': '{}' is not a number",
                    header[c], cells[c]
                )
            })?;
            if !v.is_finite() {
                return Err(format!(
                    "row {row}, column '{}': {v} is not a finite number; repair or drop the row",
                    header[c]
                ));
            }
            Ok(v)
        };
        for &c in &vars {
            coords.push(num(c)?);
        }
        let v = num(vcol)?;
        if v.abs() > MAX_VALUE {
            return Err(too_large(&format!("row {row}, column '{channel}'"), v));
        }
        values.push(v);
    }
    if values.is_empty() {
        return Err("no data rows after the header".into());
    }
    Ok((names, coords, values))
}

fn load_exr(path: &Path, opts: &UserTableOptions) -> Result<FitInput> {
    let (width, height, channels) = io::read_exr_image(path)?;
    let channel = opts.channel.clone().unwrap_or_else(|| "E".into());
    let Some((_, samples)) = channels.iter().find(|(n, _)| *n == channel) else {
        let names = channels
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(", ");
        return Err(Error::file(
            path,
            format!("no channel '{channel}'; the image has {names} (choose one with --channel)"),
        ));
    };
    let stem = path.with_extension("");
    let sidecar_path = with_ext(&stem, "json");
    let axes: Vec<GridAxis> = if let Some(decl) = &opts.axes {
        exr_axes_from_decl(decl, width, height).map_err(|m| Error::file(path, m))?
    } else if sidecar_path.exists() {
        let text =
            std::fs::read_to_string(&sidecar_path).map_err(|e| Error::io(&sidecar_path, e))?;
        let sc: Sidecar = serde_json::from_str(&text).map_err(|e| {
            Error::file(
                &sidecar_path,
                format!("not a furnace table sidecar: {e}; pass --axes instead"),
            )
        })?;
        sc.axes
    } else {
        return Err(Error::file(
            path,
            format!("has no furnace sidecar ({}); declare its axes with --axes, e.g. --axes r=0:1,mu=0:1 for a {width}x{height} image (last axis along x)", sidecar_path.display()),
        ));
    };
    let counts: Vec<usize> = axes.iter().map(|a| a.n).collect();
    let last = *counts.last().unwrap_or(&0);
    let rows: usize = counts[..counts.len().saturating_sub(1)].iter().product();
    if last != width || rows != height {
        return Err(Error::file(
            path,
            format!("image is {width}x{height} but the axes {} need {last} wide and {rows} tall (last axis along x, the others flattened along y)", counts.iter().map(|c| c.to_string()).collect::<Vec<_>>().join("x")),
        ));
    }
    let values: Vec<f64> = samples.iter().map(|&v| v as f64).collect();
    check_values(
        &values,
        |i| {
            format!(
                "pixel (x {}, y {}) of channel '{channel}'",
                i % width,
                i / width
            )
        },
        path,
    )?;
    let nodes: Vec<Vec<f64>> = axes.iter().map(GridAxis::nodes).collect();
    let names = axes.iter().map(|a| a.name.clone()).collect();
    let mut data =
        FitData::from_grid(names, &nodes, values).map_err(|e| Error::file(path, e.to_string()))?;
    data.domain = axes.iter().map(|a| (a.lo, a.hi)).collect();
    Ok(FitInput {
        source: Source {
            kind: "exr".into(),
            model: None,
            path: Some(path.display().to_string()),
            content_hash: sha256_file(path)?,
            resolution: Some(counts),
            channel,
            points: data.len(),
            restricted_to: None,
        },
        data,
        grid: Some(nodes),
        table: None,
    })
}

/// Grid axes of an EXR from `name=lo:hi[:n]`: the last axis has `width` nodes; the first ones
/// multiply to `height` (a single unknown count is inferred).
fn exr_axes_from_decl(
    decl: &[AxisDecl],
    width: usize,
    height: usize,
) -> std::result::Result<Vec<GridAxis>, String> {
    let d = decl.len();
    let mut counts: Vec<Option<usize>> = decl.iter().map(|a| a.n).collect();
    match counts[d - 1] {
        Some(n) if n != width => {
            return Err(format!(
                "--axes gives {} nodes for the last axis '{}' but the image is {width} wide",
                n,
                decl[d - 1].name
            ))
        }
        _ => counts[d - 1] = Some(width),
    }
    let known: usize = counts[..d - 1].iter().flatten().product();
    let unknown: Vec<usize> = (0..d - 1).filter(|&k| counts[k].is_none()).collect();
    match unknown.as_slice() {
        [] => {}
        [k] if known > 0 && height.is_multiple_of(known) => counts[*k] = Some(height / known),
        [_] => return Err(format!("the image height {height} is not a multiple of the given node counts ({known})")),
        _ => return Err(format!("give the node count of all but one of the first {} axes (name=lo:hi:n): the image height {height} is their product", d - 1)),
    }
    if d == 1 && height != 1 {
        return Err(format!(
            "a 1-variable table must be one row tall, the image is {height} rows"
        ));
    }
    Ok(decl
        .iter()
        .zip(&counts)
        .map(|(a, n)| GridAxis::new(&a.name, a.lo, a.hi, n.unwrap_or(2)))
        .collect())
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonGridAxis {
    name: String,
    nodes: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonGrid {
    axes: Vec<JsonGridAxis>,
    values: Vec<f64>,
}

fn load_json_grid(path: &Path, text: &str, opts: &UserTableOptions) -> Result<FitInput> {
    let grid: JsonGrid = serde_json::from_str(text).map_err(|e| {
        Error::file(path, format!("neither a furnace table sidecar nor a JSON grid {{\"axes\": [{{\"name\": ..., \"nodes\": [...]}}, ...], \"values\": [...]}}: {e}"))
    })?;
    let n: usize = grid.axes.iter().map(|a| a.nodes.len()).product();
    if grid.axes.is_empty() || grid.axes.len() > MAX_DIM {
        return Err(Error::file(
            path,
            format!("{} axes; a fit needs 1 to {MAX_DIM}", grid.axes.len()),
        ));
    }
    if grid.values.len() != n {
        return Err(Error::file(
            path,
            format!(
                "{} values for a grid of {n} nodes (last axis fastest)",
                grid.values.len()
            ),
        ));
    }
    for a in &grid.axes {
        if let Some(i) = a.nodes.iter().position(|v| !v.is_finite()) {
            return Err(Error::file(
                path,
                format!("node {i} of axis '{}' is not a finite number", a.name),
            ));
        }
        if a.nodes.windows(2).any(|w| !(w[0] < w[1])) {
            return Err(Error::file(
                path,
                format!("the nodes of axis '{}' must increase strictly", a.name),
            ));
        }
    }
    check_values(&grid.values, |i| format!("value {i}"), path)?;
    if opts.channel.as_deref().is_some_and(|c| c != "E") {
        return Err(Error::InvalidInput(
            "a JSON grid has one value array; --channel does not apply".into(),
        ));
    }
    let nodes: Vec<Vec<f64>> = grid.axes.iter().map(|a| a.nodes.clone()).collect();
    let names = grid.axes.iter().map(|a| a.name.clone()).collect();
    let data = FitData::from_grid(names, &nodes, grid.values)
        .map_err(|e| Error::file(path, e.to_string()))?;
    Ok(FitInput {
        source: Source {
            kind: "json_grid".into(),
            model: None,
            path: Some(path.display().to_string()),
            content_hash: sha256_file(path)?,
            resolution: Some(nodes.iter().map(Vec::len).collect()),
            channel: "E".into(),
            points: data.len(),
            restricted_to: None,
        },
        data,
        grid: Some(nodes),
        table: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn even_indices_keep_endpoints() {
        assert_eq!(even_indices(128, 32).first(), Some(&0));
        assert_eq!(even_indices(128, 32).last(), Some(&127));
        assert_eq!(even_indices(128, 32).len(), 32);
        assert_eq!(even_indices(5, 9), vec![0, 1, 2, 3, 4]);
        let e = even_indices(1024, 256);
        assert!(e.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn graded_indices_keep_the_first_nodes_and_the_endpoints() {
        let g = graded_indices(128, 32, 2.0);
        assert_eq!(g.len(), 32);
        assert_eq!((g[0], g[31]), (0, 127));
        assert!(g.windows(2).all(|w| w[1] > w[0]), "{g:?}");
        assert_eq!(&g[..9], &[0, 1, 2, 3, 4, 5, 6, 7, 8]);
        // p = 1 (or nonsense) is the even subset; as many picks as nodes keeps them all
        assert_eq!(graded_indices(128, 32, 1.0), even_indices(128, 32));
        assert_eq!(graded_indices(128, 32, f64::NAN), even_indices(128, 32));
        assert_eq!(graded_indices(5, 9, 2.0), vec![0, 1, 2, 3, 4]);
        // a steep grading still ends at the last node with distinct picks
        let s = graded_indices(40, 32, 8.0);
        assert!(s.windows(2).all(|w| w[1] > w[0]) && s[31] == 39, "{s:?}");
    }

    #[test]
    fn csv_errors_name_row_and_column() {
        assert!(parse_csv_table("r,mu,E\n0.1,0.2,0.5\n", "E").is_ok());
        let e = parse_csv_table("r,mu,E\n0.1,0.2,0.5\n0.1,0.3,NaN\n", "E").unwrap_err();
        assert!(
            e.contains("row 3") && e.contains("'E'") && e.contains("finite"),
            "{e}"
        );
        let e = parse_csv_table("r,mu\n0.1,0.2\n", "E").unwrap_err();
        assert!(e.contains("no value column 'E'"), "{e}");
        let e = parse_csv_table("r,mu,E\n0.1,x,0.2\n", "E").unwrap_err();
        assert!(e.contains("row 2, column 'mu'"), "{e}");
        let e = parse_csv_table("a,b,c,d,e,E\n1,2,3,4,5,6\n", "E").unwrap_err();
        assert!(e.contains("5 variable columns"), "{e}");
    }

    #[test]
    fn csv_values_beyond_the_largest_magnitude_are_refused_naming_the_row() {
        assert!(parse_csv_table("r,mu,E\n0.1,0.2,1e100\n0.2,0.2,-1e100\n", "E").is_ok());
        let e = parse_csv_table("r,mu,E\n0.1,0.2,0.5\n\n0.1,0.3,1e300\n", "E").unwrap_err();
        assert!(
            e.starts_with(
                "row 4, column 'E' is 1e300, beyond the largest magnitude a fit accepts, ±1e100"
            ) && e.contains("rescale the values"),
            "{e}"
        );
    }

    #[test]
    fn a_csv_may_start_with_a_byte_order_mark() {
        let (names, coords, values) =
            parse_csv_table("\u{feff}r,mu,E\n0.1,0.2,0.5\n", "E").unwrap();
        assert_eq!(
            (names, coords, values),
            (
                vec!["r".to_string(), "mu".to_string()],
                vec![0.1, 0.2],
                vec![0.5]
            )
        );
    }

    #[test]
    fn axes_parse_and_reject() {
        let a = parse_axes("f0=0.0125:0.25:32, r=0:1,mu=0:1").unwrap();
        assert_eq!(
            a[0],
            AxisDecl {
                name: "f0".into(),
                lo: 0.0125,
                hi: 0.25,
                n: Some(32)
            }
        );
        assert_eq!(a[2].n, None);
        assert!(parse_axes("r=1:0").is_err());
        assert!(parse_axes("r=0:1:1").is_err());
        assert!(parse_axes("r").is_err());
        assert!(parse_axes("a=0:1,b=0:1,c=0:1,d=0:1,e=0:1").is_err());
    }

    #[test]
    fn exr_axes_infer_one_count() {
        let d = parse_axes("f0=0:1:4,r=0:1,mu=0:1").unwrap();
        let ax = exr_axes_from_decl(&d, 8, 12).unwrap();
        assert_eq!(ax.iter().map(|a| a.n).collect::<Vec<_>>(), vec![4, 3, 8]);
        assert!(exr_axes_from_decl(&d, 8, 13).is_err());
        let d = parse_axes("f0=0:1,r=0:1,mu=0:1").unwrap();
        assert!(exr_axes_from_decl(&d, 8, 12).is_err());
    }
}
