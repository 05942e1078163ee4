//! Choosing a sensor (`RRI_SENSOR`) rebuilds only what runs it (issue 35):
//! the crate `rri-active-sensor` holds the chosen file, and only the
//! firmware binary and `cargo sensor-host` depend on it; rri-firmware,
//! the host tools and the robot simulator do not, so switching sensors
//! never rebuilds them (it used to relink every host tool, ~30 s each).

use host_tests::workspace;
use std::path::Path;
use std::process::Command;

/// The crates `package` is built from (normal and build edges), one name
/// per line.
fn tree(package: &str) -> Vec<String> {
    let out = Command::new(env!("CARGO"))
        .current_dir(workspace())
        .args(["tree", "--offline", "-p", package, "-e", "normal,build"])
        .args(["--prefix", "none", "--format", "{p}"])
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .collect()
}

#[test]
fn only_what_runs_the_sensor_depends_on_the_chosen_one() {
    for package in ["rri-firmware", "rri-diag", "host-tests", "rri-robot"] {
        let crates = tree(package);
        assert!(
            !crates.iter().any(|c| c == "rri-active-sensor"),
            "{package} depends on rri-active-sensor: choosing a sensor would rebuild it"
        );
    }
    for package in ["rri-sensor", "rri-sensor-host"] {
        assert!(
            tree(package).iter().any(|c| c == "rri-active-sensor"),
            "{package} runs the sensor"
        );
    }
}

#[test]
fn only_the_active_sensors_build_script_reads_rri_sensor() {
    let mut readers = Vec::new();
    let mut stack = vec![workspace()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name();
            if path.is_dir() {
                if name != "target" && name != ".git" {
                    stack.push(path);
                }
            } else if name == "build.rs"
                && std::fs::read_to_string(&path).is_ok_and(|t| {
                    // Read (`setting("RRI_SENSOR")`) or tracked
                    // (`rerun-if-env-changed=RRI_SENSOR`), not named in a
                    // comment.
                    t.contains("\"RRI_SENSOR\"") || t.contains("=RRI_SENSOR")
                })
            {
                readers.push(path);
            }
        }
    }
    let relative: Vec<&Path> = readers
        .iter()
        .filter_map(|p| p.strip_prefix(workspace()).ok())
        .collect();
    assert_eq!(
        relative,
        [Path::new("firmware/active-sensor/build.rs")],
        "build scripts reading RRI_SENSOR"
    );
}
