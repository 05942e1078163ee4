//! A sensor whose history is too large for the boards: 96 samples of the
//! distance, 2,312 bytes, whose three copies in the DTCM (the sample
//! cell's slots) take far more than the 2.7 KiB a sensor may use, so they
//! leave the stack less than its 80 KiB (budgets otherwise kept).
//! CI builds the F767 image with it (`RRI_SENSOR=host-tests/sensors/
//! oversized.rs cargo build-f767`) and expects the link to refuse it with
//! the stack rule's line: the board's rules hold on the plain board build
//! too, not only in `cargo boards`.

use rri_firmware::demo::simulated_distance;
use rri_firmware::sensor::prelude::*;

pub type ThisSensor = Oversized;

pub struct Oversized;

impl<R: RobotSet, D: DeviceSet> Sensor<R, D> for Oversized {
    type Sample = f32;
    type History = History<Self::Sample, 96>;
    const SAMPLE_EVERY_US: u32 = 1_000;

    fn new() -> Self {
        Oversized
    }

    fn sample(inputs: &mut impl Inputs, _now: Instant) -> Option<f32> {
        inputs.analog(0)
    }

    fn simulate(now: Instant) -> f32 {
        simulated_distance(now)
    }

    fn fill(&mut self, samples: &Self::History, _robot: &R, device: &mut D, cycle: &CycleInfo<'_>) {
        let value = samples.latest().map_or(0.0, |s| s.value);
        fill_reals(device, cycle.sending, &[value]);
        set_status(device, cycle.sending, if value > 0.0 { "OK" } else { "NO SAMPLE" });
    }
}
