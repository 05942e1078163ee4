//! `cargo update-swap`: an update's whole course on the QEMU board
//! (issue 43): a newer image sent while the robot runs, swapped in by the
//! bootloader once the robot stops, confirmed at OPERATING; then an image
//! that cannot talk to the robot, rolled back by the watchdog after its
//! trial. See `host_tests::update_swap`.
//!
//! Exit status: 0 when every step held, 1 when one did not (the device's
//! log follows), 2 when the images could not be built or booted.

use host_tests::{qemu, setup::Setup, update_swap};
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut out = std::io::stdout();
    if let Err(e) = qemu::ensure_qemu(&mut out) {
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
    match update_swap::run_all(&setup) {
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
