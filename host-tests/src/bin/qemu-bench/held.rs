//! Where a client on the diagnostics costs a robot message's full path:
//! each answered message's full path against the same run's messages of
//! its length that the hold touched least, grouped by what the fragment
//! guard's hold turned away in its span (`held_in`, `held_out` of
//! [`Record`]). Every message's span has two turned-away ingress calls of
//! its own (the stack asking again in the pass that handed it over, and
//! once in the reply's pass); a third is a whole pass of the runner more.
//! A measurement, not a gate: it says what a scrape or an upload puts
//! inside the span, and what each costs.

use crate::instructions;
use host_tests::qemu_bench::Record;
use std::collections::BTreeMap;

/// One group: messages whose span saw `held_in` turned-away passes and
/// `held_out` refused frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    pub held_in: u32,
    pub held_out: u32,
    pub messages: usize,
    /// Mean and largest full path over the least-held messages' median of
    /// the same length, in instructions (negative: under it).
    pub mean_excess: f64,
    pub max_excess: i64,
}

/// The groups, fewest held first; messages of a length seen only once
/// (nothing to compare with) are counted in `unmatched`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Held {
    pub groups: Vec<Group>,
    pub unmatched: usize,
}

impl Held {
    /// From a run's answered records.
    pub fn of<'r>(records: impl Iterator<Item = &'r Record>) -> Held {
        let answered: Vec<&Record> = records.filter(|r| r.answered).collect();
        let held = |r: &Record| r.held_in + r.held_out;
        // Per length: how many, and the least any was held.
        let mut lengths: BTreeMap<u32, (usize, u32)> = BTreeMap::new();
        for r in &answered {
            let e = lengths.entry(r.bytes).or_insert((0, u32::MAX));
            *e = (e.0 + 1, e.1.min(held(r)));
        }
        let mut least: BTreeMap<u32, Vec<u64>> = BTreeMap::new();
        for r in &answered {
            if lengths
                .get(&r.bytes)
                .is_some_and(|&(n, l)| n > 1 && l == held(r))
            {
                least.entry(r.bytes).or_default().push(instructions(r.full));
            }
        }
        let median: BTreeMap<u32, u64> = least
            .into_iter()
            .map(|(bytes, mut full)| {
                full.sort_unstable();
                (bytes, full[full.len() / 2])
            })
            .collect();
        let mut by_held: BTreeMap<(u32, u32), Vec<i64>> = BTreeMap::new();
        let mut unmatched = 0;
        for r in &answered {
            match median.get(&r.bytes) {
                Some(&m) => by_held
                    .entry((r.held_in, r.held_out))
                    .or_default()
                    .push(instructions(r.full) as i64 - m as i64),
                None => unmatched += 1,
            }
        }
        let groups = by_held
            .into_iter()
            .map(|((held_in, held_out), excess)| Group {
                held_in,
                held_out,
                messages: excess.len(),
                mean_excess: excess.iter().sum::<i64>() as f64 / excess.len() as f64,
                max_excess: excess.iter().copied().max().unwrap_or(0),
            })
            .collect();
        Held { groups, unmatched }
    }

    /// The groups, one line each.
    pub fn print(&self) {
        println!(
            "  the full path by what the guard's hold turned away in its span (against the same run's least-held messages of the same length):"
        );
        for g in &self.groups {
            println!(
                "    passes held {:>2}, frames held {:>2}: {:>5} messages, {:>+8.0} instructions on average, {:>+7} at most",
                g.held_in, g.held_out, g.messages, g.mean_excess, g.max_excess
            );
        }
        if self.unmatched > 0 {
            println!(
                "    {} messages of a length seen once (nothing to compare with)",
                self.unmatched
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(bytes: u32, full: u32, held_in: u32, held_out: u32) -> Record {
        Record {
            bytes,
            answered: true,
            full,
            held_in,
            held_out,
            ..Record::default()
        }
    }

    #[test]
    fn each_message_is_measured_against_the_least_held_ones_of_its_length() {
        let records = [
            r(100, 1000, 0, 0),
            r(100, 1002, 0, 0),
            r(100, 1004, 0, 0),
            r(200, 2000, 0, 0),
            // One held pass: 100 and 300 counts over the medians.
            r(100, 1102, 1, 0),
            r(200, 2300, 1, 0),
            // Seen once: nothing to compare with.
            r(300, 3000, 1, 1),
            // Every one of its length held twice: those are its reference.
            r(400, 4000, 2, 0),
            r(400, 4010, 2, 0),
            r(400, 4020, 2, 0),
            Record {
                answered: false,
                ..r(100, 0, 5, 5)
            },
        ];
        let held = Held::of(records.iter());
        assert_eq!(held.unmatched, 1);
        let one = held.groups.iter().find(|g| g.held_in == 1).cloned();
        let i = |c: u32| instructions(c) as i64;
        assert_eq!(
            one,
            Some(Group {
                held_in: 1,
                held_out: 0,
                messages: 2,
                mean_excess: (i(100) + i(300)) as f64 / 2.0,
                max_excess: i(300),
            })
        );
        let none = &held.groups[0];
        assert_eq!((none.held_in, none.messages, none.max_excess), (0, 4, i(2)));
        let two = held.groups.iter().find(|g| g.held_in == 2).cloned();
        assert_eq!(two.map(|g| (g.messages, g.max_excess)), Some((3, i(10))));
    }
}
