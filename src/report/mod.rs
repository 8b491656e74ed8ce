//! Error reports: fits against tables, the white furnace test, sphere images and `reports/README.md`.
//!
//! The end of the pipeline (model → quadrature → table → fit → emit/**report**): it reads tables
//! (through [`inputs::TableProvider`]), fit files (`fits/<model>/*.json`, [`crate::fit::FitResult`]),
//! the paper's published fits ([`crate::fit::paper`]) and benchmark CSV files, and writes figures
//! and markdown. It never changes a table or a fit.
//!
//! The white furnace test it shows is [`crate::material::furnace`]: the albedo of each
//! energy-compensated BSDF integrated over incident directions by its own quadrature, not re-read
//! from the albedo it is compensated with.
//!
//! - [`albedo`]: albedo sources a compensation reads — exact table / LUT (multilinear) and fits.
//! - [`plot`]: charts (linear/log axes, legends), heat maps with colour bars; PNG and SVG.
//! - [`spheres`]: rows of spheres of increasing roughness under a white environment (paper Figs. 2, 4).
//! - [`inputs`]: fit files, the chosen fit, measurement against a table, the paper link, benchmark CSVs.
//! - [`model`]: one model's section (`reports/<model>/`): Fig. 3, heat maps, slices, paper comparison,
//!   furnace table and spheres.
//! - [`offgrid`]: the best fits' and the LUTs' errors at the off-grid check points, and every
//!   sweep fit's, by form family.
//! - [`aniso`]: the anisotropic conductor's section: the isotropic shortcuts against the 4-D
//!   albedo, and the white furnace test of the compensated anisotropic conductor.
//! - [`readme`]: `reports/README.md` from every section, with the summary tables.
//!
//! Same inputs give the same bytes: no timestamps, fixed evaluation and summation order.
//!
//! ```no_run
//! use furnace::report::{inputs::TableProvider, model::{ReportOptions, Reporter}};
//! # fn provider() -> Box<dyn TableProvider> { unimplemented!() }
//! let tables = provider(); // e.g. the CLI's cache under data/
//! let quiet = |_: &str| {};
//! let reporter = Reporter::new(ReportOptions::new(std::path::Path::new(".")), tables.as_ref(), &quiet);
//! let conductor = furnace::bsdf::lookup("ggx-conductor")?;
//! reporter.generate(Some(&[conductor]))?; // one model's section + README.md
//! # Ok::<(), furnace::Error>(())
//! ```

// Negated comparisons (`!(x > 0.0)`) are deliberate: they treat NaN as failure.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops mirror the multilinear interpolation formula.
#![allow(clippy::needless_range_loop)]

pub mod albedo;
pub mod aniso;
pub mod inputs;
pub mod model;
pub mod offgrid;
pub mod plot;
pub mod readme;
pub mod spheres;
