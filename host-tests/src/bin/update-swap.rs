//! `cargo update-swap [-- --board h743|f767]`: an update's whole course
//! on the QEMU board, or on a rehosted NUCLEO (issue 43): a newer
//! image sent while the robot runs, swapped in by the bootloader once the
//! robot stops, confirmed at OPERATING; then an image that cannot talk to
//! the robot, rolled back by the watchdog after its trial. See
//! `host_tests::update_swap`.
//!
//! Exit status: 0 when every step held, 1 when one did not (the device's
//! log follows), 2 when the images could not be built or booted.

use clap::{Parser, ValueEnum};
use host_tests::{qemu, setup::Setup, update_swap};
use std::process::ExitCode;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Which {
    /// QEMU's mps2-an500.
    Qemu,
    /// The NUCLEO-H743ZI2 on the model of its chip (`cargo rehost`).
    H743,
    /// The NUCLEO-F767ZI on the model of its chip, its flash in
    /// dual-bank mode.
    F767,
}

#[derive(Parser, Debug)]
#[command(
    name = "cargo update-swap",
    about = "An update's whole course (swap, confirmation, rollback) on the QEMU board or a rehosted NUCLEO"
)]
struct Args {
    /// Where the course runs.
    #[arg(long, value_enum, default_value_t = Which::Qemu)]
    board: Which,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let board = match args.board {
        Which::Qemu => update_swap::Board::Qemu,
        Which::H743 => update_swap::Board::H743,
        Which::F767 => update_swap::Board::F767,
    };
    let mut out = std::io::stdout();
    let tools = match board {
        update_swap::Board::Qemu => qemu::ensure_qemu(&mut out),
        update_swap::Board::H743 | update_swap::Board::F767 => {
            host_tests::rehost::ensure_build_tools(&mut out)
        }
    };
    if let Err(e) = tools {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let setup = match Setup::new(false) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    match update_swap::run_all(&setup, board) {
        Ok(()) => {
            println!("update-swap: every step held");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod command_line {
    #[test]
    fn is_consistent() {
        <super::Args as clap::CommandFactory>::command().debug_assert();
    }
}
