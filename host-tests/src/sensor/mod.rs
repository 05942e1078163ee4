//! The host build of the sensor: the firmware's own cycle engine and demo
//! application behind std sockets, for integrators without hardware (point
//! a RobotStudio virtual controller or the robot simulator at it). Not a
//! re-implementation: every message goes through `rri_firmware::engine`.

use rri_firmware::demo::{simulated_distance, DemoApp};
use rri_firmware::engine::{
    Clock, Config, Endpoint, Engine, ErrorCode, Instant, Outcome, SensorState, Stats,
};
use rri_firmware::layout;
use rri_firmware::properties::{DeviceSet, RobotSet};
use rri_firmware::sample::{Reading, SampleCell};
use rri_firmware::tcp::{Framer, Stall, StallGuard};
use std::io::{self, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

/// Device time on the host: microseconds since the sensor started.
#[derive(Clone, Copy, Debug)]
pub struct HostClock {
    start: std::time::Instant,
}

impl HostClock {
    pub fn new() -> Self {
        HostClock {
            start: std::time::Instant::now(),
        }
    }
}

impl Default for HostClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for HostClock {
    fn now(&self) -> Instant {
        Instant(self.start.elapsed().as_micros() as u64)
    }
}

/// How to run the host sensor.
#[derive(Clone, Debug)]
pub struct SensorOptions {
    pub listen: SocketAddr,
    /// TCP instead of UDP (M10 framing).
    pub tcp: bool,
    /// The engine's settings: `layout::ENGINE_CONFIG` unless overridden.
    pub config: Config,
    /// Print a statistics line this often (`None`: never).
    pub stats_every: Option<Duration>,
    /// The device's name, for the log.
    pub device_name: &'static str,
}

impl SensorOptions {
    /// The built configuration: its address, port, protocol and settings.
    pub fn from_layout() -> Self {
        SensorOptions {
            listen: SocketAddr::from((
                layout::NETWORK_IPV4.unwrap_or([0, 0, 0, 0]),
                layout::CHANNEL_PORT,
            )),
            tcp: !layout::CHANNEL_PROTOCOL.is_udp(),
            config: layout::ENGINE_CONFIG,
            stats_every: Some(Duration::from_secs(1)),
            device_name: layout::DEVICE_NAME,
        }
    }
}

/// What a run leaves behind.
#[derive(Clone, Debug)]
pub struct SensorReport {
    pub stats: Stats,
    pub state: SensorState,
    /// Every state the engine went through, with the time (s) it was entered.
    pub states: Vec<(f64, SensorState, Option<ErrorCode>)>,
}

fn state_text(state: SensorState, error: Option<ErrorCode>) -> String {
    match error {
        Some(e) => format!("{} {}", state.name(), e.code()),
        None => state.name().to_string(),
    }
}

/// One statistics line (also the summary's body).
pub fn stats_line(s: &Stats) -> String {
    let h = &s.latency;
    let mean = if h.count > 0 {
        h.total_us as f64 / f64::from(h.count)
    } else {
        0.0
    };
    format!(
        "received {} answered {} periodic {} | dropped: foreign {} invalid-source {} throttled {} decode {} | send-errors {} stalled {} | lost {} dup {} reordered {} | timeouts {} max-lost {} | latency us min {} mean {:.0} max {}",
        s.received,
        s.answered,
        s.periodic_sent,
        s.dropped_foreign,
        s.dropped_invalid_source,
        s.dropped_throttled,
        s.dropped_decode,
        s.send_errors,
        s.stalled_closed,
        s.lost,
        s.duplicates,
        s.reordered,
        s.timeouts,
        s.max_lost_exceeded,
        if h.count > 0 { h.min_us } else { 0 },
        mean,
        h.max_us,
    )
}

fn endpoint(addr: SocketAddr) -> Option<Endpoint> {
    match addr {
        SocketAddr::V4(a) => Some(Endpoint::new(a.ip().octets(), a.port())),
        SocketAddr::V6(_) => None,
    }
}

/// Engine, application and bookkeeping of one run.
struct Sensor<'a, 'w, R: RobotSet, D: DeviceSet> {
    engine: Engine<R, D>,
    app: DemoApp<'a>,
    clock: HostClock,
    out: Vec<u8>,
    states: Vec<(f64, SensorState, Option<ErrorCode>)>,
    log: &'w mut dyn Write,
    last_stats: std::time::Instant,
    stats_every: Option<Duration>,
}

impl<R: RobotSet, D: DeviceSet> Sensor<'_, '_, R, D> {
    /// Logs a state change, if there was one.
    fn note_state(&mut self) {
        let now = (self.engine.state(), self.engine.error_code());
        if self.states.last().map(|s| (s.1, s.2)) != Some(now) {
            let t = self.clock.now().as_micros() as f64 / 1e6;
            let _ = writeln!(self.log, "[{t:9.3}s] state {}", state_text(now.0, now.1));
            self.states.push((t, now.0, now.1));
        }
    }

    fn tick(&mut self) {
        if let Some(every) = self.stats_every {
            if self.last_stats.elapsed() >= every {
                self.last_stats = std::time::Instant::now();
                let _ = writeln!(self.log, "{}", stats_line(&self.engine.stats()));
            }
        }
    }

    fn message(
        &mut self,
        from: Endpoint,
        bytes: &[u8],
        received: Instant,
    ) -> Option<(Endpoint, usize)> {
        let outcome = self.engine.on_message(
            &mut self.app,
            &self.clock,
            from,
            bytes,
            received,
            &mut self.out,
        );
        self.note_state();
        match outcome {
            Outcome::Reply { to, len } => Some((to, len)),
            Outcome::Dropped(_) => None,
        }
    }

    fn poll(&mut self) -> Option<(Endpoint, usize)> {
        let r = self.engine.poll(&mut self.app, &self.clock, &mut self.out);
        self.note_state();
        self.tick();
        r
    }
}

/// A host sensor on `127.0.0.1`, an ephemeral port, in a thread of its own
/// (for tests): [`Background::stop`] ends it and returns its report.
pub struct Background {
    pub addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: JoinHandle<io::Result<SensorReport>>,
}

impl Background {
    /// Starts it (UDP, or TCP) with `config`, for the layout the firmware
    /// was built for; waits until it listens.
    pub fn start(tcp: bool, config: Config) -> io::Result<Background> {
        Self::start_layout::<
            layout::RobotProperties,
            layout::DeviceProperties,
            { layout::MAX_RECEIVE_LEN },
        >(tcp, config, layout::DEVICE_NAME)
    }

    /// Starts it for another layout (`host_tests::layouts`): its property
    /// sets `R`, `D` and its `MAX_RECEIVE_LEN` as `RX`.
    pub fn start_layout<R, D, const RX: usize>(
        tcp: bool,
        config: Config,
        device_name: &'static str,
    ) -> io::Result<Background>
    where
        R: RobotSet + Send + 'static,
        D: DeviceSet + Send + 'static,
    {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let opts = SensorOptions {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            tcp,
            config,
            stats_every: None,
            device_name,
        };
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            run_layout::<R, D, RX>(&opts, &flag, Some(tx), &mut std::io::sink())
        });
        let addr = rx
            .recv_timeout(Duration::from_secs(5))
            .map_err(|_| io::Error::other("the sensor did not start listening"))?;
        Ok(Background { addr, stop, thread })
    }

    /// Stops it; its report, or the error that ended it early.
    pub fn stop(self) -> io::Result<SensorReport> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .map_err(|_| io::Error::other("the sensor thread panicked"))?
    }
}

/// Runs the host sensor until `stop` is set. `ready` receives the bound
/// address (useful with port 0). Log lines (state changes, statistics) go
/// to `log`.
pub fn run(
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
    log: &mut dyn Write,
) -> io::Result<SensorReport> {
    run_layout::<layout::RobotProperties, layout::DeviceProperties, { layout::MAX_RECEIVE_LEN }>(
        opts, stop, ready, log,
    )
}

/// [`run`] for any layout: its property sets `R`, `D` and its
/// `MAX_RECEIVE_LEN` as `RX` (the TCP framer's size).
pub fn run_layout<R: RobotSet, D: DeviceSet, const RX: usize>(
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
    log: &mut dyn Write,
) -> io::Result<SensorReport> {
    let cell = SampleCell::<1>::new();
    let Some((mut sampler, reader)) = cell.split() else {
        return Err(io::Error::other("sample cell already split"));
    };
    let clock = HostClock::new();
    let mut sensor = Sensor {
        engine: Engine::<R, D>::new(opts.config),
        app: DemoApp::new(reader),
        clock,
        out: vec![0; D::MAX_SEND_LEN],
        states: Vec::new(),
        log,
        last_stats: std::time::Instant::now(),
        stats_every: opts.stats_every,
    };
    sensor.note_state();
    let result = std::thread::scope(|s| {
        // The sampler: a distance reading every millisecond, published
        // without ever blocking the cycle.
        s.spawn(|| {
            while !stop.load(Ordering::Relaxed) {
                let now = clock.now();
                sampler.publish(&Reading {
                    values: [simulated_distance(now)],
                    time: now,
                });
                std::thread::sleep(Duration::from_millis(1));
            }
        });
        let r = if opts.tcp {
            serve_tcp::<R, D, RX>(&mut sensor, opts, stop, ready)
        } else {
            serve_udp(&mut sensor, opts, stop, ready)
        };
        stop.store(true, Ordering::Relaxed);
        r
    });
    if let Err(e) = result {
        sensor.engine.init_failed();
        sensor.note_state();
        return Err(e);
    }
    let stats = sensor.engine.stats();
    let _ = writeln!(sensor.log, "summary: {}", stats_line(&stats));
    Ok(SensorReport {
        stats,
        state: sensor.engine.state(),
        states: sensor.states,
    })
}

fn serve_udp<R: RobotSet, D: DeviceSet>(
    sensor: &mut Sensor<'_, '_, R, D>,
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
) -> io::Result<()> {
    let socket = UdpSocket::bind(opts.listen)?;
    socket.set_read_timeout(Some(Duration::from_micros(500)))?;
    let local = socket.local_addr()?;
    let _ = writeln!(
        sensor.log,
        "listening on udp {local} (device {})",
        opts.device_name
    );
    sensor.engine.listening();
    sensor.note_state();
    if let Some(tx) = ready {
        let _ = tx.send(local);
    }
    // One byte more than the layout allows, so a longer datagram is seen
    // as too long rather than silently cut.
    let mut buf = vec![0u8; R::MAX_RECEIVE_LEN + 1];
    while !stop.load(Ordering::Relaxed) {
        match socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                let received = sensor.clock.now();
                let Some(from) = endpoint(from) else { continue };
                if let Some((to, len)) = sensor.message(from, buf.get(..n).unwrap_or(&[]), received)
                {
                    send_udp(sensor, &socket, to, len);
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) => {}
            // ICMP port unreachable from a robot that went away.
            Err(e) if e.kind() == ErrorKind::ConnectionReset => {}
            Err(e) => return Err(e),
        }
        if let Some((to, len)) = sensor.poll() {
            send_udp(sensor, &socket, to, len);
        }
    }
    Ok(())
}

/// Sends the reply in `sensor.out`; a failure is counted and logged, never
/// fatal (a controller that went away, a full socket buffer).
fn send_udp<R: RobotSet, D: DeviceSet>(
    sensor: &mut Sensor<'_, '_, R, D>,
    socket: &UdpSocket,
    to: Endpoint,
    len: usize,
) {
    let to_addr = SocketAddr::from((to.ip, to.port));
    if let Err(e) = socket.send_to(&sensor.out[..len], to_addr) {
        sensor.engine.send_failed();
        if sensor.engine.stats().send_errors == 1 {
            let _ = writeln!(
                sensor.log,
                "reply to {to_addr} not sent ({e}); counted as send-errors, the sensor goes on"
            );
        }
    }
}

fn serve_tcp<R: RobotSet, D: DeviceSet, const RX: usize>(
    sensor: &mut Sensor<'_, '_, R, D>,
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
) -> io::Result<()> {
    let listener = TcpListener::bind(opts.listen)?;
    listener.set_nonblocking(true)?;
    let local = listener.local_addr()?;
    let _ = writeln!(
        sensor.log,
        "listening on tcp {local} (device {})",
        opts.device_name
    );
    // S2: CONNECTED once it listens, as over UDP (and on the boards).
    sensor.engine.listening();
    sensor.note_state();
    if let Some(tx) = ready {
        let _ = tx.send(local);
    }
    // A connection that arrived while another was served (M10: it may
    // close a stalled one).
    let mut waiting: Option<(TcpStream, SocketAddr)> = None;
    while !stop.load(Ordering::Relaxed) {
        let next = match waiting.take() {
            Some(c) => Some(c),
            None => match listener.accept() {
                Ok(c) => Some(c),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {
                    None
                }
                // The peer gave up between SYN and accept.
                Err(e) if e.kind() == ErrorKind::ConnectionAborted => None,
                Err(e) => return Err(e),
            },
        };
        match next {
            Some((stream, peer)) => {
                let _ = writeln!(sensor.log, "connection from {peer}");
                sensor.engine.listening();
                sensor.note_state();
                connection::<R, D, RX>(sensor, &listener, &mut waiting, stream, peer, stop);
                sensor.engine.peer_closed();
                sensor.note_state();
            }
            None => {
                let _ = sensor.poll();
                std::thread::sleep(Duration::from_micros(500));
            }
        }
    }
    Ok(())
}

/// Why a connection ended, for the log.
enum End {
    Stop,
    PeerClosed,
    Framing,
    SendFailed(io::Error),
    ReadFailed(io::Error),
    Stalled(Stall),
}

/// One TCP connection: framed messages in (M10), replies out, until the
/// peer closes, a framing error, a failed send, a stall (M10), or stop.
/// Whatever happens on the connection ends at most the connection.
fn connection<R: RobotSet, D: DeviceSet, const RX: usize>(
    sensor: &mut Sensor<'_, '_, R, D>,
    listener: &TcpListener,
    waiting: &mut Option<(TcpStream, SocketAddr)>,
    stream: TcpStream,
    peer: SocketAddr,
    stop: &AtomicBool,
) {
    let end = serve_connection::<R, D, RX>(sensor, listener, waiting, stream, peer, stop);
    let why = match end {
        End::Stop | End::PeerClosed => return,
        End::Framing => format!("framing error: message longer than {RX} bytes"),
        End::SendFailed(e) => format!("reply not sent ({e})"),
        End::ReadFailed(e) => format!("read failed ({e})"),
        End::Stalled(Stall::Incomplete) => format!(
            "an incomplete message held longer than TimeOut ({} ms)",
            sensor.engine.config().timeout_ms
        ),
        End::Stalled(Stall::SilentWhileWaiting) => format!(
            "silent for TimeOut ({} ms) while another connection waits",
            sensor.engine.config().timeout_ms
        ),
    };
    let _ = writeln!(sensor.log, "closing the connection from {peer}: {why}");
}

fn serve_connection<R: RobotSet, D: DeviceSet, const RX: usize>(
    sensor: &mut Sensor<'_, '_, R, D>,
    listener: &TcpListener,
    waiting: &mut Option<(TcpStream, SocketAddr)>,
    mut stream: TcpStream,
    peer: SocketAddr,
    stop: &AtomicBool,
) -> End {
    let timeout = Duration::from_millis(u64::from(sensor.engine.config().timeout_ms.max(1)));
    let setup = stream
        .set_nonblocking(false)
        .and_then(|()| stream.set_read_timeout(Some(Duration::from_micros(500))))
        // A peer that stops reading its replies must not block the sensor.
        .and_then(|()| stream.set_write_timeout(Some(timeout)))
        .and_then(|()| stream.set_nodelay(true));
    if let Err(e) = setup {
        return End::ReadFailed(e);
    }
    let Some(from) = endpoint(peer) else {
        return End::PeerClosed;
    };
    let mut framer = Framer::<RX>::new();
    let mut guard = StallGuard::new(sensor.engine.config().timeout_ms, sensor.clock.now());
    let mut chunk = [0u8; 4096];
    let mut replies: Vec<Vec<u8>> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut chunk) {
            Ok(0) => return End::PeerClosed,
            Ok(n) => {
                let received = sensor.clock.now();
                let mut completed = false;
                let framed = framer.push(&chunk[..n], |m| {
                    completed = true;
                    if let Some((_, len)) = sensor.message(from, m, received) {
                        replies.push(sensor.out[..len].to_vec());
                    }
                });
                for r in replies.drain(..) {
                    if let Err(e) = stream.write_all(&r) {
                        sensor.engine.send_failed();
                        return End::SendFailed(e);
                    }
                }
                if framed.is_err() {
                    sensor.engine.framing_error();
                    return End::Framing;
                }
                guard.received(received, completed, framer.pending());
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) => {}
            Err(e) if matches!(e.kind(), ErrorKind::ConnectionReset | ErrorKind::BrokenPipe) => {
                return End::PeerClosed
            }
            Err(e) => return End::ReadFailed(e),
        }
        if waiting.is_none() {
            if let Ok(c) = listener.accept() {
                let _ = writeln!(sensor.log, "connection from {} waits", c.1);
                *waiting = Some(c);
            }
        }
        if let Some(stall) = guard.check(sensor.clock.now(), waiting.is_some()) {
            sensor.engine.stalled();
            return End::Stalled(stall);
        }
        if let Some((_, len)) = sensor.poll() {
            if let Err(e) = stream.write_all(&sensor.out[..len]) {
                sensor.engine.send_failed();
                return End::SendFailed(e);
            }
        }
    }
    End::Stop
}
