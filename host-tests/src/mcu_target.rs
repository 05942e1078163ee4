//! Every command that builds for the MCU (`cargo demo`, `qemu-bench`,
//! `boards`, `hil`, `soak`, `flood`) first makes sure the
//! `thumbv7em-none-eabihf` target is installed for the project's
//! toolchain: where rustup does not install `rust-toolchain.toml`'s targets
//! by itself (`RUSTUP_AUTO_INSTALL=0`), a missing target only shows after
//! minutes of building as "can't find crate for `core`". With rustup it is
//! added (`rustup target add`, once); without, one line says how.

use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

/// The firmware's target.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// The cargo profile of every firmware build (the root Cargo.toml says why
/// it is not `release`): the figures measured here are what boards run.
pub const PROFILE: &str = "firmware";

/// Cargo's target directory (`CARGO_TARGET_DIR` or `target/`).
pub fn target_dir() -> std::path::PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) => std::path::PathBuf::from(d),
        None => crate::workspace().join("target"),
    }
}

/// The line that says how to install it.
pub fn install_hint() -> String {
    format!(
        "the {TARGET} target is not installed: run `rustup target add {TARGET}` in this checkout"
    )
}

/// Whether `sysroot` (`rustc --print sysroot`) holds the target's `core`.
pub fn installed_in(sysroot: &Path) -> bool {
    let lib = sysroot.join("lib").join("rustlib").join(TARGET).join("lib");
    std::fs::read_dir(lib).is_ok_and(|mut d| {
        d.any(|e| {
            e.is_ok_and(|e| {
                let name = e.file_name();
                let name = name.to_string_lossy();
                name.starts_with("libcore-") && name.ends_with(".rlib")
            })
        })
    })
}

/// The toolchain's sysroot, as cargo's rustc in the workspace sees it.
fn sysroot() -> Option<std::path::PathBuf> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = Command::new(rustc)
        .current_dir(crate::workspace())
        .args(["--print", "sysroot"])
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().into())
}

/// Makes sure the target is installed (checked once per process): `Ok`
/// when it is or `rustup target add` installed it, else the reason and
/// [`install_hint`].
pub fn ensure() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let Some(root) = sysroot() else {
            // No rustc to ask: let cargo say what is wrong.
            return Ok(());
        };
        if installed_in(&root) {
            return Ok(());
        }
        eprintln!(
            "{TARGET} is missing from {}: `rustup target add {TARGET}` (once)…",
            root.display()
        );
        let added = Command::new("rustup")
            .current_dir(crate::workspace())
            .args(["target", "add", TARGET])
            .status()
            .is_ok_and(|s| s.success());
        if added && installed_in(&root) {
            Ok(())
        } else {
            Err(install_hint())
        }
    })
    .clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sysroot_without_the_targets_core_is_not_installed() {
        let dir = std::env::temp_dir().join(format!("mcu-target-{}", std::process::id()));
        let lib = dir.join("lib/rustlib").join(TARGET).join("lib");
        std::fs::create_dir_all(&lib).expect("temp dir");
        assert!(!installed_in(&dir), "an empty lib folder");
        std::fs::write(lib.join("libcore-0123abcd.rlib"), b"").expect("file");
        assert!(installed_in(&dir));
        let _ = std::fs::remove_dir_all(&dir);
        assert!(!installed_in(&dir), "no folder at all");
        assert!(install_hint().contains("rustup target add thumbv7em-none-eabihf"));
    }
}
