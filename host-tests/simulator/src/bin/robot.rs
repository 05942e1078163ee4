//! `cargo robot -- --gsi DIR [--device NAME] --to ADDR [--cycles N]
//! [--rate-ms 4] [--send NAME=MS]… [--reply NAME] [--tcp] [--csv FILE]
//! [--plot FILE.svg|.png] [--pcap FILE] [--json FILE] [--fault SPEC]…
//! [--show FIELD,… [--show-csv FILE] [--show-plot FILE.svg|.png]]
//! [--replay FILE.pcap[ng] [--conversation ADDR:PORT] [--every MS |
//! --as-fast] [--tolerance [FIELD=]TOL]… [--ignore FIELD]… [--ignore-values]
//! [--diff FILE.csv]] [--extract DIR | --describe]`
//!
//! Plays the robot controller against any RRI sensor, with messages it
//! makes or (`--replay`) those of a capture from a cell. Exit status 0 if
//! and only if supervision never tripped, every reply was correct (with
//! `--replay`: matched the recorded one) and every output was written; 1
//! with the reason on stderr otherwise; 2 for bad arguments (clap's usage
//! errors), a bad GSI folder or a capture that cannot be replayed.

use clap::Parser;
use rri_robot::args::{multiple_of_4, plot_path, Properties, ReplayArgs, ShowArgs};
use rri_robot::fault::{Fault, SPECS, UDP_ONLY};
use rri_robot::{load, run, RobotOptions};
use std::io::IsTerminal;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "cargo robot",
    about = "Play the ABB robot controller's side of RRI against any sensor, from its GSI folder",
    after_help = format!(
        "Faults: {SPECS}; {UDP_ONLY} only over UDP.\n\
         Exit status: 0 when supervision never tripped, every reply was right and every output was written; 1 otherwise; 2 for bad arguments or a bad GSI folder."
    )
)]
struct Args {
    /// The controller's HOME/GSI folder (Settings.xml and one folder per device).
    #[arg(long, value_name = "DIR")]
    gsi: PathBuf,
    /// The client of Settings.xml (required when it lists several).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
    /// The sensor's address, e.g. 127.0.0.1:3002.
    #[arg(long, value_name = "ADDR:PORT", required_unless_present_any = ["extract", "describe"])]
    to: Option<SocketAddr>,
    /// Controller cycles to run (with --send: cycles of the greatest common period).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..))]
    cycles: u64,
    /// Send period of the default property, a positive multiple of 4 ms.
    #[arg(long, default_value_t = 4, value_parser = multiple_of_4)]
    rate_ms: u32,
    #[command(flatten)]
    properties: Properties,
    #[command(flatten)]
    show: ShowArgs,
    /// TCP instead of UDP (M10 framing).
    #[arg(long)]
    tcp: bool,
    /// One row per message: id, send and reply time, latency, late, verdict, property.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Latency histogram and latency over time (.svg or .png).
    #[arg(long, value_name = "FILE", value_parser = plot_path)]
    plot: Option<PathBuf>,
    /// The exchanged messages, for Wireshark (.pcapng for pcapng, else pcap).
    #[arg(long, value_name = "FILE")]
    pcap: Option<PathBuf>,
    /// The summary, for scripts.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Inject a fault (repeatable), e.g. drop:1 or pause:100:50.
    #[arg(long, value_name = "SPEC", value_parser = Fault::parse)]
    fault: Vec<Fault>,
    /// Seed of the fault injection (the same seed gives the same faults).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The first message Id (to watch the u32 wrap).
    #[arg(long, default_value_t = 1)]
    first_id: u32,
    /// Send the next message as soon as the last is answered (lock-step).
    #[arg(long)]
    no_pacing: bool,
    /// No live progress line (it is shown on a terminal).
    #[arg(long)]
    no_progress: bool,
    /// Read the device's diagnostics (its /status.json, e.g. http://10.49.65.74/) before and
    /// after the run and print its counts beside the simulator's, naming every disagreement.
    #[arg(long, value_name = "URL")]
    device_status: Option<String>,
    #[command(flatten)]
    replay: ReplayArgs,
    /// Write the robot messages of the capture given with --replay to DIR, one file each (a
    /// corpus for cargo qemu-bench -- --corpus DIR and the fuzz targets), and replay nothing.
    #[arg(long, value_name = "DIR", requires = "replay")]
    extract: Option<PathBuf>,
    /// Describe the capture given with --replay and replay nothing (no sensor needed): what the
    /// controller sent (Ids, gaps, restarts, malformed datagrams, the longest pause) and what
    /// came back (each reply paired with its message, late ones, replies to nothing).
    #[arg(long, requires = "replay", conflicts_with = "extract")]
    describe: bool,
}

fn options(a: Args) -> (RobotOptions, bool) {
    let describe = a.describe;
    (options_of(a), describe)
}

fn options_of(a: Args) -> RobotOptions {
    let to =
        a.to.unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], 0)));
    let mut o = RobotOptions::new(a.gsi, to);
    a.replay.apply(&mut o);
    if let Some(r) = &mut o.replay {
        r.extract = a.extract;
    }
    o.device = a.device;
    o.cycles = a.cycles;
    o.rate_ms = a.rate_ms;
    a.properties.apply(&mut o);
    a.show.apply(&mut o);
    o.tcp = a.tcp;
    o.csv = a.csv;
    o.plot = a.plot;
    o.pcap = a.pcap;
    o.json = a.json;
    o.faults = a.fault;
    o.seed = a.seed;
    o.first_id = a.first_id;
    o.pacing = !a.no_pacing;
    o.progress = !a.no_progress && std::io::stderr().is_terminal();
    o.device_status = a.device_status;
    o
}

fn main() -> ExitCode {
    let (opts, describe) = options(Args::parse());
    let device = match load(&opts) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let mut out = std::io::stdout();
    if describe {
        return match rri_robot::describe(&opts, &device) {
            Ok(d) => {
                let _ = d.print(&mut out);
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        };
    }
    if let Some(dir) = opts
        .replay
        .as_ref()
        .and_then(|r| r.extract.as_ref().map(|d| (r, d)))
    {
        let (r, dir) = dir;
        return match rri_robot::replay::load(r, &device)
            .and_then(|conv| rri_robot::replay::extract(&conv, dir).map(|n| (conv, n)))
        {
            Ok((conv, n)) => {
                println!(
                    "{n} robot messages of {} ↔ {} written to {}",
                    conv.controller,
                    conv.device,
                    dir.display()
                );
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        };
    }
    match run(&opts, &device, &mut out) {
        Ok((summary, _)) => {
            let _ = summary.print(&mut out);
            match summary.failure() {
                None => ExitCode::SUCCESS,
                Some(reason) => {
                    eprintln!("error: {reason}");
                    ExitCode::FAILURE
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
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
