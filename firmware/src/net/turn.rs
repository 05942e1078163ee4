//! One turn of the cycle loop, the same on either transport: a robot
//! message through the engine (counted for the bench, the fragment guard
//! told whether a reply follows), or the engine's time-driven work; then,
//! once the reply is queued, the guard and the engine exchange what each
//! knows and the monitor is told. The transports only receive and send.

use super::Monitor;
use crate::engine::{Application, Clock, Endpoint, Engine, Instant, Outcome};
use crate::fragments::{Controller, Link};
use crate::properties::{DeviceSet, RobotSet};

/// What a turn goes through: the engine, the application, the clock, the
/// monitor and the guard's link.
pub(super) struct Turn<'c, R: RobotSet, D: DeviceSet, A, C, M> {
    /// The cycle engine: the transports count their own events on it.
    pub(super) engine: &'c mut Engine<R, D>,
    app: &'c mut A,
    clock: &'c C,
    monitor: &'c mut M,
    /// Shared with the fragment guard.
    pub(super) link: &'c Link,
}

/// A message the engine handled: what came of it, and the monitor's
/// counts around the engine's work.
pub(super) struct Handled {
    pub(super) outcome: Outcome,
    counts: (u32, u32),
}

impl<'c, R: RobotSet, D: DeviceSet, A: Application<R, D>, C: Clock, M: Monitor<R, D>>
    Turn<'c, R, D, A, C, M>
{
    pub(super) fn new(
        engine: &'c mut Engine<R, D>,
        app: &'c mut A,
        clock: &'c C,
        monitor: &'c mut M,
        link: &'c Link,
    ) -> Self {
        Turn {
            engine,
            app,
            clock,
            monitor,
            link,
        }
    }

    /// The device clock now.
    pub(super) fn now(&self) -> Instant {
        self.clock.now()
    }

    /// The engine on `message` from `from`, received at `received`; its
    /// reply (if any) written to `reply`. The guard's hold ends here,
    /// before the send, which may wait for room that only the runner's
    /// egress (held until now) makes.
    pub(super) fn message(
        &mut self,
        from: Endpoint,
        message: &[u8],
        received: Instant,
        reply: &mut [u8],
    ) -> Handled {
        let before = self.monitor.count();
        let outcome = self
            .engine
            .on_message(self.app, self.clock, from, message, received, reply);
        let after = self.monitor.count();
        self.link
            .turn_done(matches!(outcome, Outcome::Reply { .. }));
        Handled {
            outcome,
            counts: (before, after),
        }
    }

    /// After the reply to `message` was queued (or none was due).
    pub(super) fn done(&mut self, message: &[u8], from: Endpoint, handled: &Handled) {
        self.exchange();
        self.monitor
            .message(self.engine, message, from, &handled.outcome, handled.counts);
    }

    /// The engine's time-driven work: where and how long a message it
    /// wrote to `reply` is, if it wrote one.
    pub(super) fn poll(&mut self, reply: &mut [u8]) -> Option<(Endpoint, usize)> {
        self.engine.poll(self.app, self.clock, reply)
    }

    /// After the time-driven work's message was queued (or none was due).
    pub(super) fn polled(&mut self) {
        self.exchange();
        self.monitor.polled(self.engine);
    }

    /// The guard learns who the controller is now, the engine's counters
    /// take the guard's.
    fn exchange(&mut self) {
        let engine = &mut *self.engine;
        self.link
            .set_controller(Controller::of(engine.peer(), engine.config().controller));
        engine.set_fragment_stats(self.link.stats());
    }
}
