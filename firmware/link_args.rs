// Included by `firmware/build.rs` and `firmware/rri-sensor/build.rs`: how
// the firmware's binaries link for the MCU.

/// Link arguments for the package's binaries on the MCU only: the host
/// build (tests) must not see them, and cargo refuses
/// `rustc-link-arg-bins` for a package without binaries (`has_bins`).
/// `rri-board.x` is written by hal-board's build script: the board's memory
/// map and cortex-m-rt's linker script.
fn mcu_link_args(workspace: &std::path::Path, has_bins: bool) {
    let mcu = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    if mcu && has_bins {
        println!("cargo:rustc-link-search={}", workspace.display());
        println!(
            "cargo:rerun-if-changed={}",
            workspace.join("memory.x").display()
        );
        println!("cargo:rustc-link-arg-bins=--nmagic");
        println!("cargo:rustc-link-arg-bins=-Trri-board.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        flip_link_notice();
    }
}

/// `.cargo/flip-link-or-lld` links through flip-link when it is installed
/// (stack overflow faults instead of corrupting statics) and through plain
/// rust-lld otherwise: say which, so a build without the protection is
/// never silent.
fn flip_link_notice() {
    println!("cargo:rerun-if-env-changed=PATH");
    let found = std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| dir.join("flip-link").is_file())
    });
    if !found {
        println!(
            "cargo::warning=flip-link is not installed: linking without stack overflow protection (install it with `cargo install flip-link`)"
        );
    }
}
