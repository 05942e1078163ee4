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
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Err(e) = args.run.check_show() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    match run_demo(&args.run) {
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
    let (board, to, http) = qemu::boot_local(elf, &setup.device)?;
    let ran = demo::drive(
        Box::new(board),
        &setup,
        args,
        to,
        http,
        &demo::qemu_ready(&setup),
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
