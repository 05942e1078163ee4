//! `cargo sensor-host`'s command line: help, bad flags, and an address
//! blamed on where it came from.

#[test]
fn sensor_host_help_goes_to_stdout_and_bad_flags_exit_2() {
    let bin = env!("CARGO_BIN_EXE_sensor-host");
    let out = std::process::Command::new(bin)
        .arg("--help")
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0));
    assert!(stdout.contains("Usage:"), "{stdout}");
    assert!(out.stderr.is_empty());
    let out = std::process::Command::new(bin)
        .args(["--udp", "--tcp"])
        .output()
        .expect("runs");
    assert_eq!(
        out.status.code(),
        Some(2),
        "conflicting flags are a usage error"
    );
}

/// An address given with `--listen` that is not this machine's is blamed on
/// `--listen`, not on the configuration.
#[test]
fn sensor_host_blames_the_address_where_it_came_from() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sensor-host"))
        .args(["--listen", "10.1.2.3:3002", "--udp"])
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("on 10.1.2.3:3002 (--listen)")
            && stderr.contains("--listen is not an address of this machine"),
        "{stderr}"
    );
    assert!(!stderr.contains("configured"), "{stderr}");
}
