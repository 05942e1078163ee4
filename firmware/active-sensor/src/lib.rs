//! The sensor a build runs: the `ThisSensor` type of the Rust file
//! `RRI_SENSOR` names (default `firmware/src/sensors/distance.rs`, the
//! demo's), as [`Active`]. The firmware binary (`rri-sensor`), `cargo
//! sensor-host` and `cargo panic-check` run it.
//!
//! A crate of its own, apart from rri-firmware (which holds the `Sensor`
//! trait, its prelude and the worked examples): choosing another file, or
//! editing it, rebuilds this crate and what runs the sensor, never the
//! protocol and cycle logic, the host tools or the robot simulator.
//! `RRI_SENSOR` may be set per command or once for a checkout in
//! `.cargo/config.toml`'s `[env]`.
//!
//! The file's own tests run with `cargo test -p rri-active-sensor` (and
//! `cargo sensor-check` runs everything CI would on it).
#![no_std]

include!(concat!(env!("OUT_DIR"), "/sensor.rs"));

/// The sensor of the file `RRI_SENSOR` names, which every board runs.
pub type Active = chosen::ThisSensor;

/// The active sensor's type, as the start-up log names it beside
/// [`ACTIVE_FILE`]: an integrator sees which sensor a board or `cargo
/// sensor-host` runs without reading the build's environment.
pub fn active_name() -> &'static str {
    core::any::type_name::<Active>()
}

#[cfg(test)]
mod tests {
    /// The start-up log names the sensor a build runs: by default the
    /// distance example, its file given from the workspace root.
    #[test]
    fn the_active_sensor_is_named_with_its_file() {
        if option_env!("RRI_SENSOR").is_some_and(|v| !v.trim().is_empty()) {
            assert!(
                super::ACTIVE_FILE.ends_with(".rs"),
                "{}",
                super::ACTIVE_FILE
            );
            return;
        }
        assert_eq!(super::ACTIVE_FILE, "firmware/src/sensors/distance.rs");
        assert!(
            super::active_name().ends_with("sensors::distance::Distance"),
            "{}",
            super::active_name()
        );
    }
}
