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

    /// Microseconds from `reference` to `self`, negative when `self` is
    /// earlier (how far a sample lies from the instant it is paired with).
    pub const fn signed_micros_since(self, reference: Instant) -> i64 {
        (self.0 as i64).wrapping_sub(reference.0 as i64)
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

/// The controller's clock against the device's: the `Ts` of the last robot
/// message that carried one (the controller's time as it sent it, M1) and
/// the device time that message arrived. The robot's data is stamped on
/// the controller's clock (T2: feedback ~8 ms old, planned 24–60 ms
/// ahead); this pair turns such a stamp into device time, where the
/// samples are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RobotClock {
    /// The message's `Ts` (controller clock).
    pub ts: Time,
    /// When it arrived (device clock).
    pub received: Instant,
}

impl RobotClock {
    /// The device time of controller time `t`: `received + (t - ts)`. Late
    /// by the message's transit time (the controller stamps `Ts` as it
    /// sends: well under a millisecond on the robot's network), which is
    /// the same for every message of a steady link. `None` before the
    /// device booted.
    pub fn device_time(&self, t: Time) -> Option<Instant> {
        let delta = t.as_micros().checked_sub(self.ts.as_micros())?;
        let at = i64::try_from(self.received.0).ok()?.checked_add(delta)?;
        u64::try_from(at).ok().map(Instant)
    }

    /// The controller time of device time `at` (the inverse of
    /// [`RobotClock::device_time`]).
    pub fn robot_time(&self, at: Instant) -> Time {
        let delta = at.signed_micros_since(self.received);
        Time::from_micros(self.ts.as_micros().saturating_add(delta))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controller_times_map_to_device_times_t2() {
        // The controller has been up for a day; the device for a second.
        let clock = RobotClock {
            ts: Time::from_micros(86_400_123_000),
            received: Instant::from_millis(1_000),
        };
        // Feedback 8 ms before the message was sent: 8 ms before it arrived.
        let feedback = Time::from_micros(86_400_115_000);
        assert_eq!(clock.device_time(feedback), Some(Instant::from_millis(992)));
        assert_eq!(clock.robot_time(Instant::from_millis(992)), feedback);
        // Planned 60 ms ahead.
        let planned = Time::from_micros(86_400_183_000);
        assert_eq!(
            clock.device_time(planned),
            Some(Instant::from_millis(1_060))
        );
        // Before the device booted: no device time.
        assert_eq!(clock.device_time(Time::from_micros(86_399_000_000)), None);
        assert_eq!(
            Instant(5).signed_micros_since(Instant(8)),
            -3,
            "earlier is negative"
        );
    }
}
