//! The host build of the sensor: the firmware's own cycle engine and any
//! sensor (`cargo sensor-host` runs the integrator's,
//! `rri_active_sensor::Active`, the file `RRI_SENSOR` names, unchanged;
//! the tests here the demo's, [`DemoSensor`]) behind std sockets, for integrators
//! without hardware (point a RobotStudio virtual controller or the robot
//! simulator at it). Not a re-implementation: every message goes through
//! `rri_firmware::engine`, every sample through the sensor's `Sampler` and
//! history as on a board; only the samples' source is the host's
//! ([`Source`]: simulated, or a recorded CSV file).

use rri_firmware::engine::{
    Application, Clock, Config, DropReason, Endpoint, Engine, ErrorCode, Instant, Outcome,
    SensorState, Stats,
};
use rri_firmware::layout;
use rri_firmware::properties::{DeviceSet, RobotSet};
use rri_firmware::sample::SampleCell;
use rri_firmware::sensor::{Ring, Sampler, Sensor, SensorApp};

/// The sensor the host-tests' own runs use ([`Background::start`]): the
/// demo's, whatever `RRI_SENSOR` says, so that choosing a sensor never
/// rebuilds these tools (only `cargo sensor-host` runs the chosen one).
pub type DemoSensor = rri_firmware::sensors::distance::Distance;
use rri_firmware::snapshot::Snapshot;
use std::io::{self, Write};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::time::Duration;

mod background;
pub use background::Background;
pub mod http;
mod source;
mod tcp;
mod udp;

pub use source::{Recording, Source};

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
    /// Where the samples come from.
    pub source: Source,
    /// Serve the diagnostics (page, JSON, metrics) here (`None`: not).
    pub http: Option<SocketAddr>,
    /// Told the diagnostics' bound address once it listens.
    pub http_ready: Option<Sender<SocketAddr>>,
    /// The sensor's source file, as the diagnostics name it.
    pub sensor_file: &'static str,
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
            source: Source::Simulated,
            http: None,
            http_ready: None,
            sensor_file: DEMO_SENSOR_FILE,
        }
    }
}

/// [`DemoSensor`]'s file, as the diagnostics name it.
pub const DEMO_SENSOR_FILE: &str = "firmware/src/sensors/distance.rs";

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

/// One statistics line (also the summary's body): every counter family
/// as `family: key value …`, named as on the page, in `/status.json` and
/// `/metrics` (`rri_diag::counters::FAMILIES`, which says what each
/// counts) and as the boards' counter line names them, then the engine's
/// latency. The fragment guard's families are left out: the host sensor
/// sits on the host's sockets, which reassemble for it.
pub fn stats_line(s: &Stats) -> String {
    let h = &s.latency;
    let mean = if h.count > 0 {
        h.total_us as f64 / h.count as f64
    } else {
        0.0
    };
    let mut line = String::new();
    for f in rri_diag::counters::FAMILIES {
        if f.key == "fragments" || f.key == "controller" {
            continue;
        }
        line.push_str(f.key);
        line.push(':');
        for m in f.members {
            line.push_str(&format!(" {} {}", m.key, (m.get)(s)));
        }
        line.push_str(" | ");
    }
    line.push_str(&format!(
        "engine latency (message in to reply ready) us: min {} mean {mean:.0} max {}",
        if h.count > 0 { h.min_us } else { 0 },
        h.max_us,
    ));
    line
}

/// Who the host sensor is, for its diagnostics.
fn host_identity<S: Sensor<R, D>, R: RobotSet, D: DeviceSet>(
    opts: &SensorOptions,
    http_port: u16,
) -> rri_diag::Identity {
    let ip = match opts.listen {
        SocketAddr::V4(a) => a.ip().octets(),
        SocketAddr::V6(_) => [0; 4],
    };
    rri_diag::Identity {
        device: opts.device_name,
        device_type: layout::DEVICE_TYPE,
        device_class: layout::DEVICE_CLASS,
        version: env!("CARGO_PKG_VERSION"),
        commit: rri_firmware::network::COMMIT,
        board: "host (cargo sensor-host)",
        sensor: core::any::type_name::<S>(),
        sensor_file: opts.sensor_file,
        mac: None,
        ip,
        prefix: 32,
        gateway: None,
        protocol: if opts.tcp {
            rri_firmware::schema::Protocol::Tcp
        } else {
            rri_firmware::schema::Protocol::Udp
        },
        port: opts.listen.port(),
        http_port,
        config: opts.config,
        received: R::INFO,
        sent: D::INFO,
    }
}

fn endpoint(addr: SocketAddr) -> Option<Endpoint> {
    match addr {
        SocketAddr::V4(a) => Some(Endpoint::new(a.ip().octets(), a.port())),
        SocketAddr::V6(_) => None,
    }
}

/// Engine, application (the sensor's cycle half) and bookkeeping of one
/// run.
struct Node<'w, R: RobotSet, D: DeviceSet, A> {
    engine: Engine<R, D>,
    app: A,
    clock: HostClock,
    out: Vec<u8>,
    states: Vec<(f64, SensorState, Option<ErrorCode>)>,
    log: &'w mut dyn Write,
    last_stats: std::time::Instant,
    stats_every: Option<Duration>,
    /// What the diagnostics service reads, and the last snapshot given
    /// to it.
    diag: Arc<http::HostDiag>,
    last: Snapshot,
    turns: u32,
}

impl<R: RobotSet, D: DeviceSet, A: Application<R, D>> Node<'_, R, D, A> {
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
        if let (Outcome::Dropped(DropReason::Decode(_)), Some(e)) =
            (outcome, self.engine.last_decode_error())
        {
            self.diag.last_bad.record(received, from, e, bytes);
        }
        self.publish();
        match outcome {
            Outcome::Reply { to, len } => Some((to, len)),
            Outcome::Dropped(_) => None,
        }
    }

    fn poll(&mut self) -> Option<(Endpoint, usize)> {
        let r = self.engine.poll(&mut self.app, &self.clock, &mut self.out);
        self.note_state();
        self.tick();
        self.publish();
        r
    }

    /// A turn's snapshot for the diagnostics (as a board's cycle does).
    fn publish(&mut self) {
        self.turns = self.turns.wrapping_add(1);
        let now = Snapshot::of(&self.engine, self.turns);
        self.diag.turn(&self.last, &now, self.clock.now());
        self.last = now;
    }
}

/// Runs sensor `S` for the built layout until `stop` is set (`cargo
/// sensor-host` runs the chosen one). `ready` receives the bound address
/// (useful with port 0). Log lines (what it samples, state changes,
/// statistics) go to `log`.
pub fn run<S: Sensor<layout::RobotProperties, layout::DeviceProperties>>(
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
    log: &mut dyn Write,
) -> io::Result<SensorReport> {
    run_with::<S, layout::RobotProperties, layout::DeviceProperties, { layout::MAX_RECEIVE_LEN }>(
        opts, stop, ready, log,
    )
}

/// [`run`] for any sensor `S` and layout: its property sets `R`, `D` and
/// its `MAX_RECEIVE_LEN` as `RX` (the TCP framer's size).
pub fn run_with<S: Sensor<R, D>, R: RobotSet, D: DeviceSet, const RX: usize>(
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
    log: &mut dyn Write,
) -> io::Result<SensorReport> {
    if let Source::Replay(r) = &opts.source {
        r.check::<S, R, D>().map_err(io::Error::other)?;
    }
    let cell = SampleCell::new(<S::History as Ring<S::Sample>>::EMPTY);
    let Some((writer, reader)) = cell.split() else {
        return Err(io::Error::other("sample cell already split"));
    };
    let clock = HostClock::new();
    let _ = writeln!(log, "sensor: {}", opts.source.describe::<S, R, D>());
    let mut node = Node {
        engine: Engine::<R, D>::new(opts.config),
        app: SensorApp::<S, R, D>::new(reader),
        clock,
        out: vec![0; D::MAX_SEND_LEN],
        states: Vec::new(),
        log,
        last_stats: std::time::Instant::now(),
        stats_every: opts.stats_every,
        diag: Arc::new(http::HostDiag::default()),
        last: Snapshot::default(),
        turns: 0,
    };
    node.note_state();
    let listener = match opts.http {
        Some(addr) => {
            let l = std::net::TcpListener::bind(addr)?;
            let bound = l.local_addr()?;
            let _ = writeln!(
                node.log,
                "diagnostics: http://{bound}/ (page), /status.json, /metrics"
            );
            if let Some(tx) = &opts.http_ready {
                let _ = tx.send(bound);
            }
            Some(l)
        }
        None => None,
    };
    let http_stop = Arc::new(AtomicBool::new(false));
    let result = std::thread::scope(|s| {
        // The sampling half, on a thread of its own (the board's background
        // executor): never blocks the cycle, whatever it does.
        s.spawn(|| {
            let mut sampler = Sampler::<S, R, D>::new(writer);
            opts.source.run(&mut sampler, &clock, stop);
        });
        if let Some(listener) = listener {
            let id = host_identity::<S, R, D>(
                opts,
                listener.local_addr().map(|a| a.port()).unwrap_or(0),
            );
            let (diag, flag) = (node.diag.clone(), http_stop.clone());
            s.spawn(move || http::serve(listener, diag, id, move || clock.now(), flag));
        }
        let r = if opts.tcp {
            tcp::serve::<R, D, _, RX>(&mut node, opts, stop, ready)
        } else {
            udp::serve(&mut node, opts, stop, ready)
        };
        stop.store(true, Ordering::Relaxed);
        http_stop.store(true, Ordering::Relaxed);
        r
    });
    if let Err(e) = result {
        node.engine.init_failed();
        node.note_state();
        return Err(e);
    }
    let stats = node.engine.stats();
    let _ = writeln!(node.log, "summary: {}", stats_line(&stats));
    Ok(SensorReport {
        stats,
        state: node.engine.state(),
        states: node.states,
    })
}
