//! `--replay` against the host sensor, as a user meets it: captures made
//! by tcpdump and tshark (`host-tests/captures/make.sh`: UDP over
//! Ethernet and Linux cooked framing, TCP, IPv4 fragments, pcap and
//! pcapng, with unrelated traffic) replay closed-loop with every reply the
//! same as the recorded one but for the sensor's live values; the same
//! replay without ignoring them finds the differences (exit 1); the
//! simulator's own `--pcap` output, pcap and pcapng, replays with none; a
//! message the recorded sensor answered and ours refuses is the headline,
//! with the firmware decoder's verdict.

use host_tests::robot::pcap::{write_pcap, Packet};
use host_tests::robot::replay::{compare::Rules, Outcome, Pace, ReplayOptions};
use host_tests::robot::{self, RobotOptions};
use host_tests::sensor::Background;
use rri_firmware::layout;
use std::path::PathBuf;

fn gsi() -> PathBuf {
    host_tests::workspace().join("firmware/gsi/GSI")
}

fn fixture(name: &str) -> PathBuf {
    host_tests::workspace()
        .join("host-tests/captures")
        .join(name)
}

/// The distance sensor's values move with time: they are live, not
/// recorded.
fn live() -> Rules {
    Rules {
        ignore: vec!["AppData".into(), "EStr".into()],
        ..Rules::default()
    }
}

fn replay(file: PathBuf, rules: Rules, tcp: bool) -> robot::report::Summary {
    replay_of(file, rules, tcp, None)
}

/// [`replay`] of the conversation whose device end is `conversation`.
fn replay_of(
    file: PathBuf,
    rules: Rules,
    tcp: bool,
    conversation: Option<std::net::SocketAddrV4>,
) -> robot::report::Summary {
    let sensor = Background::start(tcp, layout::ENGINE_CONFIG).expect("the host sensor starts");
    let device = gsi_config::load(&gsi(), None).unwrap().device;
    let mut opts = RobotOptions::new(gsi(), sensor.addr);
    opts.replay = Some(ReplayOptions {
        file,
        rules,
        pace: Pace::Recorded,
        conversation,
        ..ReplayOptions::default()
    });
    let (s, _) = robot::run(&opts, &device, &mut std::io::sink()).expect("replays");
    sensor.stop().expect("the sensor stops cleanly");
    s
}

#[test]
fn every_fixture_replays_with_the_recorded_replies_but_for_live_values() {
    for (name, tcp) in [
        ("udp-lo.pcap", false),
        ("udp-any.pcapng", false),
        ("tcp-lo.pcap", true),
        ("fragmented-lo.pcapng", false),
    ] {
        let s = replay(fixture(name), live(), tcp);
        let r = s.replay.as_ref().expect("a replay report");
        assert_eq!(s.failure(), None, "{name}: {s:?}");
        assert_eq!(
            (r.messages, r.same, r.differ, r.not_answered),
            (100, 100, 0, 0),
            "{name}"
        );
        assert_eq!(
            r.conversation.contains("TCP"),
            tcp,
            "{name}: {}",
            r.conversation
        );
        assert!(
            r.recorded_latency_us.max > 0 && r.replayed_latency_us.max > 0,
            "{name}"
        );
    }
}

#[test]
fn the_live_values_differ_when_compared_and_the_run_fails() {
    let s = replay(fixture("udp-lo.pcap"), Rules::default(), false);
    let r = s.replay.as_ref().unwrap();
    assert!(r.differ > 90, "{r:?}");
    let why = s.failure().expect("differences fail the run (exit 1)");
    assert!(
        why.contains("replies differ from the recorded ones") && why.contains("AppData"),
        "{why}"
    );
    // Values within a wide tolerance are the same again; Ids, fields and
    // acceptance still count.
    let loose = Rules {
        tolerance: 1e6,
        ignore: vec!["EStr".into()],
        ..Rules::default()
    };
    let s = replay(fixture("udp-lo.pcap"), loose, false);
    assert_eq!(s.failure(), None);
}

#[test]
fn the_simulators_own_pcap_and_pcapng_replay_with_no_difference() {
    let dir = std::env::temp_dir().join(format!("rri-roundtrip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for tcp in [false, true] {
        for ext in ["pcap", "pcapng"] {
            let file = dir.join(format!("run-{tcp}.{ext}"));
            let sensor = Background::start(tcp, layout::ENGINE_CONFIG).unwrap();
            let device = gsi_config::load(&gsi(), None).unwrap().device;
            let mut opts = RobotOptions::new(gsi(), sensor.addr);
            opts.cycles = 60;
            opts.tcp = tcp;
            opts.pcap = Some(file.clone());
            let (s, _) = robot::run(&opts, &device, &mut std::io::sink()).unwrap();
            assert_eq!(s.failure(), None);
            // The sensor listened on an ephemeral port: the conversation
            // is chosen by its end (--conversation).
            let end = match sensor.addr {
                std::net::SocketAddr::V4(a) => a,
                other => panic!("{other}"),
            };
            sensor.stop().unwrap();
            let s = replay_of(file, live(), tcp, Some(end));
            let r = s.replay.as_ref().unwrap();
            assert_eq!((r.messages, r.same), (60, 60), "tcp {tcp} {ext}: {s:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `packets` written as a pcap by the simulator's writer and replayed over
/// UDP against the host sensor, comparing Ids, acceptance and timing only.
fn replay_written(name: &str, packets: &[Packet]) -> robot::report::Summary {
    let file = std::env::temp_dir().join(format!("rri-{name}-{}.pcap", std::process::id()));
    write_pcap(&file, packets, 1_700_000_000_000_000, false).unwrap();
    let s = replay(
        file.clone(),
        Rules {
            ignore_values: true,
            ..Rules::default()
        },
        false,
    );
    let _ = std::fs::remove_file(&file);
    s
}

/// The manual's robot message with Id `id` and Ts `ts`.
fn with_id(id: u32, ts: &str) -> String {
    let good =
        std::fs::read_to_string(host_tests::shared_rri().join("examples/messages/RobData.xml"))
            .unwrap();
    let i = good.find("Id=\"").unwrap() + 4;
    let j = i + good[i..].find('"').unwrap();
    let m = format!("{}{id}{}", &good[..i], &good[j..]);
    let t = m.find("Ts=\"").unwrap() + 4;
    let u = t + m[t..].find('"').unwrap();
    format!("{}{ts}{}", &m[..t], &m[u..])
}

/// A recorded sensor's reply to Id `id`.
fn reply(id: u32) -> String {
    format!("<SensData Id=\"{id}\" Ts=\"1.0\"><EStr>ok</EStr><AppData X1=\"0\" X2=\"0\" X3=\"0\" X4=\"0\" X5=\"0\" X6=\"0\"/></SensData>")
}

/// Issue 42 #1 and #5: two 150-cycle runs of the robot program in one
/// capture (Ids 1 to 150 twice), with garbage datagrams and an Id gap.
/// Each message is paired with its own recorded reply (not the first run's:
/// recorded latencies were 0 and "150 recorded replies" were counted of
/// 300), and garbage is malformed, not lost.
#[test]
fn two_runs_in_one_capture_with_garbage_and_a_gap_pair_each_message_with_its_own_reply() {
    let robot = "127.0.0.1:40000".parse().unwrap();
    let device = "127.0.0.1:3002".parse().unwrap();
    let mut packets = Vec::new();
    let mut at = 0u64;
    for run in 0..2 {
        for id in 1..=150u32 {
            if run == 1 && (70..73).contains(&id) {
                // Never sent: a gap of 3 Ids.
                continue;
            }
            at += 4_000;
            packets.push(Packet {
                at_us: at,
                from: robot,
                to: device,
                payload: with_id(id, "1.000").into_bytes(),
            });
            packets.push(Packet {
                at_us: at + 250 + u64::from(id),
                from: device,
                to: robot,
                payload: reply(id).into_bytes(),
            });
            if id % 50 == 0 {
                at += 1_000;
                packets.push(Packet {
                    at_us: at,
                    from: robot,
                    to: device,
                    payload: b"\x00\x01 not a message".to_vec(),
                });
            }
        }
    }
    let s = replay_written("two-runs", &packets);
    let r = s.replay.as_ref().unwrap();
    assert_eq!(s.failure(), None, "{s:?}");
    assert_eq!((r.messages, r.same, r.malformed), (297, 297, 6), "{r:?}");
    let c = &r.capture;
    assert_eq!((c.replies, c.paired, c.to_nothing), (297, 297, 0));
    assert_eq!((c.ids.gaps, c.ids.skipped, c.ids.restarts.len()), (1, 3, 1));
    assert_eq!((c.malformed, c.robot_messages), (6, 303));
    // Every recorded latency is its own: 250 µs + the Id.
    for row in &r.rows {
        let id = u64::from(row.id.unwrap());
        assert_eq!(row.recorded_latency_us, Some(250 + id), "{row:?}");
    }
    // Malformed datagrams are neither sent robot messages nor lost.
    assert_eq!((s.sent, s.lost), (297, 0), "{s:?}");
    assert_eq!((s.as_recorded.garbage, s.as_recorded.dropped), (6, 3));
}

#[test]
fn a_message_answered_in_the_capture_and_refused_now_is_the_headline_with_the_decoders_verdict() {
    let robot = "127.0.0.1:40000".parse().unwrap();
    let device = "127.0.0.1:3002".parse().unwrap();
    let mut packets = Vec::new();
    for (k, (id, ts)) in [(1, "1.000"), (2, "not-a-time"), (3, "1.008")]
        .into_iter()
        .enumerate()
    {
        let at = k as u64 * 4_000;
        packets.push(Packet {
            at_us: at,
            from: robot,
            to: device,
            payload: with_id(id, ts).into_bytes(),
        });
        packets.push(Packet {
            at_us: at + 300,
            from: device,
            to: robot,
            payload: reply(id).into_bytes(),
        });
    }
    let mut s = replay_written("refused", &packets);
    let r = s.replay.as_mut().unwrap();
    assert_eq!((r.same, r.not_answered), (2, 1), "{r:?}");
    host_tests::replay::explain(r);
    let row = r
        .rows
        .iter()
        .find(|x| x.outcome == Outcome::NotAnswered)
        .unwrap();
    assert_eq!(row.id, Some(2));
    let why = row.why.clone().unwrap();
    assert!(
        why.contains("InvalidTs") && why.contains("at byte"),
        "{why}"
    );
    let headline = s.failure().unwrap();
    assert!(
        headline.contains("were not answered")
            && headline.contains("Id 2")
            && headline.contains("InvalidTs"),
        "{headline}"
    );
}
