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
    let http = port.trim() != "0";
    if http {
        println!("cargo:rustc-cfg=rri_http");
    }
    update_key(&workspace, http);
    image_version();
}

/// The image's version (`src/version.rs`): `RRI_IMAGE_VERSION` when set,
/// else the package's; refused unless it is major.minor.patch, each a
/// number below 2^16 (what an update file's trailer holds).
fn image_version() {
    println!("cargo:rerun-if-env-changed=RRI_IMAGE_VERSION");
    let (version, from) = match std::env::var("RRI_IMAGE_VERSION") {
        Ok(v) if !v.trim().is_empty() => (v.trim().to_string(), "RRI_IMAGE_VERSION"),
        _ => (
            std::env::var("CARGO_PKG_VERSION").expect("cargo sets CARGO_PKG_VERSION"),
            "rri-sensor's Cargo.toml",
        ),
    };
    let parts: Vec<&str> = version.split('.').collect();
    let numbers = parts.len() == 3
        && parts.iter().all(|p| {
            !p.is_empty()
                && p.len() <= 5
                && p.bytes().all(|b| b.is_ascii_digit())
                && p.parse::<u32>().is_ok_and(|n| n < 1 << 16)
        });
    if !numbers {
        panic!("{from}: {version:?} is not an image version: major.minor.patch, each a number below 65536 (e.g. RRI_IMAGE_VERSION=1.4.0)");
    }
    println!("cargo:rustc-env=RRI_IMAGE_VERSION={version}");
}

/// Update in the cell (issue 43): cfg `rri_update` when the board has
/// update partitions (hal-board's metadata) and the diagnostics service
/// is built in, and `$OUT_DIR/update_key.rs` with the key the firmware
/// checks update files with: the file `RRI_UPDATE_KEY` names (32 bytes,
/// `cargo sign-image -- keygen`), else `None` (and `OFF` for
/// `RRI_UPDATE_KEY=off`: no updates on any board); and the demonstration key
/// (`firmware/rri-update/demo-key/`), which `src/update.rs` takes on the
/// QEMU board alone.
fn update_key(workspace: &std::path::Path, http: bool) {
    println!("cargo::rustc-check-cfg=cfg(rri_update)");
    println!("cargo:rerun-if-env-changed=RRI_UPDATE_KEY");
    let board_has =
        board_takes_updates() && std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    if board_has && http {
        println!("cargo:rustc-cfg=rri_update");
    }
    let read = |path: &std::path::Path| -> [u8; 32] {
        println!("cargo:rerun-if-changed={}", path.display());
        let bytes = std::fs::read(path).unwrap_or_else(|e| {
            panic!(
                "RRI_UPDATE_KEY: {}: {e} (the public key `cargo sign-image -- keygen` made)",
                path.display()
            )
        });
        bytes.try_into().unwrap_or_else(|b: Vec<u8>| {
            panic!(
                "RRI_UPDATE_KEY: {}: {} bytes, an ed25519 public key is 32 (update-key.pub, not the secret update-key)",
                path.display(),
                b.len()
            )
        })
    };
    let setting = std::env::var_os("RRI_UPDATE_KEY").filter(|v| !v.is_empty());
    // `off`: no key at all, on every board: the service stays read-only.
    let off = setting.as_deref() == Some(std::ffi::OsStr::new("off"));
    let key = setting
        .filter(|_| !off)
        .map(|p| read(std::path::Path::new(&p)));
    let demo = read(&workspace.join("firmware/rri-update/demo-key/update-key.pub"));
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let text = format!(
                "/// The key `RRI_UPDATE_KEY` named at build time.\npub const KEY: Option<[u8; 32]> = {key:?};\n/// `RRI_UPDATE_KEY=off`: no updates, on any board.\npub const OFF: bool = {off};\n/// The QEMU board's demonstration key (anyone can sign with it).\npub const DEMO: [u8; 32] = {demo:?};\n"
    );
    let path = out.join("update_key.rs");
    if let Err(e) = std::fs::write(&path, text) {
        panic!("cannot write {}: {e}", path.display());
    }
}

include!("../update_cfg.rs");
