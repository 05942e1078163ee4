//! [`Background`]: a host sensor in a thread of its own on 127.0.0.1, an
//! ephemeral port, for tests (the demo's sensor, or any, fed simulated or
//! recorded samples), stopped with its report.

use super::{run_with, DemoSensor, SensorOptions, SensorReport, Source, DEMO_SENSOR_FILE};
use rri_firmware::engine::Config;
use rri_firmware::layout;
use rri_firmware::properties::{DeviceSet, RobotSet};
use rri_firmware::sensor::Sensor;
use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

/// A host sensor on `127.0.0.1`, an ephemeral port, in a thread of its own
/// (for tests): [`Background::stop`] ends it and returns its report.
pub struct Background {
    pub addr: SocketAddr,
    /// Where its diagnostics answer ([`Background::start_diagnosed`]).
    pub http: Option<SocketAddr>,
    stop: Arc<AtomicBool>,
    thread: JoinHandle<io::Result<SensorReport>>,
}

impl Background {
    /// Starts the demo's sensor ([`DemoSensor`], simulated samples; UDP,
    /// or TCP) with `config`, for the layout the firmware was built for;
    /// waits until it listens.
    pub fn start(tcp: bool, config: Config) -> io::Result<Background> {
        Self::start_sensor::<DemoSensor>(tcp, config, Source::Simulated)
    }

    /// [`Background::start`] with its diagnostics served on an ephemeral
    /// port of 127.0.0.1 ([`Background::http`]).
    pub fn start_diagnosed(tcp: bool, config: Config) -> io::Result<Background> {
        Self::start_with::<
            DemoSensor,
            layout::RobotProperties,
            layout::DeviceProperties,
            { layout::MAX_RECEIVE_LEN },
        >(tcp, config, layout::DEVICE_NAME, Source::Simulated, true)
    }

    /// Starts sensor `S` (any, for the built layout) fed by `source`: how
    /// a test runs a sensor against the robot simulator.
    pub fn start_sensor<S>(tcp: bool, config: Config, source: Source) -> io::Result<Background>
    where
        S: Sensor<layout::RobotProperties, layout::DeviceProperties> + 'static,
    {
        Self::start_with::<
            S,
            layout::RobotProperties,
            layout::DeviceProperties,
            { layout::MAX_RECEIVE_LEN },
        >(tcp, config, layout::DEVICE_NAME, source, false)
    }

    /// Starts it for another layout (`host_tests::layouts`): its property
    /// sets `R`, `D` and its `MAX_RECEIVE_LEN` as `RX`, with the demo's
    /// distance sensor (which works with any layout).
    pub fn start_layout<R, D, const RX: usize>(
        tcp: bool,
        config: Config,
        device_name: &'static str,
    ) -> io::Result<Background>
    where
        R: RobotSet + Send + 'static,
        D: DeviceSet + Send + 'static,
    {
        Self::start_with::<rri_firmware::sensors::distance::Distance, R, D, RX>(
            tcp,
            config,
            device_name,
            Source::Simulated,
            false,
        )
    }

    /// The general form: sensor `S` on layout `R`, `D` (`RX`: its
    /// `MAX_RECEIVE_LEN`), its diagnostics served when `http`.
    pub fn start_with<S, R, D, const RX: usize>(
        tcp: bool,
        config: Config,
        device_name: &'static str,
        source: Source,
        http: bool,
    ) -> io::Result<Background>
    where
        S: Sensor<R, D> + 'static,
        R: RobotSet + Send + 'static,
        D: DeviceSet + Send + 'static,
    {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let (http_tx, http_rx) = mpsc::channel();
        let opts = SensorOptions {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            tcp,
            config,
            stats_every: None,
            device_name,
            source,
            http: http.then(|| SocketAddr::from(([127, 0, 0, 1], 0))),
            http_ready: Some(http_tx),
            sensor_file: DEMO_SENSOR_FILE,
        };
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            run_with::<S, R, D, RX>(&opts, &flag, Some(tx), &mut std::io::sink())
        });
        let http = if http {
            Some(
                http_rx
                    .recv_timeout(Duration::from_secs(5))
                    .map_err(|_| io::Error::other("the diagnostics did not start listening"))?,
            )
        } else {
            None
        };
        let addr = rx
            .recv_timeout(Duration::from_secs(5))
            .map_err(|_| io::Error::other("the sensor did not start listening"))?;
        Ok(Background {
            addr,
            http,
            stop,
            thread,
        })
    }

    /// Stops it; its report, or the error that ended it early.
    pub fn stop(self) -> io::Result<SensorReport> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .map_err(|_| io::Error::other("the sensor thread panicked"))?
    }
}
