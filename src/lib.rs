//! furnace: directional-albedo tables, fits and emitters for energy-compensated BSDFs.
//!
//! Data flows one way: [`bsdf`] (models) → [`quadrature`] → table → [`fit`].

pub mod bsdf;
pub mod cli;
pub mod digest;
pub mod emit;
pub mod error;
pub mod export;
pub mod fit;
pub mod material;
pub mod math;
pub mod output;
pub mod pipeline;
pub mod progress;
pub mod quadrature;
pub mod report;
pub mod scene;
pub mod table;

pub use error::{Error, Result};

/// The tool version recorded in every output file.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
