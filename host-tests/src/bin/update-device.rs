//! `cargo update-device -- --to http://DEVICE/ --image FILE`: streams a
//! signed update file (`cargo sign-image`) to a running device over its
//! diagnostics port (`PUT /firmware`) with a progress bar, prints the
//! device's answer, then what its `/status.json` says.
//!
//! Exit status: 0 when the device took the file, 1 when it refused it
//! (its reason is printed), 2 when it could not be reached.
//!
//! Not done yet (issue 43): no board swaps the image in at its next reset
//! (no bootloader image yet; the QEMU board says so), so this does not
//! wait for the device to come back with the new version.

use clap::Parser;
use host_tests::update_device::{self, answer, describe, status};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Send a signed update file to a running device (PUT /firmware)")]
struct Args {
    /// The device's diagnostics service, e.g. http://192.168.125.4/ (the
    /// QEMU board's: the address `cargo demo` prints).
    #[arg(long)]
    to: String,
    /// The update file (`cargo sign-image -- sign ... --out FILE`).
    #[arg(long)]
    image: PathBuf,
    /// Take an image older than the running one (said loudly on the device).
    #[arg(long)]
    force: bool,
    /// Send a file whose trailer this tool cannot read (the device refuses
    /// it; to see its answer).
    #[arg(long)]
    no_check: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let file = match std::fs::read(&args.image) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {}: {e}", args.image.display());
            return ExitCode::from(2);
        }
    };
    match describe(&file) {
        Ok(what) => println!("{}: {what}", args.image.display()),
        Err(e) if args.no_check => println!("{}: {e} (sent anyway)", args.image.display()),
        Err(e) => {
            eprintln!("error: {}: {e}", args.image.display());
            return ExitCode::from(1);
        }
    }
    let bar = ProgressBar::new(file.len() as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} {eta}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(format!("to {}", update_device::base(&args.to)));
    let sent = update_device::upload(&args.to, &file, file.len(), args.force, &mut |n| {
        bar.set_position(n as u64)
    });
    bar.finish();
    let response = match sent {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    println!("device: {} {}", response.status, answer(&response));
    match status(&args.to) {
        Ok((version, Some(last))) => println!("status: running {version}; last update: {last}"),
        Ok((version, None)) => println!("status: running {version}; it takes no updates"),
        Err(e) => println!("status: not read ({e})"),
    }
    if response.status == 200 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
