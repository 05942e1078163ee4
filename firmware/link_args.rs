// Included by `firmware/rri-sensor/build.rs` and `firmware/active-sensor/build.rs`: how
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
/// (the stack below the statics: an overflow runs off RAM) and through
/// plain rust-lld otherwise, or when `RRI_LINK_WITHOUT_FLIP_LINK` is set.
/// Either way the board's MPU guard at the stack's end makes an overflow
/// fault (hal-board's `stack_guard`); say which layout, so the choice is
/// never silent. The variable is tracked so that setting it relinks.
fn flip_link_notice() {
    println!("cargo:rerun-if-env-changed=PATH");
    println!("cargo:rerun-if-env-changed=RRI_LINK_WITHOUT_FLIP_LINK");
    let found = std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| dir.join("flip-link").is_file())
    });
    let refused = std::env::var_os("RRI_LINK_WITHOUT_FLIP_LINK").is_some_and(|v| !v.is_empty());
    if !found || refused {
        println!(
            "cargo::warning=linking with rust-lld, not flip-link{}: the stack sits above the statics, guarded by 256 bytes of MPU region only (a single frame larger than that could jump it); `cargo install flip-link` puts the stack below them",
            if refused { " (RRI_LINK_WITHOUT_FLIP_LINK)" } else { " (not installed)" }
        );
    }
}
