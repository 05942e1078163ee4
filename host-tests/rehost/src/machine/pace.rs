//! Virtual time and the wall clock. A run an outside client reaches
//! (`--device`) is paced: virtual time waits for the wall clock, so the
//! client sees the device's own timing. Not while the MAC's receiver is
//! off, though (from a reset until the image sets MACCR.RE): no frame
//! from outside can reach the chip then (a bootloader's swap, the image's
//! start-up), so virtual time runs free, as fast as the host emulates,
//! and the lead it gains is never waited for. On the NUCLEOs' flash
//! models a swap is tens of seconds of the chip's time, which a paced run
//! spent waiting. Once the receiver is on, idle or not, the image is
//! paced: its timers (a trial's, the watchdog's) run at the client's
//! pace. `--pace-always` paces from the start and through every reset.

use std::time::{Duration, Instant};

/// How virtual time keeps to the wall clock.
#[derive(Debug)]
pub struct Pace {
    /// Paced at all (outside clients); `false`: deterministic, no wall
    /// clock.
    pub on: bool,
    /// Paced from the start and through every reset, frames or not.
    pub always: bool,
    /// The MAC's receiver was on since the chip's last reset.
    heard: bool,
    /// Virtual time run ahead of the wall clock while free, and what it
    /// was at the last reset.
    lead_ns: u128,
    lead_at_reset: u128,
    started: Instant,
}

impl Default for Pace {
    fn default() -> Pace {
        Pace {
            on: false,
            always: false,
            heard: false,
            lead_ns: 0,
            lead_at_reset: 0,
            started: Instant::now(),
        }
    }
}

impl Pace {
    /// Virtual time is at `time_ns`, the MAC's receiver on or not
    /// (`listening`): the note to make when it has just come on, in a
    /// paced run, for the first time since the reset.
    pub fn listening(&mut self, listening: bool, time_ns: u128) -> Option<String> {
        if self.heard || !listening {
            return None;
        }
        self.heard = true;
        (self.on && !self.always).then(|| {
            format!(
                "the image's MAC receives, at {:.3} s of the chip's time (since the run began): paced to the wall clock from here ({:.1} s run ahead of it since the last start, while no frame could reach the chip)",
                secs(time_ns),
                secs(self.lead_ns - self.lead_at_reset)
            )
        })
    }

    /// Virtual time is at `time_ns`: wait for the wall clock to catch up
    /// (at most 20 ms at once), or, free, take the lead.
    pub fn wait(&mut self, time_ns: u128) {
        if let Some(d) = self.due(time_ns, self.started.elapsed().as_nanos()) {
            std::thread::sleep(d);
        }
    }

    /// [`Pace::wait`]'s decision, `elapsed_ns` of the wall clock since
    /// the run began: how long to sleep, if at all. Free, the lead is
    /// taken instead.
    fn due(&mut self, time_ns: u128, elapsed_ns: u128) -> Option<Duration> {
        if !self.on {
            return None;
        }
        let wall = elapsed_ns + self.lead_ns;
        if !self.heard && !self.always {
            self.lead_ns += time_ns.saturating_sub(wall);
            None
        } else {
            (time_ns > wall)
                .then(|| Duration::from_nanos(((time_ns - wall) as u64).min(20_000_000)))
        }
    }

    /// The chip restarted: its MAC's receiver is off again.
    pub fn restarted(&mut self) {
        self.heard = false;
        self.lead_at_reset = self.lead_ns;
    }
}

/// Nanoseconds in seconds, for the machine's notes.
pub fn secs(ns: u128) -> f64 {
    ns as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: u128 = 1_000_000_000;
    const MS: u128 = 1_000_000;

    /// Free while the receiver is off: ten virtual seconds at once cost
    /// no wait, and are not waited for once paced (the wall clock is
    /// given, not read); after a reset free again.
    #[test]
    fn free_until_the_receiver_is_on_then_paced_and_free_again_after_a_reset() {
        let mut p = Pace {
            on: true,
            ..Pace::default()
        };
        assert_eq!(p.due(10 * S, MS), None, "free: no wait");
        assert_eq!(p.lead_ns, 10 * S - MS);
        assert_eq!(p.listening(false, 10 * S), None);
        let note = p.listening(true, 10 * S).expect("a note as it comes on");
        assert!(note.contains("at 10.000 s of the chip's time"), "{note}");
        assert!(note.contains("10.0 s run ahead"), "{note}");
        assert_eq!(p.listening(true, 10 * S), None, "once");
        // Paced: 5 ms of virtual time past wall clock and lead is waited
        // for; the lead itself is not.
        assert_eq!(
            p.due(10 * S + 5 * MS, 2 * MS),
            Some(Duration::from_millis(4))
        );
        assert_eq!(p.due(10 * S, 2 * MS), None);
        // At most 20 ms at once.
        assert_eq!(p.due(11 * S, MS), Some(Duration::from_millis(20)));
        assert_eq!(p.lead_ns, 10 * S - MS, "no lead taken while paced");
        p.restarted();
        assert_eq!(p.due(30 * S, 3 * MS), None, "free after the reset");
        assert_eq!(p.lead_ns, 30 * S - 3 * MS);
        let note = p.listening(true, 30 * S).unwrap();
        assert!(
            note.contains("20.0 s run ahead of it since the last start"),
            "{note}"
        );
        // Always paced: no lead, ever, and no note.
        let mut always = Pace {
            on: true,
            always: true,
            ..Pace::default()
        };
        assert_eq!(always.due(S, 0), Some(Duration::from_millis(20)));
        assert_eq!(always.lead_ns, 0);
        assert_eq!(always.listening(true, 1), None, "no note: paced all along");
        // Not paced at all (deterministic): never a wait.
        let mut off = Pace::default();
        assert_eq!(off.due(S, 0), None);
    }

    /// A system reset turns the MAC's receiver off, as far as the wire
    /// and the pacing know (the MAC model itself is built anew).
    #[test]
    fn a_reset_turns_the_receiver_off() {
        let mut m = crate::machine::testing::h743(&[]);
        m.resets_left = 1;
        m.pace.on = true;
        m.uc.get_data_mut().shared.link.listening = true;
        assert!(m.pace.listening(true, 0).is_some());
        m.uc.get_data_mut().scs.reset_requested = true;
        m.take_reset().unwrap();
        assert!(!m.uc.get_data().shared.link.listening);
        assert!(!m.pace.heard, "free again until the image's MAC receives");
    }
}
