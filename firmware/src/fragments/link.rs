//! [`Link`]: what the fragment guard (in the network runner) and the
//! cycle share: who the controller is, the guard's counters, the reply
//! latency at the driver, and the [`Hold`] that keeps other traffic from
//! between a robot message and its reply.

use super::{Controller, FragmentStats};
use crate::engine::Histogram;
use core::cell::{Cell, RefCell};
use critical_section::Mutex;

/// What the fragment guard (in the network runner) and the cycle share:
/// the cycle tells who the controller is after every message, the guard
/// publishes its counters after every frame that changed them. Both sides
/// hold it a few instructions under a critical section.
pub struct Link {
    controller: Mutex<Cell<Controller>>,
    stats: Mutex<Cell<FragmentStats>>,
    /// The reply latency at the driver (the guard's clock): when the
    /// last robot message's last frame came in, and every reply's time.
    wire: Mutex<RefCell<(Option<u64>, Histogram)>>,
    /// Where the robot message handed to the stack last is ([`Hold`]),
    /// and the network runner to wake when the cycle is done with it.
    hold: Mutex<RefCell<(Hold, Option<core::task::Waker>)>>,
    /// The cycle's socket exists (see [`Link::channel_open`]).
    channel_open: core::sync::atomic::AtomicBool,
    /// Whether `hold` is anything but [`Hold::Idle`], readable without a
    /// critical section: the guard asks before every frame, and nearly
    /// always nothing is held (a critical section each cost the hostile
    /// worst case about 100 instructions a frame).
    holding: core::sync::atomic::AtomicBool,
    /// Tasks that wait for a hold to end before they touch the network
    /// (the diagnostics' connections, [`Link::when_free`]).
    guests: Mutex<RefCell<[Option<core::task::Waker>; GUESTS]>>,
}

/// Tasks that may wait for a hold to end at once (the diagnostics'
/// connection slots, with room to spare).
pub const GUESTS: usize = 4;

/// Where a robot message handed to the stack is, for the guard: while
/// the cycle works on it the network runner does nothing (it would send
/// the diagnostics' segments, or anyone's, in front of the reply, and
/// take in frames the reply then waits behind); once its reply is about
/// to be queued, frames may leave (the reply first: its socket is the
/// first the runner serves) but nothing comes in before the reply has
/// left. So no other traffic is ever between a robot message and its
/// reply at the driver. [`HOLD_MAX_US`] bounds both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Hold {
    /// No robot message in the works.
    #[default]
    Idle,
    /// A robot message was handed to the stack at `since_us`; the cycle
    /// has not finished with it.
    Awaiting {
        /// When it was handed over (µs).
        since_us: u64,
    },
    /// Its reply is (about to be) queued in the socket, not yet taken by
    /// the driver.
    Composed {
        /// When the message was handed over (µs).
        since_us: u64,
        /// The runner was held once already: the reply had its egress
        /// first. Frames come in again after that (the reply may be
        /// waiting for them: an ARP answer).
        held: bool,
    },
}

/// The longest a [`Hold`] holds other traffic back (µs): half a robot
/// cycle. Only a cycle that never finishes (or a reply that cannot leave)
/// reaches it.
pub const HOLD_MAX_US: u64 = 2_000;

impl Default for Link {
    fn default() -> Self {
        Self::new()
    }
}

impl Link {
    /// Anyone may be the controller, every counter at zero (`const`, for a
    /// `static`).
    pub const fn new() -> Self {
        Link {
            controller: Mutex::new(Cell::new(Controller::ANYONE)),
            stats: Mutex::new(Cell::new(FragmentStats::ZERO)),
            wire: Mutex::new(RefCell::new((None, Histogram::EMPTY))),
            hold: Mutex::new(RefCell::new((Hold::Idle, None))),
            channel_open: core::sync::atomic::AtomicBool::new(false),
            holding: core::sync::atomic::AtomicBool::new(false),
            guests: Mutex::new(RefCell::new([const { None }; GUESTS])),
        }
    }

    /// The cycle: its socket (or sockets) on the channel port exist. The
    /// network runner serves sockets in the order they were made, so any
    /// other socket (the diagnostics') is made after this: a reply is the
    /// first frame out of a runner's turn.
    pub fn channel_open(&self) {
        self.channel_open
            .store(true, core::sync::atomic::Ordering::Release);
    }

    /// Whether [`Link::channel_open`] was called.
    pub fn is_channel_open(&self) -> bool {
        self.channel_open
            .load(core::sync::atomic::Ordering::Acquire)
    }

    /// The guard: a robot message's last frame was handed to the stack
    /// at `at_us`.
    pub fn message_in(&self, at_us: u64) {
        critical_section::with(|cs| {
            self.wire.borrow_ref_mut(cs).0 = Some(at_us);
            self.hold.borrow_ref_mut(cs).0 = Hold::Awaiting { since_us: at_us };
            self.set_holding(cs, true);
        });
    }

    /// The cycle, done with what arrived: its reply is about to be queued
    /// (`replied`; call this before the send, which may wait for room the
    /// runner makes), or there is none. Wakes the network runner the
    /// guard held back.
    pub fn turn_done(&self, replied: bool) {
        let waker = critical_section::with(|cs| {
            let mut hold = self.hold.borrow_ref_mut(cs);
            if let Hold::Awaiting { since_us } = hold.0 {
                hold.0 = if replied {
                    Hold::Composed {
                        since_us,
                        held: false,
                    }
                } else {
                    self.set_holding(cs, false);
                    Hold::Idle
                };
            }
            hold.1.take()
        });
        if let Some(w) = waker {
            w.wake();
        }
    }

    /// The guard: may a frame leave now (`false` while the cycle works on
    /// a robot message; `waker` is woken when it is done)?
    pub fn may_transmit(&self, now_us: u64, waker: &core::task::Waker) -> bool {
        self.may(now_us, waker, |h| matches!(h, Hold::Awaiting { .. }))
    }

    /// The network runner's gate (`fragments::guard::run_gated`, with `net`):
    /// may it make a pass now? `false` while the cycle works on a robot
    /// message: such a pass could take nothing in and send nothing out
    /// (the guard refuses both), only cost the message's full path: about
    /// 1,400 instructions on the QEMU board, measured with the bench's
    /// `held_in`. `waker` is woken when the cycle is done. The clock
    /// (`now_us`) is read only while the cycle works, for the hold's
    /// bound: the reply's own pass, on every message, is spared the read
    /// (100 to 200 instructions of its full path on the QEMU board).
    pub fn may_run(&self, now_us: impl FnOnce() -> u64, waker: &core::task::Waker) -> bool {
        if !self.is_holding() {
            return true;
        }
        let awaiting = critical_section::with(|cs| {
            matches!(self.hold.borrow_ref(cs).0, Hold::Awaiting { .. })
        });
        !awaiting || self.may_transmit(now_us(), waker)
    }

    /// The guard: may a frame come in now (`false` while the cycle works
    /// on a robot message, and for one runner poll once its reply is
    /// queued, so that the reply's egress comes first)?
    pub fn may_receive(&self, now_us: u64, waker: &core::task::Waker) -> bool {
        self.may(now_us, waker, |h| match h {
            Hold::Idle => false,
            Hold::Awaiting { .. } => true,
            Hold::Composed { held, .. } => !core::mem::replace(held, true),
        })
    }

    /// Whether anything is held now (no critical section: the guard's
    /// quick look before it reads the clock and asks [`Link::may_transmit`]).
    pub fn is_holding(&self) -> bool {
        self.holding.load(core::sync::atomic::Ordering::Acquire)
    }

    /// Mirrors whether `hold` holds anything (called with it, in its
    /// critical section); when the hold ends, wakes the guests waiting.
    fn set_holding(&self, cs: critical_section::CriticalSection<'_>, on: bool) {
        self.holding
            .store(on, core::sync::atomic::Ordering::Release);
        if !on {
            for w in self.guests.borrow_ref_mut(cs).iter_mut() {
                if let Some(w) = w.take() {
                    w.wake();
                }
            }
        }
    }

    /// For a task beside the cycle that must not work between a robot
    /// message and its reply (it would run on the cycle's executor in
    /// that window): `true` when nothing is held; else `waker` is woken
    /// when the hold ends (an event, not a poll: a guest costs the window
    /// nothing), and `false`.
    pub fn when_free(&self, waker: &core::task::Waker) -> bool {
        critical_section::with(|cs| {
            if !self.is_holding() {
                return true;
            }
            let mut guests = self.guests.borrow_ref_mut(cs);
            if guests.iter().flatten().any(|w| w.will_wake(waker)) {
                return false;
            }
            match guests.iter_mut().find(|w| w.is_none()) {
                Some(slot) => {
                    *slot = Some(waker.clone());
                    false
                }
                // More guests than places: let this one go on.
                None => true,
            }
        })
    }

    /// When the hold in force ends at the latest ([`HOLD_MAX_US`] after
    /// the message came in), or `None` when nothing is held. The guard
    /// sets a timer for it whenever it holds a frame back: the cycle may
    /// never end a turn for this message (a message on a connection it is
    /// not reading yet: M10's standby, while it closes the old one), and
    /// the runner, asleep, would otherwise not look again until its own
    /// next timer (a second, in a TCP reconnection: the hold's bound must
    /// wake it).
    pub fn hold_until_us(&self) -> Option<u64> {
        critical_section::with(|cs| match self.hold.borrow_ref(cs).0 {
            Hold::Idle => None,
            Hold::Awaiting { since_us } | Hold::Composed { since_us, .. } => {
                Some(since_us.saturating_add(HOLD_MAX_US))
            }
        })
    }

    /// Whether the hold (`holds`, which may note that it held) keeps a
    /// frame back now; registers `waker` for the cycle's end of turn.
    fn may(&self, now_us: u64, waker: &core::task::Waker, holds: fn(&mut Hold) -> bool) -> bool {
        if !self.is_holding() {
            return true;
        }
        critical_section::with(|cs| {
            let mut hold = self.hold.borrow_ref_mut(cs);
            let since = match hold.0 {
                Hold::Idle => return true,
                Hold::Awaiting { since_us } | Hold::Composed { since_us, .. } => since_us,
            };
            if now_us.saturating_sub(since) >= HOLD_MAX_US {
                hold.0 = Hold::Idle;
                self.set_holding(cs, false);
                return true;
            }
            if !holds(&mut hold.0) {
                return true;
            }
            if !hold.1.as_ref().is_some_and(|w| w.will_wake(waker)) {
                hold.1 = Some(waker.clone());
            }
            false
        })
    }

    /// The guard: the driver took a reply's first frame at `at_us`; the
    /// time since the message came in is recorded (a send with no message
    /// waiting, a periodic one, is not).
    pub fn reply_out(&self, at_us: u64) {
        critical_section::with(|cs| {
            let mut wire = self.wire.borrow_ref_mut(cs);
            if let Some(at) = wire.0.take() {
                wire.1.record_at(at_us.saturating_sub(at), at_us);
            }
            self.hold.borrow_ref_mut(cs).0 = Hold::Idle;
            self.set_holding(cs, false);
        });
    }

    /// The reply latency at the driver: every reply since the start.
    pub fn latency(&self) -> Histogram {
        critical_section::with(|cs| self.wire.borrow_ref(cs).1)
    }

    /// Who the controller is now.
    pub fn controller(&self) -> Controller {
        critical_section::with(|cs| self.controller.borrow(cs).get())
    }

    /// The cycle, after each message: who the controller is now.
    pub fn set_controller(&self, controller: Controller) {
        critical_section::with(|cs| self.controller.borrow(cs).set(controller));
    }

    /// The guard's counters as last published.
    pub fn stats(&self) -> FragmentStats {
        critical_section::with(|cs| self.stats.borrow(cs).get())
    }

    /// The guard: its counters changed.
    pub fn publish(&self, stats: FragmentStats) {
        critical_section::with(|cs| self.stats.borrow(cs).set(stats));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::task::Waker;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    struct Count(AtomicUsize);
    impl std::task::Wake for Count {
        fn wake(self: Arc<Self>) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn waker() -> (Arc<Count>, Waker) {
        let c = Arc::new(Count(AtomicUsize::new(0)));
        (c.clone(), Waker::from(c))
    }

    #[test]
    fn nothing_moves_while_the_cycle_works_and_the_reply_leaves_first() {
        let link = Link::new();
        let (woken, w) = waker();
        assert!(link.may_transmit(0, &w) && link.may_receive(0, &w), "idle");
        link.message_in(100);
        assert!(!link.may_transmit(150, &w), "the cycle works: nothing out");
        assert!(!link.may_receive(150, &w), "the cycle works: nothing in");
        link.turn_done(true);
        assert_eq!(woken.0.load(Ordering::Relaxed), 1, "the runner is woken");
        assert!(link.may_transmit(200, &w), "the reply may leave");
        assert!(!link.may_receive(200, &w), "nothing in before it, once");
        assert!(
            link.may_receive(210, &w),
            "then frames come in (an ARP answer)"
        );
        link.reply_out(230);
        assert!(link.may_transmit(240, &w) && link.may_receive(240, &w));
        assert_eq!(link.latency().count, 1);
        assert_eq!(link.latency().max_us, 130);
    }

    #[test]
    fn guests_wait_for_the_reply_and_are_woken_when_it_leaves() {
        let link = Link::new();
        let (woken, w) = waker();
        assert!(link.when_free(&w), "nothing held: go on");
        link.message_in(100);
        assert!(!link.when_free(&w), "held: wait");
        assert!(!link.when_free(&w), "registered once");
        link.turn_done(true);
        assert_eq!(woken.0.load(Ordering::Relaxed), 0, "the reply has not left");
        link.reply_out(150);
        assert_eq!(
            woken.0.load(Ordering::Relaxed),
            1,
            "woken as the reply leaves"
        );
        assert!(link.when_free(&w));
        // A message with no reply frees the guests at once too.
        link.message_in(200);
        assert!(!link.when_free(&w));
        link.turn_done(false);
        assert_eq!(woken.0.load(Ordering::Relaxed), 2);
    }

    #[test]
    fn a_message_without_a_reply_releases_the_runner_at_once() {
        let link = Link::new();
        let (woken, w) = waker();
        link.message_in(100);
        assert!(!link.may_transmit(120, &w));
        link.turn_done(false);
        assert_eq!(woken.0.load(Ordering::Relaxed), 1);
        assert!(link.may_transmit(130, &w) && link.may_receive(130, &w));
        assert_eq!(link.latency().count, 0, "no reply, no latency");
    }

    #[test]
    fn a_hold_never_outlasts_its_bound() {
        let link = Link::new();
        let (_, w) = waker();
        assert_eq!(link.hold_until_us(), None, "nothing held");
        link.message_in(1_000);
        assert_eq!(
            link.hold_until_us(),
            Some(1_000 + HOLD_MAX_US),
            "the guard wakes the runner then, whether the cycle ends its turn or not"
        );
        assert!(!link.may_transmit(1_000 + HOLD_MAX_US - 1, &w));
        assert!(
            link.may_transmit(1_000 + HOLD_MAX_US, &w),
            "a cycle that never finishes"
        );
        assert!(link.may_receive(1_000 + HOLD_MAX_US, &w));
        link.message_in(5_000);
        link.turn_done(true);
        assert!(!link.may_receive(5_001, &w));
        // The reply never leaves (its frame refused): frames come in again.
        assert!(link.may_receive(5_002, &w));
    }
}
