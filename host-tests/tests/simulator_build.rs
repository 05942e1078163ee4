//! The robot simulator is built once, whatever the firmware's build
//! settings: it reads GSI folders at run time, so switching `RRI_GSI_DIR`
//! between a sensor terminal and a simulator terminal must not rebuild it
//! (it used to, ~25 s each switch). Then the binary so built, as a user
//! runs it, against the host sensor: every output written, exit 0.

use host_tests::sensor::Background;
use host_tests::{built_gsi, workspace};
use rri_firmware::layout;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Builds `rri-robot`'s binary in its own target directory with the given
/// build settings; the names of the artifacts cargo had to compile.
fn build(settings: &[(&str, &str)]) -> Vec<String> {
    let mut cmd = Command::new(env!("CARGO"));
    cmd.current_dir(workspace())
        .args(["build", "--offline", "-p", "rri-robot", "--bin", "robot"])
        .args(["--message-format", "json-render-diagnostics"])
        .env(
            "CARGO_TARGET_DIR",
            workspace().join("target/simulator-build"),
        );
    for var in ["RRI_GSI_DIR", "RRI_DEVICE", "RRI_REPLY", "RRI_PERIODIC"] {
        cmd.env_remove(var);
    }
    cmd.envs(settings.iter().copied());
    let out = cmd.output().expect("cargo runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["fresh"] == false)
        .filter_map(|m| m["target"]["name"].as_str().map(String::from))
        .collect()
}

/// The binary, built once for all tests of this file (after checking it is
/// not rebuilt when the firmware's settings change).
fn robot() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        build(&[]);
        let rebuilt = build(&[
            ("RRI_GSI_DIR", "host-tests/gsi/every-type/GSI"),
            ("RRI_REPLY", "Shared"),
            ("RRI_PERIODIC", "Offsets=32"),
        ]);
        assert!(
            rebuilt.is_empty(),
            "changing the firmware's build settings rebuilt {rebuilt:?}"
        );
        workspace().join("target/simulator-build/debug/robot")
    })
}

#[test]
fn the_simulator_does_not_depend_on_the_firmware_build() {
    assert!(robot().exists());
    let out = Command::new(env!("CARGO"))
        .current_dir(workspace())
        .args([
            "tree",
            "--offline",
            "-p",
            "rri-robot",
            "-e",
            "normal,build",
            "--prefix",
            "none",
        ])
        .output()
        .expect("cargo tree runs");
    let tree = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(tree.contains("rri-framing"), "{tree}");
    assert!(
        !tree.lines().any(|l| l.starts_with("rri-firmware")),
        "rri-robot depends on rri-firmware:\n{tree}"
    );
}

fn robot_cli(args: &[&str]) -> std::process::Output {
    Command::new(robot())
        .args(args)
        .output()
        .expect("robot runs")
}

struct HostSensor(Background);

impl HostSensor {
    fn start(tcp: bool, config: rri_firmware::engine::Config) -> HostSensor {
        HostSensor(Background::start(tcp, config).expect("sensor listening"))
    }
    fn stop(self) {
        self.0.stop().expect("sensor runs");
    }
}

#[test]
fn cli_writes_csv_json_plot_and_pcap_and_exits_0() {
    let sensor = HostSensor::start(false, layout::ENGINE_CONFIG);
    let dir = std::env::temp_dir().join(format!("rri-sim-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("mkdir");
    let p = |f: &str| dir.join(f).to_string_lossy().into_owned();
    let (gsi, _) = built_gsi();
    let to = sensor.0.addr.to_string();
    let (svg, pcap) = (p("run.svg"), p("run.pcap"));
    let (csv, json) = (p("run.csv"), p("run.json"));
    let mut args = vec![
        "--gsi",
        gsi.to_str().expect("utf-8"),
        "--to",
        &to,
        "--cycles",
        "200",
        "--no-pacing",
        "--no-progress",
        "--csv",
        &csv,
        "--json",
        &json,
        "--pcap",
        &pcap,
    ];
    // Plot labels need a TrueType font (CI installs fonts-dejavu-core).
    let font = Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").exists();
    if font {
        args.extend(["--plot", svg.as_str()]);
    }
    let out = robot_cli(&args);
    sensor.stop();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("sent 200  answered 200"), "{stdout}");
    let csv = std::fs::read_to_string(p("run.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 201);
    assert!(csv.starts_with("cycle,id,sent_us,reply_us,latency_us,late,verdict,property"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("run.json")).expect("json"))
            .expect("valid JSON");
    assert_eq!(json["answered"], 200);
    assert!(json["latency_us"]["p99"].as_u64().is_some());
    if font {
        let svg = std::fs::read_to_string(&svg).expect("svg");
        assert!(svg.contains("<svg") && svg.contains("Reply latency histogram (log scale)"));
        // The run in the title; median, p99, one cycle and the lost marked.
        for text in [
            "AnyDevice over UDP, 200 cycles lock-step",
            "median ",
            "p99 ",
            "one cycle",
            "lost (0)",
        ] {
            assert!(svg.contains(text), "{text}");
        }
    }
    let pcap = std::fs::read(p("run.pcap")).expect("pcap");
    assert_eq!(&pcap[..4], &0xa1b2_c3d4u32.to_le_bytes());
    // 400 records: 200 messages and 200 replies.
    let (mut off, mut n) = (24usize, 0);
    while off + 16 <= pcap.len() {
        let len = u32::from_le_bytes(pcap[off + 8..off + 12].try_into().expect("4 bytes")) as usize;
        off += 16 + len;
        n += 1;
    }
    assert_eq!((n, off), (400, pcap.len()));
    let _ = std::fs::remove_dir_all(&dir);
}
