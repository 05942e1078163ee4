//! What a capture holds, before anything is replayed (`--describe`, and the
//! top of every replay's summary): what the controller sent (its Ids, their
//! gaps, repeats and restarts, the datagrams without a readable Id, the
//! longest pause in sending), what came back (each recorded reply paired
//! with the robot message it answers, late ones, replies to nothing), and
//! when. An integrator's first question about a cell, answered without a
//! sensor.
//!
//! Pairing is by Id *and* place: a reply answers the most recent robot
//! message before it with its Id that is not yet answered. Ids repeat in
//! real captures (a robot program restarted mid-capture, S3 duplicates, a
//! capture that sees each packet twice), and pairing by Id alone would
//! give a later message an earlier reply.

use super::conversation::message_id;
use super::conversation::{Conversation, Direction, Message};
use crate::record::Latency;
use crate::wire;
use serde::Serialize;
use std::collections::HashMap;
use std::io::{self, Write};

/// An Id this far behind the newest (16 cycles at 4 ms, or more) is a
/// restart of the controller's numbering (a new run of the robot
/// program), not a late arrival; so is one at or before the run's first.
pub const RESTART_BEHIND: u32 = 16;

/// The recorded reply of each robot message (aligned with the robot
/// messages in capture order): when it came and its bytes.
pub type Paired = Vec<Option<(u64, Vec<u8>)>>;

/// What the controller's Ids say, judged as the device judges them (S3:
/// a wrapping `u32`, newer when less than 2^31 ahead).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct IdStory {
    pub first: Option<u32>,
    pub last: Option<u32>,
    /// Gaps in the sequence, and the Ids they skip (presumed lost, S3).
    pub gaps: u64,
    pub skipped: u64,
    /// The widest gap: Ids skipped and the packet after it.
    pub widest: Option<(u64, usize)>,
    /// The same Id as the newest.
    pub duplicates: u64,
    /// An Id older than the newest (by less than [`RESTART_BEHIND`], and
    /// after the run's first).
    pub reordered: u64,
    /// The numbering started again: the packet of each restart.
    pub restarts: Vec<usize>,
}

/// A capture's conversation, described.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Description {
    pub conversation: String,
    /// The first and last message's time, µs since the Unix epoch.
    pub first_us: u64,
    pub last_us: u64,
    /// Datagrams (or TCP messages) the controller sent.
    pub robot_messages: usize,
    /// Of those, without a readable `Id`: malformed, not lost. The
    /// packet of each (the first 20).
    pub malformed: usize,
    pub malformed_packets: Vec<usize>,
    pub ids: IdStory,
    /// The controller's sending interval, µs: median, p99, max.
    pub interval_us: Latency,
    /// The longest pause in sending: µs and the packet that ended it.
    pub longest_pause: Option<(u64, usize)>,
    /// Messages the device sent, and of those the replies (the reply
    /// property's root).
    pub device_messages: usize,
    pub replies: usize,
    /// Replies paired with a robot message before them.
    pub paired: usize,
    /// Replies with an Id no unanswered robot message before them had.
    pub to_nothing: usize,
    /// Robot messages with an Id and no recorded reply.
    pub unanswered: usize,
    /// Paired replies later than one cycle, and the cycle used (ms).
    pub late: usize,
    pub cycle_ms: u32,
    /// Recorded reply latency of the paired replies, µs.
    pub latency_us: Latency,
}

/// Pairs each robot message in `robot` (capture order) with the recorded
/// reply that answers it (see the module's doc). Returns the pairing and
/// the count of replies that answer nothing.
pub fn pair(conv: &Conversation, robot: &[&Message], reply_root: &str) -> (Paired, usize) {
    let mut paired: Paired = vec![None; robot.len()];
    // Each Id's robot messages seen so far, newest last, by robot index.
    let mut open: HashMap<u32, Vec<usize>> = HashMap::new();
    let mut next_robot = 0;
    let mut to_nothing = 0;
    for m in &conv.messages {
        match m.direction {
            Direction::ToDevice => {
                // `robot` is this conversation's robot messages in order.
                if let Some(id) = robot.get(next_robot).and_then(|r| message_id(&r.payload)) {
                    open.entry(id).or_default().push(next_robot);
                }
                next_robot += 1;
            }
            Direction::ToController => {
                if wire::root_name(&m.payload).as_deref() != Some(reply_root) {
                    continue;
                }
                let Some(id) = message_id(&m.payload) else {
                    to_nothing += 1;
                    continue;
                };
                let slot = open.get_mut(&id).and_then(|list| {
                    let at = list.iter().rposition(|&k| paired[k].is_none())?;
                    Some(list.remove(at))
                });
                match slot {
                    Some(k) => paired[k] = Some((m.at_us, m.payload.clone())),
                    None => to_nothing += 1,
                }
            }
        }
    }
    (paired, to_nothing)
}

impl IdStory {
    /// Judges `ids` (one per robot message with an Id, in order; the
    /// packet beside each).
    pub fn of(ids: impl IntoIterator<Item = (u32, usize)>) -> IdStory {
        let mut s = IdStory::default();
        let mut newest: Option<u32> = None;
        let mut run_first = 0;
        for (id, packet) in ids {
            s.first.get_or_insert(id);
            s.last = Some(id);
            let Some(last) = newest else {
                newest = Some(id);
                run_first = id;
                continue;
            };
            let ahead = id.wrapping_sub(last);
            if ahead == 0 {
                s.duplicates += 1;
            } else if ahead < 1 << 31 {
                newest = Some(id);
                if ahead > 1 {
                    let skipped = u64::from(ahead - 1);
                    s.gaps += 1;
                    s.skipped += skipped;
                    if s.widest.is_none_or(|(w, _)| skipped > w) {
                        s.widest = Some((skipped, packet));
                    }
                }
            } else if last.wrapping_sub(id) < RESTART_BEHIND
                && id.wrapping_sub(run_first) < 1 << 31
                && id != run_first
            {
                s.reordered += 1;
            } else {
                s.restarts.push(packet);
                newest = Some(id);
                run_first = id;
            }
        }
        s
    }
}

impl Description {
    /// Describes `conv`: `reply_root` the reply property's root, `cycle_ms`
    /// the cycle a late reply is judged against.
    pub fn of(conv: &Conversation, reply_root: &str, cycle_ms: u32) -> Description {
        let robot: Vec<&Message> = conv
            .messages
            .iter()
            .filter(|m| m.direction == Direction::ToDevice)
            .collect();
        let pairing = pair(conv, &robot, reply_root);
        Description::of_paired(conv, &robot, &pairing, reply_root, cycle_ms)
    }

    /// [`Description::of`] for a conversation already paired: `robot` its
    /// robot messages in order, `pairing` what [`pair`] made of them.
    pub fn of_paired(
        conv: &Conversation,
        robot: &[&Message],
        pairing: &(Paired, usize),
        reply_root: &str,
        cycle_ms: u32,
    ) -> Description {
        let (paired, to_nothing) = (&pairing.0, pairing.1);
        let ids: Vec<Option<u32>> = robot.iter().map(|m| message_id(&m.payload)).collect();
        let malformed_packets: Vec<usize> = robot
            .iter()
            .zip(&ids)
            .filter(|(_, id)| id.is_none())
            .map(|(m, _)| m.number)
            .collect();
        let mut gaps: Vec<(u64, usize)> = robot
            .windows(2)
            .map(|w| (w[1].at_us.saturating_sub(w[0].at_us), w[1].number))
            .collect();
        let longest_pause = gaps.iter().copied().max_by_key(|(us, _)| *us);
        gaps.sort_unstable();
        let mut latency = Vec::new();
        let mut late = 0;
        for (m, p) in robot.iter().zip(paired) {
            if let Some((at, _)) = p {
                let us = at.saturating_sub(m.at_us);
                late += usize::from(us > u64::from(cycle_ms) * 1000);
                latency.push(us);
            }
        }
        let replies = conv
            .messages
            .iter()
            .filter(|m| {
                m.direction == Direction::ToController
                    && wire::root_name(&m.payload).as_deref() == Some(reply_root)
            })
            .count();
        Description {
            conversation: format!(
                "{} ↔ {} over {}",
                conv.controller,
                conv.device,
                if conv.tcp { "TCP" } else { "UDP" }
            ),
            first_us: conv.messages.first().map_or(0, |m| m.at_us),
            last_us: conv.messages.last().map_or(0, |m| m.at_us),
            robot_messages: robot.len(),
            malformed: malformed_packets.len(),
            malformed_packets: malformed_packets.into_iter().take(20).collect(),
            ids: IdStory::of(
                robot
                    .iter()
                    .zip(&ids)
                    .filter_map(|(m, id)| id.map(|i| (i, m.number))),
            ),
            interval_us: Latency::of(gaps.into_iter().map(|(us, _)| us).collect()),
            longest_pause,
            device_messages: conv.messages.len() - robot.len(),
            replies,
            paired: paired.iter().flatten().count(),
            to_nothing,
            unanswered: ids
                .iter()
                .zip(paired)
                .filter(|(id, p)| id.is_some() && p.is_none())
                .count(),
            late,
            cycle_ms,
            latency_us: Latency::of(latency),
        }
    }

    /// The description's lines.
    pub fn print(&self, out: &mut dyn Write) -> io::Result<()> {
        let span = self.last_us.saturating_sub(self.first_us) as f64 / 1e6;
        writeln!(out, "  the capture: {} ({span:.3} s)", self.conversation)?;
        let i = &self.ids;
        let range = match (i.first, i.last) {
            (Some(a), Some(b)) => format!("Ids {a} to {b}"),
            _ => "no Id".to_string(),
        };
        writeln!(
            out,
            "    the controller sent {} messages: {} with an Id ({range}), {} without a readable Id (malformed, not lost{})",
            self.robot_messages,
            self.robot_messages - self.malformed,
            self.malformed,
            if self.malformed_packets.is_empty() {
                String::new()
            } else {
                format!(
                    "; packets {}",
                    self.malformed_packets
                        .iter()
                        .map(usize::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        )?;
        let widest = i.widest.map_or(String::new(), |(n, p)| {
            format!(" (the widest: {n} before packet {p})")
        });
        let restarts = if i.restarts.is_empty() {
            String::new()
        } else {
            format!(
                ", numbering restarted {} times (packets {})",
                i.restarts.len(),
                i.restarts
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        writeln!(
            out,
            "    its Ids (S3): {} gaps skipping {} Ids{widest}, {} repeated, {} out of order{restarts}",
            i.gaps, i.skipped, i.duplicates, i.reordered
        )?;
        let l = &self.interval_us;
        let pause = self.longest_pause.map_or(String::new(), |(us, p)| {
            format!("; the longest pause {us} us, ended by packet {p}")
        });
        writeln!(
            out,
            "    its sending interval us: median {}  p99 {}  max {}{pause}",
            l.median, l.p99, l.max
        )?;
        writeln!(
            out,
            "    the device sent {} messages, {} of them replies: {} answer a robot message, {} answer none; {} robot messages with an Id got no reply",
            self.device_messages, self.replies, self.paired, self.to_nothing, self.unanswered
        )?;
        let r = &self.latency_us;
        writeln!(
            out,
            "    recorded reply latency us: median {}  p99 {}  max {}; later than one {} ms cycle: {}",
            r.median, r.p99, r.max, self.cycle_ms, self.late
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::SocketAddrV4;

    fn msg(number: usize, at_us: u64, to_device: bool, payload: String) -> Message {
        Message {
            number,
            at_us,
            direction: if to_device {
                Direction::ToDevice
            } else {
                Direction::ToController
            },
            payload: payload.into_bytes(),
        }
    }

    fn conv(messages: Vec<Message>) -> Conversation {
        Conversation {
            controller: [10, 0, 0, 1].into(),
            device: SocketAddrV4::new([10, 0, 0, 2].into(), 3002),
            tcp: false,
            messages,
            untimed: None,
        }
    }

    /// Two 3-message runs of the robot program in one capture, each
    /// message answered 300 µs later.
    fn two_runs() -> Conversation {
        let mut m = Vec::new();
        for (k, id) in [1, 2, 3, 1, 2, 3].into_iter().enumerate() {
            let at = k as u64 * 4_000;
            m.push(msg(2 * k + 1, at, true, format!("<RobData Id=\"{id}\"/>")));
            m.push(msg(
                2 * k + 2,
                at + 300 + k as u64,
                false,
                format!("<SensData Id=\"{id}\"/>"),
            ));
        }
        conv(m)
    }

    #[test]
    fn repeated_ids_pair_each_message_with_its_own_reply() {
        let c = two_runs();
        let robot: Vec<&Message> = c
            .messages
            .iter()
            .filter(|m| m.direction == Direction::ToDevice)
            .collect();
        let (p, nothing) = pair(&c, &robot, "SensData");
        assert_eq!(nothing, 0);
        // Each reply came 300 + k µs after its message: pairing by Id
        // alone gave the second run the first run's replies (latency 0).
        for (k, (m, r)) in robot.iter().zip(&p).enumerate() {
            let (at, _) = r.as_ref().expect("answered");
            assert_eq!(at - m.at_us, 300 + k as u64, "message {k}");
        }
        let d = Description::of(&c, "SensData", 4);
        assert_eq!((d.replies, d.paired, d.unanswered), (6, 6, 0));
        assert_eq!(d.ids.restarts, vec![7]);
        assert_eq!((d.ids.gaps, d.ids.reordered), (0, 0));
    }

    #[test]
    fn garbage_gaps_pauses_and_late_replies_are_described() {
        let mut m = vec![
            msg(1, 0, true, "<RobData Id=\"1\"/>".into()),
            msg(2, 300, false, "<SensData Id=\"1\"/>".into()),
            msg(3, 4_000, true, "garbage".into()),
            msg(4, 8_000, true, "<RobData Id=\"5\"/>".into()),
            // Late: 6 ms after its message.
            msg(5, 14_000, false, "<SensData Id=\"5\"/>".into()),
            // 124 ms pause.
            msg(6, 132_000, true, "<RobData Id=\"6\"/>".into()),
            msg(7, 132_200, false, "<SensData Id=\"99\"/>".into()),
            msg(8, 136_000, true, "<RobData Id=\"6\"/>".into()),
            msg(9, 140_000, true, "<RobData Id=\"4\"/>".into()),
        ];
        m.push(msg(10, 140_100, false, "<Other Id=\"4\"/>".into()));
        let d = Description::of(&conv(m), "SensData", 4);
        assert_eq!((d.robot_messages, d.malformed), (6, 1));
        assert_eq!(d.malformed_packets, vec![3]);
        assert_eq!((d.ids.gaps, d.ids.skipped), (1, 3));
        assert_eq!(d.ids.widest, Some((3, 4)));
        assert_eq!((d.ids.duplicates, d.ids.reordered), (1, 1));
        assert_eq!(d.longest_pause, Some((124_000, 6)));
        assert_eq!((d.device_messages, d.replies), (4, 3));
        assert_eq!((d.paired, d.to_nothing, d.unanswered, d.late), (2, 1, 3, 1));
        let mut text = Vec::new();
        d.print(&mut text).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(
            text.contains("1 without a readable Id (malformed, not lost; packets 3)"),
            "{text}"
        );
        assert!(text.contains("1 gaps skipping 3 Ids"), "{text}");
        assert!(
            text.contains("longest pause 124000 us, ended by packet 6"),
            "{text}"
        );
    }

    #[test]
    fn ids_that_wrap_are_in_order() {
        let s = IdStory::of([(u32::MAX - 1, 1), (u32::MAX, 2), (0, 3), (2, 4)]);
        assert_eq!((s.gaps, s.skipped, s.reordered), (1, 1, 0));
        assert!(s.restarts.is_empty());
    }
}
