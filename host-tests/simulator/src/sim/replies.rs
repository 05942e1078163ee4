//! Each reply as the controller takes it: matched to the message it
//! answers (M8), checked against the layout, its values shown (`--show`),
//! its latency kept. A second `impl` block of [`Sim`].

use super::Sim;
use crate::pcap::Packet;
use crate::show::{self, Shown};
use crate::wire;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

impl Sim<'_> {
    pub(crate) fn handle_reply(&mut self, bytes: &[u8], local: SocketAddr, at: Instant) {
        if self.opts.pcap.is_some() {
            let at_us = self.us(at);
            self.packets.push(Packet {
                at_us,
                from: self.opts.to,
                to: local,
                payload: bytes.to_vec(),
            });
        }
        // M11: a device property other than the reply is a periodic send
        // (its own Id sequence): checked and counted, not matched.
        let root = wire::root_name(bytes);
        let other = self
            .device
            .sent()
            .find(|p| root.as_deref() == Some(p.wire()) && p.wire() != self.reply_prop.wire());
        if let Some(prop) = other {
            match wire::check_reply(self.device, prop, bytes) {
                Ok(_) => *self.received.entry(prop.name.clone()).or_default() += 1,
                Err(e) => {
                    self.s.malformed += 1;
                    self.s
                        .first_error
                        .get_or_insert(format!("<{}>: {e}", prop.wire()));
                }
            }
            return;
        }
        let reply = match wire::check_reply(self.device, self.reply_prop, bytes) {
            Ok(r) => r,
            Err(e) => {
                self.s.malformed += 1;
                let device = &self.device.name;
                let expected = self.reply_prop.wire();
                let why = match root.as_deref() {
                    // The layout's own reply, but not as this device has it.
                    Some(r) if r == expected => format!(
                        "the reply <{r}> does not match device {device}'s layout ({e}): is the sensor built for another device?"
                    ),
                    Some(r) => format!(
                        "a reply <{r}> is no message device {device} sends (expected <{expected}>): is the sensor built for another device, or with another RRI_REPLY (--reply)?"
                    ),
                    None => e,
                };
                self.s.first_error.get_or_insert(why);
                return;
            }
        };
        *self
            .received
            .entry(self.reply_prop.name.clone())
            .or_default() += 1;
        let Some(w) = self.waiting.get_mut(&reply.id) else {
            self.s.wrong_id += 1;
            self.sup.wrong_in_row += 1;
            self.s.first_error.get_or_insert_with(|| {
                format!("reply with Id {} to no message sent (M8)", reply.id)
            });
            return;
        };
        w.expected = w.expected.saturating_sub(1);
        if w.answered {
            self.s.duplicate_replies += 1;
        } else {
            w.answered = true;
            let index = w.index;
            self.cycles[index].reply_us = Some(self.us(at));
            self.s.answered += 1;
            // One definition of late everywhere (summary, CSV, plot):
            // reply time minus actual send time, in µs, beyond one cycle.
            let latency_us = self.us(at).saturating_sub(self.cycles[index].sent_us);
            if latency_us > u64::from(self.s.rate_ms) * 1000 {
                self.s.late += 1;
                self.sup.late_in_row += 1;
            }
            self.sup.last_answer = Some(at);
            if self.show.is_some() {
                self.take_shown(bytes, index, reply.id, at);
            }
            if let Some(kept) = &mut self.replies {
                kept.insert(index, bytes.to_vec());
            }
            if !self.sup.operating && self.sup.tripped.is_none() {
                self.sup.operating = true;
                self.transition("OPERATING (first answer)");
            }
        }
        if self.waiting.get(&reply.id).is_some_and(|w| w.expected == 0) {
            self.waiting.remove(&reply.id);
        }
    }

    /// `--show`: keeps the shown values of the reply answering message
    /// `index`, and prints them unless a line was printed less than
    /// `--show-every-ms` ago.
    fn take_shown(&mut self, bytes: &[u8], index: usize, id: u32, at: Instant) {
        let Some(show) = &self.show else { return };
        let Some((ts, values)) = show.extract(bytes) else {
            return;
        };
        let every = Duration::from_millis(self.opts.show_every_ms);
        if self
            .shown_at
            .is_none_or(|last| at.duration_since(last) >= every)
        {
            self.shown_at = Some(at);
            let text = show::line(show, id, &values);
            let t = at.duration_since(self.start).as_secs_f64();
            let log = &mut self.log;
            self.bar.suspend(|| {
                let _ = writeln!(log, "[{t:9.3}s] {text}");
            });
        }
        if let Some(c) = self.cycles.get_mut(index) {
            c.shown = Some(Shown { ts, values });
        }
    }
}
