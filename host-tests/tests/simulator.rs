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
use std::path::PathBuf;
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
    assert_eq!(r.stats.lost, u64::from(dropped - tail));
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
        r.stats.duplicates, s.duplicate_replies,
        "every duplicate answered (S3)"
    );
    assert_eq!(r.stats.answered, 1000 + s.duplicate_replies);
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
    // TimeOut 300 ms and a pause of 1 s: a stall of a loaded host (the
    // simulator's thread mid-run, or the test's after the run before it
    // stops the sensor) stays well inside TimeOut, so the one Error is
    // the pause's.
    let config = Config {
        timeout_ms: 300,
        ..layout::ENGINE_CONFIG
    };
    let (s, _, r) = faulty(vec![Fault::Pause { at: 100, ms: 1_000 }], 300, config);
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
    // An Id the controller never sent: echoing `id + 1` (a later message's
    // Id) let a reply delayed by a loaded host count as the late answer to
    // the next message, which broke the run of 31 (CI-like load: 1 run
    // in 4 failed).
    let (addr, stop) = fake_sensor(Duration::ZERO, |id| Some(reply(id ^ 0x8000_0000)));
    let s = against(addr, None, 100);
    stop.store(true, Ordering::Relaxed);
    // Tripping MaxLost on wrong Ids takes more than 30 of them in a row.
    assert!(s.wrong_id > 30, "{}", s.wrong_id);
    assert_eq!(s.answered, 0);
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

/// The host tools' aliases show cargo's own output: a first build takes a
/// minute, and the GSI warnings (G6) must reach the user.
#[test]
fn aliases_do_not_silence_cargo() {
    let config = std::fs::read_to_string(host_tests::workspace().join(".cargo/config.toml"))
        .expect("read .cargo/config.toml");
    for line in config.lines().filter(|l| l.contains("\"run ")) {
        assert!(
            !line.contains(" -q "),
            "an alias runs cargo quietly: {line}"
        );
    }
}

/// One definition of late: the summary's count is the CSV's (reply minus
/// actual send, beyond one cycle), also for messages held back by a
/// `reorder` fault.
#[test]
fn summary_late_equals_the_csv_late_and_injected_faults_are_reported() {
    let sensor = HostSensor::start(false, layout::ENGINE_CONFIG);
    let mut o = options(sensor.0.addr);
    o.pacing = true;
    o.cycles = 300;
    o.faults = vec![
        Fault::Reorder(10.0),
        Fault::Drop(2.0),
        Fault::Duplicate(2.0),
    ];
    o.seed = 3;
    let (s, cycles) = simulate(&o);
    std::thread::sleep(Duration::from_millis(50));
    let r = sensor.stop();
    let csv_late = cycles
        .iter()
        .filter(|c| c.latency_us().is_some_and(|l| l > 4000))
        .count() as u64;
    assert_eq!(s.late, csv_late);
    let dropped = cycles.iter().filter(|c| c.dropped_by_fault).count() as u64;
    assert_eq!(s.injected.dropped, dropped);
    assert!(s.injected.reordered > 10, "{:?}", s.injected);
    assert_eq!(s.injected.duplicated, r.stats.duplicates);
    assert_eq!(s.injected.duplicated, s.duplicate_replies);
    let mut text = Vec::new();
    s.print(&mut text).expect("print");
    let text = String::from_utf8(text).expect("utf-8");
    assert!(
        text.contains(&format!(
            "injected: dropped {dropped}  duplicated {}  reordered {}",
            s.injected.duplicated, s.injected.reordered
        )),
        "{text}"
    );
}

#[test]
fn no_pacing_is_said_in_the_summary() {
    let sensor = HostSensor::start(false, layout::ENGINE_CONFIG);
    let mut o = options(sensor.0.addr);
    o.cycles = 10;
    let (s, _) = simulate(&o);
    sensor.stop();
    let mut text = Vec::new();
    s.print(&mut text).expect("print");
    let text = String::from_utf8(text).expect("utf-8");
    assert!(text.contains("lock-step, no pacing"), "{text}");
    assert!(!text.contains("every 4 ms"), "{text}");
}

#[test]
fn a_sensor_built_for_another_device_is_named_as_such() {
    // Another device's SensData (fields this layout does not have), then
    // another device's root altogether.
    for (answer, says) in [
        (
            r#"<SensData Id="{id}" Ts="1.0"><Valid>TRUE</Valid></SensData>"#,
            "the reply <SensData> does not match device AnyDevice's layout (unexpected element <Valid>): is the sensor built for another device?",
        ),
        (
            r#"<Offsets Id="{id}" Ts="1.0" X1="0" X2="0" X3="0"/>"#,
            "a reply <Offsets> is no message device AnyDevice sends (expected <SensData>): is the sensor built for another device, or with another RRI_REPLY (--reply)?",
        ),
    ] {
        let (addr, stop) = fake_sensor(Duration::ZERO, move |id| {
            Some(answer.replace("{id}", &id.to_string()))
        });
        let mut o = options(addr);
        o.cycles = 5;
        let (s, _) = simulate(&o);
        stop.store(true, Ordering::Relaxed);
        // Every reply is malformed; the fifth may still be on its way when
        // the run ends on a loaded host.
        assert!((1..=5).contains(&s.malformed), "{}", s.malformed);
        assert_eq!(s.answered, 0);
        let failure = s.failure().expect("fails");
        assert!(failure.contains(says), "{failure}");
    }
}

#[test]
fn nothing_listening_gets_a_hint() {
    let free = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let to = free.local_addr().expect("addr");
    drop(free);
    let mut o = options(to);
    o.pacing = true;
    o.cycles = 40; // MaxLost = 30 of the manual's device
    let (s, _) = simulate(&o);
    let failure = s.failure().expect("fails");
    assert!(
        failure.contains(&format!(
            "no reply at all from {to}: is a sensor for device AnyDevice listening there?"
        )),
        "{failure}"
    );
}

/// Every IPv4, UDP and TCP checksum in the captures is right (Wireshark
/// validates them), and a TCP capture opens with SYN, SYN-ACK, ACK and
/// closes with FIN, FIN, ACK.
#[test]
fn pcap_checksums_and_the_tcp_handshake() {
    use smoltcp::wire::{IpAddress, Ipv4Packet, TcpPacket, UdpPacket};
    for tcp in [false, true] {
        let sensor = HostSensor::start(tcp, layout::ENGINE_CONFIG);
        let dir = std::env::temp_dir().join(format!("rri-pcap-{}-{tcp}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("mkdir");
        let mut o = options(sensor.0.addr);
        o.tcp = tcp;
        o.cycles = 50;
        o.pcap = Some(dir.join("run.pcap"));
        let (s, _) = simulate(&o);
        sensor.stop();
        assert!(s.passed(), "{:?}", s.failure());
        let pcap = std::fs::read(dir.join("run.pcap")).expect("pcap");
        let mut off = 24;
        let mut flags = Vec::new();
        while off + 16 <= pcap.len() {
            let len = u32::from_le_bytes(pcap[off + 8..off + 12].try_into().expect("4")) as usize;
            let ip = Ipv4Packet::new_checked(&pcap[off + 16..off + 16 + len]).expect("IPv4");
            assert!(ip.verify_checksum(), "IPv4 checksum");
            let (src, dst) = (
                IpAddress::Ipv4(ip.src_addr()),
                IpAddress::Ipv4(ip.dst_addr()),
            );
            if tcp {
                let t = TcpPacket::new_checked(ip.payload()).expect("TCP");
                assert!(t.verify_checksum(&src, &dst), "TCP checksum");
                flags.push((t.syn(), t.ack(), t.fin(), t.payload().len()));
            } else {
                let u = UdpPacket::new_checked(ip.payload()).expect("UDP");
                assert_ne!(u.checksum(), 0, "a real UDP checksum");
                assert!(u.verify_checksum(&src, &dst), "UDP checksum");
            }
            off += 16 + len;
        }
        assert_eq!(off, pcap.len());
        if tcp {
            assert_eq!(
                flags.len(),
                6 + 100,
                "handshake, 50 messages and 50 replies, close"
            );
            assert_eq!(
                &flags[..3],
                [
                    (true, false, false, 0),
                    (true, true, false, 0),
                    (false, true, false, 0)
                ]
            );
            assert!(
                flags[3..103].iter().all(|f| f.1 && f.3 > 0),
                "data segments ACK"
            );
            assert_eq!(
                &flags[103..],
                [
                    (false, true, true, 0),
                    (false, true, true, 0),
                    (false, true, false, 0)
                ]
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The READMEs' example outputs go under target/, and outputs written into
/// the checkout's root are ignored by git. The top-level README is the short
/// door (at most 400 lines) and each crate's README holds its long guides.
#[test]
fn example_outputs_stay_out_of_the_checkout() {
    let workspace = host_tests::workspace();
    let door = std::fs::read_to_string(workspace.join("README.md")).expect("README.md");
    let lines = door.lines().count();
    assert!(
        lines <= 400,
        "README.md has {lines} lines: the door is at most 400"
    );
    for guide in [
        "firmware/README.md",
        "hal-board/README.md",
        "host-tests/README.md",
    ] {
        assert!(workspace.join(guide).is_file(), "{guide} is missing");
    }
    for path in [
        "README.md",
        "firmware/README.md",
        "hal-board/README.md",
        "host-tests/README.md",
        "firmware/rri-diag/README.md",
    ] {
        let readme = std::fs::read_to_string(workspace.join(path)).expect(path);
        for line in readme.lines().filter(|l| l.starts_with("cargo robot ")) {
            for flag in ["--plot ", "--csv ", "--pcap ", "--json "] {
                if let Some(rest) = line.split(flag).nth(1) {
                    assert!(rest.starts_with("target/"), "{path}: {line}");
                }
            }
        }
    }
    let ignore =
        std::fs::read_to_string(host_tests::workspace().join(".gitignore")).expect(".gitignore");
    for pattern in ["/*.png", "/*.svg", "/*.csv", "/*.pcap", "/*.json"] {
        assert!(ignore.lines().any(|l| l == pattern), "{pattern}");
    }
}
