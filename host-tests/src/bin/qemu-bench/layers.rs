//! Where a message's instructions go, per layer, from the firmware's own
//! probes (`rri_firmware::bench`): the full span (the stack taking the
//! completing frame from the fragment guard → the reply's first frame
//! taken by the driver) is that frame's driver, guard and smoltcp shares,
//! the engine's compute, and the rest (the executor waking the cycle, the
//! socket's copy out, the reply through smoltcp to the driver). Before the
//! span, shown apart: the completing frame read from the NIC, and the
//! earlier fragments (every layer).

use crate::instructions;
use host_tests::qemu_bench::Record;
use serde_json::{json, Value};

/// One message's instructions, per layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Split {
    /// The full span, 0 when the message was not answered.
    pub full: u64,
    /// The completing frame read from the NIC, before the span.
    pub read: u64,
    pub driver: u64,
    pub guard: u64,
    pub smoltcp: u64,
    pub compute: u64,
    /// What the full span holds besides the layers above (0 when not
    /// answered).
    pub rest: u64,
    /// The earlier frames, all layers, and how many frames there were.
    pub before: u64,
    pub frames: u32,
}

impl Split {
    pub fn of(r: &Record) -> Split {
        let (driver, guard, smoltcp, compute) = (
            instructions(r.driver),
            instructions(r.guard),
            instructions(r.smoltcp),
            instructions(r.compute),
        );
        let full = if r.answered { instructions(r.full) } else { 0 };
        Split {
            full,
            driver,
            guard,
            smoltcp,
            compute,
            rest: full.saturating_sub(driver + guard + smoltcp + compute),
            read: instructions(r.read),
            before: instructions(r.before),
            frames: r.frames,
        }
    }

    pub fn json(&self) -> Value {
        json!({"full": self.full, "read": self.read, "driver": self.driver, "guard": self.guard,
            "smoltcp": self.smoltcp, "compute": self.compute, "rest": self.rest,
            "before": self.before, "frames": self.frames})
    }
}

/// Answered rows whose probes cannot be right: no frame seen, or the
/// layers inside the span adding up to more than the span.
pub fn misfits<'a>(rows: impl Iterator<Item = &'a Record>) -> usize {
    rows.filter(|r| r.answered)
        .filter(|r| {
            let inside = u64::from(r.driver)
                + u64::from(r.guard)
                + u64::from(r.smoltcp)
                + u64::from(r.compute);
            r.frames == 0 || inside > u64::from(r.full)
        })
        .count()
}

/// The row `cost` ranks highest of an input's rows (its worst).
pub fn worst(rows: &[Record], cost: impl Fn(&Record) -> u32) -> Option<&Record> {
    rows.iter().max_by_key(|r| cost(r))
}

/// A table of each input's worst row, split.
pub fn print(title: &str, rows: &[(String, Split)]) {
    println!("\n== {title}");
    println!(
        "  {:<32} {:>7} = {:>6} + {:>6} + {:>7} + {:>7} + {:>6} | {:>5} {:>7} (frames)",
        "input", "full", "driver", "guard", "smoltcp", "compute", "rest", "read", "before"
    );
    for (name, s) in rows {
        let full = if s.full > 0 {
            s.full.to_string()
        } else {
            "-".into()
        };
        println!(
            "  {:<32} {:>7} = {:>6} + {:>6} + {:>7} + {:>7} + {:>6} | {:>5} {:>7} ({})",
            name, full, s.driver, s.guard, s.smoltcp, s.compute, s.rest, s.read, s.before, s.frames
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rest_is_what_the_layers_leave_of_the_span() {
        let r = Record {
            bytes: 3557,
            answered: true,
            compute: 100,
            full: 1000,
            frames: 3,
            read: 40,
            driver: 10,
            guard: 200,
            smoltcp: 300,
            before: 50,
            ..Record::default()
        };
        let s = Split::of(&r);
        let i = crate::INSTRUCTIONS_PER_COUNT;
        assert_eq!(s.full, 1000 * i);
        assert_eq!(s.rest, (1000 - 10 - 200 - 300 - 100) * i);
        assert_eq!((s.read, s.before), (40 * i, 50 * i));
        // Rejected: no span, no rest; the frame's layers still shown.
        let s = Split::of(&Record {
            answered: false,
            full: 0,
            ..r
        });
        assert_eq!((s.full, s.rest, s.guard), (0, 0, 200 * i));
    }

    #[test]
    fn layers_past_the_span_or_no_frame_are_misfits() {
        let ok = Record {
            answered: true,
            full: 100,
            frames: 1,
            driver: 10,
            guard: 20,
            smoltcp: 30,
            compute: 40,
            ..Record::default()
        };
        let over = Record { full: 99, ..ok };
        let unseen = Record { frames: 0, ..ok };
        let rejected = Record {
            answered: false,
            full: 0,
            ..ok
        };
        assert_eq!(misfits([ok, rejected].iter()), 0);
        assert_eq!(misfits([ok, over, unseen].iter()), 2);
    }
}
