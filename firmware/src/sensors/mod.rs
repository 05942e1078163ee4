//! The sensors this firmware can run: the two worked examples, and the one
//! the build was asked for (`RRI_SENSOR`, a path to one Rust file; default
//! [`distance`], the demo's). The firmware binary, `cargo sensor-host` and
//! `cargo panic-check` all run [`Active`]: the `ThisSensor` type of the
//! chosen file.
//!
//! A sensor file is what an integrator writes: `use
//! rri_firmware::sensor::prelude::*;`, a type implementing
//! [`Sensor`](crate::sensor::Sensor), and `pub type ThisSensor = MySensor;`.
//! It may live anywhere (beside the GSI folder); changing it or the
//! variable rebuilds the firmware.

pub mod aligned;
pub mod distance;

include!(concat!(env!("OUT_DIR"), "/sensor.rs"));

/// The sensor of the file `RRI_SENSOR` names, which every board runs.
pub type Active = chosen::ThisSensor;

/// The active sensor's type, as the start-up log names it beside
/// [`ACTIVE_FILE`]: an integrator sees which sensor a board or
/// `cargo sensor-host` runs without reading the build's environment.
pub fn active_name() -> &'static str {
    core::any::type_name::<Active>()
}

#[cfg(test)]
mod tests;
