//! The scrape run's figures (`cargo qemu-bench`: the same phases again
//! while a client reads the diagnostics), printed beside the same build's
//! quiet ones and gated: the service never at the cycle's expense.

use crate::held::Held;
use crate::paths::{full_paths, hostile_cost, spreads};
use crate::Phase;
use host_tests::qemu_bench::Spread;

/// The scrape and upload runs' full-path bound, the issue's: the max
/// within 5 % of the quiet run's max (the compute max within 1 %).
///
/// Until 2026-12-05 it held only with an allowance (1 % of the scrape
/// run's messages, 2 % of the upload run's, might be over it, none over
/// 10 %): in some runs one message was 2,000 to 3,000 instructions over
/// the others of its size (+5.1 % to +7.49 % on the max), its compute
/// unchanged. The bench's `held_in` and `held_out` found why (`held.rs`):
/// those messages' spans held a whole pass of the network runner more,
/// about 1,400 instructions, woken by a diagnostics frame arriving or a
/// socket's timer while the cycle worked, which could take nothing in and
/// send nothing out. The runner is now passed over while the cycle works
/// (`guard::run_gated`). Measured since, in five runs: the upload run's
/// max +2.15 % to +2.57 %, the scrape run's +0.58 % to +2.29 %; what
/// is left is a segment built and refused in the message's own pass
/// (`held_out`, about 350 instructions) and the interrupts of frames
/// arriving (up to about 1,250 over the others of its size).
const FULL_TOLERANCE: f64 = 0.05;

/// The scrape run's figures, beside the same build's quiet ones.
pub struct ScrapeFigures {
    pub compute: Spread,
    pub full: Spread,
    /// Messages whose full path is over the quiet max by more than
    /// [`FULL_TOLERANCE`].
    pub full_over: usize,
    /// Answered messages in the scrape run.
    pub messages: usize,
    pub hostile_max: u64,
    /// Replies lost, wrong or late (the device's count).
    pub missed: u64,
    /// What the scraper got.
    pub scraper: String,
    /// Which run: `scrape run` (a client on the diagnostics) or `upload
    /// run` (an update arriving).
    pub run: &'static str,
    /// Its full paths by what the guard's hold turned away in their spans.
    pub held: Held,
}

impl ScrapeFigures {
    /// From the scrape run `p` and what the scraper got; `quiet_full_max`
    /// is the quiet run's full-path max.
    pub fn of(run: &'static str, p: &Phase, scraper: &str, quiet_full_max: u64) -> Self {
        let (compute, full, late) = spreads(&p.sim_records, &p.realistic);
        let paths = full_paths(&p.sim_records, &p.realistic);
        let bound = quiet_full_max as f64 * (1.0 + FULL_TOLERANCE);
        ScrapeFigures {
            compute,
            full,
            full_over: paths.iter().filter(|&&f| f as f64 > bound).count(),
            messages: paths.len(),
            hostile_max: p
                .hostile
                .iter()
                .map(|(_, r)| hostile_cost(r))
                .max()
                .unwrap_or(0),
            missed: p.summary.lost + p.summary.wrong_id + p.summary.malformed + late,
            scraper: scraper.to_string(),
            run,
            held: Held::of(
                p.sim_records
                    .iter()
                    .chain(p.realistic.iter().flat_map(|(_, rows)| rows.iter())),
            ),
        }
    }

    /// Side by side with the quiet run's (compute max and median, full
    /// path max and median, hostile worst).
    pub fn print(&self, compute: (u64, u64), full: (u64, u64), hostile_max: u64) {
        println!(
            "\n== the {}: the same phases while {} ({})",
            self.run,
            if self.run == "upload run" {
                "an update arrived"
            } else {
                "the diagnostics were read"
            },
            self.scraper
        );
        println!(
            "  {:<22} {:>10} {:>10}",
            "",
            "quiet",
            self.run.split(' ').next().unwrap_or("")
        );
        for (what, quiet, scraped) in [
            ("compute max", compute.0, self.compute.max),
            ("compute median", compute.1, self.compute.median),
            ("full-path max", full.0, self.full.max),
            ("full-path median", full.1, self.full.median),
            ("hostile worst", hostile_max, self.hostile_max),
        ] {
            println!(
                "  {what:<22} {quiet:>10} {scraped:>10}  {:+.2} %",
                (scraped as f64 / quiet.max(1) as f64 - 1.0) * 100.0
            );
        }
        println!(
            "  full paths over the quiet max by more than {:.0} %: {} of {} (bound: none)",
            FULL_TOLERANCE * 100.0,
            self.full_over,
            self.messages,
        );
        println!(
            "  replies missed, wrong or late in the {}: {}",
            self.run, self.missed
        );
        self.held.print();
    }

    /// The service never at the cycle's expense: the same build's figures
    /// with and without a client on the diagnostics. Prints each failure;
    /// whether all held.
    pub fn gate(&self, compute_max: u64, full_max: u64, hostile_max: u64) -> bool {
        let mut ok = true;
        if self.full_over > 0 {
            println!(
                "FAIL: {}: {} full paths of {} over the quiet run's max {full_max} by more than {:.0} % (bound: none); see held.rs's figures above and scraped.rs",
                self.run,
                self.full_over,
                self.messages,
                FULL_TOLERANCE * 100.0,
            );
            ok = false;
        }
        let checks = [
            ("compute max", self.compute.max, compute_max, 0.01),
            ("hostile worst", self.hostile_max, hostile_max, 0.05),
        ];
        for (what, scraped, quiet, tolerance) in checks {
            if scraped as f64 > quiet as f64 * (1.0 + tolerance) {
                println!(
                    "FAIL: {}: {what} {scraped} is more than {:.0} % over the quiet run's {quiet}",
                    self.run,
                    tolerance * 100.0
                );
                ok = false;
            }
        }
        if self.missed > 0 {
            println!(
                "FAIL: {}: {} replies missed, wrong or late",
                self.run, self.missed
            );
            ok = false;
        }
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(run: &'static str, messages: usize, over: usize) -> ScrapeFigures {
        ScrapeFigures {
            compute: Spread::of(vec![100]),
            full: Spread::of(vec![1000]),
            full_over: over,
            messages,
            hostile_max: 0,
            missed: 0,
            scraper: String::new(),
            run,
            held: Held::default(),
        }
    }

    #[test]
    fn no_full_path_over_five_percent_and_the_compute_max_within_one() {
        for run in ["scrape run", "upload run"] {
            assert!(figures(run, 2059, 0).gate(100, 1000, 0));
            // One message of 2,059 over the bound fails either run.
            assert!(!figures(run, 2059, 1).gate(100, 1000, 0));
            let mut f = figures(run, 2059, 0);
            f.compute = Spread::of(vec![102]);
            assert!(!f.gate(100, 1000, 0));
            let mut f = figures(run, 2059, 0);
            f.missed = 1;
            assert!(!f.gate(100, 1000, 0));
        }
    }
}
