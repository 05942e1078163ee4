//! `cargo hil -- --board f767|h743|qemu [--to ADDR[:PORT]] [--probe SEL]
//! [--elf PATH] [--features F]... [--fault] [--inject SPEC]... [--cycles N] [--warm-up N]
//! [--tcp] [--send NAME=MS]... [--reply NAME]`: the hardware acceptance
//! run, the first real board in one command.
//!
//! On a NUCLEO (ST-LINK on USB, Ethernet to this computer's network):
//! checks that probe-rs and a probe are there (saying in one line what is
//! missing, exit status 4, before building anything), builds the firmware
//! with the `bench` feature (per-message cycle counts from the DWT), checks
//! the image's memory placement, flashes and runs it with `probe-rs run`
//! (the defmt log through the probe), waits for the banner, the Ethernet
//! link and the first state, drives it with the robot simulator after a
//! warm-up exactly as `cargo demo` does, and prints the same summary plus
//! the device's own latency per message (compute and full path, in DWT
//! cycles and µs), its codec figures at boot and its stack margin.
//! `--board qemu` runs the same harness against the QEMU board (no
//! probe), which CI does.
//!
//! `--fault` checks the fault handlers instead: the image executes an
//! undefined instruction at the end of its start-up; the run passes when
//! the fault is logged with its registers and (on QEMU, where it can be
//! seen) the board restarts, reports it from the crash record, then
//! recurses until the stack reaches its MPU guard, logs a stack overflow,
//! restarts and reports that too.
//!
//! Exit status: 0 passed; 1 failed; 2 bad arguments; 3 every reply right
//! but late (as `cargo demo`); 4 nothing to run on (probe-rs or the probe
//! missing).

use clap::{CommandFactory, FromArgMatches, Parser};
use host_tests::demo::{self, Device, Failure, RunArgs, Setup};
use host_tests::hil::{self, DeviceFigures, HilBoard};
use host_tests::probe::{self, ProbeRun};
use host_tests::qemu;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Exit status when probe-rs or the probe is missing.
const NOTHING_TO_RUN_ON: u8 = 4;

#[derive(Parser, Debug)]
#[command(
    name = "cargo hil",
    about = "Build, flash and run the firmware on a NUCLEO board (probe-rs) or the QEMU board, drive it with the robot simulator, and report the device's own latency and stack margin"
)]
struct Args {
    /// The board: f767 (NUCLEO-F767ZI), h743 (NUCLEO-H743ZI2), qemu (QEMU's mps2-an500), or
    /// f767-rehosted / h743-rehosted (the NUCLEO image on the model of its chip, `cargo rehost`).
    #[arg(long, value_parser = ["f767", "h743", "qemu", "f767-rehosted", "h743-rehosted"])]
    board: String,
    /// The device's address, ADDR or ADDR:PORT (default: Description.xml's Network Address and
    /// the channel's port). Not for qemu (its port is forwarded from 127.0.0.1).
    #[arg(long)]
    to: Option<String>,
    /// Which debug probe, as probe-rs names it (VID:PID or VID:PID:SERIAL), when several are connected.
    #[arg(long)]
    probe: Option<String>,
    /// Run this firmware image instead of building one (a `bench` build for this board).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// More cargo features for the firmware build (repeatable), e.g. hal-board/dcache-off.
    #[arg(long = "features", value_name = "FEATURE")]
    features: Vec<String>,
    /// Check the fault handlers (an image that faults on purpose, then overflows its stack) instead
    /// of driving the device.
    #[arg(long)]
    fault: bool,
    /// No probe: the board already runs this firmware; drive it over Ethernet alone and take the
    /// device's own latency and stack from its /status.json (on qemu: the same, on the QEMU
    /// board, its log unread).
    #[arg(long, conflicts_with_all = ["probe", "elf", "fault"])]
    no_probe: bool,
    #[command(flatten)]
    run: RunArgs,
}

/// The command line: the simulator's `--fault SPEC` is `--inject SPEC`
/// here, since `--fault` is this command's HardFault check.
fn command() -> clap::Command {
    Args::command().mut_arg(host_tests::run_args::FAULT_ARG, |a| a.long("inject"))
}

fn main() -> ExitCode {
    let args = match Args::from_arg_matches(&command().get_matches()) {
        Ok(args) => args,
        Err(e) => e.exit(),
    };
    let Some(board) = hil::board(&args.board) else {
        eprintln!("error: unknown board {}", args.board);
        return ExitCode::from(2);
    };
    if board.chip.is_some() && !args.no_probe {
        if let Err(missing) = probe::check(args.probe.as_deref()) {
            eprintln!("error: {}", missing.line());
            return ExitCode::from(NOTHING_TO_RUN_ON);
        }
    } else if args.to.is_some() || args.probe.is_some() {
        eprintln!("error: --to and --probe are for the NUCLEO boards (QEMU's and the rehosted boards' ports are forwarded from 127.0.0.1)");
        return ExitCode::from(2);
    }
    match hil_run(board, &args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

fn hil_run(board: &HilBoard, args: &Args) -> Result<(), Failure> {
    let mut out = std::io::stdout();
    if board.is_qemu() {
        qemu::ensure_qemu(&mut out)?;
    }
    let setup = Setup::new(args.run.tcp)?;
    if args.no_probe && board.chip.is_some() {
        return over_ethernet(args, &setup);
    }
    let elf = match &args.elf {
        Some(elf) => elf.clone(),
        None => build(board, args, &setup)?,
    };
    hil::check_image(board, &elf)?;
    let (dev, to, http) = start(board, args, &setup, elf)?;
    if args.fault {
        return fault(dev, board);
    }
    let mut dev = dev;
    let mut ready = Vec::new();
    if !board.is_qemu() {
        // Flashing comes first, then the banner; the link takes the PHY's
        // auto-negotiation (about 2 s).
        wait(&mut *dev, "rri-sensor", 60, "")?;
        wait(
            &mut *dev,
            "link up",
            15,
            "no Ethernet link: is the cable in, and does the other end auto-negotiate 100 Mbit/s full duplex? (see the device's PHY lines above)",
        )?;
        if setup.device.channel.protocol != gsi_config::Protocol::Tcp {
            ready.push(("state CONNECTED", Duration::from_secs(10)));
        }
    } else {
        ready = demo::qemu_ready(&setup);
    }
    println!(
        "== driving {} at {to}",
        match (board.chip, board.rehosted) {
            (Some(_), _) => "the board",
            (None, Some(_)) => "the image rehosted on the model of its chip",
            (None, None) => "the QEMU board",
        }
    );
    // Without a probe, the device's own figures come from /status.json,
    // read before the QEMU board stops with the run.
    let run = RunArgs {
        figures_from_status: args.no_probe,
        ..args.run.clone()
    };
    let ran = demo::drive(dev, &setup, &run, to, http, &ready, &mut out)?;
    if args.no_probe {
        // The QEMU board with its log unread: as a real board without a probe.
        demo::verdict("hil", &ran)?;
        return ran.figures.unwrap_or(Ok(())).map_err(Failure::from);
    }
    let figures = DeviceFigures::of(&ran.log);
    let csv = qemu::target_dir()
        .join("hil")
        .join(format!("{}-messages.csv", board.key));
    figures.write_csv(&csv)?;
    let device = figures.print(board, &mut out);
    println!("  per-message records: {}", csv.display());
    demo::verdict("hil", &ran)?;
    device.map_err(Failure::from)
}

/// Builds the bench image for `board` into `target/hil/`.
fn build(board: &HilBoard, args: &Args, setup: &Setup) -> Result<PathBuf, String> {
    let mut extra: Vec<&str> = vec!["bench"];
    if args.fault {
        extra.push("hal-board/fault-selftest");
    }
    extra.extend(args.features.iter().map(String::as_str));
    // A larger RTT buffer for the bench's line per message (the log never
    // blocks the firmware: a full buffer drops lines).
    let env: &[(&str, &str)] = if !board.is_qemu() {
        &[("DEFMT_RTT_BUFFER_SIZE", "4096")]
    } else {
        &[]
    };
    let name = format!("{}{}", board.key, if args.fault { "-fault" } else { "" });
    println!(
        "== building the bench firmware for {} ({}; features {})",
        board.key,
        setup.gsi.display(),
        extra.join(",")
    );
    qemu::build_board(
        &format!("board,{}", board.feature),
        &extra,
        setup.build_gsi.as_deref(),
        env,
        "hil",
        &name,
    )
}

/// `--no-probe` on a NUCLEO: the board already runs; drive it at its
/// address, then read its own figures from `/status.json`.
fn over_ethernet(args: &Args, setup: &Setup) -> Result<(), Failure> {
    let to = match &args.to {
        None => setup.channel()?,
        Some(t) => parse_to(t, setup.device.channel.port)?,
    };
    let http = SocketAddr::new(to.ip(), qemu::HTTP_PORT);
    println!("== no probe: driving the board at {to}, its figures from http://{http}/status.json");
    let run = RunArgs {
        figures_from_status: true,
        ..args.run.clone()
    };
    let ran = demo::drive(
        Box::new(host_tests::demo::Unlogged),
        setup,
        &run,
        to,
        Some(http),
        &[],
        &mut std::io::stdout(),
    )?;
    demo::verdict("hil", &ran)?;
    ran.figures.unwrap_or(Ok(())).map_err(Failure::from)
}

/// A started device, where the simulator reaches it, and where its
/// diagnostics answer.
type Started = (Box<dyn Device>, SocketAddr, Option<SocketAddr>);

/// Starts the device: `probe-rs run` on a NUCLEO, QEMU for `qemu`; where
/// the simulator reaches it, and its diagnostics.
fn start(board: &HilBoard, args: &Args, setup: &Setup, elf: PathBuf) -> Result<Started, String> {
    match board.chip {
        Some(chip) => {
            let to = match &args.to {
                None => setup.channel()?,
                Some(t) => parse_to(t, setup.device.channel.port)?,
            };
            // The bootloader first: the chip starts it, and it starts
            // the image (issue 43).
            let b = host_tests::boards::BOARDS
                .iter()
                .find(|b| Some(b.name) == board.map)
                .ok_or_else(|| format!("no memory map for {}", board.key))?;
            let boot = host_tests::boards::build_boot(b)?;
            println!(
                "== flashing the bootloader {} on {chip} with probe-rs",
                boot.display()
            );
            probe::download(chip, &boot, args.probe.as_deref())?;
            println!(
                "== flashing and running {} on {chip} with probe-rs",
                elf.display()
            );
            let cmd = probe::command(chip, &elf, args.probe.as_deref(), !args.fault);
            let http = SocketAddr::new(to.ip(), qemu::HTTP_PORT);
            Ok((Box::new(ProbeRun::start(cmd)?), to, Some(http)))
        }
        None => match board.rehosted {
            Some(engine_board) => {
                // `--fault` restarts the chip twice (the fault, then the
                // stack overflow): the model restarts it as often.
                let resets = if args.fault { "3" } else { "0" };
                let (dev, to, http) =
                    host_tests::rehost::boot_elf(engine_board, setup, &elf, &["--resets", resets])?;
                Ok((Box::new(dev), to, http))
            }
            None => {
                let (board, to, http) = qemu::boot_local(elf, &setup.device)?;
                Ok((Box::new(board), to, http))
            }
        },
    }
}

/// `ADDR` or `ADDR:PORT`.
fn parse_to(text: &str, port: u16) -> Result<SocketAddr, String> {
    text.parse::<SocketAddr>()
        .or_else(|_| {
            text.parse::<std::net::IpAddr>()
                .map(|ip| SocketAddr::new(ip, port))
        })
        .map_err(|_| format!("--to {text}: not ADDR or ADDR:PORT"))
}

/// Waits for a line, printing the log so far and `hint` when it does not
/// come.
fn wait(dev: &mut dyn Device, needle: &str, seconds: u64, hint: &str) -> Result<(), String> {
    dev.wait_for(needle, Duration::from_secs(seconds))
        .map_err(|e| {
            for line in dev.take_new() {
                println!("device: {line}");
            }
            if hint.is_empty() {
                e
            } else {
                format!("{e}\n{hint}")
            }
        })
}

/// `--fault`: the handler's log line, and on QEMU the restart.
fn fault(mut dev: Box<dyn Device>, board: &HilBoard) -> Result<(), Failure> {
    // A real board's restart ends probe-rs's run; QEMU and the model
    // restart and go on logging.
    let restart_visible = board.chip.is_none();
    let result = hil::fault_check(&mut *dev, Duration::from_secs(60), restart_visible);
    for line in dev.stop() {
        println!("device: {line}");
    }
    let seen = result?;
    println!("hil --fault: {seen}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_to;

    #[test]
    fn to_takes_an_address_with_or_without_port() {
        assert_eq!(
            parse_to("192.168.125.4", 3002).unwrap(),
            "192.168.125.4:3002".parse().unwrap()
        );
        assert_eq!(
            parse_to("192.168.125.4:4000", 3002).unwrap(),
            "192.168.125.4:4000".parse().unwrap()
        );
        assert!(parse_to("robot", 3002).is_err());
    }

    /// clap's own consistency checks (unique names and flags): a clash
    /// would otherwise show only as a panic in a debug build.
    #[test]
    fn the_command_line_is_consistent() {
        super::command().debug_assert();
    }

    /// `--inject` reaches the simulator's faults; `--fault` stays the
    /// HardFault check.
    #[test]
    fn inject_is_the_simulators_fault_and_fault_the_hardfault_check() {
        use clap::FromArgMatches;
        let m = super::command()
            .try_get_matches_from(["hil", "--board", "qemu", "--inject", "drop:1", "--fault"])
            .unwrap();
        let args = super::Args::from_arg_matches(&m).unwrap();
        assert!(args.fault);
        assert_eq!(args.run.fault.len(), 1);
    }
}
