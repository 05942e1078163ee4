//! The controller's side of the stream: which robot message goes out when,
//! with which Id (one sequence over every property, M11), and what the
//! injected faults do to it (drop, duplicate, reorder, pause, garbage,
//! oversize, second port).

use crate::fault::Faults;
use crate::motion::Motion;
use crate::record::Cycle;
use crate::sim::{Sim, Waiting};
use crate::wire;
use gsi_config::{Device, Property};
use std::time::{Duration, Instant};

/// What the sending side keeps between messages.
pub(crate) struct Stream<'d> {
    device: &'d Device,
    motion: Motion<'d>,
    faults: Faults,
    /// A message held back by the reorder fault: (Id, text, second port).
    held: Option<(u32, String, bool)>,
    /// Ids of the last tick's messages, oldest first (judged at the next
    /// tick, S1).
    pub(crate) previous: Vec<u32>,
    /// Messages sent so far: the next Id and the fault plan's index.
    sent: u64,
    /// When the next tick is due (paced runs).
    pub(crate) schedule: Instant,
}

impl<'d> Stream<'d> {
    pub(crate) fn new(device: &'d Device, faults: Faults, start: Instant) -> Self {
        Stream {
            device,
            motion: Motion::new(device),
            faults,
            held: None,
            previous: Vec::new(),
            sent: 0,
            schedule: start,
        }
    }

    /// Sends robot property `prop` (the `which`-th of the `--send` list)
    /// for cycle `c`, planned at `planned`, with whatever faults the plan
    /// gives this message.
    pub(crate) fn send(
        &mut self,
        sim: &mut Sim<'_>,
        c: u64,
        which: usize,
        prop: &Property,
        planned: Instant,
        tick: Duration,
    ) -> Result<(), String> {
        let plan = self.faults.plan(self.sent);
        if plan.pause_ms > 0 {
            sim.s.injected.pauses += 1;
            sim.transition(&format!("pausing {} ms (fault)", plan.pause_ms));
            let resume = Instant::now() + Duration::from_millis(plan.pause_ms);
            sim.pump(resume, None);
            self.schedule = Instant::now() + tick;
        }
        let id = sim.opts.first_id.wrapping_add(self.sent as u32);
        self.sent += 1;
        let t = sim.start.elapsed().as_secs_f64();
        let motion = &self.motion;
        let msg = wire::robot_message(self.device, prop, id, Motion::now(t), |f| {
            motion.value(f, c, t)
        });
        let now = Instant::now();
        if sim.opts.pacing && plan.pause_ms == 0 {
            let lag = now.saturating_duration_since(planned).as_micros() as u64;
            sim.s.send_lag_max_us = sim.s.send_lag_max_us.max(lag);
        }
        let index = sim.cycles.len();
        sim.cycles.push(Cycle {
            cycle: c,
            id,
            sent_us: sim.us(now),
            reply_us: None,
            dropped_by_fault: plan.drop,
            property: which,
            shown: None,
        });
        if plan.drop {
            sim.s.injected.dropped += 1;
            return Ok(());
        }
        let inj = &mut sim.s.injected;
        inj.duplicated += u64::from(plan.duplicate);
        inj.garbage += u64::from(plan.garbage);
        inj.oversize += u64::from(plan.oversize);
        inj.second_port += u64::from(plan.second_port);
        sim.waiting.insert(
            id,
            Waiting {
                index,
                sent: now,
                expected: if plan.duplicate { 2 } else { 1 },
                answered: false,
            },
        );
        sim.s.sent += 1;
        self.previous.push(id);
        if plan.reorder && self.held.is_none() {
            sim.s.injected.reordered += 1;
            self.held = Some((id, msg, plan.second_port));
        } else {
            sim.send(msg.as_bytes(), plan.second_port)?;
            if plan.duplicate {
                sim.send(msg.as_bytes(), plan.second_port)?;
            }
            if let Some((held_id, m, second)) = self.held.take() {
                // Latency and lateness count from the actual send.
                let now = Instant::now();
                let at_us = sim.us(now);
                if let Some(w) = sim.waiting.get_mut(&held_id) {
                    w.sent = now;
                    if let Some(c) = sim.cycles.get_mut(w.index) {
                        c.sent_us = at_us;
                    }
                }
                sim.send(m.as_bytes(), second)?;
            }
        }
        if plan.garbage {
            sim.send(b"\x01\x02<<garbage>>&&", plan.second_port)?;
        }
        if plan.oversize {
            let big = format!(
                "<{} Id=\"{id}\">{}</{}>",
                prop.wire(),
                " ".repeat(9000),
                prop.wire()
            );
            sim.send(big.as_bytes(), plan.second_port)?;
        }
        if !sim.opts.pacing && self.held.is_none() {
            sim.pump(
                Instant::now() + Duration::from_millis(200).max(tick),
                Some(id),
            );
        }
        Ok(())
    }

    /// Sends a message still held back by the reorder fault at the end.
    pub(crate) fn release_held(&mut self, sim: &mut Sim<'_>) -> Result<(), String> {
        match self.held.take() {
            Some((_, m, second)) => sim.send(m.as_bytes(), second),
            None => Ok(()),
        }
    }
}
