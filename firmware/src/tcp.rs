//! M10 on the device: the message framer (from `rri-framing`, shared with
//! the host simulator) and the [`StallGuard`] that closes connections that
//! stall.

pub use rri_framing::{Framer, FramingError};

use crate::engine::Instant;

/// Why the device closes a TCP connection its peer did not close (M10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stall {
    /// An incomplete message held longer than `TimeOut`: half a message
    /// and then nothing, or one byte now and then.
    Incomplete,
    /// Silent for `TimeOut` while another connection waits (a half-open
    /// connection of a controller that has reconnected).
    SilentWhileWaiting,
}

/// M10's stall rule for one connection, so that a stalled or half-open
/// connection never locks the controller out for longer than `TimeOut`.
/// A connection that only pauses between whole messages, with nobody
/// else waiting, is kept: `SiSetCyclic` at rate 0 is legitimate. Plain
/// clock arithmetic: the host sensor and the boards' `net::Cycle::tcp` share
/// it.
#[derive(Clone, Copy, Debug)]
pub struct StallGuard {
    timeout_us: u64,
    last_rx: Instant,
    /// When the framer last started holding an incomplete message.
    partial_since: Option<Instant>,
}

impl StallGuard {
    /// A connection accepted at `now`, supervised with `TimeOut` =
    /// `timeout_ms`.
    pub fn new(timeout_ms: u32, now: Instant) -> Self {
        StallGuard {
            timeout_us: u64::from(timeout_ms) * 1000,
            last_rx: now,
            partial_since: None,
        }
    }

    /// Bytes arrived at `now`; `completed`: at least one message ended in
    /// them; `pending`: the framer's [`Framer::pending`] afterwards.
    pub fn received(&mut self, now: Instant, completed: bool, pending: usize) {
        self.last_rx = now;
        self.partial_since = match (pending, completed, self.partial_since) {
            (0, _, _) => None,
            (_, true, _) | (_, false, None) => Some(now),
            (_, false, since) => since,
        };
    }

    /// Whether to close the connection at `now`; `waiting`: another
    /// connection is waiting to be served.
    pub fn check(&self, now: Instant, waiting: bool) -> Option<Stall> {
        let expired = |t: Instant| now.micros_since(t) >= self.timeout_us;
        if self.partial_since.is_some_and(expired) {
            Some(Stall::Incomplete)
        } else if waiting && expired(self.last_rx) {
            Some(Stall::SilentWhileWaiting)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: u32 = 40;

    fn ms(ms: u64) -> Instant {
        Instant(ms * 1000)
    }

    /// M10: half a message and then nothing is closed after `TimeOut`.
    #[test]
    fn an_incomplete_message_held_for_timeout_is_a_stall() {
        let mut g = StallGuard::new(T, ms(0));
        g.received(ms(1), false, 10);
        assert_eq!(g.check(ms(40), false), None);
        assert_eq!(g.check(ms(41), false), Some(Stall::Incomplete));
    }

    /// M10: one byte every so often does not keep a partial message alive.
    #[test]
    fn a_trickle_does_not_restart_the_clock() {
        let mut g = StallGuard::new(T, ms(0));
        for t in 0..=40 {
            g.received(ms(t), false, t as usize + 1);
        }
        assert_eq!(g.check(ms(40), false), Some(Stall::Incomplete));
    }

    /// A stream whose chunks always end mid-message is not stalled while
    /// messages keep completing.
    #[test]
    fn completing_messages_restart_the_clock() {
        let mut g = StallGuard::new(T, ms(0));
        for t in (0..400).step_by(4) {
            g.received(ms(t), true, 7);
            assert_eq!(g.check(ms(t + 3), true), None);
        }
    }

    /// M10: a pause between whole messages is kept unless someone waits.
    #[test]
    fn silence_is_a_stall_only_while_another_connection_waits() {
        let mut g = StallGuard::new(T, ms(0));
        g.received(ms(4), true, 0);
        assert_eq!(g.check(ms(100_000), false), None);
        assert_eq!(g.check(ms(43), true), None);
        assert_eq!(g.check(ms(44), true), Some(Stall::SilentWhileWaiting));
    }
}
