//! The robot simulator against the host sensor (the firmware's engine over
//! std sockets), over loopback on ephemeral ports: clean runs over UDP and
//! TCP, every `--fault` kind with the device's counters and states and the
//! simulator's verdict checked against S1–S3, and deliberately wrong
//! sensors that must trip the simulator's supervision for the right reason.

use host_tests::built_gsi;
use host_tests::robot::fault::Fault;
use host_tests::robot::report::{Cycle, Summary};
use host_tests::robot::{run, RobotOptions};
use host_tests::sensor::{self, SensorReport};
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::{Config, ErrorCode, SensorState};
use rri_firmware::layout;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// The host sensor in a thread; a run that ended in an error fails the test.
struct HostSensor(sensor::Background);

impl HostSensor {
    fn start(tcp: bool, config: Config) -> HostSensor {
        HostSensor(sensor::Background::start(tcp, config).expect("sensor listening"))
    }

    fn stop(self) -> SensorReport {
        self.0.stop().expect("sensor runs")
    }
}

fn options(to: SocketAddr) -> RobotOptions {
    let (gsi, device) = built_gsi();
    let mut o = RobotOptions::new(gsi, to);
    o.device = device;
    o.pacing = false;
    o
}

fn simulate(o: &RobotOptions) -> (Summary, Vec<Cycle>) {
    let device = host_tests::robot::load(o).expect("GSI loads");
    run(o, &device, &mut std::io::sink()).expect("simulation runs")
}

fn clean_run(tcp: bool) {
    let sensor = HostSensor::start(tcp, layout::ENGINE_CONFIG);
    let mut o = options(sensor.0.addr);
    o.tcp = tcp;
    o.cycles = 2000;
    let (s, _) = simulate(&o);
    let report = sensor.stop();
    assert!(s.passed(), "{:?}", s.failure());
    assert_eq!(
        (s.sent, s.answered, s.lost, s.wrong_id, s.malformed),
        (2000, 2000, 0, 0, 0)
    );
    assert_eq!(report.stats.answered, 2000);
    assert_eq!((report.stats.lost, report.stats.dropped_decode), (0, 0));
    if tcp {
        assert_eq!(
            report.state,
            SensorState::Closed,
            "the simulator closed the connection"
        );
    } else {
        assert_eq!(report.state, SensorState::Operating);
    }
}

#[test]
fn simulator_and_host_sensor_2000_cycles_over_udp() {
    clean_run(false);
}

#[test]
fn simulator_and_host_sensor_2000_cycles_over_tcp() {
    clean_run(true);
}

/// A run with faults against the host sensor.
fn faulty(faults: Vec<Fault>, cycles: u64, config: Config) -> (Summary, Vec<Cycle>, SensorReport) {
    let sensor = HostSensor::start(false, config);
    let mut o = options(sensor.0.addr);
    o.cycles = cycles;
    o.faults = faults;
    o.seed = 7;
    let (s, c) = simulate(&o);
    // Let the last datagrams (extras after the final message) arrive.
    std::thread::sleep(Duration::from_millis(50));
    (s, c, sensor.stop())
}

#[test]
fn fault_drop_shows_as_lost_ids_on_the_device_s3() {
    let (s, cycles, r) = faulty(vec![Fault::Drop(5.0)], 1000, layout::ENGINE_CONFIG);
    let dropped = cycles.iter().filter(|c| c.dropped_by_fault).count() as u32;
    assert!(dropped > 20, "{dropped}");
    // Ids skipped by the robot are gaps to the device, unless the very last
    // ones were dropped (no later message shows the gap).
    let tail = cycles
        .iter()
        .rev()
        .take_while(|c| c.dropped_by_fault)
        .count() as u32;
    assert_eq!(r.stats.lost, dropped - tail);
    assert_eq!(r.stats.max_lost_exceeded, 0);
    assert_eq!(r.state, SensorState::Operating);
    assert!(s.passed(), "{:?}", s.failure());
    assert_eq!(s.sent, 1000 - u64::from(dropped));
}

#[test]
fn fault_duplicate_is_answered_twice_and_counted_s3() {
    let (s, _, r) = faulty(vec![Fault::Duplicate(5.0)], 1000, layout::ENGINE_CONFIG);
    assert!(s.duplicate_replies > 20);
    assert_eq!(
        u64::from(r.stats.duplicates),
        s.duplicate_replies,
        "every duplicate answered (S3)"
    );
    assert_eq!(u64::from(r.stats.answered), 1000 + s.duplicate_replies);
    assert!(s.passed(), "{:?}", s.failure());
}

#[test]
fn fault_reorder_is_counted_and_not_lost_s3() {
    let (s, _, r) = faulty(vec![Fault::Reorder(5.0)], 1000, layout::ENGINE_CONFIG);
    assert!(r.stats.reordered > 20, "{}", r.stats.reordered);
    assert_eq!(r.stats.lost, 0, "a late message fills its gap");
    assert_eq!(s.answered, 1000);
    assert!(s.passed(), "{:?}", s.failure());
}

#[test]
fn fault_pause_longer_than_timeout_puts_the_device_in_error_and_back_s2() {
    let config = Config {
        timeout_ms: 100,
        ..layout::ENGINE_CONFIG
    };
    let (s, _, r) = faulty(vec![Fault::Pause { at: 100, ms: 300 }], 300, config);
    let states: Vec<_> = r.states.iter().map(|(_, st, e)| (*st, *e)).collect();
    assert_eq!(
        states,
        vec![
            (SensorState::Undefined, None),
            (SensorState::Connected, None),
            (SensorState::Operating, None),
            (SensorState::Error, Some(ErrorCode::Communication)),
            (SensorState::Operating, None),
        ]
    );
    assert_eq!(r.stats.timeouts, 1);
    assert!(
        s.passed(),
        "the controller sent nothing, so waited for nothing: {:?}",
        s.failure()
    );
}

#[test]
fn fault_garbage_is_dropped_and_counted_by_kind() {
    let (s, _, r) = faulty(vec![Fault::Garbage(5.0)], 1000, layout::ENGINE_CONFIG);
    assert!(r.stats.dropped_decode > 20);
    assert_eq!(r.stats.decode_errors_of(DecodeErrorKind::NotUtf8), 0);
    assert_eq!(r.stats.received, 1000 + r.stats.dropped_decode);
    assert_eq!(s.answered, 1000);
    assert!(s.passed(), "{:?}", s.failure());
}

#[test]
fn fault_oversize_is_rejected_as_too_long() {
    let (s, _, r) = faulty(vec![Fault::Oversize(5.0)], 1000, layout::ENGINE_CONFIG);
    let too_long = r.stats.decode_errors_of(DecodeErrorKind::TooLong);
    assert!(too_long > 20, "{too_long}");
    assert_eq!(too_long, r.stats.dropped_decode);
    assert!(s.passed(), "{:?}", s.failure());
}

#[test]
fn fault_second_source_port_takes_over_at_once() {
    let (s, cycles, r) = faulty(
        vec![Fault::SecondPort { from: 500 }],
        1000,
        layout::ENGINE_CONFIG,
    );
    assert_eq!(r.stats.port_takeovers, 1);
    assert_eq!(r.stats.dropped_foreign, 0);
    assert_eq!(s.answered, 1000, "replies follow the new port");
    assert!(cycles[999].reply_us.is_some());
    assert!(s.passed(), "{:?}", s.failure());
}

// --- deliberately wrong sensors ------------------------------------------------

/// A reply the layout accepts, with the given Id.
fn reply(id: u32) -> String {
    let app: String = (1..=18).map(|i| format!(" X{i}=\"0.000\"")).collect();
    format!("<SensData Id=\"{id}\" Ts=\"0.000\"><EStr>x</EStr><AppData{app}/></SensData>")
}

/// A UDP "sensor" that answers each message with `answer(id)` after
/// `delay`, or not at all.
fn fake_sensor(
    delay: Duration,
    answer: impl Fn(u32) -> Option<String> + Send + 'static,
) -> (SocketAddr, Arc<AtomicBool>) {
    let sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
    sock.set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    let addr = sock.local_addr().expect("addr");
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 65536];
        while !flag.load(Ordering::Relaxed) {
            if let Ok((n, from)) = sock.recv_from(&mut buf) {
                let text = String::from_utf8_lossy(&buf[..n]);
                let id: u32 = text
                    .split("Id=\"")
                    .nth(1)
                    .and_then(|r| r.split('"').next())
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(0);
                std::thread::sleep(delay);
                if let Some(r) = answer(id) {
                    let _ = sock.send_to(r.as_bytes(), from);
                }
            }
        }
    });
    (addr, stop)
}

fn against(addr: SocketAddr, gsi: Option<PathBuf>, cycles: u64) -> Summary {
    let mut o = options(addr);
    if let Some(g) = gsi {
        o.gsi = g;
        o.device = None;
    }
    o.pacing = true;
    o.cycles = cycles;
    simulate(&o).0
}

#[test]
fn wrong_id_echo_trips_the_verdict_m8() {
    let (addr, stop) = fake_sensor(Duration::ZERO, |id| Some(reply(id.wrapping_add(1))));
    let s = against(addr, None, 100);
    stop.store(true, Ordering::Relaxed);
    // A few replies may count as late rather than wrong on a loaded machine.
    assert!(s.wrong_id >= 90, "{}", s.wrong_id);
    assert!(!s.passed());
    let reason = s.supervision_tripped.unwrap_or_default();
    assert!(
        reason.contains("MaxLost = 30") && reason.contains("wrong Id"),
        "{reason}"
    );
}

#[test]
fn silent_sensor_trips_max_lost_s1() {
    let (addr, stop) = fake_sensor(Duration::ZERO, |_| None);
    let s = against(addr, None, 100);
    stop.store(true, Ordering::Relaxed);
    assert_eq!(s.answered, 0);
    let reason = s.supervision_tripped.clone().unwrap_or_default();
    assert!(
        reason.contains("MaxLost = 30") && reason.contains("no reply"),
        "{reason}"
    );
}

#[test]
fn late_sensor_is_counted_late_and_trips_max_lost_s1() {
    let (addr, stop) = fake_sensor(Duration::from_millis(6), |id| Some(reply(id)));
    let s = against(addr, None, 100);
    stop.store(true, Ordering::Relaxed);
    assert!(s.late > 30, "{}", s.late);
    assert_eq!(s.wrong_id + s.malformed, 0);
    let reason = s.supervision_tripped.unwrap_or_default();
    assert!(
        reason.contains("MaxLost") && reason.contains("later than one cycle"),
        "{reason}"
    );
}

/// A copy of the default GSI folder with other supervision settings.
fn gsi_with(dir_name: &str, timeout_ms: u32, max_lost: u32, dry_run: bool) -> PathBuf {
    let (src, _) = built_gsi();
    let dir = std::env::temp_dir().join(format!("rri-sim-{}-{dir_name}", std::process::id()));
    let device = std::fs::read_dir(&src)
        .expect("gsi")
        .filter_map(|e| e.ok())
        .find(|e| e.path().is_dir())
        .expect("a device folder")
        .file_name();
    std::fs::create_dir_all(dir.join(&device)).expect("mkdir");
    std::fs::copy(src.join("Settings.xml"), dir.join("Settings.xml")).expect("copy");
    std::fs::copy(
        src.join(&device).join("Configuration.xml"),
        dir.join(&device).join("Configuration.xml"),
    )
    .expect("copy");
    let d = std::fs::read_to_string(src.join(&device).join("Description.xml")).expect("read");
    let start = d.find("<Settings>").expect("settings");
    let end = d.find("</Settings>").expect("settings") + "</Settings>".len();
    let settings = format!("<Settings><TimeOut>{timeout_ms}</TimeOut><MaxLost>{max_lost}</MaxLost><DryRun>{dry_run}</DryRun></Settings>");
    std::fs::write(
        dir.join(&device).join("Description.xml"),
        format!("{}{settings}{}", &d[..start], &d[end..]),
    )
    .expect("write");
    dir
}

#[test]
fn sensor_that_stops_answering_trips_timeout_s1() {
    let answered = Arc::new(std::sync::atomic::AtomicU32::new(0));
    let count = answered.clone();
    let (addr, stop) = fake_sensor(Duration::ZERO, move |id| {
        (count.fetch_add(1, Ordering::Relaxed) < 10).then(|| reply(id))
    });
    let gsi = gsi_with("timeout", 100, 100_000, false);
    let s = against(addr, Some(gsi.clone()), 100);
    stop.store(true, Ordering::Relaxed);
    let _ = std::fs::remove_dir_all(&gsi);
    assert_eq!(s.answered, 10);
    let reason = s.supervision_tripped.unwrap_or_default();
    assert!(reason.contains("TimeOut = 100 ms"), "{reason}");
}

#[test]
fn dry_run_never_trips_s1() {
    let (addr, stop) = fake_sensor(Duration::ZERO, |_| None);
    let gsi = gsi_with("dryrun", 100, 0, true);
    let s = against(addr, Some(gsi.clone()), 60);
    stop.store(true, Ordering::Relaxed);
    let _ = std::fs::remove_dir_all(&gsi);
    assert_eq!((s.answered, s.lost), (0, 60));
    assert!(s.passed(), "{:?}", s.failure());
}

// --- the command line ----------------------------------------------------------

fn robot_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_robot"))
        .args(args)
        .output()
        .expect("robot runs")
}

#[test]
fn cli_bad_arguments_and_bad_gsi_exit_2_with_a_message() {
    let gsi = built_gsi().0;
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
            "unknown",
        ),
        (
            vec!["--gsi", gsi, "--to", "127.0.0.1:9", "--plot", "x.gif"],
            ".svg or .png",
        ),
        (
            vec!["--gsi", "/nonexistent/GSI", "--to", "127.0.0.1:9"],
            "cannot read",
        ),
    ] {
        let out = robot_cli(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
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
    assert!(csv.starts_with("cycle,id,sent_us,reply_us,latency_us,late,verdict"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("run.json")).expect("json"))
            .expect("valid JSON");
    assert_eq!(json["answered"], 200);
    assert!(json["latency_us"]["p99"].as_u64().is_some());
    if font {
        let svg = std::fs::read_to_string(&svg).expect("svg");
        assert!(svg.contains("<svg") && svg.contains("Reply latency histogram"));
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
