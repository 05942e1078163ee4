//! Device time as the engine sees it: microseconds since boot, from
//! whatever clock the board has.

use crate::value::Time;

/// A point in device time, in microseconds since boot. Boards convert their
/// timer ticks; the engine never reads a clock itself except through
/// [`Clock`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Instant(pub u64);

impl Instant {
    /// `us` microseconds since boot.
    pub const fn from_micros(us: u64) -> Self {
        Instant(us)
    }

    /// `ms` milliseconds since boot (saturating).
    pub const fn from_millis(ms: u64) -> Self {
        Instant(ms.saturating_mul(1000))
    }

    /// Microseconds since boot.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Microseconds from `earlier` to `self`, zero if `earlier` is later.
    pub const fn micros_since(self, earlier: Instant) -> u64 {
        self.0.saturating_sub(earlier.0)
    }

    /// This instant as an RRI `time` (the reply's `Ts`, M8).
    pub fn as_time(self) -> Time {
        Time::from_micros(i64::try_from(self.0).unwrap_or(i64::MAX))
    }
}

/// The device clock. Boards implement it over their timer; tests use a
/// fake one they move by hand.
pub trait Clock {
    /// The current device time: the replies' `Ts` (M8), the `TimeOut`
    /// supervision (S1) and the latency figures.
    fn now(&self) -> Instant;
}
