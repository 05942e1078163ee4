//! The worked examples on the manual's layout (the default configuration),
//! fed by hand: what each reply must carry for the samples and robot data
//! given.

use super::aligned::{Aligned, Reading, HISTORY};
use super::distance::Distance;
use crate::engine::{CycleInfo, Instant, RobotClock, SensorState, Stats};
use crate::layout::{DeviceProperties, RobotProperties};
use crate::sensor::{History, Inputs, Sensor, Stamped};
use crate::value::{Frame, Time};

/// A0 at a fixed fraction of full scale.
struct A0(f32);

impl Inputs for A0 {
    fn analog(&mut self, channel: usize) -> Option<f32> {
        (channel == 0).then_some(self.0)
    }
}

fn info(stats: &Stats, now: Instant, clock: Option<RobotClock>) -> CycleInfo<'_> {
    CycleInfo {
        state: SensorState::Operating,
        now,
        robot_id: Some(7),
        robot_ts: clock.map(|c| c.ts),
        received: clock.map(|c| c.received),
        robot_clock: clock,
        arrived: Some(0),
        sending: 0,
        stats,
    }
}

/// The tool 300 mm up, pointing down (Rx = 180°), as the simulator's.
fn robot(feedback: Time) -> RobotProperties {
    let mut r = RobotProperties::default();
    r.rob_data.feedback_time = feedback;
    r.rob_data.feedback_pose = Frame {
        x: 400.0,
        y: -35.0,
        z: 300.0,
        rx: 180.0,
        ry: 0.0,
        rz: 0.0,
    };
    r
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-3
}

#[test]
fn distance_reads_a0_as_0_to_300_mm() {
    let d = <Distance as Sensor>::sample(&mut A0(0.5), Instant(0));
    assert_eq!(d, Some(150.0));
    assert_eq!(<Distance as Sensor>::replay(&[123.5, 9.0]), Some(123.5));
}

#[test]
fn distance_projects_the_filtered_reading_along_the_tool() {
    let mut h = History::<f32, 4>::EMPTY;
    let stats = Stats::default();
    let mut device = DeviceProperties::default();
    let mut sensor = <Distance as Sensor>::new();
    let r = robot(Time::ZERO);
    h.push(Stamped {
        time: Instant::from_millis(10),
        value: 100.0,
    });
    sensor.fill(
        &h,
        &r,
        &mut device,
        &info(&stats, Instant::from_millis(12), None),
    );
    let a = device.sens_data.application_data;
    assert_eq!(device.sens_data.error_string.as_str(), "OK");
    // The first reading passes the filter unchanged; down 100 mm from z 300.
    assert!(close(a[0], 100.0) && close(a[1], 400.0) && close(a[2], -35.0));
    assert!(close(a[3], 200.0) && close(a[4], 2.0), "{a:?}");
    // 0.3 of a new reading of 200: 130.
    h.push(Stamped {
        time: Instant::from_millis(20),
        value: 200.0,
    });
    sensor.fill(
        &h,
        &r,
        &mut device,
        &info(&stats, Instant::from_millis(20), None),
    );
    assert!(close(device.sens_data.application_data[0], 130.0));
    // Too old: STALE, and never the last value as if it were fresh: the
    // distance and the point 0, only the age (180 ms) reported.
    sensor.fill(
        &h,
        &r,
        &mut device,
        &info(&stats, Instant::from_millis(200), None),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "STALE");
    let a = device.sens_data.application_data;
    assert_eq!(a[..4], [0.0; 4], "{a:?}");
    assert!(close(a[4], 180.0), "{a:?}");
    // The filter kept its state: a fresh sample goes on from 130.
    h.push(Stamped {
        time: Instant::from_millis(205),
        value: 200.0,
    });
    sensor.fill(
        &h,
        &r,
        &mut device,
        &info(&stats, Instant::from_millis(206), None),
    );
    assert!(close(device.sens_data.application_data[0], 151.0));
}

#[test]
fn distance_without_samples_says_so() {
    let stats = Stats::default();
    let mut device = DeviceProperties::default();
    let mut sensor = <Distance as Sensor>::new();
    let h = History::<f32, 4>::EMPTY;
    sensor.fill(
        &h,
        &robot(Time::ZERO),
        &mut device,
        &info(&stats, Instant(5), None),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "NO SAMPLE");
    assert_eq!(device.sens_data.application_data[4], -1.0);
}

/// Samples every ms from 0 to 63 ms, each value its time in ms (the
/// history keeps the last 24: 40 to 63 ms).
fn one_khz() -> History<Reading, HISTORY> {
    let mut h = History::EMPTY;
    for ms in 0..64u64 {
        h.push(Stamped {
            time: Instant::from_millis(ms),
            value: Reading {
                mm: ms as f32,
                in_range: ms != 40,
            },
        });
    }
    h
}

#[test]
fn aligned_pairs_the_feedback_pose_with_the_sample_of_its_instant_t2() {
    let stats = Stats::default();
    let mut device = DeviceProperties::default();
    let mut sensor = <Aligned as Sensor>::new();
    // The message left the controller at 86,400.060 s and arrived at
    // device time 60.3 ms; its feedback is 8.2 ms older than Ts: device
    // time 52.1 ms, closest sample the one of 52 ms.
    let clock = RobotClock {
        ts: Time::from_micros(86_400_060_000),
        received: Instant(60_300),
    };
    let r = robot(Time::from_micros(86_400_051_800));
    sensor.fill(
        &one_khz(),
        &r,
        &mut device,
        &info(&stats, Instant(60_400), Some(clock)),
    );
    let a = device.sens_data.application_data;
    assert_eq!(device.sens_data.error_string.as_str(), "OK");
    assert!(
        close(a[0], 52.0),
        "the sample of the feedback instant, not the newest (63): {a:?}"
    );
    assert!(close(a[1], -0.1), "52.0 ms is 0.1 ms before 52.1 ms: {a:?}");
    assert!(
        close(a[2], 400.0) && close(a[3], -35.0) && close(a[4], 300.0),
        "{a:?}"
    );
    // Feedback at device time 40 ms: that sample was out of range.
    let r = robot(Time::from_micros(86_400_039_700));
    sensor.fill(
        &one_khz(),
        &r,
        &mut device,
        &info(&stats, Instant(60_400), Some(clock)),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "OUT OF RANGE");
    assert!(close(device.sens_data.application_data[0], 40.0));
}

#[test]
fn aligned_without_robot_time_or_samples_says_which() {
    let stats = Stats::default();
    let mut device = DeviceProperties::default();
    let mut sensor = <Aligned as Sensor>::new();
    let r = robot(Time::from_micros(86_400_051_800));
    sensor.fill(
        &one_khz(),
        &r,
        &mut device,
        &info(&stats, Instant(60_400), None),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "NO FEEDBACK");
    assert_eq!(device.sens_data.application_data[..5], [0.0; 5]);
    let clock = RobotClock {
        ts: Time::from_micros(86_400_060_000),
        received: Instant(60_300),
    };
    // After a paired reply, a cycle without samples clears its values:
    // never the last cycle's as if they were new.
    sensor.fill(
        &one_khz(),
        &r,
        &mut device,
        &info(&stats, Instant(60_400), Some(clock)),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "OK");
    assert_ne!(device.sens_data.application_data[..5], [0.0; 5]);
    sensor.fill(
        &History::EMPTY,
        &r,
        &mut device,
        &info(&stats, Instant(60_400), Some(clock)),
    );
    assert_eq!(device.sens_data.error_string.as_str(), "NO SAMPLE");
    assert_eq!(device.sens_data.application_data[..5], [0.0; 5]);
}

#[test]
fn aligned_reads_a0_and_recorded_rows() {
    let full = <Aligned as Sensor>::sample(&mut A0(1.0), Instant(0));
    assert_eq!(
        full,
        Some(Reading {
            mm: 300.0,
            in_range: false
        })
    );
    assert_eq!(
        <Aligned as Sensor>::replay(&[12.0, 0.0]),
        Some(Reading {
            mm: 12.0,
            in_range: false
        })
    );
    assert_eq!(<Aligned as Sensor>::replay(&[]), None);
}
