//! The last [`EVENTS`] things that happened to the device, with their
//! times: resets and their cause, state changes, supervision trips, link
//! changes, the controller locking on or changing. Housekeeping (at the
//! background's priority) writes them by comparing the snapshots the
//! cycle publishes; the cycle never does.

// From the board, as status.rs names them (not through status.rs, which
// holds an event log: no circle).
use core::cell::Cell;
use critical_section::Mutex;
use hal_board::reset::Cause as ResetCause;
use hal_board::LinkInfo;
use rri_firmware::engine::{Endpoint, ErrorCode, Instant, SensorState};
use rri_firmware::snapshot::Snapshot;

/// Events kept.
pub const EVENTS: usize = 16;

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// The device started, and why.
    Started(ResetCause),
    /// The S2 state changed (with the error code for `ERROR`).
    State(SensorState, Option<ErrorCode>),
    /// S1: no robot message for `TimeOut`.
    TimeOut,
    /// S1: more than `MaxLost` robot messages lost in a row.
    MaxLost,
    /// The link came up (speed in Mbit/s and duplex where known).
    LinkUp(Option<u16>, Option<bool>),
    /// The link went down.
    LinkDown,
    /// A controller became the peer, or took over (S4).
    Peer(Endpoint),
}

/// One event and when it happened (device time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    /// When.
    pub at: Instant,
    /// What.
    pub kind: EventKind,
}

/// A ring of the last [`EVENTS`] events (`Copy`: the service takes a copy
/// per response).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EventLog {
    /// The first `total.min(EVENTS)` are events; the rest are
    /// [`EventLog::FILLER`] (all zero bytes, not `None`: so that a
    /// `static` log starts in `.bss` and costs no flash).
    ring: [Event; EVENTS],
    /// Events ever pushed (the next one goes to `total % EVENTS`).
    total: u32,
}

impl Default for EventLog {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl EventLog {
    /// Nothing yet.
    pub const EMPTY: EventLog = EventLog {
        ring: [Self::FILLER; EVENTS],
        total: 0,
    };

    /// What the unused entries hold (never shown).
    const FILLER: Event = Event {
        at: Instant(0),
        kind: EventKind::Started(ResetCause::PowerOn),
    };

    /// Adds `kind` at `at`, forgetting the oldest when full.
    pub fn push(&mut self, at: Instant, kind: EventKind) {
        if let Some(slot) = self.ring.get_mut(self.total as usize % EVENTS) {
            *slot = Event { at, kind };
        }
        self.total = self.total.wrapping_add(1);
    }

    /// Events ever pushed (more than are kept once it wrapped).
    pub fn total(&self) -> u32 {
        self.total
    }

    /// The kept events, newest first.
    pub fn newest_first(&self) -> impl Iterator<Item = Event> + '_ {
        let total = self.total as usize;
        (1..=EVENTS.min(total))
            .filter_map(move |back| self.ring.get(total.wrapping_sub(back) % EVENTS).copied())
    }
}

/// The board's event log: housekeeping pushes, the service copies.
pub struct Events {
    log: Mutex<Cell<EventLog>>,
}

impl Default for Events {
    fn default() -> Self {
        Self::new()
    }
}

impl Events {
    /// Empty (`const`, for a `static`).
    pub const fn new() -> Self {
        Events {
            log: Mutex::new(Cell::new(EventLog::EMPTY)),
        }
    }

    /// Adds an event.
    pub fn push(&self, at: Instant, kind: EventKind) {
        critical_section::with(|cs| {
            let cell = self.log.borrow(cs);
            let mut log = cell.get();
            log.push(at, kind);
            cell.set(log);
        });
    }

    /// After each look at the cycle (housekeeping on a board, the sensor
    /// thread on the host): the events between snapshot `last` and `now`,
    /// at `at`. One place for every form of the device, built for size.
    #[inline(never)]
    pub fn between(&self, at: Instant, last: &Snapshot, now: &Snapshot) {
        if now.state != last.state || now.error != last.error {
            self.push(at, EventKind::State(now.state, now.error));
        }
        if now.stats.timeouts > last.stats.timeouts {
            self.push(at, EventKind::TimeOut);
        }
        if now.stats.max_lost_exceeded > last.stats.max_lost_exceeded {
            self.push(at, EventKind::MaxLost);
        }
        if let Some(peer) = now.peer.filter(|_| now.peer != last.peer) {
            self.push(at, EventKind::Peer(peer));
        }
    }

    /// The link as seen now against `last` (updated): an event when it
    /// changed.
    #[inline(never)]
    pub fn link(&self, at: Instant, seen: LinkInfo, last: &mut LinkInfo) {
        if seen != *last {
            self.push(
                at,
                if seen.up {
                    EventKind::LinkUp(seen.speed_mbps, seen.full_duplex)
                } else {
                    EventKind::LinkDown
                },
            );
            *last = seen;
        }
    }

    /// A copy of the log.
    pub fn copy(&self) -> EventLog {
        critical_section::with(|cs| self.log.borrow(cs).get())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ring_keeps_the_newest_events_newest_first() {
        let mut log = EventLog::EMPTY;
        assert_eq!(log.newest_first().count(), 0);
        for i in 0..20u64 {
            log.push(Instant(i), EventKind::TimeOut);
        }
        let times: Vec<u64> = log.newest_first().map(|e| e.at.0).collect();
        assert_eq!(times, (4..20).rev().collect::<Vec<_>>());
        assert_eq!(log.total(), 20);
    }

    #[test]
    fn the_shared_log_is_copied_whole() {
        let events = Events::new();
        events.push(Instant(5), EventKind::Started(ResetCause::Watchdog));
        events.push(Instant(9), EventKind::LinkDown);
        let copy = events.copy();
        let kinds: Vec<EventKind> = copy.newest_first().map(|e| e.kind).collect();
        assert_eq!(
            kinds,
            [
                EventKind::LinkDown,
                EventKind::Started(ResetCause::Watchdog)
            ]
        );
    }
}
