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
                "the image's MAC receives, at {:.3} s of the chip's time since power-on: paced to the wall clock from here ({:.1} s run ahead of it since the last start, while no frame could reach the chip)",
                secs(time_ns),
                secs(self.lead_ns - self.lead_at_reset)
            )
        })
    }

    /// Virtual time is at `time_ns`: wait for the wall clock to catch up
    /// (at most 20 ms at once), or, free, take the lead.
    pub fn wait(&mut self, time_ns: u128) {
        if !self.on {
            return;
        }
        let wall = self.started.elapsed().as_nanos() + self.lead_ns;
        if !self.heard && !self.always {
            self.lead_ns += time_ns.saturating_sub(wall);
        } else if time_ns > wall {
            std::thread::sleep(Duration::from_nanos(
                ((time_ns - wall) as u64).min(20_000_000),
            ));
        }
    }

    /// The chip restarted: its MAC's receiver is off again.
    pub fn restarted(&mut self) {
        self.heard = false;
        self.lead_at_reset = self.lead_ns;
    }

    /// Virtual time gained on the wall clock while free, over the run.
    pub fn lead(&self) -> Duration {
        Duration::from_nanos(self.lead_ns as u64)
    }
}

/// Nanoseconds in seconds, for the machine's notes.
pub fn secs(ns: u128) -> f64 {
    ns as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Free while the receiver is off: ten virtual seconds at once cost
    /// no wait, and are not waited for once paced; after a reset free
    /// again.
    #[test]
    fn free_until_the_receiver_is_on_then_paced_and_free_again_after_a_reset() {
        let mut p = Pace {
            on: true,
            ..Pace::default()
        };
        p.wait(10_000_000_000);
        assert!(p.lead() >= Duration::from_millis(9_900));
        assert_eq!(p.listening(false, 10_000_000_000), None);
        let note = p
            .listening(true, 10_000_000_000)
            .expect("a note as it comes on");
        assert!(note.contains("at 10.000 s of the chip's time"), "{note}");
        assert_eq!(p.listening(true, 10_000_000_000), None, "once");
        // Paced now: 50 ms of virtual time past the wall clock are waited
        // for (as the machine calls it, once a slice), the lead is not.
        let t = Instant::now();
        let target = p.started.elapsed().as_nanos() + p.lead_ns + 50_000_000;
        while p.started.elapsed().as_nanos() + p.lead_ns < target {
            p.wait(target);
        }
        let waited = t.elapsed();
        assert!(waited >= Duration::from_millis(45), "{waited:?}");
        assert!(
            waited < Duration::from_secs(2),
            "{waited:?}: the lead was waited for"
        );
        p.restarted();
        let lead = p.lead();
        p.wait(30_000_000_000);
        assert!(
            p.lead() > lead + Duration::from_secs(19),
            "free after the reset"
        );
        // Always paced: no lead, ever.
        let mut always = Pace {
            on: true,
            always: true,
            ..Pace::default()
        };
        always.wait(1_000_000);
        assert_eq!(always.lead(), Duration::ZERO);
        assert_eq!(always.listening(true, 1), None, "no note: paced all along");
    }
}
