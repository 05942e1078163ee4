//! Compiles the user's GSI configuration into the firmware's message
//! layouts (`$OUT_DIR/layout.rs`, included by `src/layout.rs`).
//!
//! Environment:
//! - `RRI_GSI_DIR`: the GSI folder (Settings.xml + one folder per device);
//!   relative paths are taken from the workspace root. Default: the manual's
//!   example kept in `firmware/gsi/GSI`.
//! - `RRI_DEVICE`: which CDP client of Settings.xml; optional when there is
//!   only one.
//! - `RRI_REAL_DECIMALS`, `RRI_TIME_DECIMALS`: decimals written for reals
//!   and times in sent messages (0..=6, default 3; M5).
//! - `RRI_CONTROLLER`: pin the controller (`ip` or `ip:port`).
//! - `RRI_SEND_PERIOD_MS`: periodic sends of the reply property for
//!   one-way streams.
//! - `RRI_REPLY`: the property every robot message is answered with (its
//!   Name or Alias; default the first property the device sends, M11).
//! - `RRI_PERIODIC`: other device properties sent on their own schedules,
//!   `Name=MS[,Name=MS…]` (multiples of 4 ms), for `SiGetCyclic`.
//! - `RRI_NETMASK` (prefix length 0..=32 or a dotted mask, default 24) and
//!   `RRI_GATEWAY` (IPv4, default none): the boards' network besides the
//!   device address from Description.xml (`$OUT_DIR/network.rs`).
//! - `RRI_HTTP_PORT`: the diagnostics service's TCP port on the boards
//!   (default 80; `0` compiles it out of the firmware binary).
//!
//! The sensor (`RRI_SENSOR`) is not chosen here but in
//! `firmware/active-sensor`, so that choosing it rebuilds only what runs
//! it.
//!
//! Every problem is reported as `file:line:col: error[rule]: …` and all of
//! them at once; the G6 quirks of the manual's example build with a warning.

// A build script may stop the build where cargo broke its own promises
// (OUT_DIR, the manifest's directory): the workspace's no-panic lints are
// for the code the boards run.
#![allow(clippy::expect_used)]

use gsi_config::setting;
use rri_vocabulary::{parse_ipv4, MAX_DECIMALS};
use std::path::{Path, PathBuf};

fn main() {
    let manifest =
        PathBuf::from(setting("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let workspace = manifest.parent().unwrap_or(&manifest).to_path_buf();

    for var in gsi_config::BUILD_SETTINGS {
        println!("cargo:rerun-if-env-changed={var}");
    }
    let gsi_config::Selection {
        dir: gsi_dir,
        device,
    } = gsi_config::Selection::from_env(&workspace);
    let mut errors = Vec::new();
    let real_decimals = decimals("RRI_REAL_DECIMALS", &mut errors);
    let time_decimals = decimals("RRI_TIME_DECIMALS", &mut errors);
    let controller = controller(&mut errors);
    let send_period_ms = send_period(&mut errors);
    let mut network = network(&mut errors);
    network.push_str(&http_port(&mut errors));
    network.push_str(&commit(&workspace));

    println!("cargo:rerun-if-changed={}", gsi_dir.display());
    let loaded = gsi_config::load(&gsi_dir, device.as_deref());
    let files = match &loaded {
        Ok(l) => &l.files,
        Err(f) => &f.files,
    };
    for f in files {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    let loaded = match loaded {
        Ok(l) => l,
        Err(failed) => {
            for d in &failed.diagnostics {
                report(d);
            }
            fail(&format!(
                "the GSI configuration in {} has errors (see above)",
                gsi_dir.display()
            ));
        }
    };
    for w in &loaded.warnings {
        report(w);
    }
    let reply = match setting("RRI_REPLY") {
        None => 0,
        Some(name) => gsi_codegen::device_property(&loaded.device, "RRI_REPLY", &name)
            .unwrap_or_else(|e| {
                errors.push(e);
                0
            }),
    };
    let periodic = match setting("RRI_PERIODIC") {
        None => Vec::new(),
        Some(text) => gsi_codegen::periodic(&loaded.device, &text, reply).unwrap_or_else(|e| {
            errors.push(e);
            Vec::new()
        }),
    };
    if !errors.is_empty() {
        for e in &errors {
            println!("cargo::error={e}");
        }
        fail("bad build settings");
    }

    let opts = gsi_codegen::Options {
        crate_path: "crate".into(),
        real_decimals,
        time_decimals,
        controller,
        send_period_ms,
        reply,
        periodic,
    };
    let source = match gsi_codegen::generate(&loaded.device, &opts) {
        Ok(s) => s,
        Err(diags) => {
            for d in &diags {
                report(d);
            }
            fail("the message layouts cannot be generated (see above)");
        }
    };
    let out_dir = PathBuf::from(setting("OUT_DIR").expect("cargo sets OUT_DIR"));
    for (name, text) in [("layout.rs", source), ("network.rs", network)] {
        let out = out_dir.join(name);
        if let Err(e) = std::fs::write(&out, text) {
            fail(&format!("cannot write {}: {e}", out.display()));
        }
    }
}

/// `RRI_HTTP_PORT` (default 80, 0 = the service compiled out: the
/// firmware binary's build script then sets no cfg `rri_http`), as a
/// constant for `network.rs`.
fn http_port(errors: &mut Vec<String>) -> String {
    let port = match setting("RRI_HTTP_PORT") {
        None => 80,
        Some(v) => v.trim().parse::<u16>().unwrap_or_else(|_| {
            errors.push(format!(
                "RRI_HTTP_PORT={v}: expected a TCP port 1..=65535, or 0 to leave the diagnostics service out"
            ));
            80
        }),
    };
    format!(
        "/// `RRI_HTTP_PORT`: the diagnostics service's TCP port (default 80; 0:\n\
         /// not compiled in).\n\
         pub const HTTP_PORT: u16 = {port};\n"
    )
}

/// The commit the firmware is built from (`git describe --always`), or
/// `unknown` outside a git checkout, for the diagnostics. (Not
/// `--dirty`: only a commit reruns this script, so an edit since would
/// not show.)
fn commit(workspace: &Path) -> String {
    let git = workspace.join(".git");
    for watched in ["HEAD", "logs/HEAD"] {
        let path = git.join(watched);
        if path.exists() {
            println!("cargo:rerun-if-changed={}", path.display());
        }
    }
    let described = std::process::Command::new("git")
        .args(["describe", "--always", "--abbrev=12"])
        .current_dir(workspace)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string());
    format!(
        "/// The commit the firmware was built from (`git describe --always`).\n\
         pub const COMMIT: &str = {described:?};\n"
    )
}

/// `RRI_NETMASK` and `RRI_GATEWAY`, as Rust constants for `network.rs`.
fn network(errors: &mut Vec<String>) -> String {
    let prefix = match setting("RRI_NETMASK") {
        None => 24,
        Some(v) => match (v.trim().parse::<u8>(), parse_ipv4(&v)) {
            (Ok(bits), _) if bits <= 32 => bits,
            (_, Some(mask))
                if u32::from_be_bytes(mask).leading_ones()
                    == u32::from_be_bytes(mask).count_ones() =>
            {
                u32::from_be_bytes(mask).count_ones() as u8
            }
            _ => {
                errors.push(format!(
                    "RRI_NETMASK={v}: expected a prefix length 0..=32 or a netmask such as 255.255.255.0"
                ));
                24
            }
        },
    };
    let gateway = match setting("RRI_GATEWAY") {
        None => "None".to_string(),
        Some(v) => match parse_ipv4(&v) {
            Some([a, b, c, d]) => format!("Some([{a}, {b}, {c}, {d}])"),
            None => {
                errors.push(format!(
                    "RRI_GATEWAY={v}: expected an IPv4 address, e.g. 192.168.125.1"
                ));
                "None".to_string()
            }
        },
    };
    format!(
        "/// `RRI_NETMASK` as a prefix length (default 24).\n\
         pub const PREFIX_LEN: u8 = {prefix};\n\
         /// `RRI_GATEWAY` (default none: the controller is on the device's own subnet).\n\
         pub const GATEWAY: Option<[u8; 4]> = {gateway};\n"
    )
}

fn decimals(var: &str, errors: &mut Vec<String>) -> u8 {
    match setting(var) {
        None => 3,
        Some(v) => match v.trim().parse::<u8>() {
            Ok(n) if n <= MAX_DECIMALS => n,
            _ => {
                errors.push(format!(
                    "{var}={v}: must be a number of decimals 0..={}",
                    MAX_DECIMALS
                ));
                3
            }
        },
    }
}

/// `RRI_CONTROLLER=ip[:port]`: pin the controller (only it is answered).
fn controller(errors: &mut Vec<String>) -> Option<([u8; 4], Option<u16>)> {
    let v = setting("RRI_CONTROLLER")?;
    let (ip, port) = match v.trim().split_once(':') {
        Some((ip, port)) => (ip, Some(port)),
        None => (v.trim(), None),
    };
    let ip = parse_ipv4(ip);
    let port = match port.map(|p| p.parse::<u16>()) {
        None => Ok(None),
        Some(Ok(p)) if p > 0 => Ok(Some(p)),
        Some(_) => Err(()),
    };
    match (ip, port) {
        (Some(ip), Ok(port)) => Some((ip, port)),
        _ => {
            errors.push(format!(
                "RRI_CONTROLLER={v}: expected an IPv4 address with an optional port, e.g. 192.168.125.1 or 192.168.125.1:3000"
            ));
            None
        }
    }
}

/// `RRI_SEND_PERIOD_MS`: a multiple of 4 ms (the controller's cycle), 0 = off.
fn send_period(errors: &mut Vec<String>) -> u32 {
    match setting("RRI_SEND_PERIOD_MS") {
        None => 0,
        Some(v) => match v.trim().parse::<u32>() {
            Ok(ms) if ms % 4 == 0 => ms,
            _ => {
                errors.push(format!(
                    "RRI_SEND_PERIOD_MS={v}: must be a multiple of 4 ms (0 = off)"
                ));
                0
            }
        },
    }
}

/// Errors stop the build (`cargo::error`), warnings show in cargo's output
/// (`cargo::warning`); both keep the `file:line:col: kind[rule]` form.
fn report(d: &gsi_config::Diagnostic) {
    if d.is_error() {
        println!("cargo::error={d}");
    } else {
        println!("cargo::warning={d}");
    }
}

fn fail(summary: &str) -> ! {
    eprintln!("{summary}");
    std::process::exit(1);
}
