//! How to test a sensor against the robot simulator, on the host: the
//! sensor runs unchanged in the host sensor (`Background::start_sensor`,
//! the same `Sampler`, history and engine as on a board), the simulator
//! drives it over loopback and checks every reply against the layout, and
//! the test asserts what the sensor saw and answered.
//!
//! Two patterns: the worked example `Aligned` as it is (the simulator's
//! verdict: every reply on time, with the right Id and a valid layout), and
//! a recording sensor that keeps what each cycle gave it, to check the time
//! alignment (T2) against the simulator's real timestamps: feedback ~8 ms
//! before the message, and the paired sample within a few sampling
//! periods of that instant.

use host_tests::built_gsi;
use host_tests::robot::{load, run, RobotOptions};
use host_tests::sensor::{Background, Source};
use rri_firmware::layout;
use rri_firmware::sensor::prelude::*;
use rri_firmware::sensors::aligned::Aligned;
use std::sync::Mutex;

fn drive(addr: std::net::SocketAddr, cycles: u64) -> host_tests::robot::report::Summary {
    let (gsi, device) = built_gsi();
    let mut o = RobotOptions::new(gsi, addr);
    o.device = device;
    o.cycles = cycles;
    o.rate_ms = 4;
    let d = load(&o).expect("GSI loads");
    run(&o, &d, &mut std::io::sink())
        .expect("simulation runs")
        .0
}

#[test]
fn the_aligned_example_passes_the_simulators_checks() {
    let sensor =
        Background::start_sensor::<Aligned>(false, layout::ENGINE_CONFIG, Source::Simulated)
            .expect("sensor listening");
    let s = drive(sensor.addr, 300);
    let report = sensor.stop().expect("sensor runs");
    assert!(s.passed(), "{:?}", s.failure());
    assert_eq!((s.answered, s.wrong_id, s.malformed), (300, 0, 0));
    assert_eq!(report.stats.answered, 300);
}

/// One cycle as the recording sensor saw it: how long before the
/// message's arrival the robot's feedback was (device µs), and how far the
/// paired sample lies from that instant.
#[derive(Clone, Copy, Debug)]
struct Seen {
    feedback_before_arrival_us: i64,
    sample_offset_us: Option<i64>,
}

static SEEN: Mutex<Vec<Seen>> = Mutex::new(Vec::new());

/// Samples at 1 kHz (simulated), and records per cycle what `Aligned`
/// would pair.
struct Recorder;

impl<R: RobotSet, D: DeviceSet> Sensor<R, D> for Recorder {
    type Sample = f32;
    type History = History<f32, 64>;
    const SAMPLE_EVERY_US: u32 = 1_000;

    fn new() -> Self {
        Recorder
    }

    fn sample(_: &mut impl Inputs, _: Instant) -> Option<f32> {
        None
    }

    fn simulate(now: Instant) -> f32 {
        now.as_micros() as f32
    }

    fn fill(&mut self, samples: &Self::History, robot: &R, _: &mut D, cycle: &CycleInfo<'_>) {
        let (Some((time, _)), Some(clock), Some(received)) =
            (feedback(robot), cycle.robot_clock, cycle.received)
        else {
            return;
        };
        let Some(at) = clock.device_time(time) else {
            return;
        };
        let seen = Seen {
            feedback_before_arrival_us: received.signed_micros_since(at),
            sample_offset_us: samples.closest(at).map(|s| s.time.signed_micros_since(at)),
        };
        if let Ok(mut v) = SEEN.lock() {
            v.push(seen);
        }
    }
}

#[test]
fn feedback_time_maps_to_device_time_and_pairs_a_sample_t2() {
    let sensor =
        Background::start_sensor::<Recorder>(false, layout::ENGINE_CONFIG, Source::Simulated)
            .expect("sensor listening");
    // The sampler's first samples: 100 ms of history before the robot.
    std::thread::sleep(std::time::Duration::from_millis(100));
    let s = drive(sensor.addr, 200);
    sensor.stop().expect("sensor runs");
    assert!(s.passed(), "{:?}", s.failure());
    let seen = SEEN.lock().expect("lock").clone();
    if seen.is_empty() {
        // A layout whose robot data has no time and frame: nothing to pair.
        let probe = <layout::RobotProperties as Default>::default();
        assert!(
            feedback(&probe).is_none(),
            "feedback present but never seen"
        );
        return;
    }
    assert_eq!(seen.len(), 200, "every cycle paired");
    for s in &seen {
        // The simulator's feedback is 8 ms older than its Ts; transit on
        // loopback adds well under a millisecond.
        assert!(
            (7_500..=9_500).contains(&s.feedback_before_arrival_us),
            "{s:?}"
        );
    }
    // The host's sampler thread is scheduled by Linux: most pairs within
    // half a period, all within a few periods.
    let offsets: Vec<i64> = seen.iter().filter_map(|s| s.sample_offset_us).collect();
    assert_eq!(offsets.len(), seen.len(), "a sample for every cycle");
    let near = offsets.iter().filter(|o| o.abs() <= 600).count();
    assert!(
        near * 10 >= offsets.len() * 9,
        "{near} of {} near",
        offsets.len()
    );
    assert!(offsets.iter().all(|o| o.abs() <= 5_000), "{offsets:?}");
}
