//! What a replay found: per robot message, whether the recorded sensor and
//! this one answered it, what differs, and both latencies; the summary's
//! replay section, the `--diff` CSV and the two-series latency plot.

use super::compare::{compare, Difference};
use super::conversation::{Conversation, Message};
use super::describe::Description;
use super::options::ReplayOptions;
use crate::record::{Cycle, Latency};
use serde::Serialize;
use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;

/// How one robot message fared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Outcome {
    /// Both answered it, alike.
    Same,
    /// Both answered it, differently.
    Differs,
    /// The recorded sensor answered it; this one did not.
    NotAnswered,
    /// This sensor answered it; the recorded one did not.
    AnsweredNow,
    /// Neither answered it (both refused it).
    Neither,
}

/// One robot message of the replay.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// Its packet in the capture.
    pub number: usize,
    pub id: Option<u32>,
    pub root: String,
    pub outcome: Outcome,
    pub recorded_latency_us: Option<u64>,
    pub replayed_latency_us: Option<u64>,
    pub differences: Vec<(String, String, String)>,
    /// For a message answered in the capture and not now: the decoder's
    /// verdict where the tool that ran the replay knows it (`cargo demo`,
    /// `cargo hil`: the firmware's own decoder).
    pub why: Option<String>,
    /// The robot message as recorded (not in `--json`).
    #[serde(skip)]
    pub payload: Vec<u8>,
}

/// The replay section of the summary (and of `--json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ReplayReport {
    pub file: String,
    pub conversation: String,
    pub messages: usize,
    pub same: usize,
    pub differ: usize,
    pub not_answered: usize,
    pub answered_now: usize,
    pub neither: usize,
    /// Robot datagrams without a readable Id: sent as recorded, refused
    /// by the sensor, neither lost nor compared.
    pub malformed: usize,
    /// What the capture held.
    pub capture: Description,
    pub recorded_latency_us: Latency,
    pub replayed_latency_us: Latency,
    pub rows: Vec<Row>,
}

/// What the replay's run gave, per robot message (capture order).
pub(super) struct Run<'a> {
    /// Each message's Id (`None`: malformed, no reply expected).
    pub ids: &'a [Option<u32>],
    /// Each message's record in `cycles` (`None` without an Id).
    pub cycle_of: &'a [Option<usize>],
    pub cycles: &'a [Cycle],
    /// The recorded reply of each message ([`super::describe::pair`]).
    pub recorded: &'a super::describe::Paired,
    /// The replayed replies by their message's index in `cycles`.
    pub replayed: &'a HashMap<usize, Vec<u8>>,
}

/// Builds the report from the run: `robot` the replayed messages in order,
/// `capture` what the capture held.
pub(super) fn build(
    conv: &Conversation,
    robot: &[&Message],
    run: &Run<'_>,
    capture: Description,
    r: &ReplayOptions,
) -> ReplayReport {
    let mut rep = ReplayReport {
        file: r.file.display().to_string(),
        conversation: format!(
            "{} ↔ {} over {}",
            conv.controller,
            conv.device,
            if conv.tcp { "TCP" } else { "UDP" }
        ),
        messages: robot.len() - capture.malformed,
        malformed: capture.malformed,
        capture,
        ..ReplayReport::default()
    };
    let (mut rec_lat, mut rep_lat) = (Vec::new(), Vec::new());
    for (k, m) in robot.iter().enumerate() {
        let id = run.ids.get(k).copied().flatten();
        if id.is_none() {
            // Malformed: sent as recorded, expected to be refused; the
            // capture's description counts it.
            continue;
        }
        let cycle = run.cycle_of.get(k).copied().flatten();
        let old = run.recorded.get(k).and_then(Option::as_ref);
        let new = cycle.and_then(|i| run.replayed.get(&i));
        let recorded_latency_us = old.map(|(at, _)| at.saturating_sub(m.at_us));
        let replayed_latency_us = cycle
            .and_then(|i| run.cycles.get(i))
            .and_then(Cycle::latency_us);
        rec_lat.extend(recorded_latency_us);
        rep_lat.extend(replayed_latency_us);
        let (outcome, differences) = match (old, new) {
            (Some((_, a)), Some(b)) => {
                let d = compare(a, b, &r.rules);
                let o = if d.is_empty() {
                    Outcome::Same
                } else {
                    Outcome::Differs
                };
                (o, d)
            }
            (Some(_), None) => (Outcome::NotAnswered, Vec::new()),
            (None, Some(_)) => (Outcome::AnsweredNow, Vec::new()),
            (None, None) => (Outcome::Neither, Vec::new()),
        };
        match outcome {
            Outcome::Same => rep.same += 1,
            Outcome::Differs => rep.differ += 1,
            Outcome::NotAnswered => rep.not_answered += 1,
            Outcome::AnsweredNow => rep.answered_now += 1,
            Outcome::Neither => rep.neither += 1,
        }
        rep.rows.push(Row {
            number: m.number,
            id,
            root: crate::wire::root_name(&m.payload).unwrap_or_default(),
            outcome,
            recorded_latency_us,
            replayed_latency_us,
            differences: differences
                .into_iter()
                .map(
                    |Difference {
                         field,
                         recorded,
                         replayed,
                     }| (field, recorded, replayed),
                )
                .collect(),
            why: None,
            payload: m.payload.clone(),
        });
    }
    rep.recorded_latency_us = Latency::of(rec_lat);
    rep.replayed_latency_us = Latency::of(rep_lat);
    rep
}

impl ReplayReport {
    /// Why the replay did not pass: a message answered in the capture and
    /// not now first (the headline), then differing replies, then replies
    /// to messages the recorded sensor did not answer.
    pub fn failure(&self) -> Option<String> {
        if let Some(row) = self.rows.iter().find(|r| r.outcome == Outcome::NotAnswered) {
            return Some(format!(
                "{} of {} robot messages the recorded sensor answered were not answered; the first: packet {} (<{}> Id {}){}",
                self.not_answered,
                self.messages,
                row.number,
                row.root,
                row.id.map_or("?".into(), |i| i.to_string()),
                row.why.as_ref().map_or(String::new(), |w| format!(": {w}"))
            ));
        }
        if let Some(row) = self.rows.iter().find(|r| r.outcome == Outcome::Differs) {
            let (field, a, b) = row.differences.first().cloned().unwrap_or_default();
            return Some(format!(
                "{} replies differ from the recorded ones; the first: packet {} (Id {}): {field} recorded {a}, replayed {b}",
                self.differ,
                row.number,
                row.id.map_or("?".into(), |i| i.to_string()),
            ));
        }
        if self.answered_now > 0 {
            return Some(format!(
                "{} robot messages the recorded sensor did not answer were answered now",
                self.answered_now
            ));
        }
        None
    }

    /// The summary's replay lines.
    pub fn print(&self, out: &mut dyn Write) -> io::Result<()> {
        writeln!(out, "  replay of {} ({}):", self.file, self.conversation)?;
        self.capture.print(out)?;
        if let Some(row) = self.rows.iter().find(|r| r.outcome == Outcome::NotAnswered) {
            writeln!(
                out,
                "    ANSWERED IN THE CAPTURE, NOT NOW: {} messages; the first is packet {} (<{}> Id {}){}",
                self.not_answered,
                row.number,
                row.root,
                row.id.map_or("?".into(), |i| i.to_string()),
                row.why.as_ref().map_or(
                    " (replay against cargo sensor-host or cargo demo for the decoder's verdict)".into(),
                    |w| format!(": {w}")
                )
            )?;
        }
        writeln!(
            out,
            "    replayed: robot messages with an Id {}: same reply {}, different reply {}, answered in the capture only {}, answered now only {}, by neither {}; without an Id (malformed, sent as recorded) {}",
            self.messages, self.same, self.differ, self.not_answered, self.answered_now, self.neither, self.malformed
        )?;
        let mut by_field: Vec<(String, usize)> = Vec::new();
        for (f, ..) in self.rows.iter().flat_map(|r| r.differences.iter()) {
            match by_field.iter_mut().find(|(g, _)| g == f) {
                Some((_, n)) => *n += 1,
                None => by_field.push((f.clone(), 1)),
            }
        }
        if !by_field.is_empty() {
            let list: Vec<String> = by_field.iter().map(|(f, n)| format!("{f} {n}")).collect();
            writeln!(out, "    differences by field: {}", list.join(", "))?;
        }
        let (a, b) = (&self.recorded_latency_us, &self.replayed_latency_us);
        writeln!(
            out,
            "    reply latency us, recorded | replayed: median {} | {}  p99 {} | {}  max {} | {}",
            a.median, b.median, a.p99, b.p99, a.max, b.max
        )
    }

    /// `--diff FILE.csv`: one row per difference, and one per message
    /// answered by one sensor only.
    pub fn write_csv(&self, path: &Path) -> io::Result<()> {
        let mut f = io::BufWriter::new(std::fs::File::create(path)?);
        writeln!(
            f,
            "packet,id,outcome,field,recorded,replayed,recorded_latency_us,replayed_latency_us"
        )?;
        let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
        let opt = |v: Option<u64>| v.map_or(String::new(), |v| v.to_string());
        for r in self.rows.iter().filter(|r| r.outcome != Outcome::Same) {
            let base = format!(
                "{},{},{:?}",
                r.number,
                r.id.map_or(String::new(), |i| i.to_string()),
                r.outcome
            );
            let lat = format!(
                "{},{}",
                opt(r.recorded_latency_us),
                opt(r.replayed_latency_us)
            );
            if r.differences.is_empty() {
                let why = r.why.as_deref().unwrap_or("");
                writeln!(f, "{base},,{},,{lat}", q(why))?;
            }
            for (field, a, b) in &r.differences {
                writeln!(f, "{base},{},{},{},{lat}", q(field), q(a), q(b))?;
            }
        }
        f.flush()
    }

    /// `--plot FILE` in a replay: the recorded and the replayed reply
    /// latency of every message, against its place in the capture.
    pub fn write_plot(&self, path: &Path) -> Result<(), String> {
        use plotters::prelude::*;
        crate::font::ensure_font()?;
        match path.extension().and_then(|x| x.to_str()) {
            Some("png") => self.draw(BitMapBackend::new(path, (1100, 500)).into_drawing_area()),
            _ => self.draw(SVGBackend::new(path, (1100, 500)).into_drawing_area()),
        }
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: plotters::drawing::DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), String> {
        use plotters::prelude::*;
        let series = |pick: fn(&Row) -> Option<u64>| -> Vec<(f64, f64)> {
            self.rows
                .iter()
                .enumerate()
                .filter_map(|(i, r)| pick(r).map(|l| (i as f64, l as f64 / 1000.0)))
                .collect()
        };
        let recorded = series(|r| r.recorded_latency_us);
        let replayed = series(|r| r.replayed_latency_us);
        let top = recorded
            .iter()
            .chain(&replayed)
            .map(|p| p.1)
            .fold(1.0f64, f64::max)
            * 1.1;
        let e = |x: &dyn std::fmt::Display| x.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "Reply latency, recorded and replayed: {}",
                    self.conversation
                ),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(0f64..self.rows.len().max(1) as f64, 0f64..top)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("robot message (capture order)")
            .y_desc("reply latency (ms)")
            .draw()
            .map_err(|x| e(&x))?;
        chart
            .draw_series(recorded.iter().map(|p| Circle::new(*p, 2, BLUE.filled())))
            .map_err(|x| e(&x))?
            .label("recorded")
            .legend(|(x, y)| Circle::new((x, y), 3, BLUE.filled()));
        chart
            .draw_series(replayed.iter().map(|p| Circle::new(*p, 2, RED.filled())))
            .map_err(|x| e(&x))?
            .label("replayed")
            .legend(|(x, y)| Circle::new((x, y), 3, RED.filled()));
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))
    }
}
