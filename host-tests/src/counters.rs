//! The device's own counters as its log shows them once a second, for the
//! QEMU runs that check them (`cargo soak`, `cargo flood`,
//! `cargo qemu-bench`).

use crate::qemu::Qemu;
use std::time::Duration;

/// The device's counters, from its once-a-second `counters:` log line:
/// the engine's, the fragment guard's (S5) and the network chip's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceCounters {
    pub received: u64,
    pub answered: u64,
    pub foreign: u64,
    pub invalid: u64,
    pub throttled: u64,
    pub decode: u64,
    /// The engine's reply latency (message in to reply ready), µs: the
    /// longest and the mean. The page and `/metrics` show the driver's
    /// (frame to frame), which also holds the network's own time.
    pub latency_max_us: u64,
    pub latency_mean_us: u64,
    pub fragments: Fragments,
    /// The network chip's receive counters; `None` where the board does
    /// not read them (`nic n/a`).
    pub nic: Option<Nic>,
}

/// The fragment guard's counters (`rri_firmware::fragments::FragmentStats`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fragments {
    pub fragments: u64,
    pub reassembled: u64,
    pub oversize: u64,
    pub unwanted: u64,
    pub malformed: u64,
    pub no_buffer: u64,
    pub duplicate: u64,
    pub timed_out: u64,
    pub evicted: u64,
    pub spoiled: u64,
    /// The controller's datagrams handed to the stack whole.
    pub controller_in: u64,
    /// The controller's sets given up incomplete (timed out or superseded:
    /// a fragment never came).
    pub controller_incomplete: u64,
    /// The controller's sets lost in reassembly itself.
    pub controller_dropped: u64,
}

/// The network chip's receive counters (`hal_board::NicCounters`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Nic {
    pub rx_frames: u64,
    pub rx_dropped: u64,
    pub status_full: u64,
    pub fifo_max: u64,
}

impl DeviceCounters {
    /// `[…] counters: messages: received R answered A | dropped: foreign F
    /// invalid_source I throttled T decode D | … | engine latency (…) us:
    /// max M mean N | fragments: … | controller: in C … | nic read:
    /// rx_frames X …` (`firmware/rri-sensor/src/housekeeping.rs`): groups
    /// of `family: key value …`, named as on the page and in `/metrics`.
    pub fn parse(line: &str) -> Option<DeviceCounters> {
        let (_, rest) = line.split_once("] counters: ")?;
        let groups = CounterLine::of(rest);
        let get = |family: &str, key: &str| groups.get(family, key);
        let nic = match groups.head("nic")? {
            "nic read" => Some(Nic {
                rx_frames: get("nic", "rx_frames")?,
                rx_dropped: get("nic", "rx_dropped")?,
                status_full: get("nic", "status_full")?,
                fifo_max: get("nic", "fifo_max")?,
            }),
            _ => None,
        };
        let f = |key: &str| get("fragments", key);
        Some(DeviceCounters {
            received: get("messages", "received")?,
            answered: get("messages", "answered")?,
            foreign: get("dropped", "foreign")?,
            invalid: get("dropped", "invalid_source")?,
            throttled: get("dropped", "throttled")?,
            decode: get("dropped", "decode")?,
            latency_max_us: get("engine", "max")?,
            latency_mean_us: get("engine", "mean")?,
            fragments: Fragments {
                fragments: f("fragments")?,
                reassembled: f("reassembled")?,
                oversize: f("oversize")?,
                unwanted: f("unwanted")?,
                malformed: f("malformed")?,
                no_buffer: f("no_buffer")?,
                duplicate: f("duplicate")?,
                timed_out: f("timed_out")?,
                evicted: f("evicted")?,
                spoiled: f("spoiled")?,
                controller_in: get("controller", "in")?,
                controller_incomplete: get("controller", "incomplete")?,
                controller_dropped: get("controller", "dropped")?,
            },
            nic,
        })
    }

    /// Every message received was answered or dropped for a counted reason.
    pub fn add_up(&self) -> bool {
        self.received == self.answered + self.foreign + self.invalid + self.throttled + self.decode
    }

    /// Waits (up to `timeout`) for a counter line logged after line
    /// `start` and returns the last one.
    pub fn fresh(board: &Qemu, start: usize, timeout: Duration) -> Result<DeviceCounters, String> {
        let end = std::time::Instant::now() + timeout;
        loop {
            if let Some(c) = board.since(start).iter().rev().find_map(|l| Self::parse(l)) {
                return Ok(c);
            }
            if std::time::Instant::now() > end {
                let tail = board.since(start.saturating_sub(5));
                return Err(format!(
                    "no counter line from the device within {timeout:?}; its last lines:\n{}",
                    tail.join("\n")
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// A counter line split into its groups: `family: key value key value`
/// between ` | ` (a group's head may say more after its family's name:
/// `nic read`, `engine latency (…) us`).
pub struct CounterLine<'a> {
    groups: Vec<(&'a str, Vec<(&'a str, &'a str)>)>,
}

impl<'a> CounterLine<'a> {
    /// The groups of `text` (the line after `counters: `).
    pub fn of(text: &'a str) -> CounterLine<'a> {
        let groups = text
            .split(" | ")
            .filter_map(|g| {
                let (head, body) = g.trim().split_once(':')?;
                let words: Vec<&str> = body.split_whitespace().collect();
                let pairs = words
                    .chunks(2)
                    .filter_map(|p| Some((*p.first()?, *p.get(1)?)));
                Some((head, pairs.collect()))
            })
            .collect();
        CounterLine { groups }
    }

    /// The whole head of the group of `family` (its first word).
    pub fn head(&self, family: &str) -> Option<&'a str> {
        self.group(family).map(|(h, _)| *h)
    }

    /// `key`'s value in the group of `family`.
    pub fn get(&self, family: &str, key: &str) -> Option<u64> {
        let (_, pairs) = self.group(family)?;
        pairs.iter().find(|(k, _)| *k == key)?.1.parse().ok()
    }

    /// The group whose head starts with `family`.
    fn group(&self, family: &str) -> Option<&(&'a str, Vec<(&'a str, &'a str)>)> {
        self.groups
            .iter()
            .find(|(h, _)| h.split_whitespace().next() == Some(family))
    }

    /// Every `(family, key)` in the line's order.
    pub fn keys(&self) -> Vec<(&'a str, &'a str)> {
        self.groups
            .iter()
            .flat_map(|(h, pairs)| {
                let family = h.split_whitespace().next().unwrap_or("");
                pairs.iter().map(move |(k, _)| (family, *k))
            })
            .collect()
    }
}

/// Where a run's lost robot messages went, from the robot's figures and
/// the device's counters (a flood run's losses, split): robot messages
/// the device never got whole (in the emulated NIC or before it, a
/// fragment of them included), those lost in reassembly itself, those
/// that reached the stack whole but were not answered (the UDP socket's
/// queue or the engine), and answers that never reached the robot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LossSplit {
    pub sent: u64,
    pub answered: u64,
    /// Never reached the firmware whole: sent − reached the stack −
    /// dropped in reassembly.
    pub nic: u64,
    /// The controller's sets the fragment guard dropped (spoiled or
    /// refused a buffer).
    pub reassembly: u64,
    /// Reached the stack whole, not answered: the socket's queue or the
    /// engine.
    pub engine: u64,
    /// Answered by the device, never seen by the robot.
    pub way_back: u64,
}

impl LossSplit {
    /// `sent` and `answered` as the robot counted them, the device's
    /// counters at the end of the run (every robot message counted since
    /// boot: nothing else may talk to the device as the controller first).
    pub fn of(sent: u64, answered: u64, d: &DeviceCounters) -> LossSplit {
        // A robot message the engine answered reached it, though the guard
        // counts a controller's datagram only once the cycle has told it
        // the controller's port: the first from a new port (a controller
        // that reconnected) is answered without counting in `controller: in`.
        let reached = d.fragments.controller_in.max(d.answered);
        let reassembly = d.fragments.controller_dropped;
        LossSplit {
            sent,
            answered,
            nic: sent.saturating_sub(reached + reassembly),
            reassembly,
            engine: reached.saturating_sub(d.answered),
            way_back: d.answered.saturating_sub(answered),
        }
    }

    /// [`LossSplit::of`] for a run after a warm-up (`warm`: what it sent,
    /// and what the robot saw answered) in which the simulator sent
    /// `unanswerable` datagrams on purpose (garbage, which the decoder
    /// rejects; duplicates, which the engine drops): the device counts
    /// since boot and counts those as reaching it, so both come off its
    /// counters. Without this a host stall (messages lost before the
    /// device) showed as the engine's loss, and was not tried again.
    pub fn of_counted_run(
        (sent, answered): (u64, u64),
        warm: (u64, u64),
        unanswerable: u64,
        mut d: DeviceCounters,
    ) -> LossSplit {
        d.fragments.controller_in = d
            .fragments
            .controller_in
            .saturating_sub(warm.0 + unanswerable);
        d.answered = d.answered.saturating_sub(warm.1);
        LossSplit::of(sent, answered, &d)
    }

    /// Whether a run of the robot simulator (`summary`, after `warm`) lost
    /// messages only before the firmware had them, by the device's last
    /// counter line in `log`, and nothing else went wrong (no wrong or
    /// malformed reply, every output written): what a stall of the host
    /// running the emulated board in real time looks like (QEMU's user
    /// networking drops what it cannot deliver in time). `cargo demo`
    /// exits 3 for it, as for lateness alone, and CI tries again.
    pub fn lost_before_firmware(
        summary: &crate::robot::report::Summary,
        warm: (u64, u64),
        log: &[String],
    ) -> bool {
        let Some(d) = log.iter().rev().find_map(|l| DeviceCounters::parse(l)) else {
            return false;
        };
        let i = &summary.injected;
        let split = LossSplit::of_counted_run(
            (summary.sent, summary.answered),
            warm,
            i.garbage + i.duplicated,
            d,
        );
        summary.wrong_id == 0
            && summary.malformed == 0
            && summary.output_errors.is_empty()
            && split.lost() == split.nic
    }

    /// Lost, as the robot saw it.
    pub fn lost(&self) -> u64 {
        self.sent - self.answered.min(self.sent)
    }

    /// The parts account for every loss.
    pub fn adds_up(&self) -> bool {
        self.nic + self.reassembly + self.engine + self.way_back == self.lost()
    }

    /// `lost L: emulated NIC N, reassembly R, engine E, way back W`.
    pub fn line(&self) -> String {
        format!(
            "lost {}: never reached the firmware whole (emulated NIC and before) {}, reassembly {}, engine (socket queue or engine) {}, answers lost on the way back {}{}",
            self.lost(),
            self.nic,
            self.reassembly,
            self.engine,
            self.way_back,
            if self.adds_up() { "" } else { " (DOES NOT ADD UP)" }
        )
    }
}

#[cfg(test)]
mod counter_tests {
    use super::*;

    /// Issue 42 #8: the device's log names every counter as the page,
    /// `/status.json` and `/metrics` do (`rri_diag::counters::FAMILIES`,
    /// which says what each counts). Read from the firmware's source: the
    /// line as the boards log it, its values filled in.
    #[test]
    fn the_log_names_every_counter_as_the_page_and_metrics_do() {
        let src = include_str!("../../firmware/rri-sensor/src/housekeeping.rs");
        let start = src.find("\"counters: ").expect("the counter line's format") + 1;
        let len = src[start..].find('"').expect("its end");
        let format = &src[start..start + len];
        let line = format!(
            "[ 1.0 INFO ] {}",
            format.replace("{=str}", "read").replace("{}", "7")
        );
        let groups = CounterLine::of(line.split_once("counters: ").expect("prefix").1);
        let keys = groups.keys();
        assert!(keys.len() > 30, "{keys:?}");
        for (family, key) in keys {
            let known = match family {
                "engine" => ["max", "mean"].contains(&key),
                "nic" => ["rx_frames", "rx_dropped", "status_full", "fifo_max"].contains(&key),
                _ => rri_diag::counters::FAMILIES
                    .iter()
                    .any(|f| f.key == family && f.members.iter().any(|m| m.key == key)),
            };
            assert!(
                known,
                "the log's `{family}: {key}` is no counter of the page's"
            );
        }
        let d = DeviceCounters::parse(&line).expect("the firmware's line parses");
        assert_eq!(
            (d.received, d.latency_max_us, d.fragments.controller_in),
            (7, 7, 7)
        );
    }

    const LINE: &str = "[    3.0 INFO ] counters: messages: received 11 answered 6 | dropped: foreign 1 invalid_source 1 throttled 1 decode 2 | transport: send_errors 0 tcp_stalled 0 | ids: lost 0 duplicates 0 reordered 0 | supervision: timeouts 0 | engine latency (message in to reply ready; the page and /metrics show the driver's, frame to frame) us: max 900 mean 500 | fragments: fragments 30 reassembled 8 oversize 10 unwanted 1 malformed 2 no_buffer 3 duplicate 0 timed_out 4 evicted 5 spoiled 2 | controller: in 9 incomplete 1 dropped 1 | nic read: rx_frames 120 rx_dropped 7 status_full 1 fifo_max 4560";

    /// CI's run of 2026-11-27: a 100 ms host stall during `cargo demo --
    /// --http-attack --fault drop:1 --fault garbage:1` lost 14 messages
    /// before the device (the simulator saw them never reach its engine),
    /// but the split blamed the engine for 15 (the warm-up and the 16
    /// garbage datagrams counted as the controller's), so CI did not try
    /// again.
    #[test]
    fn a_counted_runs_split_leaves_out_the_warm_up_and_the_garbage() {
        let line = "[  188.816886 INFO ] counters: messages: received 3221 answered 3205 | dropped: foreign 0 invalid_source 0 throttled 0 decode 16 | transport: send_errors 0 tcp_stalled 0 | ids: lost 45 duplicates 0 reordered 0 | supervision: timeouts 1 | engine latency (message in to reply ready; the page and /metrics show the driver's, frame to frame) us: max 8840 mean 147 | fragments: fragments 0 reassembled 0 oversize 0 unwanted 0 malformed 0 no_buffer 0 duplicate 0 timed_out 0 evicted 0 spoiled 0 | controller: in 3220 incomplete 0 dropped 0 | nic read: rx_frames 5201 rx_dropped 0 status_full 0 fifo_max 10288";
        let d = DeviceCounters::parse(line).expect("a counter line");
        let s = LossSplit::of_counted_run((2969, 2955), (250, 250), 16, d);
        assert_eq!((s.nic, s.reassembly, s.engine, s.way_back), (14, 0, 0, 0));
        assert!(s.adds_up());
    }

    /// CI's second run that day: QEMU's user networking dropped 56
    /// messages during a host stall (its "Failed to send packet" lines);
    /// every one the firmware got it answered. That is the host's, tried
    /// again (exit 3); a wrong reply, or a message the firmware had and
    /// did not answer, is not.
    #[test]
    fn losses_before_the_firmware_alone_are_the_hosts() {
        let line = |controller_in: u64, answered: u64| {
            format!("[  183.8 INFO ] counters: messages: received {controller_in} answered {answered} | dropped: foreign 0 invalid_source 0 throttled 0 decode 0 | transport: send_errors 0 tcp_stalled 0 | ids: lost 56 duplicates 0 reordered 0 | supervision: timeouts 0 | engine latency (message in to reply ready; the page and /metrics show the driver's, frame to frame) us: max 10693 mean 124 | fragments: fragments 0 reassembled 0 oversize 0 unwanted 0 malformed 0 no_buffer 0 duplicate 0 timed_out 0 evicted 0 spoiled 0 | controller: in {controller_in} incomplete 0 dropped 0 | nic read: rx_frames 2900 rx_dropped 0 status_full 0 fifo_max 4000")
        };
        let mut summary = crate::robot::report::Summary {
            sent: 2500,
            answered: 2444,
            lost: 56,
            ..Default::default()
        };
        // The run's own line: 2,693 counted in (the first from the robot's
        // port is answered before the guard knows it), 2,694 answered.
        let host = LossSplit::lost_before_firmware(&summary, (250, 250), &[line(2693, 2694)]);
        assert!(host);
        // One more the firmware had and did not answer: not the host's.
        let engine = [line(2695, 2694)];
        assert!(!LossSplit::lost_before_firmware(
            &summary,
            (250, 250),
            &engine
        ));
        // A wrong reply: never the host's.
        summary.wrong_id = 1;
        assert!(!LossSplit::lost_before_firmware(
            &summary,
            (250, 250),
            &[line(2693, 2694)]
        ));
        // No counters from the device: nothing to tell it by.
        summary.wrong_id = 0;
        assert!(!LossSplit::lost_before_firmware(&summary, (250, 250), &[]));
    }

    #[test]
    fn counter_line_parses_and_adds_up() {
        let c = DeviceCounters::parse(LINE).unwrap();
        assert_eq!(
            (
                c.received,
                c.answered,
                c.foreign,
                c.invalid,
                c.throttled,
                c.decode
            ),
            (11, 6, 1, 1, 1, 2)
        );
        assert!(c.add_up());
        assert!(!DeviceCounters { received: 12, ..c }.add_up());
        let f = c.fragments;
        assert_eq!(
            (f.fragments, f.oversize, f.no_buffer, f.timed_out, f.spoiled),
            (30, 10, 3, 4, 2)
        );
        assert_eq!(
            (
                f.controller_in,
                f.controller_incomplete,
                f.controller_dropped
            ),
            (9, 1, 1)
        );
        assert_eq!(
            c.nic,
            Some(Nic {
                rx_frames: 120,
                rx_dropped: 7,
                status_full: 1,
                fifo_max: 4560
            })
        );
        let na = LINE.replace("nic read:", "nic n/a:");
        assert_eq!(DeviceCounters::parse(&na).unwrap().nic, None);
        assert_eq!(DeviceCounters::parse("[ 1 INFO ] state CONNECTED"), None);
    }

    #[test]
    fn losses_split_three_ways_and_add_up() {
        let c = DeviceCounters::parse(LINE).unwrap();
        // 20 sent, 5 answered: 9 reached the stack whole, 1 dropped in
        // reassembly, so 10 never reached it; the engine answered 6 of the
        // 9; the robot saw 5 of those 6.
        let s = LossSplit::of(20, 5, &c);
        assert_eq!((s.nic, s.reassembly, s.engine, s.way_back), (10, 1, 3, 1));
        assert!(s.adds_up());
        assert_eq!(s.lost(), 15);
    }

    #[test]
    fn an_answered_message_reached_the_engine_though_the_guard_did_not_count_it() {
        // The first datagram from a controller's new port is answered
        // before the guard knows the port: controller in 9, answered 10.
        let mut c = DeviceCounters::parse(LINE).unwrap();
        c.answered = 10;
        let s = LossSplit::of(12, 10, &c);
        assert_eq!((s.nic, s.reassembly, s.engine, s.way_back), (1, 1, 0, 0));
        assert!(s.adds_up());
    }
}
