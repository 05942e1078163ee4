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
use std::io::{self, Write};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

mod tcp;
mod udp;

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
            tcp::serve::<R, D, RX>(&mut sensor, opts, stop, ready)
        } else {
            udp::serve(&mut sensor, opts, stop, ready)
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
