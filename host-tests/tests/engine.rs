//! The cycle engine driven by a fake clock through every S-rule scenario
//! (PROTOCOL.md S1–S3, M8, M10), on the manual example's layout.

use host_tests::layouts::anydevice::{self as layout, SensDataMessage};
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::{
    Application, Clock, Config, CycleInfo, DropReason, Endpoint, Engine, ErrorCode, Instant,
    Outcome, Pinned, SensorState, STRANGER_INTERVAL_MS,
};
use rri_firmware::tcp::{Framer, FramingError};
use std::cell::Cell;

type TestEngine = Engine<layout::RobotProperties, layout::DeviceProperties>;

/// Device time under the test's control; every reading advances it by
/// `step` µs, so the engine's receive → reply-ready time is measurable.
struct FakeClock {
    now: Cell<u64>,
    step: u64,
}

impl FakeClock {
    fn at_ms(ms: u64) -> Self {
        FakeClock {
            now: Cell::new(ms * 1000),
            step: 0,
        }
    }
    fn set_ms(&self, ms: u64) {
        self.now.set(ms * 1000);
    }
}

impl Clock for FakeClock {
    fn now(&self) -> Instant {
        let t = self.now.get();
        self.now.set(t + self.step);
        Instant(t)
    }
}

/// Records what the engine showed the application, and writes a marker.
#[derive(Default)]
struct Probe {
    calls: u32,
    last_id: Option<u32>,
    last_state: Option<SensorState>,
    last_ts: Option<rri_firmware::value::Time>,
}

impl Application<layout::RobotProperties, layout::DeviceProperties> for Probe {
    fn cycle(
        &mut self,
        robot: &layout::RobotProperties,
        device: &mut layout::DeviceProperties,
        info: &CycleInfo<'_>,
    ) {
        self.calls += 1;
        self.last_id = info.robot_id;
        self.last_state = Some(info.state);
        self.last_ts = info.robot_ts;
        device.sens_data.application_data[0] = robot.rob_data.feedback_pose.x;
    }
}

const ROBOT: Endpoint = Endpoint::new([192, 168, 125, 1], 50_000);
const OTHER: Endpoint = Endpoint::new([192, 168, 125, 66], 50_000);

fn config() -> Config {
    Config {
        timeout_ms: 100,
        max_lost: 3,
        dry_run: false,
        controller: None,
        reply: 0,
        send_period_ms: 0,
        periodic: &[],
        format: layout::FORMAT,
    }
}

fn msg(id: u32) -> String {
    format!(
        r#"<RobData Id="{id}" Ts="1.5"><P_act X="12.5" Y="0" Z="0" Rx="0" Ry="0" Rz="0"/></RobData>"#
    )
}

struct Rig {
    engine: TestEngine,
    app: Probe,
    clock: FakeClock,
    buf: [u8; layout::MAX_SEND_LEN],
}

impl Rig {
    fn new(config: Config) -> Self {
        let mut engine = TestEngine::new(config);
        engine.listening();
        Rig {
            engine,
            app: Probe::default(),
            clock: FakeClock::at_ms(0),
            buf: [0; layout::MAX_SEND_LEN],
        }
    }

    /// Delivers robot message `id` from `from` at `ms`.
    fn send(&mut self, from: Endpoint, id: u32, ms: u64) -> Outcome {
        self.raw(from, msg(id).as_bytes(), ms)
    }

    fn raw(&mut self, from: Endpoint, bytes: &[u8], ms: u64) -> Outcome {
        self.clock.set_ms(ms);
        let received = Instant::from_millis(ms);
        self.engine.on_message(
            &mut self.app,
            &self.clock,
            from,
            bytes,
            received,
            &mut self.buf,
        )
    }

    fn reply_text(&self, len: usize) -> String {
        String::from_utf8(self.buf[..len].to_vec()).expect("utf-8")
    }

    fn poll(&mut self, ms: u64) -> Option<(Endpoint, usize)> {
        self.clock.set_ms(ms);
        self.engine.poll(&mut self.app, &self.clock, &mut self.buf)
    }
}

#[test]
fn s2_undefined_connected_operating() {
    let mut engine = TestEngine::new(config());
    assert_eq!(engine.state(), SensorState::Undefined);
    engine.listening();
    assert_eq!(engine.state(), SensorState::Connected);
    let mut rig = Rig {
        engine,
        app: Probe::default(),
        clock: FakeClock::at_ms(0),
        buf: [0; layout::MAX_SEND_LEN],
    };
    assert!(matches!(rig.send(ROBOT, 1, 0), Outcome::Reply { .. }));
    assert_eq!(rig.engine.state(), SensorState::Operating);
    assert_eq!(rig.engine.state().rapid_value(), 2);
}

#[test]
fn m8_reply_echoes_the_id_with_the_device_time_and_the_apps_data() {
    let mut rig = Rig::new(config());
    rig.clock.step = 0;
    let Outcome::Reply { to, len } = rig.send(ROBOT, 4711, 1234) else {
        panic!("no reply")
    };
    assert_eq!(to, ROBOT);
    let text = rig.reply_text(len);
    assert!(
        text.starts_with(r#"<SensData Id="4711" Ts="1.234">"#),
        "{text}"
    );
    assert!(
        text.contains(r#"X1="12.500""#),
        "the application's value: {text}"
    );
    assert_eq!(rig.app.last_id, Some(4711));
    assert_eq!(
        rig.app.last_ts,
        Some(rri_firmware::value::Time::from_millis(1500))
    );
    assert!(
        len <= <SensDataMessage as rri_firmware::schema::Message>::MAX_ENCODED_LEN,
        "no amplification"
    );
}

#[test]
fn s1_timeout_into_error_and_back_on_the_next_message() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    assert_eq!(rig.poll(100), None);
    assert_eq!(
        rig.engine.state(),
        SensorState::Operating,
        "exactly TimeOut is not yet late"
    );
    rig.poll(101);
    assert_eq!(rig.engine.state(), SensorState::Error);
    assert_eq!(rig.engine.error_code().map(ErrorCode::code), Some(112_602));
    assert_eq!(rig.engine.stats().timeouts, 1);
    rig.poll(500);
    assert_eq!(rig.engine.stats().timeouts, 1, "counted once per silence");
    assert!(matches!(rig.send(ROBOT, 2, 501), Outcome::Reply { .. }));
    assert_eq!(rig.engine.state(), SensorState::Operating);
    assert_eq!(rig.engine.error_code(), None);
}

#[test]
fn s1_max_lost_exceeded_by_a_gap_burst() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 10, 0);
    rig.send(ROBOT, 14, 4); // 3 lost = MaxLost: tolerated
    assert_eq!(rig.engine.state(), SensorState::Operating);
    assert!(
        matches!(rig.send(ROBOT, 19, 8), Outcome::Reply { .. }),
        "still answered"
    ); // 4 lost
    assert_eq!(rig.engine.state(), SensorState::Error);
    assert_eq!(rig.engine.error_code(), Some(ErrorCode::Communication));
    let s = rig.engine.stats();
    assert_eq!((s.lost, s.max_lost_exceeded), (7, 1));
    rig.send(ROBOT, 20, 12);
    assert_eq!(
        rig.engine.state(),
        SensorState::Operating,
        "back on the next good message"
    );
}

#[test]
fn s1_dry_run_supervises_neither_timeout_nor_max_lost() {
    let mut rig = Rig::new(Config {
        dry_run: true,
        ..config()
    });
    rig.send(ROBOT, 1, 0);
    rig.send(ROBOT, 100, 4);
    rig.poll(10_000);
    assert_eq!(rig.engine.state(), SensorState::Operating);
    let s = rig.engine.stats();
    assert_eq!((s.lost, s.max_lost_exceeded, s.timeouts), (98, 1, 0));
}

#[test]
fn s3_duplicates_and_reordered_ids_are_answered_and_counted() {
    let mut rig = Rig::new(config());
    for (id, ms) in [(5, 0), (5, 4), (7, 8), (6, 12), (8, 16)] {
        assert!(
            matches!(rig.send(ROBOT, id, ms), Outcome::Reply { .. }),
            "id {id}"
        );
    }
    let s = rig.engine.stats();
    // 6 was skipped when 7 came, then arrived late: not lost (S3).
    assert_eq!(
        (s.duplicates, s.reordered, s.lost, s.answered),
        (1, 1, 0, 5)
    );
    assert_eq!(rig.engine.state(), SensorState::Operating);
}

#[test]
fn s3_wrap_from_4294967295_to_0() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, u32::MAX - 1, 0);
    rig.send(ROBOT, u32::MAX, 4);
    let Outcome::Reply { len, .. } = rig.send(ROBOT, 0, 8) else {
        panic!()
    };
    assert!(rig.reply_text(len).starts_with(r#"<SensData Id="0""#));
    rig.send(ROBOT, 1, 12);
    let s = rig.engine.stats();
    assert_eq!(
        (s.id_wraps, s.lost, s.reordered, s.max_lost_exceeded),
        (1, 0, 0, 0)
    );
    assert_eq!(rig.engine.state(), SensorState::Operating);
}

#[test]
fn peer_lock_on_first_valid_message_and_foreign_sources_dropped() {
    let mut rig = Rig::new(config());
    // An invalid message does not lock anybody in.
    assert_eq!(
        rig.raw(OTHER, b"<Junk/>", 0),
        Outcome::Dropped(DropReason::Decode(DecodeErrorKind::WrongRoot))
    );
    assert_eq!(rig.engine.peer(), None);
    rig.send(ROBOT, 1, 1);
    assert_eq!(rig.engine.peer(), Some(ROBOT));
    assert_eq!(
        rig.send(OTHER, 1, 2),
        Outcome::Dropped(DropReason::ForeignSource)
    );
    assert_eq!(
        rig.send(OTHER, 2, 50),
        Outcome::Dropped(DropReason::ForeignSource)
    );
    let s = rig.engine.stats();
    assert_eq!((s.peer_locked, s.dropped_foreign, s.answered), (1, 2, 1));
    assert_eq!(
        rig.app.calls, 1,
        "the application never sees foreign messages"
    );
}

/// Defect 2 of the hostile-world issue (S4): a datagram from port 0 (or a
/// broadcast, multicast, reserved or `0.x` address) was admitted as the
/// controller on a new port. Never admitted, counted, no reply; the
/// controller keeps its Id sequence.
#[test]
fn invalid_sources_are_never_admitted() {
    let mut rig = Rig::new(config());
    let spoofed = [
        Endpoint::new(ROBOT.ip, 0),
        Endpoint::new([255, 255, 255, 255], 6510),
        Endpoint::new([224, 0, 0, 1], 6510),
        Endpoint::new([239, 255, 255, 250], 1900),
        Endpoint::new([240, 0, 0, 1], 6510),
        Endpoint::new([0, 0, 0, 0], 6510),
        Endpoint::new([0, 1, 2, 3], 6510),
    ];
    // Before any peer: none of them locks in.
    for (i, from) in spoofed.iter().enumerate() {
        assert_eq!(
            rig.send(*from, i as u32 + 1, i as u64),
            Outcome::Dropped(DropReason::InvalidSource),
            "{from:?}"
        );
    }
    assert_eq!(rig.engine.peer(), None);
    rig.send(ROBOT, 1, 10);
    // With a peer: port 0 from the controller's own address is no port
    // takeover, and the next Id is not a gap.
    for (i, from) in spoofed.iter().enumerate() {
        assert_eq!(
            rig.send(*from, 100 + i as u32, 11 + i as u64),
            Outcome::Dropped(DropReason::InvalidSource)
        );
    }
    assert!(matches!(rig.send(ROBOT, 2, 30), Outcome::Reply { to, .. } if to == ROBOT));
    let s = rig.engine.stats();
    assert_eq!(s.dropped_invalid_source, 2 * spoofed.len() as u64);
    assert_eq!(
        (s.peer_locked, s.port_takeovers, s.lost, s.answered),
        (1, 0, 0, 2)
    );
    assert_eq!(rig.app.calls, 2);
}

#[test]
fn peer_new_port_takes_over_at_once() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 100, 0);
    let reconnected = Endpoint::new(ROBOT.ip, 50_001);
    let Outcome::Reply { to, .. } = rig.send(reconnected, 1, 4) else {
        panic!()
    };
    assert_eq!(to, reconnected);
    assert_eq!(rig.engine.stats().port_takeovers, 1);
    // A reconnected controller starts its Ids again: not reordering (S3).
    rig.send(reconnected, 2, 8);
    let s = rig.engine.stats();
    assert_eq!((s.reordered, s.duplicates, s.lost), (0, 0, 0));
}

#[test]
fn peer_takeover_after_silence() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    assert_eq!(
        rig.send(OTHER, 500, 99),
        Outcome::Dropped(DropReason::ForeignSource)
    );
    let Outcome::Reply { to, .. } = rig.send(OTHER, 501, 100) else {
        panic!("silent for TimeOut")
    };
    assert_eq!(to, OTHER);
    let s = rig.engine.stats();
    assert_eq!(
        (s.peer_takeovers, s.lost),
        (1, 0),
        "a new peer starts its own id stream"
    );
    assert_eq!(
        rig.send(ROBOT, 2, 101),
        Outcome::Dropped(DropReason::ForeignSource)
    );
}

#[test]
fn pinned_controller_is_the_only_one_answered() {
    let pinned = Pinned {
        ip: ROBOT.ip,
        port: None,
    };
    let mut rig = Rig::new(Config {
        controller: Some(pinned),
        ..config()
    });
    assert_eq!(
        rig.send(OTHER, 1, 0),
        Outcome::Dropped(DropReason::ForeignSource)
    );
    assert!(matches!(rig.send(ROBOT, 1, 1), Outcome::Reply { .. }));
    assert_eq!(
        rig.send(OTHER, 1, 10_000),
        Outcome::Dropped(DropReason::ForeignSource),
        "even after silence"
    );
}

#[test]
fn decode_errors_are_counted_by_kind_and_change_nothing() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    let before = rig.engine.robot().clone();
    let bad = br#"<RobData Id="2"><P_act X="99" Y="abc"/></RobData>"#;
    assert_eq!(
        rig.raw(ROBOT, bad, 4),
        Outcome::Dropped(DropReason::Decode(DecodeErrorKind::InvalidNumber))
    );
    assert_eq!(
        rig.engine.robot().clone(),
        before,
        "X=99 of the rejected message is not kept"
    );
    assert_eq!(
        rig.raw(ROBOT, b"\xff", 5),
        Outcome::Dropped(DropReason::Decode(DecodeErrorKind::NotUtf8))
    );
    let s = rig.engine.stats();
    assert_eq!(s.dropped_decode, 2);
    assert_eq!(s.decode_errors_of(DecodeErrorKind::InvalidNumber), 1);
    assert_eq!(s.decode_errors_of(DecodeErrorKind::NotUtf8), 1);
    assert_eq!(s.received, 3);
    assert_eq!(rig.engine.state(), SensorState::Operating);
}

#[test]
fn m2_tolerances_reach_the_statistics() {
    let mut rig = Rig::new(config());
    rig.raw(
        ROBOT,
        br#"<RobData Id="1" Extra="1"><Foo/><AppData>0</AppData></RobData>"#,
        0,
    );
    let s = rig.engine.stats();
    assert_eq!(
        (
            s.unknown_attributes,
            s.unknown_elements,
            s.shape_mismatches,
            s.missing_fields
        ),
        (1, 1, 1, 7)
    );
}

#[test]
fn s2_init_failure_is_error_112600() {
    let mut engine = TestEngine::new(config());
    engine.init_failed();
    assert_eq!(engine.state(), SensorState::Error);
    assert_eq!(engine.error_code().map(ErrorCode::code), Some(112_600));
    assert_eq!(engine.state().rapid_value(), -1);
}

#[test]
fn latency_histogram_in_device_ticks() {
    let mut rig = Rig::new(config());
    rig.clock.step = 7; // every clock reading advances 7 µs
    for id in 1..=10 {
        rig.send(ROBOT, id, u64::from(id) * 4);
    }
    let h = rig.engine.stats().latency;
    assert_eq!(h.count, 10);
    // receive (t) → app reads now (t) → encode reads now (t+7) → reply
    // ready read (t+14): 14 µs each.
    assert_eq!((h.min_us, h.max_us), (14, 14));
    assert_eq!(h.buckets[4], 10, "8 ≤ 14 < 16");
}

#[test]
fn periodic_send_mode_for_one_way_streams() {
    let pinned = Pinned {
        ip: ROBOT.ip,
        port: Some(3000),
    };
    let mut rig = Rig::new(Config {
        dry_run: true,
        send_period_ms: 8,
        controller: Some(pinned),
        ..config()
    });
    // Before the robot ever speaks: to the pinned controller's port.
    let (to, len) = rig.poll(0).expect("due at once");
    assert_eq!(to, Endpoint::new(ROBOT.ip, 3000));
    assert!(rig
        .reply_text(len)
        .starts_with(r#"<SensData Id="1" Ts="0.000">"#));
    assert_eq!(rig.poll(4), None);
    assert!(rig.poll(8).is_some());
    // After a stall, no burst: one send, then the period again.
    assert!(rig.poll(100).is_some());
    assert_eq!(rig.poll(104), None);
    assert!(rig.poll(108).is_some());
    // A robot message locks the peer: sends follow it.
    rig.send(ROBOT, 1, 110);
    let (to, len) = rig.poll(116).expect("due");
    assert_eq!(to, ROBOT);
    assert!(
        rig.reply_text(len).starts_with(r#"<SensData Id="5""#),
        "own ids count on"
    );
    assert_eq!(rig.engine.stats().periodic_sent, 5);
    assert_eq!(rig.app.last_id, None, "a periodic cycle has no robot id");
}

#[test]
fn periodic_send_needs_a_destination() {
    let mut rig = Rig::new(Config {
        dry_run: true,
        send_period_ms: 4,
        ..config()
    });
    assert_eq!(rig.poll(0), None, "nobody to send to yet");
    rig.send(ROBOT, 1, 1);
    assert!(rig.poll(2).is_some());
}

// --- TCP (M10) -----------------------------------------------------------------

fn frames(chunks: &[&[u8]]) -> Result<Vec<String>, FramingError> {
    let mut framer = Framer::<{ layout::MAX_RECEIVE_LEN }>::new();
    let mut out = Vec::new();
    for c in chunks {
        framer.push(c, |m| {
            out.push(String::from_utf8(m.to_vec()).expect("utf-8"))
        })?;
    }
    Ok(out)
}

#[test]
fn m10_two_messages_split_at_every_byte_boundary() {
    let first =
        std::fs::read_to_string(host_tests::shared_rri().join("examples/messages/RobData.xml"))
            .expect("manual");
    let second = r#"<?xml version="1.0"?><!-- x > y --><RobData Id="112" Ts="1.206"><Foo a=">"><![CDATA[</RobData>]]></Foo></RobData>"#;
    let stream = format!("{first}\n{second}\r\n");
    let bytes = stream.as_bytes();
    for cut in 0..=bytes.len() {
        let got = frames(&[&bytes[..cut], &bytes[cut..]]).expect("fits");
        assert_eq!(
            got,
            vec![first.trim().to_string(), second.to_string()],
            "cut at {cut}"
        );
    }
    let one_by_one: Vec<&[u8]> = bytes.chunks(1).collect();
    assert_eq!(frames(&one_by_one).expect("fits").len(), 2);
}

#[test]
fn m10_framed_messages_go_through_the_same_engine() {
    let mut rig = Rig::new(config());
    let mut framer = Framer::<{ layout::MAX_RECEIVE_LEN }>::new();
    let stream = format!("{}{}{}", msg(1), msg(2), msg(3));
    let mut ids = Vec::new();
    let mut messages = Vec::new();
    framer
        .push(stream.as_bytes(), |m| messages.push(m.to_vec()))
        .expect("fits");
    for (i, m) in messages.iter().enumerate() {
        if let Outcome::Reply { len, .. } = rig.raw(ROBOT, m, i as u64) {
            ids.push(rig.reply_text(len)[..20].to_string());
        }
    }
    assert_eq!(
        ids,
        vec![
            r#"<SensData Id="1" Ts="#,
            r#"<SensData Id="2" Ts="#,
            r#"<SensData Id="3" Ts="#
        ]
    );
}

#[test]
fn m10_a_message_longer_than_the_buffer_is_a_framing_error() {
    let mut framer = Framer::<64>::new();
    let long = format!(r#"<RobData Id="1">{}</RobData>"#, " ".repeat(64));
    assert_eq!(
        framer.push(long.as_bytes(), |_| panic!("no message")),
        Err(FramingError)
    );
    assert_eq!(framer.pending(), 0, "reset for the next connection");
    // A stream of garbage without any tag ends the same way.
    assert_eq!(
        Framer::<64>::new().push(&[b'x'; 100], |_| ()),
        Err(FramingError)
    );
    // Whitespace between messages is never buffered.
    let mut f = Framer::<8>::new();
    assert_eq!(f.push(&[b' '; 1000], |_| ()), Ok(()));
}

#[test]
fn m10_peer_close_moves_to_closed_and_framing_errors_are_counted() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    rig.engine.framing_error();
    rig.engine.peer_closed();
    assert_eq!(rig.engine.state(), SensorState::Closed);
    assert_eq!(rig.engine.state().rapid_value(), 3);
    let s = rig.engine.stats();
    assert_eq!((s.framing_errors, s.closed), (1, 1));
    rig.engine.listening(); // a new connection
    assert_eq!(rig.engine.state(), SensorState::Connected);
}

/// Hostile world, floods (peer rule, S4): a flood from a second port of the
/// controller's address was decoded in full, datagram after datagram, and
/// a flood of the costliest rejected inputs at ten times the cycle rate
/// starved the controller on the QEMU board (`cargo flood`: 356 of 2,000
/// answered). Once a peer is locked, other sources are decoded at most
/// once per robot cycle; a controller that reconnected still takes over.
#[test]
fn a_flood_from_another_port_costs_at_most_one_decode_per_cycle() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    let second = Endpoint::new(ROBOT.ip, ROBOT.port + 1);
    // 100 garbage datagrams within one cycle: one decoded, 99 throttled.
    for i in 0..100u64 {
        let at = 1 + i * (STRANGER_INTERVAL_MS - 1) / 100;
        let r = rig.raw(second, b"<RobData Id=\"x\"/>", at);
        assert!(matches!(r, Outcome::Dropped(_)), "{r:?}");
    }
    let s = rig.engine.stats();
    assert_eq!((s.dropped_decode, s.dropped_throttled), (1, 99));
    // The controller is answered all along, with its own Id sequence.
    assert!(matches!(rig.send(ROBOT, 2, 4), Outcome::Reply { to, .. } if to == ROBOT));
    // A foreign address is dropped before this (not counted as throttled).
    assert_eq!(
        rig.send(OTHER, 9, 5),
        Outcome::Dropped(DropReason::ForeignSource)
    );
    // One cycle after the last stranger let through, the second port's
    // valid message is decoded and takes over (a reconnecting controller).
    let after = 1 + STRANGER_INTERVAL_MS;
    assert!(matches!(rig.send(second, 50, after), Outcome::Reply { to, .. } if to == second));
    // Now the old port is the stranger.
    assert_eq!(
        rig.send(ROBOT, 3, after + 1),
        Outcome::Dropped(DropReason::Throttled)
    );
    let s = rig.engine.stats();
    assert_eq!(
        (s.port_takeovers, s.dropped_throttled, s.dropped_foreign),
        (1, 100, 1)
    );
    assert_eq!(
        s.received,
        s.answered + s.dropped_decode + s.dropped_throttled + s.dropped_foreign
    );
}

/// Before any peer there is no cycle to protect: nothing is throttled.
#[test]
fn nothing_is_throttled_before_a_peer_is_locked() {
    let mut rig = Rig::new(config());
    for i in 0..10u16 {
        let from = Endpoint::new(ROBOT.ip, 40_000 + i);
        assert_eq!(
            rig.raw(from, b"garbage", 0),
            Outcome::Dropped(DropReason::Decode(DecodeErrorKind::Malformed))
        );
    }
    assert!(matches!(rig.send(ROBOT, 1, 0), Outcome::Reply { .. }));
    assert_eq!(rig.engine.stats().dropped_throttled, 0);
}

/// TCP (M10): after the served connection closes, the next connection's
/// first message is the controller reconnecting, even within one cycle of
/// the last stranger: never throttled (the sensor_transport reset test
/// caught this).
#[test]
fn a_new_connection_after_a_close_is_never_throttled() {
    let mut rig = Rig::new(config());
    rig.send(ROBOT, 1, 0);
    let second = Endpoint::new(ROBOT.ip, ROBOT.port + 1);
    assert!(matches!(rig.send(second, 1, 1), Outcome::Reply { .. }));
    rig.engine.peer_closed();
    let third = Endpoint::new(ROBOT.ip, ROBOT.port + 2);
    assert!(matches!(rig.send(third, 1, 2), Outcome::Reply { to, .. } if to == third));
    assert_eq!(rig.engine.stats().dropped_throttled, 0);
}
