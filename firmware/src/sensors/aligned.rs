//! Time-aligned measurement (T2), the reason RRI carries timestamps: the
//! robot's feedback pose is ~8 ms old when its message arrives, so the
//! newest sample belongs to another position of the tool. This sensor
//! samples at 1 kHz, keeps the last 24 ms, and answers each message with
//! the sample taken closest to the robot's feedback time, beside the
//! feedback pose it belongs to: `[distance, offset_ms, x, y, z]` in the
//! first `real` array (the manual's `AppData`), where `offset_ms` is how
//! far the sample lies from the feedback instant (at most half a sampling
//! period while the sampler keeps pace), and `OK` / `OUT OF RANGE` /
//! `NO SAMPLE` / `NO FEEDBACK` in the first `string` field. It works with
//! any layout whose robot data has a `time` and a `frame` field.

use rri_firmware::demo::simulated_distance;
use rri_firmware::sensor::prelude::*;

/// What the firmware and `cargo sensor-host` run when `RRI_SENSOR` names
/// this file.
pub type ThisSensor = Aligned;

/// Samples kept (one per ms).
pub const HISTORY: usize = 24;

/// A0's full scale as a distance.
pub const RANGE_MM: f32 = 300.0;

/// One sample: the distance, and whether a target was in range (an
/// analog distance sensor reads full scale when it sees none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Distance, mm.
    pub mm: f32,
    /// A target was in range.
    pub in_range: bool,
}

/// No state of its own: every reply comes from the history.
pub struct Aligned;

impl<R: RobotSet, D: DeviceSet> Sensor<R, D> for Aligned {
    type Sample = Reading;
    /// 24 ms at 1 kHz: three times the feedback's age, and small enough
    /// for the boards (three copies of 392 bytes in the DTCM, see
    /// firmware/README.md's "How much RAM your sensor may take").
    type History = History<Self::Sample, HISTORY>;
    const SAMPLE_EVERY_US: u32 = 1_000;

    fn new() -> Self {
        Aligned
    }

    fn sample(inputs: &mut impl Inputs, _now: Instant) -> Option<Reading> {
        let fraction = inputs.analog(0)?;
        Some(Reading {
            mm: fraction * RANGE_MM,
            in_range: fraction < 0.99,
        })
    }

    fn simulate(now: Instant) -> Reading {
        Reading {
            mm: simulated_distance(now),
            in_range: true,
        }
    }

    /// A recorded row: `mm` or `mm,in_range` (in range when non-zero).
    fn replay(columns: &[f32]) -> Option<Reading> {
        match *columns {
            [mm] => Some(Reading { mm, in_range: true }),
            [mm, flag] => Some(Reading {
                mm,
                in_range: flag != 0.0,
            }),
            _ => None,
        }
    }

    fn fill(&mut self, samples: &Self::History, robot: &R, device: &mut D, cycle: &CycleInfo<'_>) {
        // Where the robot was, and when: its feedback time (controller
        // clock) as a device time, where the samples are.
        let robot_at = feedback(robot)
            .and_then(|(time, pose)| Some((cycle.robot_clock?.device_time(time)?, pose)));
        // Never stale as fresh: without a pairing the values are 0 and the
        // status says why.
        let Some((at, pose)) = robot_at else {
            fill_reals(device, cycle.sending, &[0.0; 5]);
            set_status(device, cycle.sending, "NO FEEDBACK");
            return;
        };
        let status = match samples.closest(at) {
            None => {
                fill_reals(device, cycle.sending, &[0.0; 5]);
                "NO SAMPLE"
            }
            Some(s) => {
                let offset_ms = s.time.signed_micros_since(at) as f32 / 1000.0;
                let values = [s.value.mm, offset_ms, pose.x, pose.y, pose.z];
                fill_reals(device, cycle.sending, &values);
                if s.value.in_range {
                    "OK"
                } else {
                    "OUT OF RANGE"
                }
            }
        };
        set_status(device, cycle.sending, status);
    }
}
