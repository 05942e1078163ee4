//! Every property of a configuration travels (M11), on the every-type
//! layout: three properties the controller sends (`RsRobData` as
//! `<RobData>`, `Shared`, `Speed`), four the device sends (`RsSensData`,
//! `Shared`, `Speed`, `Offsets`). The engine's S1–S3 scenarios with mixed
//! properties, then the host sensor against the robot simulator over UDP
//! and TCP with three robot properties at 4, 16 and 64 ms, the reply of
//! our choice and a second device property sent every 32 ms.

use host_tests::layouts::every_type::{self as layout, DeviceProperty, RobotProperty};
use host_tests::robot::{run, RobotOptions};
use host_tests::sensor::Background;
use host_tests::workspace;
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::{
    Application, Clock, Config, CycleInfo, DropReason, Endpoint, Engine, ErrorCode, Instant,
    Outcome, Periodic, SensorState,
};
use std::cell::Cell;

type TestEngine = Engine<layout::RobotProperties, layout::DeviceProperties>;

const ROBOT: Endpoint = Endpoint::new([127, 0, 0, 1], 40_000);

struct FakeClock(Cell<u64>);

impl Clock for FakeClock {
    fn now(&self) -> Instant {
        Instant(self.0.get())
    }
}

/// What the application was shown, per call.
#[derive(Default)]
struct Probe {
    arrived: Vec<Option<usize>>,
    sending: Vec<usize>,
}

impl Application<layout::RobotProperties, layout::DeviceProperties> for Probe {
    fn cycle(
        &mut self,
        robot: &layout::RobotProperties,
        device: &mut layout::DeviceProperties,
        info: &CycleInfo<'_>,
    ) {
        self.arrived.push(info.arrived);
        self.sending.push(info.sending);
        // Echo what arrived into what goes out, to see it on the wire.
        device.shared.distance = robot.rs_rob_data.gain + robot.speed;
        device.offsets = [robot.shared.distance, robot.speed, 1.0];
    }
}

struct Rig {
    engine: TestEngine,
    app: Probe,
    clock: FakeClock,
    out: Vec<u8>,
}

impl Rig {
    fn new(config: Config) -> Rig {
        let mut engine = TestEngine::new(config);
        engine.listening();
        Rig {
            engine,
            app: Probe::default(),
            clock: FakeClock(Cell::new(0)),
            out: vec![0; layout::MAX_SEND_LEN],
        }
    }

    fn at(&mut self, ms: u64, text: &str) -> Outcome {
        self.clock.0.set(ms * 1000);
        self.engine.on_message(
            &mut self.app,
            &self.clock,
            ROBOT,
            text.as_bytes(),
            Instant::from_millis(ms),
            &mut self.out,
        )
    }

    fn reply(&self, outcome: Outcome) -> String {
        match outcome {
            Outcome::Reply { len, .. } => String::from_utf8(self.out[..len].to_vec()).unwrap(),
            Outcome::Dropped(r) => panic!("dropped: {r:?}"),
        }
    }

    fn poll(&mut self, ms: u64) -> Option<String> {
        self.clock.0.set(ms * 1000);
        self.engine
            .poll(&mut self.app, &self.clock, &mut self.out)
            .map(|(_, len)| String::from_utf8(self.out[..len].to_vec()).unwrap())
    }
}

fn config() -> Config {
    Config {
        reply: DeviceProperty::Shared.index(),
        ..layout::ENGINE_CONFIG
    }
}

fn rob_data(id: u32, gain: &str) -> String {
    format!(r#"<RobData Id="{id}" Ts="0.5"><Gain>{gain}</Gain></RobData>"#)
}
fn shared(id: u32, distance: &str) -> String {
    format!(r#"<Shared Id="{id}"><Distance>{distance}</Distance></Shared>"#)
}
fn speed(id: u32, v: &str) -> String {
    format!(r#"<?xml version="1.0"?><Speed Id="{id}">{v}</Speed>"#)
}

#[test]
fn m11_every_robot_property_is_decoded_into_its_own_record_and_answered() {
    let mut rig = Rig::new(config());
    let r = rig.at(0, &rob_data(1, "2.5"));
    assert!(
        rig.reply(r).starts_with(r#"<Shared Id="1" Ts="#),
        "reply property, M8 Id"
    );
    let r = rig.at(4, &speed(2, "40"));
    let text = rig.reply(r);
    assert!(text.starts_with(r#"<Shared Id="2""#), "{text}");
    assert!(
        text.contains("<Distance>42.500</Distance>"),
        "2.5 + 40: {text}"
    );
    let r = rig.at(8, &shared(3, "7.25"));
    assert!(rig.reply(r).starts_with(r#"<Shared Id="3""#));

    // M2 per property: each keeps its own last good value.
    let robot = rig.engine.robot();
    assert_eq!(
        (robot.rs_rob_data.gain, robot.speed, robot.shared.distance),
        (2.5, 40.0, 7.25)
    );
    assert_eq!(
        rig.app.arrived,
        [
            Some(RobotProperty::RsRobData.index()),
            Some(RobotProperty::Speed.index()),
            Some(RobotProperty::Shared.index())
        ]
    );
    assert_eq!(rig.app.sending, [DeviceProperty::Shared.index(); 3]);
    let s = rig.engine.stats();
    assert_eq!((s.answered, s.lost, s.dropped_decode), (3, 0, 0));
    assert_eq!(rig.engine.state(), SensorState::Operating);
}

#[test]
fn m11_a_rejected_message_changes_only_nothing() {
    let mut rig = Rig::new(config());
    rig.at(0, &speed(1, "3"));
    rig.at(4, &rob_data(2, "1"));
    // Bad value in Speed: Speed and RobData keep their values.
    assert_eq!(
        rig.at(8, &speed(3, "x")),
        Outcome::Dropped(DropReason::Decode(DecodeErrorKind::InvalidNumber))
    );
    // A root that is no property the controller sends (Offsets is the
    // device's; Unused has Flag="None").
    for root in ["Offsets", "Unused", "SensData"] {
        assert_eq!(
            rig.at(12, &format!(r#"<{root} Id="4"/>"#)),
            Outcome::Dropped(DropReason::Decode(DecodeErrorKind::WrongRoot)),
            "{root}"
        );
    }
    let robot = rig.engine.robot();
    assert_eq!((robot.speed, robot.rs_rob_data.gain), (3.0, 1.0));
}

#[test]
fn s3_one_id_sequence_across_properties_loses_nothing() {
    let mut rig = Rig::new(config());
    let mut id = 1;
    for tick in 0..64u64 {
        for (every, text) in [(1, 0), (4, 1), (16, 2)] {
            if tick % every == 0 {
                let msg = match text {
                    0 => rob_data(id, "1"),
                    1 => shared(id, "2"),
                    _ => speed(id, "3"),
                };
                let r = rig.at(tick * 4, &msg);
                rig.reply(r);
                id += 1;
            }
        }
    }
    let s = rig.engine.stats();
    assert_eq!((s.lost, s.duplicates, s.reordered), (0, 0, 0));
    assert_eq!(
        (s.max_lost_exceeded, rig.engine.state()),
        (0, SensorState::Operating)
    );
    assert!(!rig.engine.ids_per_property());
}

#[test]
fn s1_per_property_numbering_trips_no_false_max_lost() {
    // MaxLost = 5 with DryRun = false (the layout's own settings).
    const { assert!(!layout::DRY_RUN) };
    let mut rig = Rig::new(config());
    // Speed's counter ahead of the others (its SiSetCyclic ran longer):
    // one sequence would make every Speed message a gap of hundreds.
    let mut next = [1u32, 1, 1000];
    for tick in 0..256u64 {
        for (p, every) in [(0, 1), (1, 4), (2, 16)] {
            if tick % every == 0 {
                let id = next[p];
                next[p] += 1;
                let msg = match p {
                    0 => rob_data(id, "1"),
                    1 => shared(id, "2"),
                    _ => speed(id, "3"),
                };
                let r = rig.at(tick * 4, &msg);
                rig.reply(r);
                assert_eq!(rig.engine.state(), SensorState::Operating, "tick {tick}");
            }
        }
    }
    let s = rig.engine.stats();
    assert_eq!(
        (s.lost, s.max_lost_exceeded, s.duplicates, s.reordered),
        (0, 0, 0, 0),
        "{s:?}"
    );
    assert!(rig.engine.ids_per_property());

    // A real burst of RobData losses is still seen, and trips S1.
    let r = rig.at(2000, &rob_data(next[0] + 6, "1"));
    rig.reply(r);
    let s = rig.engine.stats();
    assert_eq!((s.lost, s.max_lost_exceeded), (6, 1));
    assert_eq!(rig.engine.error_code(), Some(ErrorCode::Communication));
}

#[test]
fn periodic_device_properties_go_out_on_their_own_schedule() {
    static PERIODIC: [Periodic; 1] = [Periodic {
        property: 3, // Offsets
        period_ms: 32,
    }];
    assert_eq!(DeviceProperty::Offsets.index(), 3);
    let mut rig = Rig::new(Config {
        periodic: &PERIODIC,
        ..config()
    });
    assert_eq!(rig.poll(0), None, "no controller known yet");
    let r = rig.at(0, &speed(1, "9"));
    rig.reply(r);
    let first = rig.poll(1).expect("due at once");
    assert!(first.starts_with(r#"<Offsets Id="1""#), "{first}");
    assert!(
        first.contains(r#"X2="9.000""#),
        "the application filled it: {first}"
    );
    assert_eq!(rig.poll(20), None);
    let second = rig.poll(33).expect("32 ms later");
    assert!(
        second.starts_with(r#"<Offsets Id="2""#),
        "own Id sequence: {second}"
    );
    assert_eq!(
        rig.app.sending.last(),
        Some(&DeviceProperty::Offsets.index())
    );
    assert_eq!(rig.app.arrived.last(), Some(&None));
    // Replies still carry the robot's Id and the reply property.
    let r = rig.at(34, &speed(2, "1"));
    assert!(rig.reply(r).starts_with(r#"<Shared Id="2""#));
    assert_eq!(rig.engine.stats().periodic_sent, 2);
}

/// The host sensor for the every-type layout, replying with `Shared` and
/// sending `RsSensData` every 32 ms; the simulator sends all three robot
/// properties.
fn end_to_end(tcp: bool) {
    static PERIODIC: [Periodic; 1] = [Periodic {
        property: 0, // RsSensData
        period_ms: 32,
    }];
    // TimeOut 2 s on both sides (the GSI says 100 ms): in lock-step, a
    // loaded host's stall of either thread for 100 ms would trip
    // supervision though every message is answered; S1's TimeOut has its
    // own tests (simulator.rs, the engine's).
    let config = Config {
        periodic: &PERIODIC,
        timeout_ms: 2_000,
        ..config()
    };
    let sensor = Background::start_layout::<
        layout::RobotProperties,
        layout::DeviceProperties,
        { layout::MAX_RECEIVE_LEN },
    >(tcp, config, layout::DEVICE_NAME)
    .expect("sensor listening");
    let mut o = RobotOptions::new(
        workspace().join("host-tests/gsi/every-type/GSI"),
        sensor.addr,
    );
    o.tcp = tcp;
    // Lock-step (each message after the last reply), so a loaded test
    // machine cannot trip the simulator's 24 ms MaxLost window; the
    // 32 ms schedule itself is timed by the engine test above.
    o.pacing = false;
    o.cycles = 1000;
    o.sends = vec![
        ("RsRobData".into(), 4),
        ("shared".into(), 16),
        ("Speed".into(), 64),
    ];
    o.reply = Some("Shared".into());
    let mut device = host_tests::robot::load(&o).expect("every-type loads");
    device.supervision.timeout_ms = 2_000;
    let (s, cycles) = run(&o, &device, &mut std::io::sink()).expect("simulation runs");
    let report = sensor.stop().expect("sensor runs");

    assert!(s.passed(), "{:?}", s.failure());
    assert_eq!(
        (s.sent, s.lost, s.wrong_id, s.malformed),
        (1000 + 250 + 63, 0, 0, 0)
    );
    let per: Vec<_> = s
        .properties
        .iter()
        .map(|p| (p.name.as_str(), p.direction.as_str(), p.messages, p.lost))
        .collect();
    assert_eq!(
        per[..3],
        [
            ("RsRobData", "sent", 1000, 0),
            ("Shared", "sent", 250, 0),
            ("Speed", "sent", 63, 0)
        ]
    );
    assert!(per.contains(&("Shared", "reply", 1313, 0)), "{per:?}");
    let periodic = per
        .iter()
        .find(|p| p.0 == "RsSensData")
        .unwrap_or_else(|| panic!("no periodic RsSensData: {per:?}"));
    assert_eq!(periodic.1, "periodic");
    assert!(periodic.2 >= 1, "{per:?}");
    // One Id sequence, as a controller numbers one channel.
    assert!(cycles.windows(2).all(|w| w[1].id == w[0].id + 1));

    let st = report.stats;
    assert_eq!((st.answered, st.lost, st.dropped_decode), (1313, 0, 0));
    assert_eq!(st.max_lost_exceeded, 0);
    // The sensor goes on sending until it is stopped, after the run.
    assert!(
        st.periodic_sent >= periodic.2,
        "every periodic message the simulator counted was sent"
    );
}

#[test]
fn m11_three_robot_properties_a_chosen_reply_and_a_periodic_one_over_udp() {
    end_to_end(false);
}

#[test]
fn m11_three_robot_properties_a_chosen_reply_and_a_periodic_one_over_tcp() {
    end_to_end(true);
}
