//! The cycle's state and counters, published for the tasks that watch it.
//!
//! The cycle runs on the urgent executor and owns the engine; housekeeping
//! (LEDs, watchdog, logs) runs in thread mode and must never hold the
//! engine, or a slow log line could delay an answer. So after each turn the
//! cycle copies a [`Snapshot`] into a [`Published`] cell (under a
//! critical section, after the reply is on its way) and the watchers read
//! the latest copy whenever they like.
//!
//! The cycle writes the engine's figures straight into the cell
//! ([`Published::publish_of`]): one copy of the counters a turn, not the
//! three of building a snapshot, moving it and swapping it into a `Cell`.
//! Measured when the counters became `u64` (issue 42 #11): the copies
//! were most of the 1,155 instructions the full path gained.

use crate::engine::{Endpoint, Engine, ErrorCode, Instant, PropertySeen, SensorState, Stats};
use crate::properties::MAX_PROPERTIES;
use crate::properties::{DeviceSet, RobotSet};
use core::cell::RefCell;
use critical_section::Mutex;

/// What the watchers see of the cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Snapshot {
    /// The S2 state, for the status LED and the log.
    pub state: SensorState,
    /// The S2 error code while the state is `ERROR`.
    pub error: Option<ErrorCode>,
    /// The controller being answered (S4), if one spoke.
    pub peer: Option<Endpoint>,
    /// Every counter, as of this turn.
    pub stats: Stats,
    /// Turns of the cycle loop (messages and polls): the watchdog is fed
    /// only while this moves.
    pub heartbeat: u32,
    /// When the last robot message that decoded arrived.
    pub last_message: Option<Instant>,
    /// Per robot property: messages decoded and their interval (M11).
    pub robot_seen: [PropertySeen; MAX_PROPERTIES],
}

impl Snapshot {
    /// The engine's state after turn number `heartbeat`.
    pub fn of<R: RobotSet, D: DeviceSet>(engine: &Engine<R, D>, heartbeat: u32) -> Self {
        let mut s = Snapshot::default();
        s.fill(engine, heartbeat);
        s
    }

    /// Overwrites this snapshot with the engine's state, in place.
    #[inline(always)]
    fn fill<R: RobotSet, D: DeviceSet>(&mut self, engine: &Engine<R, D>, heartbeat: u32) {
        self.state = engine.state();
        self.error = engine.error_code();
        self.peer = engine.peer();
        self.stats = *engine.stats_ref();
        self.heartbeat = heartbeat;
        self.last_message = engine.last_message();
        self.robot_seen = engine.robot_seen();
    }
}

/// One writer (the cycle), any number of readers, none of them waiting for
/// more than one copy.
pub struct Published {
    latest: Mutex<RefCell<Snapshot>>,
}

impl Default for Published {
    fn default() -> Self {
        Self::new()
    }
}

impl Published {
    /// Holds an `UNDEFINED` snapshot until the first publish (`const`, for
    /// a `static`).
    pub const fn new() -> Self {
        Published {
            latest: Mutex::new(RefCell::new(Snapshot {
                state: SensorState::Undefined,
                error: None,
                peer: None,
                stats: Stats::ZERO,
                heartbeat: 0,
                last_message: None,
                robot_seen: [PropertySeen {
                    messages: 0,
                    interval_us: 0,
                }; MAX_PROPERTIES],
            })),
        }
    }

    // Every borrow below is taken and given back inside one critical
    // section, so none can find another outstanding: the `try_` forms
    // never fail, and are used because they cannot panic.

    /// Replaces the copy (the cycle, after each turn).
    pub fn publish(&self, snapshot: &Snapshot) {
        critical_section::with(|cs| {
            if let Ok(mut s) = self.latest.borrow(cs).try_borrow_mut() {
                *s = *snapshot;
            }
        });
    }

    /// Replaces the copy with `engine`'s state after turn `heartbeat`,
    /// written in place (the cycle, after each turn).
    pub fn publish_of<R: RobotSet, D: DeviceSet>(&self, engine: &Engine<R, D>, heartbeat: u32) {
        critical_section::with(|cs| {
            if let Ok(mut s) = self.latest.borrow(cs).try_borrow_mut() {
                s.fill(engine, heartbeat);
            }
        });
    }

    /// The last published copy; for any number of watchers.
    pub fn latest(&self) -> Snapshot {
        critical_section::with(|cs| {
            self.latest
                .borrow(cs)
                .try_borrow()
                .map(|s| *s)
                .unwrap_or_default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readers_get_the_last_published_copy() {
        let cell = Published::new();
        assert_eq!(cell.latest(), Snapshot::default());
        let mut s = Snapshot {
            state: SensorState::Operating,
            heartbeat: 7,
            ..Snapshot::default()
        };
        s.stats.answered = 3;
        cell.publish(&s);
        assert_eq!(cell.latest(), s);
        s.heartbeat = 8;
        cell.publish(&s);
        assert_eq!(cell.latest().heartbeat, 8);
    }
}
