//! `furnace export`: a thin wrapper over [`crate::export`].

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};

use super::{parse_resolution, QuadratureArgs};
use crate::error::{Error, Result};
use crate::export::{self, cycles, filament, generic, Compute, Files};
use crate::output::Target;

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormatArg {
    /// Blender Cycles' shader.tables: the eight GGX arrays, Cycles' layout and conventions.
    Cycles,
    /// Filament's split-sum DFG table (also Godot's and three.js' sizes).
    Filament,
    /// Any model on a grid, as furnace's table files (EXR + exact f64 + JSON).
    Generic,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrecisionArg {
    /// RG16F (half floats).
    F16,
    /// RG32F.
    F32,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodingArg {
    /// Filament's dfg.inc (RG16F words).
    Inc,
    /// A C++ header.
    Cpp,
    /// An ES module.
    Js,
    /// Raw little-endian texels, with a JSON header beside it (<file>.json).
    Bin,
}

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// The renderer whose layout to write.
    #[arg(long, value_enum)]
    pub format: FormatArg,
    /// The file to write (generic: an .exr, with .f64 and .json beside it), or `-` for standard
    /// output (cycles, and filament's inc, cpp and js encodings: one text file). An existing file
    /// is replaced only if furnace export wrote it.
    #[arg(long)]
    pub output: PathBuf,
    /// filament: side of the square table (a power of two; Filament uses 128).
    #[arg(long)]
    pub size: Option<usize>,
    /// filament: texel precision.
    #[arg(long, value_enum, default_value_t = PrecisionArg::F16)]
    pub precision: PrecisionArg,
    /// filament: encoding (default from the --output extension: .inc, .h/.hpp/.cpp, .js/.mjs,
    /// .bin/.raw).
    #[arg(long, value_enum)]
    pub encoding: Option<EncodingArg>,
    /// cycles: Cycles' own shader.tables, whose eight GGX arrays are replaced (everything else
    /// is kept byte for byte); --output may be this file.
    #[arg(long)]
    pub splice: Option<PathBuf>,
    /// generic: the model (see `furnace models`).
    #[arg(long)]
    pub model: Option<String>,
    /// generic: nodes per axis (`64`, or `32x64`); default 64 per axis.
    #[arg(long)]
    pub resolution: Option<String>,
    /// Folder of the table cache.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Compute every table, reading and writing no cache.
    #[arg(long)]
    pub no_cache: bool,
    #[command(flatten)]
    pub quadrature: QuadratureArgs,
}

/// Refuses options that do not apply to the format.
fn check_options(args: &ExportArgs) -> Result<()> {
    let only = |given: bool, flag: &str, format: &str, why: &str| -> Result<()> {
        if given {
            return Err(Error::InvalidInput(format!(
                "{flag} applies to --format {format} only{why}"
            )));
        }
        Ok(())
    };
    let f = args.format;
    only(
        args.size.is_some() && f != FormatArg::Filament,
        "--size",
        "filament",
        if f == FormatArg::Cycles {
            ": Cycles' arrays have fixed sizes (32×32 and 32 for GGX, 16×16×16 and 16×16 for glass and the Schlick factors)"
        } else {
            " (the generic format takes --resolution)"
        },
    )?;
    only(
        args.encoding.is_some() && f != FormatArg::Filament,
        "--encoding",
        "filament",
        "",
    )?;
    only(
        args.precision != PrecisionArg::F16 && f != FormatArg::Filament,
        "--precision",
        "filament",
        "",
    )?;
    only(
        args.splice.is_some() && f != FormatArg::Cycles,
        "--splice",
        "cycles",
        "",
    )?;
    only(
        (args.model.is_some() || args.resolution.is_some()) && f != FormatArg::Generic,
        "--model and --resolution",
        "generic",
        "",
    )?;
    if Target::from_arg(&args.output).is_stdout() {
        let two_files = match f {
            FormatArg::Generic => Some("the generic format writes three files (.exr, .f64, .json)"),
            FormatArg::Filament if args.encoding == Some(EncodingArg::Bin) => {
                Some("the bin encoding writes the texels and a JSON header beside them")
            }
            _ => None,
        };
        if let Some(why) = two_files {
            return Err(Error::InvalidInput(format!(
                "--output -: {why}, so they cannot go to standard output; give a file name"
            )));
        }
        if f == FormatArg::Filament && args.encoding.is_none() {
            return Err(Error::InvalidInput(
                "--output -: standard output has no extension to tell the encoding from; give --encoding inc, cpp or js".into(),
            ));
        }
    }
    Ok(())
}

pub fn export_cmd(args: &ExportArgs) -> Result<()> {
    check_options(args)?;
    let target = Target::from_arg(&args.output);
    // an unwritable output is refused before any table is computed
    target.check("--output")?;
    let start = Instant::now();
    let compute = Compute {
        quadrature: args.quadrature.settings()?,
        data_dir: (!args.no_cache).then(|| args.data_dir.clone()),
    };
    let out = match args.format {
        FormatArg::Cycles => cycles::export(&compute, &args.output, args.splice.as_deref())?,
        FormatArg::Filament => {
            let size = args.size.unwrap_or(128);
            let precision = match args.precision {
                PrecisionArg::F16 => filament::Precision::F16,
                PrecisionArg::F32 => filament::Precision::F32,
            };
            let encoding = match args.encoding {
                Some(EncodingArg::Inc) => filament::Encoding::Inc,
                Some(EncodingArg::Cpp) => filament::Encoding::Cpp,
                Some(EncodingArg::Js) => filament::Encoding::Js,
                Some(EncodingArg::Bin) => filament::Encoding::Bin,
                None => filament::Encoding::from_path(&args.output).ok_or_else(|| {
                    Error::InvalidInput(format!(
                        "--output {}: cannot tell the encoding from the extension; name the file .inc, .h, .cpp, .js or .bin, or give --encoding",
                        args.output.display()
                    ))
                })?,
            };
            filament::export(&compute, size, precision, encoding, &args.output)?
        }
        FormatArg::Generic => {
            let name = args.model.as_deref().ok_or_else(|| {
                Error::InvalidInput("--format generic needs --model (see `furnace models`)".into())
            })?;
            let model = args.quadrature.model(name)?;
            let resolution = parse_resolution(
                "--resolution",
                args.resolution.as_deref(),
                &vec![64; model.axes().len()],
            )?;
            generic::export(&compute, model.as_ref(), &resolution, &args.output)?
        }
    };
    match (&target, &out.files) {
        (Target::Stdout, Files::Bytes(files)) if files.len() == 1 => {
            target.write(&files[0].bytes)?
        }
        (Target::Stdout, _) => {
            return Err(Error::InvalidInput(
                "--output -: this export is not one file; give a file name".into(),
            ))
        }
        (Target::File(_), _) => export::write(&out)?,
    }
    for t in &out.tables {
        eprintln!(
            "{:<28} {:>6} cells, max error estimate {:.1e}{}, {:.2} s",
            t.name,
            t.cells,
            t.max_error_estimate,
            if t.unconverged > 0 {
                format!(" ({} cells above the tolerance)", t.unconverged)
            } else {
                String::new()
            },
            t.seconds
        );
    }
    match &target {
        Target::Stdout => eprintln!("    wrote {}", target.describe()),
        Target::File(_) => {
            for p in out.paths() {
                eprintln!("    wrote {}", p.display());
            }
        }
    }
    eprintln!(
        "export done in {:.2} s; max error estimate {:.1e}",
        start.elapsed().as_secs_f64(),
        out.max_error_estimate()
    );
    Ok(())
}
