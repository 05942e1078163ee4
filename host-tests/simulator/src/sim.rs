//! One run in progress: the controller's supervision (S1), the messages
//! waiting for their replies, the checks of every reply (M8 and the
//! layout), and the log of state transitions.

use crate::link::{Event, Link};
use crate::pcap::Packet;
use crate::record::{Cycle, Latency};
use crate::report::{PropertyFigures, Summary};
use crate::show::Show;
use crate::RobotOptions;
use gsi_config::{Device, Property};
use std::collections::HashMap;
use std::io::{ErrorKind, Write};
use std::time::{Duration, Instant};

/// The controller's supervision (S1) and state as it would show in RAPID.
pub(crate) struct Supervision {
    pub(crate) dry_run: bool,
    pub(crate) timeout: Duration,
    pub(crate) max_lost: u32,
    pub(crate) in_row: u32,
    /// Of the unanswered run: replies that came with a wrong Id or late,
    /// so a trip names the cause.
    pub(crate) wrong_in_row: u32,
    pub(crate) late_in_row: u32,
    pub(crate) tripped: Option<String>,
    pub(crate) operating: bool,
    pub(crate) last_answer: Option<Instant>,
}

/// A message waiting for its reply.
pub(crate) struct Waiting {
    pub(crate) index: usize,
    pub(crate) sent: Instant,
    /// Replies still expected (2 for a duplicated message).
    pub(crate) expected: u8,
    pub(crate) answered: bool,
}

pub(crate) struct Sim<'a> {
    pub(crate) opts: &'a RobotOptions,
    pub(crate) device: &'a Device,
    pub(crate) reply_prop: &'a Property,
    /// Replies and periodic messages by device property name.
    pub(crate) received: HashMap<String, u64>,
    pub(crate) link: Link,
    pub(crate) start: Instant,
    pub(crate) cycles: Vec<Cycle>,
    pub(crate) waiting: HashMap<u32, Waiting>,
    pub(crate) sup: Supervision,
    pub(crate) s: Summary,
    pub(crate) packets: Vec<Packet>,
    pub(crate) log: &'a mut dyn Write,
    pub(crate) bar: indicatif::ProgressBar,
    /// `--show`: the columns to take from each answering reply; `None`:
    /// replies are not parsed beyond their checks.
    pub(crate) show: Option<Show>,
    /// When the last live line of shown values was printed.
    pub(crate) shown_at: Option<Instant>,
    /// `--replay`: the first reply to each message, by its index in
    /// `cycles`, kept to compare.
    pub(crate) replies: Option<HashMap<usize, Vec<u8>>>,
}

impl<'a> Sim<'a> {
    /// A run about to start: nothing sent, supervision as the device's
    /// configuration says (S1), the progress bar if asked for.
    pub(crate) fn new(
        opts: &'a RobotOptions,
        device: &'a Device,
        reply_prop: &'a Property,
        link: Link,
        tick_ms: u32,
        log: &'a mut dyn Write,
    ) -> Self {
        let bar = if opts.progress {
            let bar = indicatif::ProgressBar::new(opts.cycles);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:32}] {pos}/{len} cycles {msg}",
            ) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar
        } else {
            indicatif::ProgressBar::hidden()
        };
        Sim {
            opts,
            device,
            reply_prop,
            received: HashMap::new(),
            link,
            start: Instant::now(),
            cycles: Vec::with_capacity(opts.cycles as usize),
            waiting: HashMap::new(),
            sup: Supervision {
                dry_run: device.supervision.dry_run,
                timeout: Duration::from_millis(u64::from(device.supervision.timeout_ms)),
                max_lost: device.supervision.max_lost,
                in_row: 0,
                wrong_in_row: 0,
                late_in_row: 0,
                tripped: None,
                operating: false,
                last_answer: None,
            },
            s: Summary {
                device: device.name.clone(),
                target: opts.to.to_string(),
                transport: if opts.tcp { "TCP" } else { "UDP" }.into(),
                rate_ms: tick_ms,
                paced: opts.pacing,
                cycles: opts.cycles,
                ..Summary::default()
            },
            packets: Vec::new(),
            log,
            bar,
            show: None,
            shown_at: None,
            replies: None,
        }
    }

    /// S1 at send time: were the last cycle's messages answered within it?
    /// An answered one ends a run of unanswered ones; more than `MaxLost`
    /// in a row trips supervision, naming the cause.
    pub(crate) fn judge_previous(&mut self, previous: &mut Vec<u32>) {
        for prev in previous.drain(..) {
            if self.waiting.get(&prev).is_none_or(|w| w.answered) {
                self.sup.in_row = 0;
                self.sup.wrong_in_row = 0;
                self.sup.late_in_row = 0;
            } else {
                self.sup.in_row += 1;
            }
        }
        if self.sup.in_row > self.sup.max_lost {
            let n = self.sup.max_lost;
            let cause = if self.sup.wrong_in_row > 0 {
                format!("{} replies carried a wrong Id (M8)", self.sup.wrong_in_row)
            } else if self.sup.late_in_row > 0 {
                format!("{} replies came later than one cycle", self.sup.late_in_row)
            } else {
                "no reply at all".to_string()
            };
            self.trip(format!(
                "more than MaxLost = {n} messages in a row unanswered: {cause}"
            ));
        }
    }

    /// The device's new log lines and the progress bar after cycle `c`.
    pub(crate) fn show_progress(&mut self, c: u64) {
        self.device_lines();
        let elapsed = self.start.elapsed().as_secs_f64();
        // A rate over less than a second is noise (the first reading would
        // be thousands of messages per second).
        let rate = if elapsed >= 1.0 {
            format!("{:.0} msg/s, ", self.s.sent as f64 / elapsed)
        } else {
            String::new()
        };
        // Message first: one redraw shows both with the same counts.
        self.bar.set_message(format!(
            "{rate}answered {}, late {}, lost {}",
            self.s.answered,
            self.s.late,
            self.unanswered(Instant::now())
        ));
        self.bar.set_position(c + 1);
    }

    /// Waits (one tick, at least 200 ms) for the replies still due.
    pub(crate) fn collect_last(&mut self, tick: Duration) {
        let drain = Instant::now() + tick.max(Duration::from_millis(200));
        while !self.waiting.values().all(|w| w.answered) && Instant::now() < drain {
            self.pump(drain.min(Instant::now() + tick), None);
        }
        self.bar.finish_and_clear();
        self.device_lines();
    }

    /// The run's summary (lost, latency, supervision, per property), its
    /// per-message records and its captured packets.
    pub(crate) fn finish(self, sends: &[(&Property, u32)]) -> (Summary, Vec<Cycle>, Vec<Packet>) {
        let mut s = self.s;
        let cycles = self.cycles;
        // One pass: per sent property, its messages (those a fault did not
        // drop), the answered and the lost ones; and the lost in all.
        let mut per = vec![(0u64, 0u64, 0u64); sends.len()];
        s.lost = 0;
        for c in &cycles {
            let lost = !c.dropped_by_fault && c.reply_us.is_none();
            s.lost += u64::from(lost);
            if let Some((messages, answered, lost_here)) = per.get_mut(c.property) {
                *messages += u64::from(!c.dropped_by_fault);
                *answered += u64::from(c.reply_us.is_some());
                *lost_here += u64::from(lost);
            }
        }
        s.latency_us = Latency::of(cycles.iter().filter_map(Cycle::latency_us).collect());
        s.supervision_tripped = self.sup.tripped;
        s.properties = sends
            .iter()
            .zip(per)
            .map(|((p, ms), (messages, answered, lost))| PropertyFigures {
                name: p.name.clone(),
                direction: "sent".into(),
                period_ms: Some(*ms),
                messages,
                answered,
                lost,
            })
            .collect();
        for p in self.device.sent() {
            if let Some(&n) = self.received.get(&p.name) {
                s.properties.push(PropertyFigures {
                    name: p.name.clone(),
                    direction: if p.name == self.reply_prop.name {
                        "reply"
                    } else {
                        "periodic"
                    }
                    .into(),
                    period_ms: None,
                    messages: n,
                    answered: 0,
                    lost: 0,
                });
            }
        }
        s.elapsed_s = self.start.elapsed().as_secs_f64();
        (s, cycles, self.packets)
    }
}

impl Sim<'_> {
    pub(crate) fn us(&self, t: Instant) -> u64 {
        t.duration_since(self.start).as_micros() as u64
    }

    pub(crate) fn transition(&mut self, what: &str) {
        let t = self.start.elapsed().as_secs_f64();
        let log = &mut self.log;
        // Around the live progress bar, not through it.
        self.bar.suspend(|| {
            let _ = writeln!(log, "[{t:9.3}s] controller: {what}");
        });
    }

    /// Prints what the device logged since the last call.
    pub(crate) fn device_lines(&mut self) {
        let Some(shared) = &self.opts.device_log else {
            return;
        };
        let lines: Vec<String> = match shared.lock() {
            Ok(mut l) => l.drain(..).collect(),
            Err(_) => return,
        };
        let log = &mut self.log;
        self.bar.suspend(|| {
            for line in &lines {
                let _ = writeln!(log, "device: {line}");
            }
        });
    }

    /// Messages older than one cycle still without an answer.
    pub(crate) fn unanswered(&self, now: Instant) -> usize {
        let cycle = Duration::from_millis(u64::from(self.s.rate_ms));
        self.waiting
            .values()
            .filter(|w| !w.answered && now.duration_since(w.sent) > cycle)
            .count()
    }

    pub(crate) fn trip(&mut self, reason: String) {
        if self.sup.dry_run || self.sup.tripped.is_some() {
            return;
        }
        self.transition(&format!("ERROR 112602 ({reason})"));
        self.sup.tripped = Some(reason);
        self.sup.operating = false;
    }

    pub(crate) fn send(&mut self, bytes: &[u8], second: bool) -> Result<(), String> {
        let now = Instant::now();
        let (from, r) = if let Some((main, s2)) = &self.link.udp {
            let sock = match (second, s2) {
                (true, Some(s)) => s,
                _ => main,
            };
            let from = sock.local_addr().ok();
            let sent = match (&self.opts.udp_send, from) {
                (Some(send), Some(from)) => (send.0)(from, self.opts.to, bytes),
                _ => sock.send_to(bytes, self.opts.to).map(|_| ()),
            };
            (from, sent)
        } else if let Some(stream) = &mut self.link.tcp {
            if self.link.closed {
                return Ok(());
            }
            (stream.local_addr().ok(), stream.write_all(bytes))
        } else {
            return Ok(());
        };
        if let Err(e) = r {
            if !matches!(
                e.kind(),
                ErrorKind::ConnectionRefused
                    | ErrorKind::WouldBlock
                    | ErrorKind::BrokenPipe
                    | ErrorKind::ConnectionReset
            ) {
                return Err(format!("cannot send to {}: {e}", self.opts.to));
            }
        }
        if self.opts.pcap.is_some() {
            let at_us = self.us(now);
            self.packets.push(Packet {
                at_us,
                from: from.unwrap_or(self.opts.to),
                to: self.opts.to,
                payload: bytes.to_vec(),
            });
        }
        Ok(())
    }

    /// S1 TimeOut: messages wait and nothing has been answered for longer.
    pub(crate) fn check_timeout(&mut self, now: Instant) {
        let oldest = self
            .waiting
            .values()
            .filter(|w| !w.answered)
            .map(|w| w.sent)
            .min();
        if let Some(oldest) = oldest {
            let since = self.sup.last_answer.map_or(oldest, |a| a.max(oldest));
            if now.duration_since(since) > self.sup.timeout {
                let ms = self.sup.timeout.as_millis();
                self.trip(format!("no answer within TimeOut = {ms} ms"));
            }
        }
    }

    /// Receives and checks replies until `until`, or until message `id`
    /// is answered when given.
    ///
    /// Replies already received are handled first, before the TimeOut
    /// check and before returning when the schedule is already due: after
    /// a stall of this thread (a loaded host), the replies the receiver
    /// thread stamped on arrival during the stall count as what they
    /// were, answers in time, not as a run of lost messages.
    pub(crate) fn pump(&mut self, until: Instant, id: Option<u32>) {
        loop {
            while let Ok(event) = self.link.events.try_recv() {
                self.on_event(event);
            }
            let now = Instant::now();
            self.check_timeout(now);
            if id.is_some_and(|id| self.waiting.get(&id).is_none_or(|w| w.answered)) || now >= until
            {
                return;
            }
            if self.link.closed {
                self.trip("the sensor closed the TCP connection".into());
                return;
            }
            // Wake at least every 2 ms for the TimeOut check.
            let wait = (until - now).min(Duration::from_millis(2));
            if let Ok(event) = self.link.events.recv_timeout(wait) {
                self.on_event(event);
            }
        }
    }

    /// One thing the receiver thread saw: a reply (stamped on arrival) or
    /// the TCP connection closing.
    fn on_event(&mut self, event: Event) {
        match event {
            Event::Data(bytes, local, at) => self.handle_reply(&bytes, local, at),
            Event::Closed => self.link.closed = true,
        }
    }
}

mod replies;

#[cfg(test)]
#[path = "sim_tests.rs"]
mod tests;
