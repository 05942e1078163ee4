//! The scrape run's figures (`cargo qemu-bench`: the same phases again
//! while a client reads the diagnostics), printed beside the same build's
//! quiet ones and gated: the service never at the cycle's expense.

use crate::paths::{full_paths, hostile_cost, spreads};
use crate::Phase;
use host_tests::qemu_bench::Spread;

/// The scrape run's full-path bound: within 5 % of the quiet run's max,
/// but for at most [`SCRAPE_COINCIDENCE_SHARE`] of the messages, none over
/// 10 %. Measured: in some runs (2 of 5) one message of the ~1,500 is
/// about 2,000 instructions over the others of its size (+5.1 %, +5.3 % on
/// the max), outside the engine (its compute is unchanged). The likely
/// cause, read in smoltcp 0.13's `Interface::poll` and not yet attributed
/// by a measurement: after the runner hands a robot message to the stack,
/// the same poll goes on to its egress pass, where a diagnostics socket
/// with a segment due (an ACK, a FIN, the rest of a response) builds it
/// before the held driver refuses it (the pass stops at the first refusal:
/// one segment at most, about 5 % of the max). The compute max is held to
/// 1 %, as the issue asks.
const SCRAPE_FULL_TOLERANCE: f64 = 0.05;
const SCRAPE_COINCIDENCE_TOLERANCE: f64 = 0.10;
/// At most this share of the scrape run's messages over
/// [`SCRAPE_FULL_TOLERANCE`] (1 %).
const SCRAPE_COINCIDENCE_SHARE: f64 = 0.01;

/// The scrape run's figures, beside the same build's quiet ones.
pub struct ScrapeFigures {
    pub compute: Spread,
    pub full: Spread,
    /// Messages whose full path is over the quiet max by more than
    /// [`SCRAPE_FULL_TOLERANCE`], and by more than
    /// [`SCRAPE_COINCIDENCE_TOLERANCE`].
    pub full_over: usize,
    pub full_far_over: usize,
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
}

impl ScrapeFigures {
    /// From the scrape run `p` and what the scraper got; `quiet_full_max`
    /// is the quiet run's full-path max.
    pub fn of(run: &'static str, p: &Phase, scraper: &str, quiet_full_max: u64) -> Self {
        let (compute, full, late) = spreads(&p.sim_records, &p.realistic);
        let paths = full_paths(&p.sim_records, &p.realistic);
        let over = |tolerance: f64| {
            let bound = quiet_full_max as f64 * (1.0 + tolerance);
            paths.iter().filter(|&&f| f as f64 > bound).count()
        };
        ScrapeFigures {
            compute,
            full,
            full_over: over(SCRAPE_FULL_TOLERANCE),
            full_far_over: over(SCRAPE_COINCIDENCE_TOLERANCE),
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
            "  full paths over the quiet max by more than {:.0} %: {} of {} (bound: {:.0} % of them, none over {:.0} %)",
            SCRAPE_FULL_TOLERANCE * 100.0,
            self.full_over,
            self.messages,
            SCRAPE_COINCIDENCE_SHARE * 100.0,
            SCRAPE_COINCIDENCE_TOLERANCE * 100.0
        );
        println!(
            "  replies missed, wrong or late in the {}: {}",
            self.run, self.missed
        );
    }

    /// The service never at the cycle's expense: the same build's figures
    /// with and without a client on the diagnostics. Prints each failure;
    /// whether all held.
    pub fn gate(&self, compute_max: u64, full_max: u64, hostile_max: u64) -> bool {
        let mut ok = true;
        let allowed = (self.messages as f64 * SCRAPE_COINCIDENCE_SHARE) as usize;
        if self.full_over > allowed || self.full_far_over > 0 {
            println!(
                "FAIL: {}: {} full paths of {} over the quiet run's max {full_max} by more than {:.0} % (bound: {allowed}), {} by more than {:.0} % (bound: 0); see scraped.rs",
                self.run,
                self.full_over,
                self.messages,
                SCRAPE_FULL_TOLERANCE * 100.0,
                self.full_far_over,
                SCRAPE_COINCIDENCE_TOLERANCE * 100.0,
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
