//! The engine's build-time settings, generated from the GSI configuration
//! and the build settings as `layout::ENGINE_CONFIG`.

use super::Pinned;
use crate::schema::Format;

/// Build-time settings of the engine (generated as `layout::ENGINE_CONFIG`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// S1 `TimeOut`, also how long a peer must be silent before another
    /// address may take over.
    pub timeout_ms: u32,
    /// S1 `MaxLost`: a gap of more lost ids than this is a communication
    /// error.
    pub max_lost: u32,
    /// S1 `DryRun`: neither `TimeOut` nor `MaxLost` is supervised.
    pub dry_run: bool,
    /// `RRI_CONTROLLER`: only this address is ever answered.
    pub controller: Option<Pinned>,
    /// `RRI_REPLY`: the device property every robot message is answered
    /// with (its index among the device's properties).
    pub reply: usize,
    /// `RRI_SEND_PERIOD_MS`: the reply property sent unprompted, for
    /// one-way streams (0 = off).
    pub send_period_ms: u32,
    /// `RRI_PERIODIC`: device properties sent on their own schedules (for
    /// `SiGetCyclic` subscriptions of other data); at most
    /// [`crate::properties::MAX_PROPERTIES`] entries are served.
    pub periodic: &'static [Periodic],
    /// `RRI_REAL_DECIMALS`, `RRI_TIME_DECIMALS`: how sent numbers are
    /// written (M5).
    pub format: Format,
}

/// A device property sent every `period_ms` (a multiple of 4 ms) once a
/// controller is known, Id from the device's own sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Periodic {
    /// Index among the device's properties.
    pub property: usize,
    /// Milliseconds between sends (0 = off).
    pub period_ms: u32,
}
