//! Emitting one fit file: its source files next to it (or one file to a target) and its LUT,
//! as `furnace emit` and `furnace run` write them.

use std::path::{Path, PathBuf};

use super::generate::FormChoice;
use super::{build_unit, EmitOptions, Lang, SourceFit};
use crate::error::{Error, Result};
use crate::fit::file as fitfile;
use crate::fit::job::FitRecord;
use crate::output::Target;
use crate::table::io;

/// What [`emit_fit_file`] writes and where it reads and writes.
#[derive(Clone, Debug)]
pub struct EmitFileOptions {
    /// Output formats.
    pub langs: Vec<Lang>,
    /// The languages as spelled on the command line that regenerates the files (`all`,
    /// `rust,wgsl,glsl`), quoted in the emitted headers.
    pub lang_arg: String,
    /// Evaluation form of the polynomials.
    pub form: FormChoice,
    /// Appended to every emitted name (checked by [`super::check_suffix`]).
    pub suffix: String,
    /// Table cache (where the fit file's table is looked up and LUT tables are cached).
    pub data_dir: PathBuf,
    /// Folder for LUTs.
    pub lut_dir: PathBuf,
    /// Nodes per axis of LUTs.
    pub lut_resolution: usize,
    /// Recompute LUT tables even when cached.
    pub force: bool,
}

/// The table a fit file refers to, if it is still in the cache: at the stem the file records,
/// or where the same table lives under `data_dir`.
pub fn referenced_table(file: &FitRecord, data_dir: &Path) -> Result<Option<crate::table::Table>> {
    let Some(t) = file.table.as_ref().filter(|t| t.is_current()) else {
        return Ok(None);
    };
    if let Some(table) = io::load_cached(&t.spec, &t.stem)? {
        return Ok(Some(table));
    }
    let Ok(model) = t.spec.model_id().and_then(crate::bsdf::get) else {
        return Ok(None);
    };
    let stem = io::table_stem(data_dir, model.as_ref(), &t.spec);
    io::load_cached(&t.spec, &stem)
}

/// The points of the user's table a fit file was made from, if that file is still there (as
/// the fit command named it, or beside the fit file) with the content hash the fit recorded;
/// a fit restricted to a sub-box gets the points inside it. `None` for a furnace table's fit
/// and for a table that cannot be read as it was (an EXR whose axes were given on the command
/// line, say): the header then states the fit's own error plus the f32 bound.
pub fn user_points(file: &FitRecord, fit_path: &Path) -> Option<super::UserPoints> {
    let src = &file.source;
    if file.table.is_some() || src.kind == "furnace_table" || src.kind.starts_with("paper") {
        return None;
    }
    let named = PathBuf::from(src.path.as_deref()?);
    let beside = fit_path.parent().map(|d| d.join(&named));
    let path = std::iter::once(named.clone())
        .chain(beside)
        .find(|p| p.is_file())?;
    let options = crate::fit::source::UserTableOptions {
        channel: Some(src.channel.clone()),
        axes: None,
    };
    let input = crate::fit::source::load_user_table(&path, &options).ok()?;
    let a = &file.fit.approximant;
    if input.source.content_hash != src.content_hash || input.data.names != a.variables {
        return None;
    }
    let data = &input.data;
    let inside = |x: &[f64]| {
        src.restricted_to
            .as_ref()
            .is_none_or(|b| x.iter().zip(b).all(|(v, (lo, hi))| (*lo..=*hi).contains(v)))
    };
    let (mut coords, mut values) = (Vec::new(), Vec::new());
    for i in 0..data.len() {
        let x = data.point(i);
        if inside(x) {
            coords.extend_from_slice(x);
            values.push(data.values[i]);
        }
    }
    (!values.is_empty()).then(|| super::UserPoints {
        name: named.display().to_string(),
        coords,
        values,
    })
}

/// Emits the fit file at `path` in `options.langs`: source files next to it (or the one file of
/// `target`), LUTs under `options.lut_dir`. Every byte is produced (and every shader validated)
/// before anything is written. `log` gets the notes and accuracy lines `furnace emit` prints.
/// Returns the files written.
pub fn emit_fit_file(
    path: &Path,
    options: &EmitFileOptions,
    target: Option<&Target>,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>> {
    let (args, langs) = (options, &options.langs);
    let file = fitfile::read(path)?;
    let table = referenced_table(&file, &args.data_dir)?;
    // said once the fit is emitted, so a refusal is not preceded by a note about its table
    let note = match &file.table {
        Some(t) if !t.is_current() => Some(format!("note: the table record of {} does not match its content hash (a table of another version of the quadrature engine, or an edited record); the header states the fit's error on its data plus the f32 bound instead of measuring the code on the table", path.display())),
        Some(_) if table.is_none() => Some(format!("note: the table of {} is not in the cache; the header states the fit's error on its data plus the f32 bound instead of measuring the code on the table", path.display())),
        _ => None,
    };
    let points = user_points(&file, path);
    let src = SourceFit::new(path, file, table)?.with_points(points);
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| Error::file(path, "a fit file needs a file name"))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut command = format!(
        "furnace emit --fit {} --lang {}",
        path.display(),
        args.lang_arg
    );
    if !args.suffix.is_empty() {
        command.push_str(&format!(" --suffix {}", args.suffix));
    }
    let guard = super::guard_macro(&format!("{} {stem}{}", src.subject(), args.suffix));
    let opts = EmitOptions {
        form: args.form,
        suffix: args.suffix.clone(),
        ..EmitOptions::default()
    };
    let (mut unit, emitted) =
        build_unit(&stem, &guard, std::slice::from_ref(&src), &command, &opts)?;
    if langs.contains(&Lang::Lut) {
        unit.luts.push(super::lut_for_fit(
            &src,
            &unit,
            &emitted[0].function,
            args.lut_resolution,
            &args.data_dir,
            args.force,
        )?);
    }
    // every byte is produced (and every shader validated) before anything is written
    let mut artifacts = Vec::new();
    for &lang in langs {
        artifacts.extend(super::emitter(lang).produce(&unit)?);
    }
    let written = match target {
        Some(t) => {
            t.write(&artifacts[0].bytes)?;
            vec![match t {
                Target::Stdout => PathBuf::from("-"),
                Target::File(p) => p.clone(),
            }]
        }
        None => super::write_artifacts(&artifacts, &dir, &args.lut_dir)?,
    };
    if let Some(note) = &note {
        log(note);
    }
    for e in &emitted {
        let st = &e.stress;
        log(&format!(
            "{}: {:?} form, {} coefficients; f32 − f64 at {} stress points max {:.1e} (IEEE) / {:.1e} (FMA) / {:.1e} (GPU model); {}",
            e.function, e.form.form, e.n_coefficients, st.random_points + st.edge_points, st.max_diff_ieee, st.max_diff_fused, st.max_diff_gpu,
            if e.bound.max_error.is_finite() {
                format!("bound {:.1e} over the whole domain", e.bound.max_error)
            } else {
                "no bound proved over the whole domain".into()
            }
        ));
        if let Some(t) = &e.table {
            log(&format!(
                "    on its table ({} {}): f64 MAE {:.2e} max {:.2e}; f32 MAE {:.2e} max {:.2e}",
                t.points,
                if src.table.is_some() {
                    "nodes"
                } else {
                    "points"
                },
                t.f64_mae,
                t.f64_max,
                t.f32_mae,
                t.f32_max
            ));
        }
    }
    for l in &unit.luts {
        if let Some(c) = &l.comparison {
            log(&format!(
                "LUT {} ({} B f32, {} B f16) vs fit ({} B) at the {} nodes of the {}: LUT f32 MAE {:.2e} max {:.2e}, f16 MAE {:.2e} max {:.2e}; fit MAE {:.2e} max {:.2e}",
                l.stem,
                4 * l.cells(),
                2 * l.cells(),
                c.fit_bytes.unwrap_or(0),
                c.points,
                c.reference,
                c.lut_f32_mae,
                c.lut_f32_max,
                c.lut_f16_mae,
                c.lut_f16_max,
                c.fit_f32_mae.unwrap_or(f64::NAN),
                c.fit_f32_max.unwrap_or(f64::NAN)
            ));
        }
    }
    Ok(written)
}
