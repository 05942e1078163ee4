//! The simulator's command line as a user meets it: usage errors exit 2
//! with a message in the user's words (clap's, or ours for faults, output
//! paths and fonts), `--help` goes to stdout and exits 0. No sensor
//! needed: every case fails before the first message.

use std::path::PathBuf;

/// The manual's example, kept in the firmware.
fn gsi() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/gsi/GSI")
}

fn robot_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_robot"))
        .args(args)
        .output()
        .expect("robot runs")
}

#[test]
fn cli_bad_arguments_and_bad_gsi_exit_2_with_a_message() {
    let gsi = gsi();
    let gsi = gsi.to_str().expect("utf-8 path");
    for (args, says) in [
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--rate-ms", "5"],
            "multiple of 4",
        ),
        (vec!["--gsi", gsi], "--to"),
        (vec!["--to", "127.0.0.1:9"], "--gsi"),
        (vec!["--gsi", gsi, "--to", "nowhere"], "ADDR:PORT"),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--fault", "explode:1"],
            "no such fault",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--fault", "pause:10"],
            "pause:CYCLE:MS",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--fault", "drop"],
            "drop needs a percentage",
        ),
        (vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--cycles", "0"], "--cycles"),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--tcp", "--fault", "garbage:1"],
            "--fault garbage:1 only works over UDP (garbage, oversize and second-port need datagrams)",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--csv", "/nonexistent-dir/x.csv"],
            "--csv /nonexistent-dir/x.csv: No such file or directory",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--plot", "x.gif"],
            ".svg or .png",
        ),
        (
            vec!["--gsi", "/nonexistent/GSI", "--to", "127.0.0.1:9"],
            "cannot read",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--show", "AppData.X1,Distance"],
            "--show Distance: no such field in the reply <SensData> of device AnyDevice; available: EStr, AppData.X1,",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--show-csv", "x.csv"],
            "--show",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--show", "EStr", "--show-plot", "x.gif"],
            ".svg or .png",
        ),
    ] {
        let out = robot_cli(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}

#[test]
fn cli_help_goes_to_stdout_and_exits_0() {
    let out = robot_cli(&["--help"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0));
    assert!(
        stdout.contains("Usage:") && stdout.contains("--send"),
        "{stdout}"
    );
    assert!(out.stderr.is_empty());
}

#[test]
fn cli_a_missing_plot_font_is_an_error_not_a_silent_fallback() {
    let gsi = gsi();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_robot"))
        .args(["--gsi", gsi.to_str().expect("utf-8"), "--to", "127.0.0.1:9"])
        .args(["--plot", "/tmp/never-written.svg"])
        .env("RRI_PLOT_FONT", "/missing.ttf")
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("RRI_PLOT_FONT=/missing.ttf"), "{stderr}");
}
