//! The robot-controller simulator: plays the IRC5 side of RRI as the manual
//! describes, against any sensor, from a GSI folder read at run time.
//!
//! Every `rate` ms it sends the controller's property with changing data
//! (or, with `--send NAME=MS`, several properties each at its own rate, in
//! one Id sequence as a controller numbers one channel, M11), checks each
//! reply (M8 Id echo, the reply property's root and fields against the
//! layout, decodable values), accepts the device's periodic properties,
//! supervises like the controller (S1: `TimeOut`, `MaxLost`, `DryRun`), and
//! summarises: sent, answered, late, lost, wrong Id, malformed, latency
//! percentiles, and per property.

pub mod args;
pub mod fault;
pub mod motion;
pub mod numbers;
pub mod report;
pub mod wire;

use fault::{Fault, Faults};
use gsi_config::{Device, Property};
use motion::Motion;
use report::{Cycle, Latency, Packet, PropertyFigures, Summary};
use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

/// Everything `cargo robot` takes.
#[derive(Clone, Debug)]
pub struct RobotOptions {
    pub gsi: PathBuf,
    pub device: Option<String>,
    pub to: SocketAddr,
    pub cycles: u64,
    /// Send period, a multiple of 4 ms.
    pub rate_ms: u32,
    /// `--send NAME=MS`: the properties to send, each every MS ms (one
    /// `SiSetCyclic` each). Empty: the first property the controller sends,
    /// every `rate_ms`.
    pub sends: Vec<(String, u32)>,
    /// `--reply NAME`: the property the device answers with (the device's
    /// `RRI_REPLY`); `None`: the first property the device sends.
    pub reply: Option<String>,
    /// `false`: send the next message as soon as the last one is answered
    /// (tests); latencies still count as late beyond one `rate_ms` cycle.
    pub pacing: bool,
    pub tcp: bool,
    pub csv: Option<PathBuf>,
    pub plot: Option<PathBuf>,
    pub pcap: Option<PathBuf>,
    pub json: Option<PathBuf>,
    pub faults: Vec<Fault>,
    pub seed: u64,
    /// Id of the first message (to test the u32 wrap, S3).
    pub first_id: u32,
    pub progress: bool,
    /// Lines of the device's own log (e.g. the QEMU board's defmt output),
    /// printed above the progress bar as they come (`cargo demo`).
    pub device_log: Option<Arc<Mutex<Vec<String>>>>,
}

impl RobotOptions {
    pub fn new(gsi: PathBuf, to: SocketAddr) -> Self {
        RobotOptions {
            gsi,
            device: None,
            to,
            cycles: 1000,
            rate_ms: 4,
            sends: Vec::new(),
            reply: None,
            pacing: true,
            tcp: false,
            csv: None,
            plot: None,
            pcap: None,
            json: None,
            faults: Vec::new(),
            seed: 1,
            first_id: 1,
            progress: false,
            device_log: None,
        }
    }
}

/// The controller's supervision (S1) and state as it would show in RAPID.
struct Supervision {
    dry_run: bool,
    timeout: Duration,
    max_lost: u32,
    in_row: u32,
    /// Of the unanswered run: replies that came with a wrong Id or late,
    /// so a trip names the cause.
    wrong_in_row: u32,
    late_in_row: u32,
    tripped: Option<String>,
    operating: bool,
    last_answer: Option<Instant>,
}

/// A message waiting for its reply.
struct Waiting {
    index: usize,
    sent: Instant,
    /// Replies still expected (2 for a duplicated message).
    expected: u8,
    answered: bool,
}

/// What the receiver threads hand over: a reply and when it arrived.
enum Event {
    Data(Vec<u8>, SocketAddr, Instant),
    Closed,
}

/// The transport to the sensor. Receiving runs on threads that block on
/// their socket and timestamp each reply the moment it arrives; the main
/// loop waits on a channel with precise timeouts (a socket's own receive
/// timeout is only as fine as the kernel tick).
struct Link {
    udp: Option<(UdpSocket, Option<UdpSocket>)>,
    tcp: Option<TcpStream>,
    events: mpsc::Receiver<Event>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
    closed: bool,
}

impl Link {
    fn udp(to: SocketAddr, second_port: bool) -> std::io::Result<Link> {
        let (tx, events) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let main = UdpSocket::bind(local_for(to))?;
        let second = if second_port {
            Some(UdpSocket::bind(local_for(to))?)
        } else {
            None
        };
        let mut threads = Vec::new();
        for sock in std::iter::once(&main).chain(second.as_ref()) {
            let sock = sock.try_clone()?;
            sock.set_read_timeout(Some(Duration::from_millis(20)))?;
            let local = sock.local_addr()?;
            let (tx, stop) = (tx.clone(), stop.clone());
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 65_536];
                while !stop.load(Ordering::Relaxed) {
                    if let Ok((n, _)) = sock.recv_from(&mut buf) {
                        let at = Instant::now();
                        if tx.send(Event::Data(buf[..n].to_vec(), local, at)).is_err() {
                            return;
                        }
                    }
                }
            }));
        }
        Ok(Link {
            udp: Some((main, second)),
            tcp: None,
            events,
            stop,
            threads,
            closed: false,
        })
    }

    fn tcp(to: SocketAddr) -> std::io::Result<Link> {
        let (tx, events) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let stream = TcpStream::connect_timeout(&to, Duration::from_secs(2))?;
        stream.set_nodelay(true)?;
        let mut reader = stream.try_clone()?;
        reader.set_read_timeout(Some(Duration::from_millis(20)))?;
        let local = stream.local_addr()?;
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut framer = Box::new(rri_framing::Framer::<65_536>::new());
            let mut chunk = [0u8; 8192];
            while !flag.load(Ordering::Relaxed) {
                match reader.read(&mut chunk) {
                    Ok(0) => {
                        let _ = tx.send(Event::Closed);
                        return;
                    }
                    Ok(n) => {
                        let at = Instant::now();
                        let _ = framer.push(&chunk[..n], |m| {
                            let _ = tx.send(Event::Data(m.to_vec(), local, at));
                        });
                    }
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                    Err(_) => {
                        let _ = tx.send(Event::Closed);
                        return;
                    }
                }
            }
        });
        Ok(Link {
            udp: None,
            tcp: Some(stream),
            events,
            stop,
            threads: vec![thread],
            closed: false,
        })
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

struct Sim<'a> {
    opts: &'a RobotOptions,
    device: &'a Device,
    reply_prop: &'a Property,
    /// Replies and periodic messages by device property name.
    received: HashMap<String, u64>,
    link: Link,
    start: Instant,
    cycles: Vec<Cycle>,
    waiting: HashMap<u32, Waiting>,
    sup: Supervision,
    s: Summary,
    packets: Vec<Packet>,
    log: &'a mut dyn Write,
    bar: indicatif::ProgressBar,
}

fn local_for(to: SocketAddr) -> SocketAddr {
    if to.ip().is_loopback() {
        SocketAddr::from(([127, 0, 0, 1], 0))
    } else {
        SocketAddr::from(([0, 0, 0, 0], 0))
    }
}

impl Sim<'_> {
    fn us(&self, t: Instant) -> u64 {
        t.duration_since(self.start).as_micros() as u64
    }

    fn transition(&mut self, what: &str) {
        let t = self.start.elapsed().as_secs_f64();
        let log = &mut self.log;
        // Around the live progress bar, not through it.
        self.bar.suspend(|| {
            let _ = writeln!(log, "[{t:9.3}s] controller: {what}");
        });
    }

    /// Prints what the device logged since the last call.
    fn device_lines(&mut self) {
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
    fn unanswered(&self, now: Instant) -> usize {
        let cycle = Duration::from_millis(u64::from(self.s.rate_ms));
        self.waiting
            .values()
            .filter(|w| !w.answered && now.duration_since(w.sent) > cycle)
            .count()
    }

    fn trip(&mut self, reason: String) {
        if self.sup.dry_run || self.sup.tripped.is_some() {
            return;
        }
        self.transition(&format!("ERROR 112602 ({reason})"));
        self.sup.tripped = Some(reason);
        self.sup.operating = false;
    }

    fn send(&mut self, bytes: &[u8], second: bool) -> Result<(), String> {
        let now = Instant::now();
        let (from, r) = if let Some((main, s2)) = &self.link.udp {
            let sock = match (second, s2) {
                (true, Some(s)) => s,
                _ => main,
            };
            (
                sock.local_addr().ok(),
                sock.send_to(bytes, self.opts.to).map(|_| ()),
            )
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

    fn handle_reply(&mut self, bytes: &[u8], local: SocketAddr, at: Instant) {
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
            if !self.sup.operating && self.sup.tripped.is_none() {
                self.sup.operating = true;
                self.transition("OPERATING (first answer)");
            }
        }
        if self.waiting.get(&reply.id).is_some_and(|w| w.expected == 0) {
            self.waiting.remove(&reply.id);
        }
    }

    /// S1 TimeOut: messages wait and nothing has been answered for longer.
    fn check_timeout(&mut self, now: Instant) {
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
    fn pump(&mut self, until: Instant, id: Option<u32>) {
        loop {
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
            match self.link.events.recv_timeout(wait) {
                Ok(Event::Data(bytes, local, at)) => self.handle_reply(&bytes, local, at),
                Ok(Event::Closed) => self.link.closed = true,
                Err(_) => {}
            }
        }
    }
}

/// Loads the device or says exactly why not.
pub fn load(opts: &RobotOptions) -> Result<Device, String> {
    gsi_config::load(&opts.gsi, opts.device.as_deref())
        .map(|l| l.device)
        .map_err(|f| f.to_string())
}

/// `name` among `props` by Name or Alias, in any case (G4), or why not.
fn find_property<'d>(
    device: &'d Device,
    name: &str,
    robot_sends: bool,
) -> Result<&'d Property, String> {
    let (list, who): (Vec<&Property>, &str) = if robot_sends {
        (device.received().collect(), "the controller sends")
    } else {
        (device.sent().collect(), "the device sends")
    };
    list.iter()
        .copied()
        .find(|p| p.is_named(name))
        .ok_or_else(|| {
            let choices: Vec<&str> = list.iter().map(|p| p.name.as_str()).collect();
            format!(
                "no property \"{}\" that {who} in {}; choose one of: {}",
                name.trim(),
                device.name,
                choices.join(", ")
            )
        })
}

/// The properties to send and their periods (M11): `--send`, or the first
/// robot property every `--rate-ms`.
fn sends<'d>(opts: &RobotOptions, device: &'d Device) -> Result<Vec<(&'d Property, u32)>, String> {
    if opts.sends.is_empty() {
        let first = device.received().next().ok_or(
            "the configuration has no property the controller sends (Flag WriteOnly or ReadWrite)",
        )?;
        return Ok(vec![(first, opts.rate_ms)]);
    }
    let mut out: Vec<(&Property, u32)> = Vec::new();
    for (name, ms) in &opts.sends {
        let p =
            find_property(device, name, true).map_err(|e| format!("--send {name}={ms}: {e}"))?;
        if *ms == 0 || !ms.is_multiple_of(4) {
            return Err(format!(
                "--send {name}={ms}: the period must be a positive multiple of 4 ms"
            ));
        }
        if out.iter().any(|(q, _)| q.name == p.name) {
            return Err(format!("--send {name}: given twice"));
        }
        out.push((p, *ms));
    }
    Ok(out)
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Runs the simulation; `log` gets state transitions.
pub fn run(
    opts: &RobotOptions,
    device: &Device,
    log: &mut dyn Write,
) -> Result<(Summary, Vec<Cycle>), String> {
    if opts.rate_ms == 0 || !opts.rate_ms.is_multiple_of(4) {
        return Err(format!(
            "--rate-ms {}: must be a positive multiple of 4 (the controller's cycle)",
            opts.rate_ms
        ));
    }
    if opts.cycles == 0 {
        return Err("--cycles 0: nothing to send; give at least 1".into());
    }
    // Every output is checked before the first message, so a bad path
    // costs no run.
    for (flag, path) in [
        ("--csv", &opts.csv),
        ("--plot", &opts.plot),
        ("--pcap", &opts.pcap),
        ("--json", &opts.json),
    ] {
        if let Some(p) = path {
            std::fs::File::create(p).map_err(|e| format!("{flag} {}: {e}", p.display()))?;
        }
    }
    if opts.plot.is_some() {
        report::ensure_font().map_err(|e| format!("--plot: {e}"))?;
    }
    let sends = sends(opts, device)?;
    // One controller cycle of the simulation: every period is a multiple.
    let tick_ms = sends.iter().fold(0, |g, &(_, ms)| gcd(g, ms));
    let reply_prop = match &opts.reply {
        Some(name) => {
            find_property(device, name, false).map_err(|e| format!("--reply {name}: {e}"))?
        }
        None => device.sent().next().ok_or(
            "the configuration has no property the device sends (Flag ReadOnly or ReadWrite)",
        )?,
    };
    let faults = Faults::new(opts.faults.clone(), opts.seed);
    if opts.tcp {
        if let Some(f) = faults.udp_only() {
            return Err(format!(
                "--fault {f} only works over UDP ({} need datagrams)",
                fault::UDP_ONLY
            ));
        }
    }
    let link = if opts.tcp {
        Link::tcp(opts.to).map_err(|e| format!("cannot connect to {} over TCP: {e}", opts.to))?
    } else {
        let second = opts
            .faults
            .iter()
            .any(|f| matches!(f, Fault::SecondPort { .. }));
        Link::udp(opts.to, second).map_err(|e| format!("cannot open a UDP socket: {e}"))?
    };
    let start = Instant::now();
    let start_unix_us = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
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

    let mut sim = Sim {
        opts,
        device,
        reply_prop,
        received: HashMap::new(),
        link,
        start,
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
    };
    let sending: Vec<String> = sends
        .iter()
        .map(|(p, ms)| format!("{} every {ms} ms", p.wire()))
        .collect();
    sim.transition(&format!(
        "CONNECTED to {} ({}, {} over {}, DryRun={}, TimeOut={} ms, MaxLost={})",
        device.name,
        opts.to,
        sending.join(", "),
        sim.s.transport,
        device.supervision.dry_run,
        device.supervision.timeout_ms,
        device.supervision.max_lost
    ));
    let motion = Motion::new(device);
    let mut faults = faults;
    let tick = Duration::from_millis(u64::from(tick_ms));
    let mut schedule = start;
    let mut held: Option<(u32, String, bool)> = None;
    // Ids of the last tick's messages, oldest first.
    let mut previous: Vec<u32> = Vec::new();
    // Messages sent so far: the next Id (one sequence, M11) and the fault
    // plan's index.
    let mut m: u64 = 0;
    for c in 0..opts.cycles {
        let planned = schedule;
        if opts.pacing {
            sim.pump(planned, None);
            schedule += tick;
        }
        // S1 at send time: were the last cycle's messages answered within
        // it? An answered one ends a run of unanswered ones.
        for prev in previous.drain(..) {
            if sim.waiting.get(&prev).is_none_or(|w| w.answered) {
                sim.sup.in_row = 0;
                sim.sup.wrong_in_row = 0;
                sim.sup.late_in_row = 0;
            } else {
                sim.sup.in_row += 1;
            }
        }
        if sim.sup.in_row > sim.sup.max_lost {
            let n = sim.sup.max_lost;
            let cause = if sim.sup.wrong_in_row > 0 {
                format!("{} replies carried a wrong Id (M8)", sim.sup.wrong_in_row)
            } else if sim.sup.late_in_row > 0 {
                format!("{} replies came later than one cycle", sim.sup.late_in_row)
            } else {
                "no reply at all".to_string()
            };
            sim.trip(format!(
                "more than MaxLost = {n} messages in a row unanswered: {cause}"
            ));
        }
        let now_ms = c * u64::from(tick_ms);
        for (which, &(robot_prop, period)) in sends.iter().enumerate() {
            if now_ms % u64::from(period) != 0 {
                continue;
            }
            let plan = faults.plan(m);
            if plan.pause_ms > 0 {
                sim.s.injected.pauses += 1;
                sim.transition(&format!("pausing {} ms (fault)", plan.pause_ms));
                let resume = Instant::now() + Duration::from_millis(plan.pause_ms);
                sim.pump(resume, None);
                schedule = Instant::now() + tick;
            }
            let id = opts.first_id.wrapping_add(m as u32);
            m += 1;
            let t = start.elapsed().as_secs_f64();
            let msg = wire::robot_message(device, robot_prop, id, Motion::now(t), |f| {
                motion.value(f, c, t)
            });
            let now = Instant::now();
            if opts.pacing && plan.pause_ms == 0 {
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
            });
            if plan.drop {
                sim.s.injected.dropped += 1;
                continue;
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
            previous.push(id);
            if plan.reorder && held.is_none() {
                sim.s.injected.reordered += 1;
                held = Some((id, msg, plan.second_port));
            } else {
                sim.send(msg.as_bytes(), plan.second_port)?;
                if plan.duplicate {
                    sim.send(msg.as_bytes(), plan.second_port)?;
                }
                if let Some((held_id, m, second)) = held.take() {
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
                    robot_prop.wire(),
                    " ".repeat(9000),
                    robot_prop.wire()
                );
                sim.send(big.as_bytes(), plan.second_port)?;
            }
            if !opts.pacing && held.is_none() {
                sim.pump(
                    Instant::now() + Duration::from_millis(200).max(tick),
                    Some(id),
                );
            }
        }
        if c % 50 == 0 {
            sim.device_lines();
            let elapsed = start.elapsed().as_secs_f64();
            // A rate over less than a second is noise (the first reading
            // would be thousands of messages per second).
            let rate = if elapsed >= 1.0 {
                format!("{:.0} msg/s, ", sim.s.sent as f64 / elapsed)
            } else {
                String::new()
            };
            // Message first: one redraw shows both with the same counts.
            sim.bar.set_message(format!(
                "{rate}answered {}, late {}, lost {}",
                sim.s.answered,
                sim.s.late,
                sim.unanswered(Instant::now())
            ));
            sim.bar.set_position(c + 1);
        }
    }
    if let Some((_, m, second)) = held.take() {
        sim.send(m.as_bytes(), second)?;
    }
    // Collect the last replies.
    let drain = Instant::now() + tick.max(Duration::from_millis(200));
    while !sim.waiting.values().all(|w| w.answered) && Instant::now() < drain {
        sim.pump(drain.min(Instant::now() + tick), None);
    }
    sim.bar.finish_and_clear();
    sim.device_lines();

    let mut s = sim.s.clone();
    s.lost = sim
        .cycles
        .iter()
        .filter(|c| !c.dropped_by_fault && c.reply_us.is_none())
        .count() as u64;
    s.latency_us = Latency::of(sim.cycles.iter().filter_map(Cycle::latency_us).collect());
    s.supervision_tripped = sim.sup.tripped.clone();
    s.properties = sends
        .iter()
        .enumerate()
        .map(|(which, (p, ms))| {
            let mine = || sim.cycles.iter().filter(move |c| c.property == which);
            PropertyFigures {
                name: p.name.clone(),
                direction: "sent".into(),
                period_ms: Some(*ms),
                messages: mine().filter(|c| !c.dropped_by_fault).count() as u64,
                answered: mine().filter(|c| c.reply_us.is_some()).count() as u64,
                lost: mine()
                    .filter(|c| !c.dropped_by_fault && c.reply_us.is_none())
                    .count() as u64,
            }
        })
        .collect();
    for p in device.sent() {
        if let Some(&n) = sim.received.get(&p.name) {
            s.properties.push(PropertyFigures {
                name: p.name.clone(),
                direction: if p.name == sim.reply_prop.name {
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
    s.elapsed_s = start.elapsed().as_secs_f64();
    let rate_us = u64::from(tick_ms) * 1000;
    // Every output that can be written is; the others are reported with
    // the summary (the JSON last, so it lists them).
    let mut errors = Vec::new();
    if let Some(p) = &opts.csv {
        if let Err(e) = report::write_csv(p, &sim.cycles, rate_us) {
            errors.push(format!("--csv {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.plot {
        if let Err(e) = report::write_plot(p, &sim.cycles, rate_us, &s, start_unix_us) {
            errors.push(format!("--plot {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.pcap {
        if let Err(e) = report::write_pcap(p, &sim.packets, start_unix_us, opts.tcp) {
            errors.push(format!("--pcap {}: {e}", p.display()));
        }
    }
    s.output_errors = errors;
    if let Some(p) = &opts.json {
        if let Err(e) = report::write_json(p, &s) {
            s.output_errors.push(format!("--json {}: {e}", p.display()));
        }
    }
    Ok((s, sim.cycles))
}
