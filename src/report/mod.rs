//! Error reports: plots, the white furnace test, sphere images and `reports/README.md`.

pub mod albedo;
pub mod furnace;
pub mod quad;
