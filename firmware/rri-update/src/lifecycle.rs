//! What the running image does about the swap, ticked by the board's
//! housekeeping with what it sees (issue 43: never mid-motion, rollback).
//!
//! - **On trial** (the bootloader swapped this image in: the state
//!   partition says [`State::Swap`](crate::State)), the image confirms
//!   itself once it reaches OPERATING with its controller. With no
//!   controller heard at all for [`SELF_TEST_MS`] it confirms itself on
//!   its self-test: it started, brought its network and services up and
//!   ran that long without a fault (a cell whose controller is off must
//!   not lose a good update). A controller heard but no OPERATING within
//!   [`TRIAL_MS`] of first hearing it is an image that cannot talk to its
//!   controller: it stops feeding the watchdog, and the watchdog's reset
//!   sends it back to the bootloader, which swaps the previous image back.
//!   A hang or a crash on trial ends the same way.
//! - **Confirmed**, with an update marked (and a bootloader that swaps),
//!   the image restarts into the bootloader's swap as soon as its
//!   controller is not OPERATING (never mid-motion), and not before the
//!   mark is [`ANSWER_MS`] old (the upload's answer has gone out).
//!
//! Plain logic over milliseconds, tested on the host; the board supplies
//! the clock, the snapshot, the flash and the reset.

/// No controller heard for this long on trial: the self-test is passed.
pub const SELF_TEST_MS: u64 = 60_000;
/// A controller heard but no OPERATING for this long after first hearing
/// it, on trial: the image gives up (the watchdog rolls it back).
pub const TRIAL_MS: u64 = 30_000;
/// An update marked this long before the restart into its swap: the
/// upload's answer has gone out to its client by then (the answer is
/// rendered right after the mark, on the same executor, in milliseconds).
pub const ANSWER_MS: u64 = 1_000;

/// What the board's housekeeping saw this tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Seen {
    /// Milliseconds since this start.
    pub now_ms: u64,
    /// The engine is OPERATING with its controller.
    pub operating: bool,
    /// Anything from the controller arrived since this start (a message,
    /// answered or refused by the decoder).
    pub heard: bool,
    /// An update is checked and marked for the swap.
    pub marked: bool,
}

/// Why an image on trial confirmed itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Confirmed {
    /// It reached OPERATING with its controller.
    Operating,
    /// No controller for [`SELF_TEST_MS`]: its self-test.
    SelfTest,
}

impl Confirmed {
    /// As the log and the status say it.
    pub const fn text(self) -> &'static str {
        match self {
            Confirmed::Operating => "it reached OPERATING with its controller",
            Confirmed::SelfTest => {
                "no controller within 60 s, and it ran that long without a fault (its self-test)"
            }
        }
    }
}

/// What to do now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Nothing.
    Wait,
    /// Mark the running image good in the state partition (once).
    Confirm(Confirmed),
    /// Stop feeding the watchdog: on trial, a controller heard for
    /// [`TRIAL_MS`] and never OPERATING (returned once; the image then
    /// waits for the reset).
    GiveUp,
    /// Restart into the bootloader's swap (the controller is not
    /// OPERATING, an update is marked).
    Restart,
}

/// Where the running image stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Standing {
    /// Confirmed: a reset boots it again.
    Confirmed,
    /// Swapped in and not yet confirmed: a reset boots the previous image.
    OnTrial {
        /// When the controller was first heard on this start.
        heard_at: Option<u64>,
    },
    /// Gave up on trial; the watchdog will reset it.
    GaveUp,
}

/// Where the running image stands, as the status says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Image {
    /// Confirmed: a reset boots it again.
    Confirmed,
    /// On trial: a reset brings the previous image back.
    OnTrial,
    /// Gave up on trial: the watchdog resets it, the previous image comes
    /// back.
    GaveUp,
}

impl Image {
    /// As `/status.json` and the page say it.
    pub const fn name(self) -> &'static str {
        match self {
            Image::Confirmed => "confirmed",
            Image::OnTrial => "on trial",
            Image::GaveUp => "gave up",
        }
    }

    /// For an atomic cell.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// From [`Image::code`]; anything else reads as confirmed.
    pub const fn from_code(code: u8) -> Image {
        match code {
            1 => Image::OnTrial,
            2 => Image::GaveUp,
            _ => Image::Confirmed,
        }
    }
}

/// The running image's course.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lifecycle {
    standing: Standing,
    /// A bootloader swaps what is marked (else a marked update waits).
    swaps: bool,
    /// When an update was first seen marked.
    marked_at: Option<u64>,
}

impl Lifecycle {
    /// `on_trial`: the state partition said swap at start-up; `swaps`: the
    /// board has a bootloader that swaps.
    pub const fn new(on_trial: bool, swaps: bool) -> Self {
        Lifecycle {
            standing: if on_trial {
                Standing::OnTrial { heard_at: None }
            } else {
                Standing::Confirmed
            },
            swaps,
            marked_at: None,
        }
    }

    /// Where the image stands.
    pub const fn standing(&self) -> Standing {
        self.standing
    }

    /// Where the image stands, as the status says it.
    pub const fn image(&self) -> Image {
        match self.standing {
            Standing::Confirmed => Image::Confirmed,
            Standing::OnTrial { .. } => Image::OnTrial,
            Standing::GaveUp => Image::GaveUp,
        }
    }

    /// One tick.
    pub fn tick(&mut self, seen: Seen) -> Step {
        match self.standing {
            Standing::GaveUp => Step::Wait,
            Standing::Confirmed => {
                self.marked_at = match (seen.marked, self.marked_at) {
                    (false, _) => None,
                    (true, None) => Some(seen.now_ms),
                    (true, at) => at,
                };
                let answered = self
                    .marked_at
                    .is_some_and(|at| seen.now_ms.saturating_sub(at) >= ANSWER_MS);
                if self.swaps && answered && !seen.operating {
                    Step::Restart
                } else {
                    Step::Wait
                }
            }
            Standing::OnTrial { heard_at } => {
                let heard_at = match (heard_at, seen.heard) {
                    (None, true) => Some(seen.now_ms),
                    (h, _) => h,
                };
                if seen.operating {
                    self.standing = Standing::Confirmed;
                    return Step::Confirm(Confirmed::Operating);
                }
                match heard_at {
                    None if seen.now_ms >= SELF_TEST_MS => {
                        self.standing = Standing::Confirmed;
                        Step::Confirm(Confirmed::SelfTest)
                    }
                    Some(at) if seen.now_ms.saturating_sub(at) >= TRIAL_MS => {
                        self.standing = Standing::GaveUp;
                        Step::GiveUp
                    }
                    h => {
                        self.standing = Standing::OnTrial { heard_at: h };
                        Step::Wait
                    }
                }
            }
        }
    }

    /// The confirmation could not be written (a flash error): the image
    /// stays on trial, and the next tick tries again.
    pub fn confirm_failed(&mut self) {
        if self.standing == Standing::Confirmed {
            self.standing = Standing::OnTrial { heard_at: None };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seen(now_ms: u64) -> Seen {
        Seen {
            now_ms,
            ..Seen::default()
        }
    }

    #[test]
    fn on_trial_it_confirms_at_operating_once() {
        let mut l = Lifecycle::new(true, true);
        assert_eq!(l.tick(seen(100)), Step::Wait);
        let heard = Seen {
            heard: true,
            ..seen(200)
        };
        assert_eq!(l.tick(heard), Step::Wait);
        let op = Seen {
            operating: true,
            ..heard
        };
        assert_eq!(l.tick(op), Step::Confirm(Confirmed::Operating));
        assert_eq!(l.standing(), Standing::Confirmed);
        assert_eq!(l.tick(op), Step::Wait);
    }

    #[test]
    fn on_trial_with_no_controller_it_confirms_after_the_self_test() {
        let mut l = Lifecycle::new(true, true);
        assert_eq!(l.tick(seen(SELF_TEST_MS - 1)), Step::Wait);
        assert_eq!(
            l.tick(seen(SELF_TEST_MS)),
            Step::Confirm(Confirmed::SelfTest)
        );
    }

    #[test]
    fn on_trial_a_controller_heard_and_never_operating_gives_up_once() {
        let mut l = Lifecycle::new(true, true);
        let heard = |ms| Seen {
            heard: true,
            ..seen(ms)
        };
        // First heard late: past the self-test's time there is no
        // self-test confirmation, a controller was heard.
        let first = SELF_TEST_MS - 10_000;
        assert_eq!(l.tick(heard(first)), Step::Wait);
        assert_eq!(l.tick(seen(SELF_TEST_MS)), Step::Wait);
        assert_eq!(l.tick(heard(first + TRIAL_MS - 1)), Step::Wait);
        assert_eq!(l.tick(heard(first + TRIAL_MS)), Step::GiveUp);
        assert_eq!(l.standing(), Standing::GaveUp);
        let op = Seen {
            operating: true,
            ..heard(first + TRIAL_MS + 1)
        };
        assert_eq!(l.tick(op), Step::Wait, "given up stays given up");
    }

    #[test]
    fn a_confirmed_image_restarts_for_a_marked_update_only_when_not_operating() {
        let mut l = Lifecycle::new(false, true);
        let marked = Seen {
            marked: true,
            operating: true,
            ..seen(10)
        };
        assert_eq!(l.tick(marked), Step::Wait);
        let stopped = Seen {
            operating: false,
            ..marked
        };
        // Not before the upload's answer has had ANSWER_MS to go out.
        assert_eq!(l.tick(stopped), Step::Wait);
        let later = Seen {
            now_ms: 10 + ANSWER_MS,
            ..stopped
        };
        assert_eq!(l.tick(later), Step::Restart);
        assert_eq!(l.tick(seen(20 + ANSWER_MS)), Step::Wait, "nothing marked");
        // Marked again (after a cancel): the wait starts again.
        let again = Seen {
            now_ms: 30 + ANSWER_MS,
            ..stopped
        };
        assert_eq!(l.tick(again), Step::Wait);
    }

    #[test]
    fn without_a_bootloader_that_swaps_a_marked_update_waits() {
        let mut l = Lifecycle::new(false, false);
        let marked = Seen {
            marked: true,
            ..seen(10)
        };
        assert_eq!(l.tick(marked), Step::Wait);
        assert_eq!(
            l.tick(Seen {
                now_ms: 10 + ANSWER_MS,
                ..marked
            }),
            Step::Wait
        );
    }

    #[test]
    fn an_image_on_trial_never_restarts_for_a_marked_update() {
        // The desk refuses uploads on trial; even so, trial comes first.
        let mut l = Lifecycle::new(true, true);
        let marked = Seen {
            marked: true,
            ..seen(10)
        };
        assert_eq!(l.tick(marked), Step::Wait);
    }

    #[test]
    fn the_image_standing_round_trips_through_its_code() {
        for i in [Image::Confirmed, Image::OnTrial, Image::GaveUp] {
            assert_eq!(Image::from_code(i.code()), i);
        }
        assert_eq!(Lifecycle::new(true, true).image(), Image::OnTrial);
        assert_eq!(Lifecycle::new(false, true).image(), Image::Confirmed);
    }

    #[test]
    fn a_failed_confirmation_is_tried_again() {
        let mut l = Lifecycle::new(true, true);
        let op = Seen {
            operating: true,
            ..seen(10)
        };
        assert_eq!(l.tick(op), Step::Confirm(Confirmed::Operating));
        l.confirm_failed();
        assert_eq!(l.tick(op), Step::Confirm(Confirmed::Operating));
    }
}
