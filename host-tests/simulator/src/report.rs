//! What a run produced: per-cycle records, the summary and its verdict,
//! and the CSV and JSON files; the plot is [`crate::plot`]'s, the capture
//! [`crate::pcap`]'s.

pub use crate::record::{Cycle, Injected, Latency, RunCounts};
use serde::Serialize;
use std::io::{self, Write};
use std::path::Path;

/// The end-of-run summary (also `--json`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Summary {
    pub device: String,
    pub target: String,
    pub transport: String,
    pub rate_ms: u32,
    pub cycles: u64,
    pub sent: u64,
    pub answered: u64,
    /// Answered later than one cycle.
    pub late: u64,
    /// Never answered.
    pub lost: u64,
    /// Replies whose Id matches no message sent (M8).
    pub wrong_id: u64,
    /// Replies that are not the expected message (root, fields, values).
    pub malformed: u64,
    /// Extra replies to messages sent twice (a `duplicate` fault).
    pub duplicate_replies: u64,
    /// What `--fault` injected, to check a device's counters against.
    pub injected: Injected,
    /// `--replay`: what the capture's own robot messages hold that a
    /// device counts as it counts injected faults (Ids skipped by the
    /// recorded controller, datagrams without a readable Id), so
    /// `--device-status` expects them.
    pub as_recorded: Injected,
    /// `false` with `--no-pacing` (lock-step: each message after the last
    /// reply, as fast as the sensor answers).
    pub paced: bool,
    /// Paced runs: the most a message went out after its scheduled time
    /// (the simulator's own scheduling jitter, not the sensor's).
    pub send_lag_max_us: u64,
    /// Outputs (`--csv`, `--plot`, `--pcap`, `--json`) that could not be
    /// written after the run.
    pub output_errors: Vec<String>,
    pub latency_us: Latency,
    /// The controller's supervision verdict (S1): `None` = never tripped.
    pub supervision_tripped: Option<String>,
    /// The first problem with a reply, for the user.
    pub first_error: Option<String>,
    pub elapsed_s: f64,
    /// Per property (M11): each one sent, then each device property
    /// received (the reply, periodic ones).
    pub properties: Vec<PropertyFigures>,
    /// `--device-status`: the device's own counts beside these.
    pub device_status: Option<crate::device_status::Comparison>,
    /// `--replay`: every reply against the recorded one.
    pub replay: Option<crate::replay::report::ReplayReport>,
}

/// One property's share of a run.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct PropertyFigures {
    pub name: String,
    /// `sent` (by the simulator), `reply` or `periodic` (by the device).
    pub direction: String,
    /// Sending period (sent properties).
    pub period_ms: Option<u32>,
    /// Messages sent, or received from the device.
    pub messages: u64,
    /// Of the sent ones: answered, never answered.
    pub answered: u64,
    pub lost: u64,
}

impl Summary {
    /// What `--device-status` holds the device's counts against.
    pub fn counts(&self) -> RunCounts {
        RunCounts {
            sent: self.sent,
            answered: self.answered,
            duplicate_replies: self.duplicate_replies,
            injected: self.injected.clone(),
            as_recorded: self.as_recorded.clone(),
            tripped: self.supervision_tripped.is_some(),
        }
    }

    /// Exit status 0 if and only if supervision never tripped and every
    /// reply was correct.
    pub fn passed(&self) -> bool {
        self.supervision_tripped.is_none() && self.wrong_id == 0 && self.malformed == 0
    }

    /// The run failed on timing alone: supervision tripped, yet every
    /// message was answered, every reply was right and every output was
    /// written, so only lateness (S1's `MaxLost` late replies in a row)
    /// tripped it. On a shared machine running an emulated board in real
    /// time, a stall of the host looks exactly like this; a missing or
    /// wrong reply never does.
    pub fn late_only(&self) -> bool {
        self.supervision_tripped.is_some()
            && self.late > 0
            && self.lost == 0
            && self.answered == self.sent
            && self.wrong_id == 0
            && self.malformed == 0
            && self.output_errors.is_empty()
    }

    /// Why the run did not pass.
    pub fn failure(&self) -> Option<String> {
        if let Some(s) = &self.supervision_tripped {
            let hint = if self.answered == 0 && self.malformed == 0 {
                format!(
                    "; no reply at all from {}: is a sensor for device {} listening there?",
                    self.target, self.device
                )
            } else {
                String::new()
            };
            return Some(format!("supervision tripped: {s}{hint}"));
        }
        if !self.output_errors.is_empty() {
            return Some(format!(
                "the run passed but not every output was written: {}",
                self.output_errors.join("; ")
            ));
        }
        if self.wrong_id > 0 {
            return Some(format!("{} replies with a wrong Id (M8)", self.wrong_id));
        }
        if self.malformed > 0 {
            return Some(format!(
                "{} malformed replies; first: {}",
                self.malformed,
                self.first_error.as_deref().unwrap_or("?")
            ));
        }
        self.replay
            .as_ref()
            .and_then(crate::replay::report::ReplayReport::failure)
    }

    pub fn print(&self, out: &mut dyn Write) -> io::Result<()> {
        let l = &self.latency_us;
        let pace = if self.paced {
            format!("every {} ms", self.rate_ms)
        } else {
            "lock-step, no pacing".to_string()
        };
        writeln!(
            out,
            "robot simulator: {} cycles to {} ({} over {}, {pace}) in {:.2} s",
            self.cycles, self.device, self.target, self.transport, self.elapsed_s
        )?;
        let i = &self.injected;
        if !i.is_empty() {
            writeln!(
                out,
                "  injected: dropped {}  duplicated {}  reordered {}  garbage {}  oversize {}  pauses {}  second-port {}",
                i.dropped, i.duplicated, i.reordered, i.garbage, i.oversize, i.pauses, i.second_port
            )?;
        }
        writeln!(out, "  sent {}  answered {}  late {}  lost {}  wrong Id {}  malformed {}  duplicate replies {}", self.sent, self.answered, self.late, self.lost, self.wrong_id, self.malformed, self.duplicate_replies)?;
        writeln!(
            out,
            "  latency us (reply - actual send; late = more than one cycle): min {}  median {}  p99 {}  p99.9 {}  max {}",
            l.min, l.median, l.p99, l.p99_9, l.max
        )?;
        if self.paced {
            writeln!(
                out,
                "  sending lag behind schedule (the simulator's own jitter) us: max {}",
                self.send_lag_max_us
            )?;
        }
        if self.properties.len() > 2 {
            for p in &self.properties {
                match p.period_ms {
                    Some(ms) => writeln!(
                        out,
                        "  {} every {ms} ms: sent {}  answered {}  lost {}",
                        p.name, p.messages, p.answered, p.lost
                    )?,
                    None => writeln!(
                        out,
                        "  {} ({}): received {}",
                        p.name, p.direction, p.messages
                    )?,
                }
            }
        }
        match &self.supervision_tripped {
            None => writeln!(out, "  supervision: never tripped")?,
            Some(s) => writeln!(out, "  supervision: TRIPPED ({s})")?,
        }
        if let Some(c) = &self.device_status {
            c.print(out)?;
        }
        if let Some(r) = &self.replay {
            r.print(out)?;
        }
        Ok(())
    }
}

pub fn write_csv(path: &Path, cycles: &[Cycle], rate_us: u64) -> io::Result<()> {
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "cycle,id,sent_us,reply_us,latency_us,late,verdict,property"
    )?;
    for c in cycles {
        let verdict = if c.dropped_by_fault {
            "dropped-by-fault"
        } else if c.reply_us.is_none() {
            "lost"
        } else {
            "answered"
        };
        let lat = c.latency_us();
        writeln!(
            f,
            "{},{},{},{},{},{},{},{}",
            c.cycle,
            c.id,
            c.sent_us,
            c.reply_us.map(|v| v.to_string()).unwrap_or_default(),
            lat.map(|v| v.to_string()).unwrap_or_default(),
            lat.is_some_and(|l| l > rate_us),
            verdict,
            c.property
        )?;
    }
    f.flush()
}

pub fn write_json(path: &Path, summary: &Summary) -> io::Result<()> {
    let text = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
    std::fs::write(path, text + "\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles() {
        let l = Latency::of((1..=1000).collect());
        assert_eq!(
            (l.min, l.median, l.p99, l.p99_9, l.max),
            (1, 501, 990, 999, 1000)
        );
        assert_eq!(Latency::of(vec![]), Latency::default());
    }

    /// S1: a trip on late replies alone is told apart from one with a
    /// missing, wrong or malformed reply.
    #[test]
    fn late_only_is_a_trip_with_every_reply_there_and_right() {
        let late = Summary {
            sent: 500,
            answered: 500,
            late: 60,
            supervision_tripped: Some("30 late".into()),
            ..Summary::default()
        };
        assert!(late.late_only());
        assert!(!Summary {
            supervision_tripped: None,
            ..late.clone()
        }
        .late_only());
        assert!(!Summary {
            lost: 1,
            answered: 499,
            ..late.clone()
        }
        .late_only());
        assert!(!Summary {
            wrong_id: 1,
            ..late.clone()
        }
        .late_only());
        assert!(!Summary {
            malformed: 1,
            ..late.clone()
        }
        .late_only());
        assert!(!Summary {
            late: 0,
            ..late.clone()
        }
        .late_only());
        let unwritten = Summary {
            output_errors: vec!["plot".into()],
            ..late
        };
        assert!(!unwritten.late_only());
    }
}
