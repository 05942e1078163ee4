//! What the bench's records come to, as instructions: the compute and
//! full-path spreads, every answered full path, a hostile input's cost.
//! Used by the quiet run's report and the scrape run's alike.

use crate::{instructions, CYCLE_AT_216MHZ};
use host_tests::qemu_bench::{Input, Record, Spread};

/// Compute and full-path spreads over a simulator run and the realistic
/// inputs, and the replies the device saw late (a full path past one
/// cycle at 216 MHz).
pub fn spreads(sim: &[Record], realistic: &[(Input, Vec<Record>)]) -> (Spread, Spread, u64) {
    let mut compute: Vec<u64> = sim.iter().map(|r| instructions(r.compute)).collect();
    for (_, rows) in realistic {
        compute.extend(rows.iter().map(|r| instructions(r.compute)));
    }
    let full = full_paths(sim, realistic);
    let late = sim
        .iter()
        .filter(|r| r.answered && instructions(r.full) > CYCLE_AT_216MHZ)
        .count() as u64;
    (Spread::of(compute), Spread::of(full), late)
}

/// Every answered message's full path, in instructions.
pub fn full_paths(sim: &[Record], realistic: &[(Input, Vec<Record>)]) -> Vec<u64> {
    let answered = |r: &&Record| r.answered;
    sim.iter()
        .chain(realistic.iter().flat_map(|(_, rows)| rows.iter()))
        .filter(answered)
        .map(|r| instructions(r.full))
        .collect()
}

/// A hostile input's cost: the longer of its compute and full paths where
/// it was answered, its compute path where it was rejected.
pub fn hostile_cost(rows: &[Record]) -> u64 {
    rows.iter()
        .map(|r| instructions(hostile_counts(r)))
        .max()
        .unwrap_or(0)
}

/// One row's hostile cost, in counts.
pub fn hostile_counts(r: &Record) -> u32 {
    if r.answered {
        r.full.max(r.compute)
    } else {
        r.compute
    }
}
