//! # rri-firmware: an ABB Robot Reference Interface sensor, `no_std`
//!
//! The protocol and cycle logic of the sensor box, free of any board: it
//! builds for the host (tested with plain `cargo test`) and for
//! `thumbv7em-none-eabihf`. Boards (in `hal-board`) supply only the network
//! driver, the clock and their pins.
//!
//! - [`layout`]: the message layouts generated at build time from the user's
//!   GSI folder (`RRI_GSI_DIR`, `RRI_DEVICE`; see the README).
//! - [`value`]: the RRI value types (exact time, frame, joints, strings).
//! - [`schema`]: the vocabulary the generated layouts are written in;
//!   [`properties`]: how the engine sees several properties per direction.
//! - [`sensor`]: the one trait an integrator implements for their measuring
//!   device; [`sensors`]: the worked examples (the one `RRI_SENSOR`
//!   chooses is in the crate `rri-active-sensor`, so that choosing it
//!   never rebuilds this one).
//!
//! Rules: no heap, no recursion, no panics on any input; every buffer is
//! sized by a generated constant.
#![cfg_attr(not(test), no_std)]
// `unsafe_code` is denied and the cycle path may not panic (no panicking
// index, unwrap/expect or explicit panic): the workspace lints
// (Cargo.toml); `sample` is the one exception to the first (its module
// doc argues the soundness).
#![warn(missing_docs)]

// Sensor files say `rri_firmware::…`, inside this crate (the examples) as
// outside it (the file `RRI_SENSOR` names, in `rri-active-sensor`).
extern crate self as rri_firmware;

#[cfg(feature = "codec-baseline")]
pub mod baseline;
#[cfg(feature = "bench")]
pub mod bench;
pub mod bench_line;
pub mod codec;
pub mod demo;
pub mod engine;
pub mod fragments;
pub mod layout;
#[cfg(feature = "net")]
pub mod net;
pub mod network;
pub mod properties;
pub mod sample;
pub mod schema;
pub mod sensor;
pub mod sensors;
pub mod snapshot;
pub mod tcp;
pub mod value;
