//! The firmware's build script as a user meets it: `cargo build` with
//! `RRI_GSI_DIR` / `RRI_DEVICE` set. Runs a nested cargo build in its own
//! target directory (offline: the outer build already fetched every crate).

use host_tests::{shared_rri, workspace};
use std::process::{Command, Output};

fn build_firmware(gsi_dir: &std::path::Path, device: Option<&str>) -> Output {
    build_firmware_with(gsi_dir, device, &[])
}

fn build_firmware_with(
    gsi_dir: &std::path::Path,
    device: Option<&str>,
    settings: &[(&str, &str)],
) -> Output {
    let mut cmd = Command::new(env!("CARGO"));
    for var in ["RRI_REPLY", "RRI_PERIODIC", "RRI_SEND_PERIOD_MS"] {
        cmd.env_remove(var);
    }
    cmd.envs(settings.iter().copied());
    cmd.current_dir(workspace())
        .args(["build", "--offline", "-q", "-p", "rri-firmware", "--lib"])
        .env(
            "CARGO_TARGET_DIR",
            workspace().join("target/build-script-tests"),
        )
        .env("RRI_GSI_DIR", gsi_dir)
        .env_remove("RRI_REAL_DECIMALS")
        .env_remove("RRI_TIME_DECIMALS");
    match device {
        Some(d) => cmd.env("RRI_DEVICE", d),
        None => cmd.env_remove("RRI_DEVICE"),
    };
    cmd.output().expect("cargo runs")
}

#[test]
fn g1_real_world_without_device_fails_listing_clients_then_builds_with_it() {
    let dir = shared_rri().join("real-world/GSI");
    let out = build_firmware(&dir, None);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail:\n{stderr}");
    assert!(
        stderr.contains("Settings.xml:5:2: error[G1]: Settings.xml lists 3 CDP clients (NACMaster, NACMasterUdp, UdpTest)"),
        "{stderr}"
    );

    let out = build_firmware(&dir, Some("UdpTest"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "UdpTest must build:\n{stderr}");
}

#[test]
fn a_broken_configuration_fails_the_build_with_every_error() {
    let src = workspace().join("firmware/gsi/GSI");
    let dir = std::env::temp_dir().join(format!("rri-build-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("AnyDevice")).expect("mkdir");
    for f in ["Settings.xml", "AnyDevice/Description.xml"] {
        std::fs::copy(src.join(f), dir.join(f)).expect("copy");
    }
    let cfg = std::fs::read_to_string(src.join("AnyDevice/Configuration.xml")).expect("read");
    let cfg = cfg
        .replace("Name=\"FeedbackTime\"", "Name=\"FeedbackTimeStamp\"")
        .replace("Type=\"Joint\"", "Type=\"Joins\"");
    std::fs::write(dir.join("AnyDevice/Configuration.xml"), cfg).expect("write");

    let out = build_firmware(&dir, None);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail:\n{stderr}");
    let cfg = dir.join("AnyDevice/Configuration.xml");
    for expected in [
        format!(
            "{}:16:14: error[G4]: field name \"FeedbackTimeStamp\" has 17 characters (max 16)",
            cfg.display()
        ),
        format!("{}:20:36: error[G5]: unknown type \"Joins\"", cfg.display()),
        format!("{}:15:7: warning[G6]: stray text", cfg.display()),
    ] {
        assert!(
            stderr.contains(&expected),
            "missing `{expected}` in:\n{stderr}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn m11_rri_reply_and_rri_periodic_errors_name_the_choices_then_a_good_pair_builds() {
    let dir = workspace().join("host-tests/gsi/every-type/GSI");
    let out = build_firmware_with(
        &dir,
        None,
        &[("RRI_REPLY", "RsRobData"), ("RRI_PERIODIC", "Offsets=30")],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail:\n{stderr}");
    for expected in [
        "RRI_REPLY=RsRobData: property \"RsRobData\" is Flag=\"WriteOnly\": the device never sends it; choose one the device sends: RsSensData, Shared, Speed, Offsets",
        "RRI_PERIODIC: Offsets=30: the period must be a positive multiple of 4 ms",
    ] {
        assert!(stderr.contains(expected), "missing `{expected}` in:\n{stderr}");
    }

    let out = build_firmware_with(
        &dir,
        None,
        &[("RRI_REPLY", "Shared"), ("RRI_PERIODIC", "Offsets=32")],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "must build:\n{stderr}");
}
