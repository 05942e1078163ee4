//! Chooses the board's memory map for the linker.
//!
//! The firmware links with `-Trri-board.x`, which this script writes. The
//! linker looks for cortex-m-rt's `INCLUDE memory.x` in its working
//! directory (the workspace root, whose `memory.x` is the NUCLEO-F767ZI
//! application's) before any search path, so a board cannot just put its
//! own `memory.x` on the search path: it would be silently ignored. Every
//! board therefore gets a complete script: its flash partitions
//! (`memory/<board>-flash.x`), its `MEMORY` block (`memory/<board>.x`, the
//! root `memory.x` for the F767, or the bootloader's `<board>-boot.x`),
//! then cortex-m-rt's own `link.x.in` without the `INCLUDE memory.x`
//! line. Only a build with no board uses cortex-m-rt's `link.x` as it is.
//! `cargo boards` checks the result in each board's ELF
//! (`host-tests/src/boards.rs`, `board_map.rs`).

use std::path::{Path, PathBuf};

/// A board with a memory map of its own.
struct OwnMap {
    /// Its cargo feature.
    feature: &'static str,
    /// The application's map.
    map: &'static str,
    /// Its bootloader's map (hal-board's `boot` feature), if it has one.
    boot: Option<&'static str>,
    /// The flash partitions both maps link with, ahead of either.
    flash: Option<&'static str>,
    /// Whether its peripheral access crate supplies `device.x` (the weak
    /// aliases of the interrupt handlers, which cortex-m-rt's own `link.x`
    /// includes when its `device` feature is on).
    device_x: bool,
}

const OWN_MAP: &[OwnMap] = &[
    OwnMap {
        feature: "mps2-an500",
        map: "memory/mps2-an500.x",
        boot: Some("memory/mps2-an500-boot.x"),
        flash: Some("memory/mps2-an500-flash.x"),
        device_x: false,
    },
    OwnMap {
        feature: "nucleo-f767zi",
        // The root memory.x: the workspace's own map (the F767 was the
        // first board), now one board among the others.
        map: "../memory.x",
        boot: Some("memory/nucleo-f767zi-boot.x"),
        flash: Some("memory/nucleo-f767zi-flash.x"),
        device_x: true,
    },
    OwnMap {
        feature: "nucleo-h743zi",
        map: "memory/nucleo-h743zi.x",
        boot: Some("memory/nucleo-h743zi-boot.x"),
        flash: Some("memory/nucleo-h743zi-flash.x"),
        device_x: true,
    },
];

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo"));
    println!("cargo:rerun-if-changed=build.rs");
    let bare_metal = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    let board = OWN_MAP.iter().find(|b| {
        let var = format!(
            "CARGO_FEATURE_{}",
            b.feature.to_uppercase().replace('-', "_")
        );
        std::env::var_os(var).is_some()
    });
    let boot = std::env::var_os("CARGO_FEATURE_BOOT").is_some();
    // cfg `app_board`: the application's side of a board (its executor,
    // handlers, stack and sections), not its bootloader's (`boot`) and not
    // the host build.
    println!("cargo::rustc-check-cfg=cfg(app_board)");
    let any_board = ["MPS2_AN500", "STM32"]
        .iter()
        .any(|f| std::env::var_os(format!("CARGO_FEATURE_{f}")).is_some());
    if bare_metal && any_board && !boot {
        println!("cargo:rustc-cfg=app_board");
    }
    let script = match board {
        Some(board) if bare_metal => {
            let map = match (boot, board.boot) {
                (false, _) => board.map,
                (true, Some(map)) => map,
                (true, None) => panic!(
                    "hal-board's `boot` feature: the board `{}` has no bootloader yet",
                    board.feature
                ),
            };
            let map = manifest.join(map);
            println!("cargo:rerun-if-changed={}", map.display());
            let mut memory = read(&map);
            if let Some(flash) = board.flash {
                let flash = manifest.join(flash);
                println!("cargo:rerun-if-changed={}", flash.display());
                memory = format!("{}\n{memory}", read(&flash));
            }
            if std::env::var_os("CARGO_FEATURE_REHOST_BROKEN_BSS").is_some() {
                // A broken variant for the rehosting test alone (Cargo.toml).
                memory = memory.replace("} INSERT BEFORE .bss;", "} INSERT AFTER .bss;");
            }
            if std::env::var_os("CARGO_FEATURE_REHOST_BROKEN_DTCM").is_some() {
                // The rings in RAM (the DTCM); the stack rule cannot hold then.
                memory = memory.replacen("  } > DMA_RAM\n", "  } > RAM\n", 1);
                memory = memory
                    .lines()
                    .filter(|l| !l.contains("128K - (SIZEOF(.data)") && !l.contains("the statics leave the stack under"))
                    .collect::<Vec<_>>()
                    .join("\n");
            }
            let mut body = cortex_m_rt_body(&manifest);
            if board.device_x {
                // As cortex-m-rt's build script appends it: after
                // `EXTERN(__INTERRUPTS)`, or the weak aliases would win over
                // the firmware's handlers.
                body.push_str("\n/* The PAC's interrupt handler aliases */\nINCLUDE device.x\n");
            }
            format!("/* Generated by hal-board/build.rs: {} + cortex-m-rt's link.x.in */\n{memory}\n{body}", map.display())
        }
        _ => "/* Generated by hal-board/build.rs: cortex-m-rt's link.x with the root memory.x */\nINCLUDE link.x\n".to_string(),
    };
    // The budgets in the boards' maps hold for the product image; a bench
    // build (cycle records, the baseline codec) is measured, never
    // deployed, and is held to the chip's memories and a 64 KiB stack.
    let bench = u8::from(std::env::var_os("CARGO_FEATURE_BENCH").is_some());
    let script = format!("/* 1: a measurement build (hal-board's `bench`) */\n__rri_bench_build = {bench};\n{script}");
    let path = out.join("rri-board.x");
    if let Err(e) = std::fs::write(&path, script) {
        panic!("cannot write {}: {e}", path.display());
    }
    println!("cargo:rustc-link-search={}", out.display());
    // Whether the upload's path is built (issue 43): on a board with
    // update partitions, and on the host (the service's tests). The
    // firmware's and the diagnostics' build scripts read it
    // (`DEP_RRI_HAL_BOARD_UPDATES`); a board without partitions carries
    // none of it.
    // 1: the board takes updates (the QEMU board; the host, for the
    // service's tests). 2: only with a key of the integrator's built in
    // (`RRI_UPDATE_KEY`): a product board takes no demonstration key, so
    // without one its image carries none of the upload's path (and none
    // of its RAM: the NUCLEOs' DTCM is the stack's). 0: none.
    let feature = |f: &str| std::env::var_os(format!("CARGO_FEATURE_{f}")).is_some();
    let updates = if !bare_metal || feature("MPS2_AN500") {
        1
    } else if feature("NUCLEO_H743ZI") || feature("NUCLEO_F767ZI") {
        2
    } else {
        0
    };
    println!("cargo::metadata=updates={updates}");
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// cortex-m-rt's linker script (the version in Cargo.lock, from cargo's
/// registry sources) without its `INCLUDE memory.x`.
fn cortex_m_rt_body(manifest: &Path) -> String {
    let workspace = manifest.parent().unwrap_or(manifest);
    let lock_path = workspace.join("Cargo.lock");
    println!("cargo:rerun-if-changed={}", lock_path.display());
    let lock = read(&lock_path);
    let version = lock
        .split("[[package]]")
        .find(|p| p.contains("name = \"cortex-m-rt\"\n"))
        .and_then(|p| p.lines().find_map(|l| l.strip_prefix("version = \"")))
        .map(|v| v.trim_end_matches('"').to_string())
        .unwrap_or_else(|| panic!("cortex-m-rt is not in {}", lock_path.display()));
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
        .expect("CARGO_HOME or HOME");
    let registry = cargo_home.join("registry").join("src");
    let found = std::fs::read_dir(&registry)
        .into_iter()
        .flatten()
        .flatten()
        .map(|index| {
            index
                .path()
                .join(format!("cortex-m-rt-{version}"))
                .join("link.x.in")
        })
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "cortex-m-rt {version}'s link.x.in is not under {} (run `cargo fetch`)",
                registry.display()
            )
        });
    println!("cargo:rerun-if-changed={}", found.display());
    let body = read(&found);
    let include = "INCLUDE memory.x";
    assert!(
        body.contains(include),
        "{} has no `{include}` line: cortex-m-rt changed, review hal-board/build.rs",
        found.display()
    );
    body.replacen(include, "/* MEMORY: the board's, above */", 1)
}
