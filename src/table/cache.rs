//! The table cache: every table furnace uses is read from `data/<model>/<resolution>…` when a
//! table with the same inputs is there ([`io::load_cached`]), else tabulated and saved. This is
//! the one place that decides.

use super::{io, tabulate, Table, TableSpec};
use crate::bsdf::Model;
use crate::error::Result;
use crate::progress::Observer;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A table got from the cache or computed.
#[derive(Clone, Debug)]
pub struct Tabulated {
    pub table: Table,
    /// Where it lives, without extension ([`io::table_stem`]).
    pub stem: PathBuf,
    /// Read from the cache rather than computed.
    pub cached: bool,
    /// Wall time of getting it (for the terminal only).
    pub seconds: f64,
}

/// The table of `spec` from the cache under `data_dir`, or tabulated (reporting its cells to
/// `progress`) and saved there. `force` recomputes even when a cached table matches.
pub fn get_or_tabulate(
    model: &dyn Model,
    spec: &TableSpec,
    data_dir: &Path,
    force: bool,
    progress: &dyn Observer,
) -> Result<Tabulated> {
    let stem = io::table_stem(data_dir, model, spec);
    let start = Instant::now();
    if !force {
        if let Some(table) = io::load_cached(spec, &stem)? {
            return Ok(Tabulated {
                table,
                stem,
                cached: true,
                seconds: start.elapsed().as_secs_f64(),
            });
        }
    }
    progress.begin(
        &format!("{} {}", spec.model, spec.resolution_name()),
        spec.cells() as u64,
    );
    let table = tabulate(model, spec, &|n| progress.advance(n));
    progress.end();
    let table = table?;
    io::save(&table, &stem)?;
    Ok(Tabulated {
        table,
        stem,
        cached: false,
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Quiet;
    use crate::quadrature::QuadratureSettings;

    #[test]
    fn a_second_request_reads_the_cache_and_force_recomputes() {
        let dir = std::env::temp_dir().join(format!("furnace-cache-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let model = crate::bsdf::find("oren-nayar-fon").unwrap();
        let spec = TableSpec::new(model.as_ref(), &[5, 5], QuadratureSettings::default()).unwrap();
        let first = get_or_tabulate(model.as_ref(), &spec, &dir, false, &Quiet).unwrap();
        let again = get_or_tabulate(model.as_ref(), &spec, &dir, false, &Quiet).unwrap();
        let forced = get_or_tabulate(model.as_ref(), &spec, &dir, true, &Quiet).unwrap();
        assert!(!first.cached && again.cached && !forced.cached);
        assert_eq!(first.table.values, again.table.values);
        assert_eq!(first.stem, dir.join("oren-nayar-fon/5x5"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
