//! # Your sensor, in one place
//!
//! An integrator's measuring device (a distance sensor on an ADC, a laser
//! line on SPI, a force sensor on I²C) becomes an RRI sensor by
//! implementing one trait, [`Sensor`], in one file: what a sample is, how
//! it is taken and how often, and how each reply is filled from the
//! samples and the robot's data. Nothing else changes: every board, the
//! host sensor (`cargo sensor-host`) and the tests run that file as it is.
//! The build picks the file with `RRI_SENSOR` (see [`crate::sensors`]).
//!
//! Two halves, because they run at two priorities:
//! - **sampling** ([`Sensor::sample`]) on the background executor every
//!   [`Sensor::SAMPLE_EVERY_US`]: it may take its time (an ADC conversion,
//!   an I²C transfer) without ever delaying an answer. Each sample is
//!   stamped with the device time it was taken (T2) and kept in the
//!   sensor's [`Sensor::History`], published wait-free
//!   ([`crate::sample`]).
//! - **the cycle** ([`Sensor::fill`]) at the cycle's priority, once per
//!   message sent: it must be bounded (no blocking, no heap, no waiting on
//!   the sampler) and return well within the robot's 4 ms cycle.
//!
//! Time alignment (T2): the robot's data is ~8 ms old (feedback) or 24–60
//! ms ahead (planned), stamped on the controller's clock. [`CycleInfo`]
//! carries the device time each robot message arrived and the controller's
//! `Ts` ([`RobotClock`](crate::engine::RobotClock)), which map a controller time to a device time,
//! and [`History::closest`] finds the sample of that instant.
//!
//! The board hands the sampling half its peripherals through `hal-board`
//! ([`Inputs`]): chip code stays there, and the sensor stays chip-free, so
//! its sample type can never break a board's build.

mod fields;
mod history;

pub use fields::{feedback, fill_reals, first_frame, set_status};
pub use hal_board::io::{Inputs, Simulated};
pub use history::{History, Ring, Stamped};

pub mod math;

use crate::engine::{Application, CycleInfo, Instant};
use crate::layout::{DeviceProperties, RobotProperties};
use crate::sample::{SampleReader, SampleWriter};
use core::marker::PhantomData;

/// Everything a sensor file needs: `use rri_firmware::sensor::prelude::*;`
/// (its [`math`] too: `math::sin(x)`, the same on the host
/// and the MCU).
pub mod prelude {
    pub use super::{
        feedback, fill_reals, first_frame, math, set_status, History, Inputs, Sensor, Stamped,
    };
    pub use crate::engine::{CycleInfo, Instant, RobotClock};
    pub use crate::layout::{DeviceProperties, RobotProperties};
    pub use crate::properties::{DeviceSet, RobotSet};
    pub use crate::value::{Frame, Time};
}

/// A measuring device as an RRI sensor. `R` and `D` are the robot's and
/// the device's property sets: the built layout's by default
/// (`impl Sensor for MySensor` and then `robot.rob_data.feedback_pose`),
/// or any, for a sensor that works with every layout (the examples in
/// [`crate::sensors`]).
pub trait Sensor<R = RobotProperties, D = DeviceProperties>: Sized {
    /// One sample: any `Copy` type (a value, several channels, a status,
    /// the device's own timestamp). Changing it is this one line: the
    /// board never sees it.
    type Sample: Copy + Send;
    /// The samples [`Sensor::fill`] sees: `History<Self::Sample, N>`, the
    /// last `N` (size it to cover how far back the robot's data reaches:
    /// feedback is ~8 ms old, T2).
    type History: Ring<Self::Sample>;
    /// How often the background executor takes a sample, in µs.
    const SAMPLE_EVERY_US: u32;

    /// The cycle half's state at start-up (filters, counters).
    fn new() -> Self;

    /// Takes one sample from the board's inputs, on the background
    /// executor: it may wait for a conversion or a transfer, never for the
    /// cycle. `now` is the device time it is taken at (its stamp).
    /// `None`: no sample this time (nothing is added to the history).
    fn sample(inputs: &mut impl Inputs, now: Instant) -> Option<Self::Sample>;

    /// A plausible sample at `now`, for where nothing real can be read:
    /// the QEMU board and `cargo sensor-host`'s simulated source.
    fn simulate(now: Instant) -> Self::Sample;

    /// A sample from one row of a recorded CSV file, its columns after the
    /// time (`cargo sensor-host -- --replay FILE`). `None`: the row is
    /// refused; the default refuses every row.
    fn replay(columns: &[f32]) -> Option<Self::Sample> {
        let _ = columns;
        None
    }

    /// Fills the device property about to be sent (`cycle.sending`) from
    /// the samples and the robot's data; whatever it leaves there goes out.
    /// Runs at the cycle's priority: bounded work, no blocking, no heap.
    ///
    /// The contract: never a stale value as a fresh one. The property
    /// keeps what the last call wrote (the engine does not clear it), so
    /// when there is no fresh sample for a value, write it as 0 (or empty)
    /// and say why in a status field, as both examples do (`STALE`,
    /// `NO SAMPLE`, `NO FEEDBACK`): a robot program that reads the value
    /// without the status must not follow an old measurement.
    fn fill(&mut self, samples: &Self::History, robot: &R, device: &mut D, cycle: &CycleInfo<'_>);
}

/// The sampling half's plumbing: the writer of the cell the cycle reads,
/// whose slots hold the history (no copy of it here). The board's (or the host's) sampler task calls
/// [`Sampler::step`] every [`Sensor::SAMPLE_EVERY_US`].
pub struct Sampler<'a, S, R = RobotProperties, D = DeviceProperties>
where
    S: Sensor<R, D>,
{
    /// Publishes the history; the history itself lives in the cell's
    /// slots ([`SampleWriter::publish_with`]), not here.
    writer: SampleWriter<'a, S::History>,
    _layout: PhantomData<fn(&R, &mut D)>,
}

impl<'a, S: Sensor<R, D>, R, D> Sampler<'a, S, R, D> {
    /// A sampler publishing through `writer`.
    pub fn new(writer: SampleWriter<'a, S::History>) -> Self {
        Sampler {
            writer,
            _layout: PhantomData,
        }
    }

    /// Takes one sample at `now` ([`Sensor::simulate`] when the inputs are
    /// [`Inputs::simulated`], else [`Sensor::sample`]) and publishes the
    /// history; `false` when the sensor had none.
    pub fn step(&mut self, inputs: &mut impl Inputs, now: Instant) -> bool {
        let sample = if inputs.simulated() {
            Some(S::simulate(now))
        } else {
            S::sample(inputs, now)
        };
        match sample {
            Some(value) => {
                self.push(Stamped { time: now, value });
                true
            }
            None => false,
        }
    }

    /// Adds a sample from elsewhere (a recorded file) and publishes.
    pub fn push(&mut self, sample: Stamped<S::Sample>) {
        // The last history published plus this sample, built in the
        // writer's slot: no copy of the history kept here.
        self.writer.publish_with(|history| history.push(sample));
    }
}

/// A [`Sensor`] as the engine's [`Application`]: each cycle it takes the
/// newest history the sampler published (one atomic swap, no copy) and
/// calls [`Sensor::fill`].
pub struct SensorApp<'a, S, R = RobotProperties, D = DeviceProperties>
where
    S: Sensor<R, D>,
{
    sensor: S,
    reader: SampleReader<'a, S::History>,
    _layout: PhantomData<fn(&R, &mut D)>,
}

impl<'a, S: Sensor<R, D>, R, D> SensorApp<'a, S, R, D> {
    /// The sensor's cycle half ([`Sensor::new`]), reading what the
    /// [`Sampler`] publishes through `reader`.
    pub fn new(reader: SampleReader<'a, S::History>) -> Self {
        SensorApp {
            sensor: S::new(),
            reader,
            _layout: PhantomData,
        }
    }

    /// The sensor itself (tests look at its state).
    pub fn sensor(&self) -> &S {
        &self.sensor
    }
}

impl<S: Sensor<R, D>, R, D> Application<R, D> for SensorApp<'_, S, R, D> {
    fn cycle(&mut self, robot: &R, device: &mut D, info: &CycleInfo<'_>) {
        let samples = self.reader.latest();
        self.sensor.fill(samples, robot, device, info);
    }
}

#[cfg(test)]
mod tests;
