//! `cargo demo [-- --tcp] [--cycles N] [--warm-up N] [--send NAME=MS]…
//! [--reply NAME] [--oversize-attack]`: the whole product in one command.
//! Installs QEMU when it is missing, builds the sensor firmware for QEMU's
//! `mps2-an500` board (Cortex-M7, LAN9118 Ethernet), boots it, warms it up,
//! drives it with the robot-controller simulator (2,500 cycles at 4 ms: 10 s
//! of robot time) while showing the device's own log, and exits 0 only when
//! every reply was right and on time and the firmware is still running
//! ([`host_tests::demo`], which `cargo hil` shares).
//! `--oversize-attack` sends the attack of S5's issue after the warm-up
//! (two 9,000-byte datagrams) and then requires every robot message
//! answered.

use clap::Parser;
use host_tests::demo::{self, Failure, RunArgs, Setup};
use host_tests::qemu;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "cargo demo",
    about = "Boot the sensor firmware on QEMU (mps2-an500) and drive it with the robot simulator"
)]
struct Args {
    #[command(flatten)]
    run: RunArgs,
    /// The board: `qemu` (QEMU's mps2-an500, the default), or `f767` /
    /// `h743` for a NUCLEO image rehosted on the model of its chip (`cargo
    /// rehost`, paced to the wall clock).
    #[arg(long, default_value = "qemu", value_parser = ["qemu", "f767", "h743"])]
    board: String,
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Err(e) = args.run.check_show() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let result = if args.board == "qemu" {
        run_demo(&args.run)
    } else {
        run_rehosted(&args.board, &args.run)
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

fn run_demo(args: &RunArgs) -> Result<(), Failure> {
    let mut out = std::io::stdout();
    qemu::ensure_qemu(&mut out)?;
    let setup = Setup::new(args.tcp)?;
    println!(
        "== building the firmware for QEMU {} ({})",
        qemu::MACHINE,
        setup.gsi.display()
    );
    let name = if args.tcp { "demo-tcp" } else { "demo" };
    let elf = qemu::build_firmware(&[], setup.build_gsi.as_deref(), name)?;
    let mut args = args.clone();
    args.image = Some(elf.clone());
    let (board, to, http) = qemu::boot_local(elf, &setup.device)?;
    let ran = demo::drive(
        Box::new(board),
        &setup,
        &args,
        to,
        http,
        &demo::qemu_ready(&setup),
        &mut out,
    )?;
    demo::verdict("demo", &ran)
}

/// The demo on a rehosted NUCLEO image: the same run, summary and exit
/// codes, the engine in place of QEMU.
fn run_rehosted(board: &str, args: &RunArgs) -> Result<(), Failure> {
    let mut out = std::io::stdout();
    let setup = Setup::new(args.tcp)?;
    let (dev, to, http) = host_tests::rehost::boot(board, &setup)?;
    let ran = demo::drive(
        Box::new(dev),
        &setup,
        args,
        to,
        http,
        &host_tests::rehost::ready(),
        &mut out,
    )?;
    demo::verdict("demo", &ran)
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
