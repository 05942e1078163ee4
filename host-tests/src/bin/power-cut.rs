//! `cargo power-cut [-- --board f767] [-- --all] [-- --tear]`: the power cut at a
//! flash operation of an update on a rehosted NUCLEO (issue 43: the
//! NUCLEO-H743ZI2 by default, the F767 in dual-bank mode), and the board after
//! it: the upload's cut must leave the old image answering and taking
//! the file again, the swap's must be finished by the bootloader and the
//! new image answer. See `host_tests::power_cut`.
//!
//! Exit status: 0 when every cut ended so; 1 when one did not, or when
//! the images could not be built or the censuses not made (the first
//! error is said); 2 when the build tools or the GSI folder are missing.

use clap::{Parser, ValueEnum};
use host_tests::{power_cut, setup::Setup};
use std::process::ExitCode;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Which {
    /// The NUCLEO-H743ZI2 on the model of its chip (`cargo rehost`).
    H743,
    /// The NUCLEO-F767ZI on the model of its chip, its flash in
    /// dual-bank mode.
    F767,
}

#[derive(Parser, Debug)]
#[command(
    name = "cargo power-cut",
    about = "Cut the power at flash operations of an update on a rehosted NUCLEO, and check the board after each"
)]
struct Args {
    /// The board.
    #[arg(long, value_enum, default_value_t = Which::H743)]
    board: Which,
    /// Cut at the first and the last operation of every run of one kind
    /// in one partition by one program (61 cuts on the H743, about 16 minutes), not only
    /// at the few chosen ones.
    #[arg(long)]
    all: bool,
    /// Each cut tears the operation it falls on. On the H743 the flash
    /// words it reached are left with an ECC their bits disagree with,
    /// each read of one a double ECC error until the sector's erase; on
    /// the F767 (no ECC) each bit it was changing changed or not, and
    /// reads back so. Without it the power fails as the operation starts.
    #[arg(long)]
    tear: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let board = match args.board {
        Which::H743 => host_tests::update_swap::Board::H743,
        Which::F767 => host_tests::update_swap::Board::F767,
    };
    if let Err(e) = host_tests::rehost::ensure_build_tools(&mut std::io::stdout()) {
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
    let kind = if args.tear {
        power_cut::CutKind::Tearing
    } else {
        power_cut::CutKind::Before
    };
    match power_cut::run_all(&setup, board, args.all, kind) {
        Ok(()) => ExitCode::SUCCESS,
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
