//! On-disk tables: `data/<model>/<resolution>.{exr,f64,json}`, written by [`crate::output`]
//! (each file atomically; the sidecar last, so it commits the other two) and read back only when
//! the sidecar's content hash matches the request and the f64 file's checksum matches the
//! sidecar.

use super::{ErrorSummary, GridAxis, Table, TableSpec, ENGINE_VERSION};
use crate::bsdf::Model;
use crate::digest::sha256_hex;
use crate::error::{Error, Result};
use crate::quadrature::QuadratureSettings;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The JSON sidecar of a table.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Sidecar {
    pub tool: String,
    pub tool_version: String,
    pub engine_version: u32,
    /// Cache key: SHA-256 of the spec, engine version and the model's integrator revision
    /// ([`TableSpec::content_hash`]).
    pub content_hash: String,
    pub model: String,
    pub model_parameters: serde_json::Value,
    pub axes: Vec<GridAxis>,
    pub outputs: Vec<String>,
    pub quadrature: QuadratureSettings,
    /// How values are laid out in the EXR and f64 files.
    pub layout: String,
    /// SHA-256 of the f64 file.
    pub f64_sha256: String,
    pub errors: ErrorSummary,
    /// What the values are, in words (written by exports, [`save_described`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub definition: Option<String>,
}

/// Where a table lives: `dir/<cache name>/<resolution>[-<hash8>]` without extension.
pub fn table_stem(dir: &Path, model: &dyn Model, spec: &TableSpec) -> PathBuf {
    let default_domain = model
        .axes()
        .iter()
        .zip(&spec.axes)
        .all(|(a, g)| a.default_range == (g.lo, g.hi) && g.nodes.is_none());
    let mut name = spec.resolution_name();
    if !default_domain {
        name.push('-');
        name.push_str(&spec.content_hash()[..8]);
    }
    dir.join(model.id().key()).join(name)
}

pub(crate) fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

const LAYOUT: &str = "row-major, last axis fastest; EXR: one image n_last wide and (product of the other counts) tall, \
row = flattened index of the other axes, one f32 channel per output plus 'err' (per-cell error estimate); \
f64 file: little-endian f64, each output's cells in turn, then the error estimates";

fn f64_bytes(table: &Table) -> Vec<u8> {
    let mut bytes = Vec::with_capacity((table.values.len() + table.errors.len()) * 8);
    for v in table.values.iter().chain(&table.errors) {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes
}

fn exr_bytes(table: &Table, path: &Path) -> Result<Vec<u8>> {
    use exr::prelude::*;
    let spec = &table.spec;
    let width = spec.axes.last().map(|a| a.n).unwrap_or(1);
    let height = table.cells() / width;
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for (o, name) in spec.outputs.iter().enumerate() {
        let data: Vec<f32> = table.output(o).iter().map(|&v| v as f32).collect();
        channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(data)));
    }
    channels.push(AnyChannel::new(
        "err",
        FlatSamples::F32(table.errors.iter().map(|&v| v as f32).collect()),
    ));
    let mut attributes = LayerAttributes::named(spec.model.as_str());
    attributes.comments = Some(Text::from(
        format!(
            "furnace {}: directional albedo of {} over {}",
            crate::VERSION,
            spec.model,
            spec.axes
                .iter()
                .map(|a| a.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )
        .as_str(),
    ));
    // Blocks in increasing y: the parallel encoder then sorts its chunks, so the same table
    // always gives the same bytes (with the default, unspecified order it writes them as the
    // threads finish).
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let layer = Layer::new(
        (width, height),
        attributes,
        encoding,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| crate::Error::file(path, format!("cannot encode EXR: {e}")))?;
    Ok(bytes.into_inner())
}

/// Writes the table's three files (f64, EXR, then the sidecar that commits them).
pub fn save(table: &Table, stem: &Path) -> Result<Sidecar> {
    save_described(table, stem, None)
}

/// [`save`] with a definition of the values recorded in the sidecar.
pub fn save_described(table: &Table, stem: &Path, definition: Option<&str>) -> Result<Sidecar> {
    let raw = f64_bytes(table);
    crate::output::write(&with_ext(stem, "f64"), &raw)?;
    let exr = with_ext(stem, "exr");
    crate::output::write(&exr, &exr_bytes(table, &exr)?)?;
    let sidecar = Sidecar {
        tool: "furnace".into(),
        tool_version: crate::VERSION.into(),
        engine_version: ENGINE_VERSION,
        content_hash: table.spec.content_hash(),
        model: table.spec.model.clone(),
        model_parameters: table.spec.model_parameters.clone(),
        axes: table.spec.axes.clone(),
        outputs: table.spec.outputs.clone(),
        quadrature: table.spec.quadrature.clone(),
        layout: LAYOUT.into(),
        f64_sha256: sha256_hex(&raw),
        errors: table.summary.clone(),
        definition: definition.map(String::from),
    };
    let json = serde_json::to_string_pretty(&sidecar).expect("sidecar serialises");
    crate::output::write(&with_ext(stem, "json"), format!("{json}\n").as_bytes())?;
    Ok(sidecar)
}

/// Reads a cached table if its sidecar matches `spec` exactly; `Ok(None)` when there is no
/// usable cache (missing, stale, or inconsistent files — which are then recomputed).
pub fn load_cached(spec: &TableSpec, stem: &Path) -> Result<Option<Table>> {
    let json_path = with_ext(stem, "json");
    let Ok(text) = std::fs::read_to_string(&json_path) else {
        return Ok(None);
    };
    let Ok(sidecar) = serde_json::from_str::<Sidecar>(&text) else {
        return Ok(None);
    };
    if sidecar.content_hash != spec.content_hash() {
        return Ok(None);
    }
    let Ok(raw) = std::fs::read(with_ext(stem, "f64")) else {
        return Ok(None);
    };
    let cells = spec.cells();
    let n_out = spec.outputs.len();
    if raw.len() != (n_out + 1) * cells * 8 || sha256_hex(&raw) != sidecar.f64_sha256 {
        return Ok(None);
    }
    let all: Vec<f64> = raw
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    let (values, errors) = all.split_at(n_out * cells);
    Ok(Some(Table {
        spec: spec.clone(),
        values: values.to_vec(),
        errors: errors.to_vec(),
        summary: sidecar.errors,
    }))
}

/// Reads a table's sidecar and f64 values from `stem` whatever its spec (for `fit --table`).
pub fn load_any(stem: &Path) -> Result<Table> {
    let json_path = with_ext(stem, "json");
    let text = std::fs::read_to_string(&json_path).map_err(|e| Error::io(&json_path, e))?;
    let sidecar: Sidecar = serde_json::from_str(&text)
        .map_err(|e| Error::file(&json_path, format!("not a furnace table sidecar: {e}")))?;
    let spec = TableSpec {
        model: sidecar.model.clone(),
        model_parameters: sidecar.model_parameters.clone(),
        axes: sidecar.axes.clone(),
        outputs: sidecar.outputs.clone(),
        quadrature: sidecar.quadrature.clone(),
    };
    spec.validate()?;
    load_cached(&spec, stem)?.ok_or_else(|| {
        Error::file(
            with_ext(stem, "f64"),
            "missing or inconsistent with its sidecar; re-run `furnace tabulate --force`",
        )
    })
}

/// Reads an EXR table written by [`save`] back as f32 channels (for checks and external use).
pub fn read_exr_channels(path: &Path) -> Result<Vec<(String, Vec<f32>)>> {
    Ok(read_exr_image(path)?.2)
}

/// Width, height and named f32 channels (row-major, y down) of an EXR image.
pub type ExrImage = (usize, usize, Vec<(String, Vec<f32>)>);

/// Reads the first layer of an EXR file. Used to fit tables made elsewhere.
pub fn read_exr_image(path: &Path) -> Result<ExrImage> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| crate::Error::file(path, format!("cannot read EXR: {e}")))?;
    let size = image.layer_data.size;
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok((size.width(), size.height(), channels))
}

/// Paths of the three files of a table stem.
pub fn files(stem: &Path) -> [PathBuf; 3] {
    [
        with_ext(stem, "exr"),
        with_ext(stem, "f64"),
        with_ext(stem, "json"),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::QuadratureSettings;
    use crate::table::{ErrorSummary, GridAxis, TableSpec};

    /// A table tall enough for the EXR to hold many compressed blocks.
    fn tall_table() -> Table {
        let spec = TableSpec {
            model: "test".into(),
            model_parameters: serde_json::Value::Null,
            axes: vec![
                GridAxis::new("f0", 0.0, 1.0, 40),
                GridAxis::new("r", 0.0, 1.0, 30),
                GridAxis::new("mu", 0.0, 1.0, 7),
            ],
            outputs: vec!["E".into()],
            quadrature: QuadratureSettings::default(),
        };
        let cells = spec.cells();
        Table {
            values: (0..cells).map(|c| (c as f64 * 0.37).sin()).collect(),
            errors: (0..cells).map(|c| c as f64 * 1e-12).collect(),
            spec,
            summary: ErrorSummary {
                max_error_estimate: 0.0,
                max_error_at: vec![],
                refined_cells: 0,
                unconverged_cells: 0,
                unconverged: vec![],
                max_order_used: 0,
            },
        }
    }

    #[test]
    fn the_exr_writes_its_blocks_in_increasing_order() {
        use exr::prelude::*;
        let table = tall_table();
        let path = Path::new("t.exr");
        let bytes = exr_bytes(&table, path).unwrap();
        let meta =
            exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes), false).unwrap();
        let header = &meta.headers[0];
        assert!(header.chunk_count > 8, "{} blocks", header.chunk_count);
        assert_eq!(header.line_order, LineOrder::Increasing);
        for _ in 0..8 {
            assert!(exr_bytes(&table, path).unwrap() == bytes);
        }
    }
}
