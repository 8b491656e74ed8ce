//! Error reports: plots, the white furnace test, sphere images and `reports/README.md`.

pub mod albedo;
pub mod furnace;
pub mod quad;
pub mod plot;
pub mod spheres;
pub mod inputs;
pub mod model;
pub mod readme;
