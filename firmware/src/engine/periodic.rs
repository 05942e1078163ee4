//! Time-driven work of the engine: the `TimeOut` supervision (S1/S2) and
//! the device's periodic sends, each schedule on its own period, the most
//! overdue first.

use super::stats::bump;
use super::{Application, Clock, Endpoint, Engine, ErrorCode, Instant, Send, SensorState};
use crate::properties::{DeviceSet, RobotSet, MAX_PROPERTIES};

impl<R: RobotSet, D: DeviceSet> Engine<R, D> {
    /// Time-driven work, to be called at least every few milliseconds:
    /// the `TimeOut` supervision (S1/S2) and the periodic sends (the reply
    /// property for one-way streams, `periodic` properties). Returns a
    /// message to send, if one is due; when several are due at once, the
    /// others go out on the next calls.
    pub fn poll<A: Application<R, D>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        out: &mut [u8],
    ) -> Option<(Endpoint, usize)> {
        let now = clock.now();
        let timeout_us = u64::from(self.config.timeout_ms) * 1000;
        let silent = self
            .last_rx
            .is_some_and(|t| now.micros_since(t) > timeout_us);
        if !self.config.dry_run && self.state == SensorState::Operating && silent {
            bump(&mut self.stats.timeouts);
            self.set_state(SensorState::Error, Some(ErrorCode::Communication));
        }
        let (to, send) = self.periodic(now)?;
        match self.respond(app, clock, send, out) {
            Ok(len) => {
                bump(&mut self.stats.sent);
                bump(&mut self.stats.periodic_sent);
                Some((to, len))
            }
            Err(reason) => {
                self.stats.count_drop(reason);
                None
            }
        }
    }

    /// Schedule `slot` (device property `property` every `period_ms`, 0 =
    /// off): its due time, set to `now` the first time it is looked at;
    /// `best` or this schedule, whichever is due and more overdue, as
    /// (slot, property, period µs, due).
    fn due(
        &mut self,
        slot: usize,
        property: usize,
        period_ms: u32,
        now: Instant,
        best: Option<(usize, usize, u64, Instant)>,
    ) -> Option<(usize, usize, u64, Instant)> {
        let next = match self.next_send.get_mut(slot) {
            Some(next) if period_ms > 0 => next,
            _ => return best,
        };
        let due = *next.get_or_insert(now);
        if due <= now && best.is_none_or(|b| due < b.3) {
            Some((slot, property, u64::from(period_ms) * 1000, due))
        } else {
            best
        }
    }

    /// The periodic send that is due at `now`, if any, and where it goes:
    /// advances its schedule and the device's own Id sequence.
    fn periodic(&mut self, now: Instant) -> Option<(Endpoint, Send)> {
        if matches!(self.state, SensorState::Undefined | SensorState::Closed) {
            return None;
        }
        let to = self.peers.destination()?;
        // The most overdue schedule goes first, so one that is always due
        // cannot starve the others. With one device property there is
        // nothing but the reply to send (a compile-time constant:
        // single-property firmware carries no table walk).
        let config = self.config;
        let mut chosen = self.due(0, config.reply, config.send_period_ms, now, None);
        if D::WIRE_NAMES.len() > 1 {
            for (k, p) in config.periodic.iter().take(MAX_PROPERTIES).enumerate() {
                chosen = self.due(k + 1, p.property, p.period_ms, now, chosen);
            }
        }
        let (slot, property, period_us, due) = chosen?;
        // The next slot; after a stall, resume from now instead of bursting.
        let following = due.0.saturating_add(period_us);
        if let Some(next) = self.next_send.get_mut(slot) {
            *next = Some(Instant(if following <= now.0 {
                now.0.saturating_add(period_us)
            } else {
                following
            }));
        }
        self.own_id = self.own_id.wrapping_add(1);
        let send = Send {
            property,
            id: self.own_id,
            arrived: None,
            received: None,
        };
        Some((to, send))
    }
}
