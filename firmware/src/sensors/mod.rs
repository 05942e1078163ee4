//! The two worked examples of a sensor. The one a build runs is chosen
//! with `RRI_SENSOR` (a path to one Rust file; default [`distance`], the
//! demo's) in the crate `rri-active-sensor` (`firmware/active-sensor`):
//! the firmware binary, `cargo sensor-host` and `cargo panic-check` run
//! its `Active`, and choosing another file rebuilds only them.
//!
//! A sensor file is what an integrator writes: `use
//! rri_firmware::sensor::prelude::*;`, a type implementing
//! [`Sensor`](crate::sensor::Sensor), and `pub type ThisSensor = MySensor;`.
//! It may live anywhere (beside the GSI folder); changing it or the
//! variable rebuilds what runs it.

pub mod aligned;
pub mod distance;

#[cfg(test)]
mod tests;
