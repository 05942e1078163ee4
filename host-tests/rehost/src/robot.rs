//! The robot controller in the machine's own virtual time, for
//! deterministic runs (`--robot N`): every 4 ms of virtual time the next
//! message of the GSI folder's first robot property (built by the robot
//! simulator's own `wire::robot_message`, values from its `Motion`), over
//! the bridge as UDP or M10-framed TCP; every reply checked with the
//! simulator's `wire::check_reply`. A reply is late when the next message
//! is due before it arrives (more than one cycle), lost when its message is
//! still unanswered at the end; no wall clock anywhere, so two runs of
//! the same image give the same figures.

use crate::bridge::Bridge;
use gsi_config::{Device, Property};
use std::collections::BTreeMap;

/// The controller's cycle (RRI's 4 ms).
pub const CYCLE_NS: u128 = 4_000_000;

pub struct Robot {
    device: Device,
    send: usize,
    reply: usize,
    port: u16,
    tcp: bool,
    cycles: u64,
    next_id: u32,
    next_at: u128,
    /// Messages waiting for their reply: Id -> sent at (ns).
    waiting: BTreeMap<u32, u128>,
    framer: rri_framing::Framer<8192>,
    pub sent: u64,
    pub answered: u64,
    pub late: u64,
    pub wrong: u64,
    pub first_error: Option<String>,
    /// Latencies in ns of virtual time (the bridge's poll granularity:
    /// one slice).
    pub latencies: Vec<u128>,
}

impl Robot {
    /// A run of `cycles` messages to `device`'s channel port, starting
    /// at virtual time `start_ns`.
    pub fn new(device: Device, cycles: u64, start_ns: u128) -> Result<Robot, String> {
        let send = position(&device, true)?;
        let reply = position(&device, false)?;
        let port = device.channel.port;
        let tcp = device.channel.protocol == gsi_config::Protocol::Tcp;
        Ok(Robot {
            device,
            send,
            reply,
            port,
            tcp,
            cycles,
            next_id: 1,
            next_at: start_ns,
            waiting: BTreeMap::new(),
            framer: rri_framing::Framer::new(),
            sent: 0,
            answered: 0,
            late: 0,
            wrong: 0,
            first_error: None,
            latencies: Vec::new(),
        })
    }

    fn prop(&self, i: usize) -> &Property {
        &self.device.properties[i]
    }

    /// Whether every message has been sent and the last cycle is over.
    pub fn done(&self, now_ns: u128) -> bool {
        self.sent >= self.cycles && now_ns >= self.next_at
    }

    /// The robot's turn at virtual time `now_ns`: replies taken, the next
    /// message sent when it is due.
    pub fn step(&mut self, bridge: &mut Bridge, now_ns: u128) -> Result<(), String> {
        if self.tcp && self.sent == 0 && !bridge.tcp_ready() {
            if bridge.tcp_received.is_empty() && !self.waiting.contains_key(&0) {
                bridge.open_tcp(self.port)?;
                self.waiting.insert(0, 0);
            }
            // Not connected yet: the first message waits.
            self.next_at = self.next_at.max(now_ns);
            return Ok(());
        }
        self.waiting.remove(&0);
        let mut replies: Vec<Vec<u8>> = bridge.replies.drain(..).collect();
        if self.tcp {
            let bytes = std::mem::take(&mut bridge.tcp_received);
            let mut framed = Vec::new();
            self.framer
                .push(&bytes, |m| framed.push(m.to_vec()))
                .map_err(|e| format!("robot: the device's TCP stream: {e}"))?;
            replies.extend(framed);
        }
        for r in replies {
            let prop = self.prop(self.reply);
            match rri_robot::wire::check_reply(&self.device, prop, &r) {
                Ok(reply) => match self.waiting.remove(&reply.id) {
                    Some(at) => {
                        self.answered += 1;
                        let latency = now_ns.saturating_sub(at);
                        if latency > CYCLE_NS {
                            self.late += 1;
                        }
                        self.latencies.push(latency);
                    }
                    None => self.note(format!(
                        "a reply with Id {} that no waiting message has",
                        reply.id
                    )),
                },
                Err(e) => self.note(format!(
                    "a reply that fails its check: {e}: {}",
                    String::from_utf8_lossy(&r)
                )),
            }
        }
        if self.sent < self.cycles && now_ns >= self.next_at {
            let id = self.next_id;
            let t = self.sent as f64 * 0.004;
            let motion = rri_robot::motion::Motion::new(&self.device);
            let msg =
                rri_robot::wire::robot_message(&self.device, self.prop(self.send), id, t, |f| {
                    motion.value(f, id as u64, t)
                });
            if self.tcp {
                bridge.send_tcp(msg.as_bytes());
            } else {
                bridge.send_udp(msg.as_bytes(), self.port);
            }
            self.waiting.insert(id, now_ns);
            self.sent += 1;
            self.next_id += 1;
            self.next_at += CYCLE_NS;
        }
        Ok(())
    }

    fn note(&mut self, what: String) {
        self.wrong += 1;
        if self.first_error.is_none() {
            self.first_error = Some(what);
        }
    }

    /// Messages never answered.
    pub fn lost(&self) -> u64 {
        self.sent - self.answered
    }

    /// One line: the run's counts and latencies (virtual time).
    pub fn summary(&self) -> String {
        let mut l = self.latencies.clone();
        l.sort_unstable();
        let at = |q: f64| {
            l.get(((l.len() as f64 - 1.0) * q) as usize)
                .copied()
                .unwrap_or(0)
                / 1000
        };
        format!(
            "robot (virtual time, {}): sent {} answered {} late {} lost {} wrong {}; latency us (at the bridge's 50 us polls) min {} median {} max {}",
            if self.tcp { "TCP" } else { "UDP" },
            self.sent,
            self.answered,
            self.late,
            self.lost(),
            self.wrong,
            at(0.0),
            at(0.5),
            at(1.0)
        )
    }
}

/// The first property the controller sends (`robot_sends`), or the first
/// the device sends.
pub(crate) fn position(device: &Device, robot_sends: bool) -> Result<usize, String> {
    let wanted: Vec<&Property> = if robot_sends {
        device.received().collect()
    } else {
        device.sent().collect()
    };
    let first = wanted.first().ok_or_else(|| {
        format!(
            "the GSI folder has no property the {} sends",
            if robot_sends { "controller" } else { "device" }
        )
    })?;
    device
        .properties
        .iter()
        .position(|p| std::ptr::eq(p, *first))
        .ok_or_else(|| "property not found".to_string())
}
