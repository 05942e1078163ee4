//! Links the bootloader with the board's bootloader map (`rri-board.x`,
//! written by hal-board's build script for its `boot` feature). No
//! `defmt.x`: the bootloader logs nothing.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let mcu = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    if mcu && std::env::var_os("CARGO_FEATURE_BOARD").is_some() {
        println!("cargo:rustc-link-arg-bins=--nmagic");
        println!("cargo:rustc-link-arg-bins=-Trri-board.x");
    }
}
