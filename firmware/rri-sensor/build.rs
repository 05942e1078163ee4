//! Links the firmware binary for the MCU (the board's memory map, defmt's
//! table; see `../link_args.rs`) and sets cfg `rri_http` unless
//! `RRI_HTTP_PORT=0` leaves the diagnostics service out (rri-firmware's
//! build script checks the value and generates `network::HTTP_PORT`).

include!("../link_args.rs");

fn main() {
    let manifest = std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    );
    let workspace = manifest
        .parent()
        .and_then(|p| p.parent())
        .unwrap_or(&manifest)
        .to_path_buf();
    mcu_link_args(&workspace, true);
    println!("cargo:rerun-if-env-changed=RRI_HTTP_PORT");
    println!("cargo::rustc-check-cfg=cfg(rri_http)");
    let port = std::env::var("RRI_HTTP_PORT").unwrap_or_default();
    if port.trim() != "0" {
        println!("cargo:rustc-cfg=rri_http");
    }
}
