//! `--device-status URL`: both sides of the wire in one table. The
//! simulator reads the device's own counters from its diagnostics
//! (`/status.json`, schema 1: our firmware and host sensor serve it)
//! before the first message and after the last, and puts what changed
//! beside its own counts, naming every disagreement and which side of the
//! wire it points at ("12 sent, 12 lost before the device": the network,
//! not the firmware).
//!
//! The page is read with [`crate::http_get`].

pub use crate::http_get::{get, parse, status_url, Response};
use crate::record::RunCounts;
use serde::Serialize;
use serde_json::Value;
use std::io::Write;
use std::time::Duration;

/// The device's counters that the simulator can check.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DeviceCounts {
    pub state: String,
    pub received: u64,
    pub answered: u64,
    pub dropped_decode: u64,
    pub dropped_foreign: u64,
    pub dropped_invalid_source: u64,
    pub dropped_throttled: u64,
    pub lost: u64,
    pub duplicates: u64,
    pub reordered: u64,
    pub timeouts: u64,
    pub max_lost: u64,
    pub send_errors: u64,
    /// The fragment guard: the controller's sets given up or lost.
    pub controller_incomplete: u64,
    pub controller_dropped: u64,
    /// The network chip's own drops, where the board reads them.
    pub nic_dropped: Option<u64>,
}

impl DeviceCounts {
    /// Reads `/status.json` (schema 1).
    pub fn from_json(v: &Value) -> Result<Self, String> {
        if v["schema"].as_u64() != Some(1) {
            return Err(format!("not a status of schema 1 (schema {})", v["schema"]));
        }
        let c = &v["counters"];
        let n = |group: &str, key: &str| -> Result<u64, String> {
            c[group][key]
                .as_u64()
                .ok_or_else(|| format!("counters.{group}.{key} missing"))
        };
        Ok(DeviceCounts {
            state: v["state"]["state"].as_str().unwrap_or("?").to_string(),
            received: n("messages", "received")?,
            answered: n("messages", "answered")?,
            dropped_decode: n("dropped", "decode")?,
            dropped_foreign: n("dropped", "foreign")?,
            dropped_invalid_source: n("dropped", "invalid_source")?,
            dropped_throttled: n("dropped", "throttled")?,
            lost: n("ids", "lost")?,
            duplicates: n("ids", "duplicates")?,
            reordered: n("ids", "reordered")?,
            timeouts: n("supervision", "timeouts")?,
            max_lost: n("supervision", "max_lost")?,
            send_errors: n("transport", "send_errors")?,
            controller_incomplete: n("controller", "incomplete")?,
            controller_dropped: n("controller", "dropped")?,
            nic_dropped: c["nic"]["rx_dropped"].as_u64(),
        })
    }

    /// GETs and reads the device's status at `url`.
    pub fn read(url: &str) -> Result<Self, String> {
        let url = status_url(url);
        let r = get(&url, Duration::from_secs(5))?;
        if r.status != 200 {
            return Err(format!("{url}: HTTP {}", r.status));
        }
        let v: Value =
            serde_json::from_slice(&r.body).map_err(|e| format!("{url}: not JSON: {e}"))?;
        Self::from_json(&v).map_err(|e| format!("{url}: {e}"))
    }

    /// What changed from `before` to `self`.
    fn since(&self, before: &DeviceCounts) -> DeviceCounts {
        let d = |a: u64, b: u64| a.saturating_sub(b);
        DeviceCounts {
            state: self.state.clone(),
            received: d(self.received, before.received),
            answered: d(self.answered, before.answered),
            dropped_decode: d(self.dropped_decode, before.dropped_decode),
            dropped_foreign: d(self.dropped_foreign, before.dropped_foreign),
            dropped_invalid_source: d(self.dropped_invalid_source, before.dropped_invalid_source),
            dropped_throttled: d(self.dropped_throttled, before.dropped_throttled),
            lost: d(self.lost, before.lost),
            duplicates: d(self.duplicates, before.duplicates),
            reordered: d(self.reordered, before.reordered),
            timeouts: d(self.timeouts, before.timeouts),
            max_lost: d(self.max_lost, before.max_lost),
            send_errors: d(self.send_errors, before.send_errors),
            controller_incomplete: d(self.controller_incomplete, before.controller_incomplete),
            controller_dropped: d(self.controller_dropped, before.controller_dropped),
            nic_dropped: self
                .nic_dropped
                .zip(before.nic_dropped)
                .map(|(a, b)| d(a, b)),
        }
    }
}

/// One row of the table.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Row {
    pub what: String,
    pub simulator: u64,
    pub device: u64,
}

/// Both sides of the wire over one run.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Comparison {
    /// The device's counters' change over the run.
    pub device: DeviceCounts,
    pub rows: Vec<Row>,
    /// Every disagreement, with the side of the wire it points at.
    pub disagreements: Vec<String>,
    /// One of them points inside the device (a message taken and not
    /// answered, more rejected than was sent to be rejected): the
    /// network explains the others.
    pub in_firmware: bool,
}

/// The simulator's `s` beside the device's counters from `before` to
/// `after` the run.
pub fn compare(s: &RunCounts, before: &DeviceCounts, after: &DeviceCounts) -> Comparison {
    let d = after.since(before);
    // A replay sends the capture's own malformed datagrams and Id gaps:
    // the device counts them as it counts injected ones.
    let sent = s.sent + s.injected.duplicated;
    let i = &s.injected.plus(&s.as_recorded);
    let rejected =
        d.dropped_decode + d.dropped_foreign + d.dropped_invalid_source + d.dropped_throttled;
    let robot_in = d.received.saturating_sub(rejected);
    let row = |what: &str, simulator: u64, device: u64| Row {
        what: what.to_string(),
        simulator,
        device,
    };
    let rows = vec![
        row("robot messages sent / taken by the engine", sent, robot_in),
        row(
            "replies received / sent",
            s.answered + s.duplicate_replies,
            d.answered,
        ),
        row(
            "malformed datagrams sent (injected or recorded) / rejected by the decoder",
            i.garbage + i.oversize,
            d.dropped_decode,
        ),
        row(
            "Ids skipped (drop fault or in the capture) / counted lost (S3)",
            i.dropped,
            d.lost,
        ),
        row(
            "messages duplicated / counted duplicates (S3)",
            i.duplicated,
            d.duplicates,
        ),
        row(
            "messages reordered / counted reordered (S3)",
            i.reordered,
            d.reordered,
        ),
    ];
    let mut why = Vec::new();
    let mut in_firmware = false;
    if robot_in < sent {
        let missing = sent - robot_in;
        let mut text = format!(
            "{sent} sent, {missing} never reached the device's engine: lost before the device (the network, or its network chip), not in the firmware"
        );
        if let Some(nic) = d.nic_dropped.filter(|n| *n > 0) {
            text.push_str(&format!("; the network chip counted {nic} frames dropped"));
        }
        if d.controller_incomplete + d.controller_dropped > 0 {
            text.push_str(&format!(
                "; the fragment guard gave up {} of the controller's sets",
                d.controller_incomplete + d.controller_dropped
            ));
        }
        why.push(text);
    }
    if d.answered > s.answered + s.duplicate_replies {
        why.push(format!(
            "the device sent {} replies, {} arrived: {} lost on the way back (the network)",
            d.answered,
            s.answered + s.duplicate_replies,
            d.answered - s.answered - s.duplicate_replies
        ));
    }
    if robot_in > d.answered {
        in_firmware = true;
        why.push(format!(
            "the device took {robot_in} robot messages and answered {}: {} unanswered inside the device (send errors: {})",
            d.answered,
            robot_in - d.answered,
            d.send_errors
        ));
    }
    if d.dropped_decode > i.garbage + i.oversize {
        in_firmware = true;
        why.push(format!(
            "the device rejected {} datagrams, the simulator sent {} it should reject: see the device's last bad message",
            d.dropped_decode,
            i.garbage + i.oversize
        ));
    }
    if d.dropped_foreign + d.dropped_throttled + d.dropped_invalid_source > 0 {
        why.push(format!(
            "the device dropped {} datagrams from other senders (foreign {}, throttled {}, invalid {}): someone else is talking to it",
            d.dropped_foreign + d.dropped_throttled + d.dropped_invalid_source,
            d.dropped_foreign,
            d.dropped_throttled,
            d.dropped_invalid_source
        ));
    }
    if d.lost != i.dropped {
        why.push(format!(
            "the device counted {} Ids lost, the simulator skipped {} (a gap at the very end shows only when a later message arrives)",
            d.lost, i.dropped
        ));
    }
    if (d.timeouts + d.max_lost > 0) != s.tripped {
        why.push(format!(
            "supervision: the simulator {}, the device counted {} TimeOut and {} MaxLost",
            if s.tripped {
                "tripped"
            } else {
                "never tripped"
            },
            d.timeouts,
            d.max_lost
        ));
    }
    Comparison {
        device: d,
        rows,
        disagreements: why,
        in_firmware,
    }
}

impl Comparison {
    /// The table and the disagreements, for the summary.
    pub fn print(&self, out: &mut dyn Write) -> std::io::Result<()> {
        writeln!(
            out,
            "  both sides of the wire (simulator | device, this run):"
        )?;
        for r in &self.rows {
            let mark = if r.simulator == r.device { " " } else { "≠" };
            writeln!(
                out,
                "    {:<52} {:>8} | {:<8} {mark}",
                r.what, r.simulator, r.device
            )?;
        }
        writeln!(out, "    device state now: {}", self.device.state)?;
        if self.disagreements.is_empty() {
            writeln!(out, "    the two sides agree")?;
        }
        for w in &self.disagreements {
            writeln!(out, "    disagreement: {w}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts(received: u64, answered: u64, decode: u64, lost: u64) -> DeviceCounts {
        DeviceCounts {
            state: "OPERATING".into(),
            received,
            answered,
            dropped_decode: decode,
            lost,
            ..DeviceCounts::default()
        }
    }

    #[test]
    fn losses_are_put_on_the_right_side_of_the_wire() {
        let mut s = RunCounts {
            sent: 100,
            answered: 88,
            ..RunCounts::default()
        };
        s.injected.garbage = 5;
        // 10 never reached the device, 2 replies lost on the way back.
        let c = compare(
            &s,
            &counts(50, 40, 1, 0),
            &counts(50 + 90 + 5, 40 + 90, 1 + 5, 0),
        );
        assert_eq!(c.rows[0].simulator, 100);
        assert_eq!(c.rows[0].device, 90);
        assert!(
            c.disagreements[0].starts_with("100 sent, 10 never reached"),
            "{:?}",
            c.disagreements
        );
        assert!(
            c.disagreements[1].contains("2 lost on the way back"),
            "{:?}",
            c.disagreements
        );
        // Agreement.
        let s = RunCounts {
            sent: 10,
            answered: 10,
            ..RunCounts::default()
        };
        assert!(compare(&s, &counts(0, 0, 0, 0), &counts(10, 10, 0, 0))
            .disagreements
            .is_empty());
    }

    /// Issue 42 #7: a replay of a capture holding 33 garbage datagrams and
    /// 18 skipped Ids is not "the device rejected 33, the simulator sent 0
    /// it should reject" — the simulator sent them, as recorded.
    #[test]
    fn a_replay_expects_the_captures_own_garbage_and_id_gaps() {
        let mut s = RunCounts {
            sent: 1_482,
            answered: 1_482,
            ..RunCounts::default()
        };
        s.as_recorded.garbage = 33;
        s.as_recorded.dropped = 18;
        let c = compare(&s, &counts(0, 0, 0, 0), &counts(1_482 + 33, 1_482, 33, 18));
        assert!(c.disagreements.is_empty(), "{:?}", c.disagreements);
        assert!(!c.in_firmware);
        assert_eq!((c.rows[2].simulator, c.rows[2].device), (33, 33));
        // Without them, the same counts are blamed on the firmware.
        s.as_recorded = crate::record::Injected::default();
        let c = compare(&s, &counts(0, 0, 0, 0), &counts(1_482 + 33, 1_482, 33, 18));
        assert!(c.in_firmware, "{:?}", c.disagreements);
    }
}
