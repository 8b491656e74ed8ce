//! Tables computed in slices and joined: a shard K/N is a deterministic share of the table's
//! units of parallel work ([`Units`]), written as `<stem>.shard-K-of-N.{bin,json}`;
//! [`merge`] checks that N shards of one request cover every unit exactly once and assembles
//! the table, byte-identical to a single run (a cell's value depends only on its coordinates
//! and the quadrature settings, never on what else is computed).
//!
//! The binary file holds, cell by cell in unit order, the outputs (f64), the error estimate
//! (f64), the order reached (u32) and whether it converged (u8), little-endian. The JSON file
//! records the request (the table's spec and content hash), K, N, the unit range, the cell count
//! and the SHA-256 of the binary file; it is written last and commits the shard.

use super::io::with_ext;
use super::{
    assemble, compute_units, CellResult, Progress, Table, TableSpec, Units, ENGINE_VERSION,
};
use crate::bsdf::{Model, MAX_OUTPUTS};
use crate::digest::sha256_hex;
use crate::error::{Error, Result};
use crate::output;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Largest number of shards a table may be split into.
pub const MAX_SHARDS: usize = 1 << 20;

/// Which slice of a table: `index` of `count` (0 ≤ index < count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardId {
    pub index: usize,
    pub count: usize,
}

impl ShardId {
    /// Parses `K/N` (K counted from 0, as Slurm's `--array=0-(N-1)` and Kubernetes' indexed
    /// jobs number their tasks).
    pub fn parse(text: &str) -> Result<ShardId> {
        let bad = |why: &str| {
            Error::InvalidInput(format!(
                "--shard {text}: {why}; give K/N with 0 ≤ K < N ≤ {MAX_SHARDS}, e.g. --shard 0/4"
            ))
        };
        let (k, n) = text.split_once('/').ok_or_else(|| bad("no '/'"))?;
        let index: usize = k.trim().parse().map_err(|_| bad("K is not a count"))?;
        let count: usize = n.trim().parse().map_err(|_| bad("N is not a count"))?;
        if count == 0 || count > MAX_SHARDS {
            return Err(bad("N out of range"));
        }
        if index >= count {
            return Err(bad("K must be below N"));
        }
        Ok(ShardId { index, count })
    }

    /// The units of `units` this shard computes: [⌊K·U/N⌋, ⌊(K+1)·U/N⌋).
    pub fn units(&self, units: usize) -> std::ops::Range<usize> {
        let at = |k: usize| ((k as u128 * units as u128) / self.count as u128) as usize;
        at(self.index)..at(self.index + 1)
    }
}

/// The record of a shard (its JSON file).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShardSidecar {
    pub tool: String,
    pub tool_version: String,
    pub engine_version: u32,
    pub content_hash: String,
    pub spec: TableSpec,
    pub shard: usize,
    pub shards: usize,
    pub units: (usize, usize),
    pub cells: usize,
    pub bin_sha256: String,
}

/// The files of shard `id` of the table at `stem`: (binary, JSON).
pub fn shard_files(stem: &Path, id: ShardId) -> (PathBuf, PathBuf) {
    let base = stem.with_file_name(format!(
        "{}.shard-{}-of-{}",
        stem.file_name()
            .map(|s| s.to_string_lossy())
            .unwrap_or_default(),
        id.index,
        id.count
    ));
    (with_ext(&base, "bin"), with_ext(&base, "json"))
}

fn cell_bytes(n_out: usize, results: &[CellResult]) -> Vec<u8> {
    let mut out = Vec::with_capacity(results.len() * (8 * n_out + 13));
    for (v, err, order, converged) in results {
        for x in &v[..n_out] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&err.to_le_bytes());
        out.extend_from_slice(&(*order as u32).to_le_bytes());
        out.push(u8::from(*converged));
    }
    out
}

fn parse_cells(n_out: usize, bytes: &[u8]) -> Vec<CellResult> {
    let size = 8 * n_out + 13;
    bytes
        .chunks_exact(size)
        .map(|c| {
            let f = |i: usize| f64::from_le_bytes(c[8 * i..8 * i + 8].try_into().expect("8 bytes"));
            let mut v = [0.0; MAX_OUTPUTS];
            for (o, x) in v.iter_mut().enumerate().take(n_out) {
                *x = f(o);
            }
            let order = u32::from_le_bytes(c[8 * n_out + 8..8 * n_out + 12].try_into().expect("4"));
            (v, f(n_out), order as usize, c[8 * n_out + 12] != 0)
        })
        .collect()
}

/// Computes shard `id` of `spec` and writes its two files next to the table's `stem`.
/// Returns the JSON file's path.
pub fn tabulate_shard(
    model: &dyn Model,
    spec: &TableSpec,
    id: ShardId,
    stem: &Path,
    progress: Progress,
) -> Result<PathBuf> {
    super::check_request(model, spec)?;
    let layout = Units::of(model, spec);
    let range = id.units(layout.units);
    let results: Vec<CellResult> = compute_units(model, spec, &layout, range.clone(), progress)
        .into_iter()
        .flatten()
        .collect();
    let bin = cell_bytes(spec.outputs.len(), &results);
    let (bin_path, json_path) = shard_files(stem, id);
    output::write(&bin_path, &bin)?;
    let sidecar = ShardSidecar {
        tool: "furnace".into(),
        tool_version: crate::VERSION.into(),
        engine_version: ENGINE_VERSION,
        content_hash: spec.content_hash(),
        spec: spec.clone(),
        shard: id.index,
        shards: id.count,
        units: (range.start, range.end),
        cells: results.len(),
        bin_sha256: sha256_hex(&bin),
    };
    let json = serde_json::to_string_pretty(&sidecar).expect("shard sidecar serialises");
    output::write(&json_path, format!("{json}\n").as_bytes())?;
    Ok(json_path)
}

/// Reads the `count` shards of `spec` (a table of `model`) next to `stem` and assembles the
/// table. Refuses shards
/// of another request, a missing or damaged shard, or a split other than `count`.
pub fn merge(model: &dyn Model, spec: &TableSpec, count: usize, stem: &Path) -> Result<Table> {
    super::check_request(model, spec)?;
    if count == 0 || count > MAX_SHARDS {
        return Err(Error::InvalidInput(format!(
            "--shards {count}: give the N the shards were computed with (1 to {MAX_SHARDS})"
        )));
    }
    let layout = Units::of(model, spec);
    let n_out = spec.outputs.len();
    let hash = spec.content_hash();
    let mut ordered: Vec<Option<CellResult>> = vec![None; spec.cells()];
    for index in 0..count {
        let id = ShardId { index, count };
        let (bin_path, json_path) = shard_files(stem, id);
        let text = std::fs::read_to_string(&json_path).map_err(|e| {
            Error::file(
                &json_path,
                format!(
                    "shard {index}/{count} is missing ({e}): run `furnace tabulate --shard {index}/{count}` with the same options"
                ),
            )
        })?;
        let sidecar: ShardSidecar = serde_json::from_str(&text)
            .map_err(|e| Error::file(&json_path, format!("not a shard record: {e}")))?;
        let range = id.units(layout.units);
        if sidecar.content_hash != hash
            || sidecar.engine_version != ENGINE_VERSION
            || sidecar.shard != index
            || sidecar.shards != count
            || sidecar.units != (range.start, range.end)
        {
            return Err(Error::file(
                &json_path,
                format!(
                    "shard {index}/{count} was computed for another request (model, resolution, quadrature settings or furnace's engine differ): recompute it with `furnace tabulate --shard {index}/{count}` and the options of this merge"
                ),
            ));
        }
        let bin = std::fs::read(&bin_path).map_err(|e| Error::io(&bin_path, e))?;
        if sha256_hex(&bin) != sidecar.bin_sha256
            || bin.len() != sidecar.cells * (8 * n_out + 13)
            || sidecar.cells != (range.end - range.start) * layout.unit_len
        {
            return Err(Error::file(
                &bin_path,
                format!("shard {index}/{count} is damaged (its checksum or size does not match its record): recompute it"),
            ));
        }
        let cells = parse_cells(n_out, &bin);
        for (i, r) in cells.into_iter().enumerate() {
            let (unit, k) = (range.start + i / layout.unit_len, i % layout.unit_len);
            ordered[layout.cell_of(unit, k)] = Some(r);
        }
    }
    assemble(spec, ordered)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_ids_parse_and_cover_every_unit_once() {
        assert_eq!(
            ShardId::parse("2/5").unwrap(),
            ShardId { index: 2, count: 5 }
        );
        for bad in ["5/5", "1", "a/3", "1/0", "-1/3", "0/2000000"] {
            let e = ShardId::parse(bad).unwrap_err().to_string();
            assert!(e.contains("--shard"), "{bad}: {e}");
        }
        for units in [0, 1, 7, 1000, 16384] {
            for count in [1, 3, 4, 64] {
                let mut next = 0;
                for index in 0..count {
                    let r = ShardId { index, count }.units(units);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, units);
            }
        }
    }

    #[test]
    fn cells_round_trip_through_bytes() {
        let cells: Vec<CellResult> = vec![
            ([0.25, -1e-300, 3.0], 1e-9, 12, true),
            ([f64::MIN_POSITIVE, 0.5, 0.0], 2e-7, 97, false),
        ];
        for n_out in [1, 3] {
            let back = parse_cells(n_out, &cell_bytes(n_out, &cells));
            for (a, b) in back.iter().zip(&cells) {
                assert_eq!(a.0[..n_out], b.0[..n_out]);
                assert_eq!((a.1, a.2, a.3), (b.1, b.2, b.3));
            }
        }
    }
}
