//! The message layouts of the device this firmware was built for, generated
//! by `build.rs` (with `gsi-codegen`) from the GSI folder in `RRI_GSI_DIR`
//! (device `RRI_DEVICE`), or from the manual's `AnyDevice` example kept in
//! `firmware/gsi/GSI` when unset.
//!
//! To read what was generated: `target/*/build/rri-firmware-*/out/layout.rs`,
//! or the golden copy for the default configuration in
//! `host-tests/golden/anydevice_layout.rs`.

include!(concat!(env!("OUT_DIR"), "/layout.rs"));
