//! The parts a run's summary is built from, which know nothing of it: one
//! message's record ([`Cycle`]), latency figures ([`Latency`]), counts of
//! what was sent on purpose ([`Injected`]) and the counts the device's
//! own are held against ([`RunCounts`]).

use serde::Serialize;

/// One robot message and what came back.
#[derive(Clone, Debug, Default)]
pub struct Cycle {
    pub cycle: u64,
    pub id: u32,
    /// µs since the run started.
    pub sent_us: u64,
    pub reply_us: Option<u64>,
    /// Not sent (a `drop` fault).
    pub dropped_by_fault: bool,
    /// Which `--send` property (position in the list; 0 by default).
    pub property: usize,
    /// With `--show`: the shown values of the reply that answered it.
    pub shown: Option<crate::shown::Shown>,
}

impl Cycle {
    pub fn latency_us(&self) -> Option<u64> {
        self.reply_us.map(|r| r.saturating_sub(self.sent_us))
    }
}

/// Faults injected by `--fault`, by kind.
#[derive(Clone, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Injected {
    /// Messages not sent (their Ids skipped).
    pub dropped: u64,
    /// Messages sent twice.
    pub duplicated: u64,
    /// Messages held back and sent after the next one.
    pub reordered: u64,
    /// Garbage datagrams sent besides the messages.
    pub garbage: u64,
    /// 9,000-byte datagrams sent besides the messages.
    pub oversize: u64,
    /// Pauses in sending.
    pub pauses: u64,
    /// Messages sent from the second source port.
    pub second_port: u64,
}

impl Injected {
    pub(crate) fn is_empty(&self) -> bool {
        *self == Injected::default()
    }

    /// Both counts together (what was injected and what was recorded).
    pub fn plus(&self, o: &Injected) -> Injected {
        Injected {
            dropped: self.dropped + o.dropped,
            duplicated: self.duplicated + o.duplicated,
            reordered: self.reordered + o.reordered,
            garbage: self.garbage + o.garbage,
            oversize: self.oversize + o.oversize,
            pauses: self.pauses + o.pauses,
            second_port: self.second_port + o.second_port,
        }
    }
}

/// What a run sent and got, as `--device-status` holds the device's
/// counts against them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunCounts {
    pub sent: u64,
    pub answered: u64,
    pub duplicate_replies: u64,
    pub injected: Injected,
    /// A replay's capture's own malformed datagrams and Id gaps.
    pub as_recorded: Injected,
    /// Supervision tripped (S1).
    pub tripped: bool,
}

/// Latency figures of a set of samples (µs).
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Latency {
    pub min: u64,
    pub median: u64,
    pub p99: u64,
    pub p99_9: u64,
    pub max: u64,
}

impl Latency {
    pub fn of(mut samples: Vec<u64>) -> Latency {
        if samples.is_empty() {
            return Latency::default();
        }
        samples.sort_unstable();
        let at = |q: f64| samples[(((samples.len() - 1) as f64) * q).round() as usize];
        Latency {
            min: samples[0],
            median: at(0.5),
            p99: at(0.99),
            p99_9: at(0.999),
            max: samples[samples.len() - 1],
        }
    }
}
