//! `cargo sensor-host -- [--listen ADDR] [--udp|--tcp] [--replay FILE.csv]
//! [overrides]`
//!
//! The firmware's cycle engine and sensor (the file `RRI_SENSOR` names,
//! default the demo's distance sensor) on the host, with std sockets,
//! built for the same GSI configuration as the firmware (`RRI_GSI_DIR`,
//! `RRI_DEVICE`). Samples are the sensor's own `simulate`, or recorded
//! ones replayed from a CSV file. Logs what it samples, state changes and
//! one statistics line per second; Ctrl-C or SIGTERM prints a summary and
//! exits 0. `--http ADDR:PORT` serves the diagnostics a board serves (the
//! firmware's own rendering: page, `/status.json`, `/metrics`).

use clap::Parser;
use host_tests::sensor::{run, Recording, SensorOptions, Source};
use rri_active_sensor::Active;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

#[derive(Parser, Debug)]
#[command(
    name = "cargo sensor-host",
    about = "The sensor firmware's cycle engine and sensor (RRI_SENSOR) on std sockets",
    after_help = "Defaults come from the built configuration (Description.xml): the device's address and channel port, its protocol, TimeOut, MaxLost and DryRun. The sensor is the file RRI_SENSOR named at build time (default firmware/src/sensors/distance.rs)."
)]
struct Args {
    /// Address and port to listen on (default: the configured device address and channel port).
    #[arg(long, value_name = "ADDR:PORT")]
    listen: Option<SocketAddr>,
    /// UDP, whatever the configuration says.
    #[arg(long, conflicts_with = "tcp")]
    udp: bool,
    /// TCP (M10 framing), whatever the configuration says.
    #[arg(long)]
    tcp: bool,
    /// S1 TimeOut in ms.
    #[arg(long, value_name = "MS")]
    timeout_ms: Option<u32>,
    /// S1 MaxLost.
    #[arg(long, value_name = "N")]
    max_lost: Option<u32>,
    /// S1 DryRun.
    #[arg(long, value_name = "true|false")]
    dry_run: Option<bool>,
    /// Send the reply property unprompted every MS ms (a multiple of 4; 0 = off).
    #[arg(long, value_name = "MS", value_parser = multiple_of_4)]
    send_period_ms: Option<u32>,
    /// Recorded samples instead of simulated ones: rows `time_s,col1,col2,...` (a header line
    /// and `#` comments allowed), replayed at their times, over and over; the columns after the
    /// time go to the sensor's `replay`.
    #[arg(long, value_name = "FILE.csv")]
    replay: Option<PathBuf>,
    /// Serve the diagnostics here: the status page (`/`), `/status.json` and `/metrics`, the
    /// same as a board's (e.g. 127.0.0.1:8080).
    #[arg(long, value_name = "ADDR:PORT")]
    http: Option<SocketAddr>,
}

fn multiple_of_4(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(ms) if ms % 4 == 0 => Ok(ms),
        _ => Err("must be a multiple of 4 ms (0 = off)".into()),
    }
}

fn options(a: &Args) -> SensorOptions {
    let mut o = SensorOptions::from_layout();
    if let Some(addr) = a.listen {
        o.listen = addr;
    }
    if a.udp {
        o.tcp = false;
    }
    if a.tcp {
        o.tcp = true;
    }
    if let Some(ms) = a.timeout_ms {
        o.config.timeout_ms = ms;
    }
    if let Some(n) = a.max_lost {
        o.config.max_lost = n;
    }
    if let Some(d) = a.dry_run {
        o.config.dry_run = d;
    }
    if let Some(ms) = a.send_period_ms {
        o.config.send_period_ms = ms;
    }
    o.http = a.http;
    o.sensor_file = rri_active_sensor::ACTIVE_FILE;
    o
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut opts = options(&args);
    if let Some(path) = &args.replay {
        match Recording::read(path) {
            Ok(r) => opts.source = Source::Replay(r),
            Err(e) => {
                eprintln!("error: --replay {e}");
                return ExitCode::from(2);
            }
        }
    }
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        eprintln!("error: cannot install the Ctrl-C handler: {e}");
        return ExitCode::FAILURE;
    }
    let mut out = std::io::stdout();
    match run::<Active>(&opts, &stop, None, &mut out) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            // Whose address it is: the command line's or the configuration's.
            let whose = if args.listen.is_some() {
                "--listen"
            } else {
                "the configured device address (Description.xml)"
            };
            let hint = if e.kind() == std::io::ErrorKind::AddrNotAvailable {
                format!("; {whose} is not an address of this machine: try --listen 127.0.0.1:PORT or 0.0.0.0:PORT")
            } else {
                String::new()
            };
            eprintln!(
                "error: cannot open the {} socket on {} ({whose}): {e} (state ERROR 112600){hint}",
                if opts.tcp { "TCP" } else { "UDP" },
                opts.listen,
            );
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod command_line {
    /// clap's own consistency checks (unique names and flags): a clash
    /// would otherwise show only as a panic in a debug build.
    #[test]
    fn is_consistent() {
        <super::Args as clap::CommandFactory>::command().debug_assert();
    }
}
