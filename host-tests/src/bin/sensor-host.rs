//! `cargo sensor-host -- [--listen ADDR] [--udp|--tcp] [overrides]`
//!
//! The firmware's cycle engine and demo application on the host, with std
//! sockets, built for the same GSI configuration as the firmware
//! (`RRI_GSI_DIR`, `RRI_DEVICE`). Logs state changes and one statistics
//! line per second; Ctrl-C or SIGTERM prints a summary and exits 0.

use host_tests::sensor::{run, SensorOptions};
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

const USAGE: &str = "usage: cargo sensor-host -- [--listen ADDR:PORT] [--udp | --tcp]
                          [--timeout-ms N] [--max-lost N] [--dry-run true|false] [--send-period-ms N]

Defaults come from the built configuration (Description.xml): the device's
address and channel port, its protocol, TimeOut, MaxLost and DryRun.";

fn parse(args: &[String]) -> Result<SensorOptions, String> {
    let mut o = SensorOptions::from_layout();
    let mut i = 0;
    let value = |i: usize| {
        args.get(i + 1)
            .ok_or_else(|| format!("{} needs a value", args[i]))
    };
    while i < args.len() {
        match args[i].as_str() {
            "--listen" => {
                let v = value(i)?;
                o.listen = v.parse::<SocketAddr>().map_err(|_| {
                    format!("--listen {v}: expected ADDR:PORT, e.g. 127.0.0.1:3002")
                })?;
                i += 1;
            }
            "--udp" => o.tcp = false,
            "--tcp" => o.tcp = true,
            "--timeout-ms" => {
                o.config.timeout_ms = value(i)?
                    .parse()
                    .map_err(|_| "--timeout-ms: a number of milliseconds")?;
                i += 1;
            }
            "--max-lost" => {
                o.config.max_lost = value(i)?.parse().map_err(|_| "--max-lost: a number")?;
                i += 1;
            }
            "--dry-run" => {
                o.config.dry_run = value(i)?.parse().map_err(|_| "--dry-run: true or false")?;
                i += 1;
            }
            "--send-period-ms" => {
                let ms: u32 = value(i)?
                    .parse()
                    .map_err(|_| "--send-period-ms: a number")?;
                if !ms.is_multiple_of(4) {
                    return Err("--send-period-ms must be a multiple of 4".into());
                }
                o.config.send_period_ms = ms;
                i += 1;
            }
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other}")),
        }
        i += 1;
    }
    Ok(o)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opts = match parse(&args) {
        Ok(o) => o,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("error: {e}");
            }
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        eprintln!("error: cannot install the Ctrl-C handler: {e}");
        return ExitCode::FAILURE;
    }
    let mut out = std::io::stdout();
    match run(&opts, &stop, None, &mut out) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!(
                "error: cannot open the {} socket on {}: {e} (state ERROR 112600){}",
                if opts.tcp { "TCP" } else { "UDP" },
                opts.listen,
                if e.kind() == std::io::ErrorKind::AddrNotAvailable {
                    "; the configured address is not on this machine: try --listen 127.0.0.1:PORT or 0.0.0.0:PORT"
                } else {
                    ""
                }
            );
            ExitCode::FAILURE
        }
    }
}
