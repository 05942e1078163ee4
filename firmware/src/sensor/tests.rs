//! The plumbing between a sensor's two halves: what the sampler takes
//! reaches `fill` whole and stamped, simulated where the inputs say so,
//! and a sample the sensor declined never enters the history.

use super::*;
use crate::engine::{SensorState, Stats};
use crate::sample::SampleCell;
use hal_board::io::Absent;

/// Counts its samples; the reply's first real is the newest sample, the
/// second how many the history holds.
struct Counting;

/// An input whose A0 reads `level`.
struct Level(f32);

impl Inputs for Level {
    fn analog(&mut self, channel: usize) -> Option<f32> {
        (channel == 0).then_some(self.0)
    }
}

impl Sensor for Counting {
    type Sample = (u32, f32);
    type History = History<Self::Sample, 4>;
    const SAMPLE_EVERY_US: u32 = 1_000;

    fn new() -> Self {
        Counting
    }

    fn sample(inputs: &mut impl Inputs, now: Instant) -> Option<(u32, f32)> {
        Some((now.as_micros() as u32, inputs.analog(0)?))
    }

    fn simulate(now: Instant) -> (u32, f32) {
        (now.as_micros() as u32, -1.0)
    }

    fn fill(
        &mut self,
        samples: &Self::History,
        _: &RobotProperties,
        device: &mut DeviceProperties,
        _: &CycleInfo<'_>,
    ) {
        let newest = samples.latest().map_or(0.0, |s| s.value.1);
        fill_reals(device, 0, &[newest, samples.len() as f32]);
    }
}

fn info(stats: &Stats, now: u64) -> CycleInfo<'_> {
    CycleInfo {
        state: SensorState::Operating,
        now: Instant(now),
        robot_id: Some(1),
        robot_ts: None,
        received: Some(Instant(now)),
        robot_clock: None,
        arrived: Some(0),
        sending: 0,
        stats,
    }
}

fn cycle(app: &mut SensorApp<'_, Counting>, now: u64) -> [f32; 2] {
    let stats = Stats::default();
    let mut device = DeviceProperties::default();
    app.cycle(&RobotProperties::default(), &mut device, &info(&stats, now));
    let d = device.sens_data.application_data;
    [d[0], d[1]]
}

#[test]
fn samples_reach_the_cycle_stamped_and_in_order() {
    let cell = SampleCell::new(<History<(u32, f32), 4>>::EMPTY);
    let (writer, reader) = cell.split().expect("split");
    let mut sampler = Sampler::<Counting>::new(writer);
    let mut app = SensorApp::<Counting>::new(reader);
    assert_eq!(cycle(&mut app, 0), [0.0, 0.0], "nothing sampled yet");
    for (t, level) in [(1_000, 0.25), (2_000, 0.5)] {
        assert!(sampler.step(&mut Level(level), Instant(t)));
    }
    assert_eq!(cycle(&mut app, 2_500), [0.5, 2.0]);
    for t in 3..10 {
        sampler.step(&mut Level(t as f32), Instant(t * 1_000));
    }
    assert_eq!(cycle(&mut app, 9_500), [9.0, 4.0], "the last four kept");
}

#[test]
fn simulated_inputs_ask_the_sensor_to_simulate() {
    let cell = SampleCell::new(<History<(u32, f32), 4>>::EMPTY);
    let (writer, reader) = cell.split().expect("split");
    let mut sampler = Sampler::<Counting>::new(writer);
    let mut app = SensorApp::<Counting>::new(reader);
    assert!(sampler.step(&mut Simulated, Instant(7)));
    assert_eq!(cycle(&mut app, 10), [-1.0, 1.0]);
}

#[test]
fn a_declined_sample_adds_nothing() {
    let cell = SampleCell::new(<History<(u32, f32), 4>>::EMPTY);
    let (writer, reader) = cell.split().expect("split");
    let mut sampler = Sampler::<Counting>::new(writer);
    let mut app = SensorApp::<Counting>::new(reader);
    assert!(!sampler.step(&mut Absent, Instant(7)), "no A0: no sample");
    assert_eq!(cycle(&mut app, 10), [0.0, 0.0]);
}
