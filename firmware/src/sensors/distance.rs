//! The demo's sensor, what every board runs unless `RRI_SENSOR` names
//! another file: a laser distance sensor on the robot's tool, on the
//! board's analog input A0 (0–3.3 V for 0–300 mm), sampled at 100 Hz.
//! Each reply carries the low-pass filtered distance and the point it
//! measured in robot coordinates (the robot's pose moved that far along
//! the tool's z axis): `[distance, x, y, z, age_ms]` in the first `real`
//! array (the manual's `AppData`), and `OK` / `STALE` / `NO SAMPLE` in the
//! first `string` field (`ErrorString`). It works with any layout.

use rri_firmware::demo::{project, simulated_distance, LowPass};
use rri_firmware::sensor::prelude::*;

/// What the firmware and `cargo sensor-host` run when `RRI_SENSOR` names
/// this file (the default).
pub type ThisSensor = Distance;

/// A0's full scale as a distance.
pub const RANGE_MM: f32 = 300.0;
/// A sample older than this is reported `STALE` (and not used).
pub const STALE_AFTER_US: u64 = 100_000;

/// The cycle half's state: the filter.
pub struct Distance {
    filter: LowPass,
}

impl<R: RobotSet, D: DeviceSet> Sensor<R, D> for Distance {
    /// A distance in mm.
    type Sample = f32;
    /// Only the newest is used: a short history.
    type History = History<Self::Sample, 4>;
    /// 100 Hz.
    const SAMPLE_EVERY_US: u32 = 10_000;

    fn new() -> Self {
        Distance {
            filter: LowPass::new(0.3),
        }
    }

    fn sample(inputs: &mut impl Inputs, _now: Instant) -> Option<f32> {
        inputs.analog(0).map(|fraction| fraction * RANGE_MM)
    }

    fn simulate(now: Instant) -> f32 {
        simulated_distance(now)
    }

    /// A recorded distance: the first column, in mm.
    fn replay(columns: &[f32]) -> Option<f32> {
        columns.first().copied()
    }

    fn fill(&mut self, samples: &Self::History, robot: &R, device: &mut D, cycle: &CycleInfo<'_>) {
        let latest = samples.latest();
        let age_us = latest.map(|s| cycle.now.micros_since(s.time));
        let status = match age_us {
            None => "NO SAMPLE",
            Some(age) if age > STALE_AFTER_US => "STALE",
            Some(_) => "OK",
        };
        // Never stale as fresh: without a fresh sample the distance and
        // the point are 0 and the status says why (the filter keeps its
        // state for when samples come back); only the age is reported.
        let distance = match latest {
            Some(s) if status == "OK" => Some(self.filter.update(s.value)),
            _ => None,
        };
        let point = match (first_frame(robot), distance) {
            (Some(pose), Some(d)) => project(&pose, d),
            _ => [0.0; 3],
        };
        let age_ms = age_us.map_or(-1.0, |us| us as f32 / 1000.0);
        let d = distance.unwrap_or(0.0);
        fill_reals(
            device,
            cycle.sending,
            &[d, point[0], point[1], point[2], age_ms],
        );
        set_status(device, cycle.sending, status);
    }
}
