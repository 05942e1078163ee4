//! `cargo hil` on a machine without a board: before building anything it
//! says in one line what is missing and exits 4; with a probe listed it
//! goes on. probe-rs is replaced by a missing path or a small script
//! (`PROBE_RS`), so no probe-rs install or hardware is needed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn hil(args: &[&str], probe_rs: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .env("PROBE_RS", probe_rs)
        .output()
        .expect("run hil")
}

/// A `probe-rs` that answers `list` with `listing`.
fn fake_probe_rs(name: &str, listing: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = std::env::temp_dir().join(format!("rri-hil-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("probe-rs");
    std::fs::write(
        &path,
        format!("#!/bin/sh\n[ \"$1\" = list ] && printf '{listing}' && exit 0\nexit 1\n"),
    )
    .unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path
}

fn one_line(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    err
}

#[test]
fn without_probe_rs_it_says_how_to_install_it() {
    let out = hil(&["--board", "f767"], Path::new("/nonexistent/probe-rs"));
    assert_eq!(out.status.code(), Some(4));
    let err = one_line(&out);
    assert!(err.contains("probe-rs is not installed"), "{err}");
    assert!(
        err.contains("cargo install probe-rs-tools --locked"),
        "{err}"
    );
}

#[test]
fn without_a_probe_it_says_to_connect_one() {
    let probe_rs = fake_probe_rs("none", "No debug probes were found.\\n");
    let out = hil(&["--board", "h743"], &probe_rs);
    assert_eq!(out.status.code(), Some(4));
    let err = one_line(&out);
    assert!(err.contains("no debug probe found"), "{err}");
    assert!(err.contains("ST-LINK"), "{err}");
    // Another probe than the one asked for is not enough either.
    let probe_rs = fake_probe_rs(
        "other",
        "The following debug probes were found:\\n[0]: STLink V3 -- 0483:374e:0042 (ST-LINK)\\n",
    );
    let out = hil(&["--board", "f767", "--probe", "0483:374b"], &probe_rs);
    assert_eq!(out.status.code(), Some(4));
    assert!(one_line(&out).contains("no debug probe matching `0483:374b`"));
}

#[test]
fn with_a_probe_it_goes_on() {
    let probe_rs = fake_probe_rs(
        "one",
        "The following debug probes were found:\\n[0]: STLink V2-1 -- 0483:374b:066D (ST-LINK)\\n",
    );
    // Past the probe check, to the image (which does not exist): exit 1,
    // not 4, and nothing built.
    let out = hil(
        &["--board", "f767", "--elf", "/nonexistent/rri-sensor.elf"],
        &probe_rs,
    );
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/rri-sensor.elf"));
}
