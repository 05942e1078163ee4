//! `--replay FILE`: a capture from a cell replayed against any sensor,
//! closed-loop. The controller's side of the conversation (its robot
//! messages, Ids and payloads as recorded) goes to the sensor at the
//! recorded times (or `--every MS`, or `--as-fast`: each once the last is
//! answered), the controller's supervision (S1, from the GSI folder)
//! judges the replies as it judges any run, and each reply is compared
//! with the one the recorded sensor sent ([`compare`]): Id, fields,
//! values within a tolerance, and latency, recorded beside replayed.
//!
//! `--extract DIR` turns the same conversation into a corpus: one file per
//! robot message, for `cargo qemu-bench -- --corpus DIR` and the fuzz
//! targets.

pub mod capture;
pub mod compare;
pub mod conversation;
pub mod describe;
mod options;
pub mod report;
mod tcp;

pub use conversation::message_id;
pub use options::{Pace, ReplayOptions};
pub use report::{Outcome, ReplayReport};

use crate::link::Link;
use crate::record::{Cycle, Injected};
use crate::report::Summary;
use crate::sim::{Sim, Waiting};
use crate::{wire, RobotOptions};
use conversation::{Conversation, Direction};
use describe::Description;
use gsi_config::{Device, Property};
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

/// The conversation `opts` names in its file, for `device`.
pub fn load(r: &ReplayOptions, device: &Device) -> Result<Conversation, String> {
    let capture = capture::read(&r.file)?;
    conversation::find(&capture, device.channel.port, r.conversation)
        .map_err(|e| format!("{}: {e}", r.file.display()))
}

/// `--describe`: what the capture's conversation holds, with no sensor
/// ([`describe`]); `reply` the property the device answers with.
pub fn describe_file(
    r: &ReplayOptions,
    device: &Device,
    reply: &Property,
) -> Result<Description, String> {
    let conv = load(r, device)?;
    Ok(Description::of(
        &conv,
        reply.wire(),
        tick_ms(&conv, Pace::Recorded),
    ))
}

/// `--extract DIR`: every robot message of the conversation as a file,
/// `PACKET-ROOT-ID.xml`, in capture order. Returns how many.
pub fn extract(conv: &Conversation, dir: &Path) -> Result<usize, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("--extract {}: {e}", dir.display()))?;
    let mut n = 0;
    for m in conv
        .messages
        .iter()
        .filter(|m| m.direction == Direction::ToDevice)
    {
        let root = wire::root_name(&m.payload).unwrap_or_else(|| "unreadable".into());
        let id = message_id(&m.payload).map_or("noid".to_string(), |i| i.to_string());
        let safe: String = root
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        let path = dir.join(format!("{:06}-{safe}-{id}.xml", m.number));
        std::fs::write(&path, &m.payload).map_err(|e| format!("{}: {e}", path.display()))?;
        n += 1;
    }
    Ok(n)
}

/// The cycle the replay's lateness is judged against: the recorded
/// messages' median interval (rounded to the controller's 4 ms), or
/// `--every`.
fn tick_ms(conv: &Conversation, pace: Pace) -> u32 {
    if let Pace::Every(ms) = pace {
        return ms;
    }
    let mut gaps: Vec<u64> = conv
        .messages
        .iter()
        .filter(|m| m.direction == Direction::ToDevice)
        .map(|m| m.at_us)
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| w[1].saturating_sub(w[0]))
        .collect();
    gaps.sort_unstable();
    let median_ms = gaps.get(gaps.len() / 2).map_or(4, |us| us / 1000);
    ((median_ms as u32 + 2) / 4 * 4).max(4)
}

/// Replays the conversation of `r.file` against `opts.to` (over the
/// transport the conversation used) and compares every reply.
pub fn run(
    opts: &RobotOptions,
    r: &ReplayOptions,
    device: &Device,
    reply: &Property,
    log: &mut dyn Write,
) -> Result<(Summary, Vec<Cycle>), String> {
    let conv = load(r, device)?;
    let robot: Vec<&conversation::Message> = conv
        .messages
        .iter()
        .filter(|m| m.direction == Direction::ToDevice)
        .collect();
    let first_us = robot.first().map(|m| m.at_us).ok_or_else(|| {
        format!(
            "{}: the conversation {} ↔ {} holds no robot message",
            r.file.display(),
            conv.controller,
            conv.device
        )
    })?;
    if let (Pace::Recorded, Some((first, n))) = (r.pace, conv.untimed) {
        return Err(format!(
            "{}: {n} messages of the conversation have no timestamp (pcapng simple packet blocks; the first: packet {first}), so they cannot be sent at the recorded times: replay with --every MS or --as-fast",
            r.file.display()
        ));
    }
    let sent_property = robot_property(device, &robot).ok_or(
        "the configuration has no property the controller sends (Flag WriteOnly or ReadWrite)",
    )?;
    let pairing = describe::pair(&conv, &robot, reply.wire());
    let tick = tick_ms(&conv, r.pace);
    let description = Description::of_paired(&conv, &robot, &pairing, reply.wire(), tick);
    let recorded = pairing.0;
    let mut opts = opts.clone();
    opts.tcp = conv.tcp;
    opts.cycles = robot.len() as u64;
    opts.pacing = r.pace != Pace::AsFast;
    opts.rate_ms = tick;
    let link = if conv.tcp {
        Link::tcp(opts.to).map_err(|e| format!("cannot connect to {} over TCP: {e}", opts.to))?
    } else {
        Link::udp(opts.to, false).map_err(|e| format!("cannot open a UDP socket: {e}"))?
    };
    let _ = writeln!(
        log,
        "replaying {} of {} ({} ↔ {} over {}: {} robot messages with an Id, {} without (malformed: sent as recorded, no reply expected), {} recorded replies) to {}",
        if conv.tcp { "the TCP messages" } else { "the datagrams" },
        r.file.display(),
        conv.controller,
        conv.device,
        if conv.tcp { "TCP" } else { "UDP" },
        robot.len() - description.malformed,
        description.malformed,
        description.replies,
        opts.to
    );
    let mut sim = Sim::new(&opts, device, reply, link, tick, log);
    sim.replies = Some(HashMap::new());
    sim.transition(&format!(
        "CONNECTED to {} ({}, the capture's {} messages, DryRun={}, TimeOut={} ms, MaxLost={})",
        device.name,
        opts.to,
        robot.len(),
        device.supervision.dry_run,
        device.supervision.timeout_ms,
        device.supervision.max_lost
    ));
    let tick_d = Duration::from_millis(u64::from(tick));
    let mut previous: Vec<u32> = Vec::new();
    let mut sent_ids: Vec<Option<u32>> = Vec::with_capacity(robot.len());
    // The simulator's record of each robot message with an Id (a datagram
    // without one expects no reply: it is not a cycle, and not lost).
    let mut cycle_of: Vec<Option<usize>> = Vec::with_capacity(robot.len());
    for (k, m) in robot.iter().enumerate() {
        let due = match r.pace {
            Pace::Recorded => sim.start + Duration::from_micros(m.at_us.saturating_sub(first_us)),
            Pace::Every(ms) => sim.start + Duration::from_millis(u64::from(ms) * k as u64),
            Pace::AsFast => Instant::now(),
        };
        sim.pump(due, None);
        sim.judge_previous(&mut previous);
        let id = message_id(&m.payload);
        let now = Instant::now();
        let index = sim.cycles.len();
        cycle_of.push(id.map(|_| index));
        if let Some(id) = id {
            sim.cycles.push(Cycle {
                cycle: k as u64,
                id,
                sent_us: sim.us(now),
                reply_us: None,
                dropped_by_fault: false,
                property: 0,
                shown: None,
            });
            sim.waiting.insert(
                id,
                Waiting {
                    index,
                    sent: now,
                    expected: 1,
                    answered: false,
                },
            );
            previous.push(id);
            sim.s.sent += 1;
        }
        sent_ids.push(id);
        sim.send(&m.payload, false)?;
        if r.pace == Pace::AsFast {
            if let Some(id) = id {
                sim.pump(now + Duration::from_millis(200).max(tick_d), Some(id));
            }
        }
        if k % 50 == 0 {
            sim.show_progress(k as u64);
        }
    }
    sim.collect_last(tick_d);
    let replayed = sim.replies.take().unwrap_or_default();
    let (mut s, cycles, _) = sim.finish(&[(sent_property, tick)]);
    s.as_recorded = Injected {
        dropped: description.ids.skipped,
        garbage: description.malformed as u64,
        ..Injected::default()
    };
    let run = report::Run {
        ids: &sent_ids,
        cycle_of: &cycle_of,
        cycles: &cycles,
        recorded: &recorded,
        replayed: &replayed,
    };
    let report = report::build(&conv, &robot, &run, description, r);
    if let Some(p) = &r.diff_csv {
        if let Err(e) = report.write_csv(p) {
            s.output_errors.push(format!("--diff {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.plot {
        if let Err(e) = report.write_plot(p) {
            s.output_errors.push(format!("--plot {}: {e}", p.display()));
        }
    }
    s.replay = Some(report);
    Ok((s, cycles))
}

/// The robot property most of the replayed messages carry (for the
/// summary's per-property line).
fn robot_property<'d>(
    device: &'d Device,
    robot: &[&conversation::Message],
) -> Option<&'d Property> {
    let mut count: HashMap<String, usize> = HashMap::new();
    for m in robot {
        if let Some(r) = wire::root_name(&m.payload) {
            *count.entry(r).or_default() += 1;
        }
    }
    device
        .received()
        .max_by_key(|p| count.get(p.wire()).copied().unwrap_or(0))
}
