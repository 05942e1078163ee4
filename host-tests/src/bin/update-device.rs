//! `cargo update-device -- --to http://DEVICE/ --image FILE`: streams a
//! signed update file (`cargo sign-image`) to a running device over its
//! diagnostics port (`PUT /firmware`) with a progress bar, prints the
//! device's answer, then waits for the device to come back running the
//! file's version (it restarts into the bootloader's swap once its
//! controller is not OPERATING) and prints what its `/status.json` says.
//!
//! Exit status: 0 when the device runs the new version, 1 when it refused
//! the file (its reason is printed), 2 when it could not be reached, 3
//! when it took the file but did not run it within `--wait` (its
//! controller still OPERATING, or a board without a bootloader).
//!
//! `--cancel` instead cancels the update the device has marked, before it
//! restarts into it (`DELETE /firmware`).

use clap::Parser;
use host_tests::update_device::{self, answer, describe, status};
use host_tests::update_file;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Parser)]
#[command(about = "Send a signed update file to a running device (PUT /firmware)")]
struct Args {
    /// The device's diagnostics service, e.g. http://192.168.125.4/ (the
    /// QEMU board's: the address `cargo demo` prints).
    #[arg(long)]
    to: String,
    /// The update file (`cargo sign-image -- sign ... --out FILE`).
    #[arg(long, required_unless_present = "cancel")]
    image: Option<PathBuf>,
    /// Cancel the update the device has marked, before it restarts into
    /// it (`DELETE /firmware`; refused when nothing is marked, or while
    /// the running image is on trial).
    #[arg(long, conflicts_with = "image")]
    cancel: bool,
    /// Take an image older than the running one (said loudly on the device).
    #[arg(long)]
    force: bool,
    /// Send a file whose trailer this tool cannot read (the device refuses
    /// it; to see its answer).
    #[arg(long)]
    no_check: bool,
    /// Seconds to wait for the device to come back running the new
    /// version (0: do not wait).
    #[arg(long, default_value_t = 120)]
    wait: u64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let Some(image) = args.image.clone() else {
        return cancel(&args.to);
    };
    let file = match std::fs::read(&image) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {}: {e}", image.display());
            return ExitCode::from(2);
        }
    };
    match describe(&file) {
        Ok(what) => println!("{}: {what}", image.display()),
        Err(e) if args.no_check => println!("{}: {e} (sent anyway)", image.display()),
        Err(e) => {
            eprintln!("error: {}: {e}", image.display());
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
    if response.status != 200 {
        match status(&args.to) {
            Ok(s) => println!(
                "status: running {}; last update: {}",
                s.version,
                s.last.as_deref().unwrap_or("none (it takes no updates)")
            ),
            Err(e) => println!("status: not read ({e})"),
        }
        return ExitCode::from(1);
    }
    let version = match update_file::trailer_of(&file) {
        Ok(t) => format!(
            "{}.{}.{}",
            t.version.major, t.version.minor, t.version.patch
        ),
        Err(_) => return ExitCode::SUCCESS,
    };
    if args.wait == 0 {
        println!("not waiting for the device to run {version} (--wait 0)");
        return ExitCode::SUCCESS;
    }
    println!(
        "waiting up to {} s for the device to run {version} (it restarts into the swap once its controller is not OPERATING)",
        args.wait
    );
    let mut said = String::new();
    let waited = update_device::wait_for(
        &args.to,
        &version,
        Duration::from_secs(args.wait),
        &mut |secs, seen| {
            let now = match seen {
                Ok(s) => format!("still running {}", s.version),
                Err(_) => "restarting (no answer)".to_string(),
            };
            if now != said {
                println!("  {secs:>3} s: {now}");
                said = now;
            }
        },
    );
    match waited {
        Ok(s) => {
            println!(
                "device: running {}{} (last reset: {}; this image: {})",
                s.version,
                s.previous
                    .as_deref()
                    .map_or(String::new(), |p| format!(", replacing {p}")),
                s.last_reset.as_deref().unwrap_or("?"),
                s.image.as_deref().unwrap_or("?")
            );
            if s.image.as_deref() == Some("on trial") {
                println!("  on trial: it confirms itself at OPERATING with its controller (or after 60 s without one); a reset before that brings the previous image back");
            }
            ExitCode::SUCCESS
        }
        Err(last) => {
            match last {
                Some(s) => println!(
                    "device: still running {} after {} s: the file is marked, and the device restarts into it once its controller is not OPERATING",
                    s.version, args.wait
                ),
                None => println!(
                    "device: no answer for {} s after it took the file",
                    args.wait
                ),
            }
            ExitCode::from(3)
        }
    }
}

/// `--cancel`: the device's answer; 0 cancelled, 1 refused, 2 unreachable.
fn cancel(to: &str) -> ExitCode {
    match update_device::cancel(to) {
        Ok(r) => {
            println!("device: {} {}", r.status, answer(&r));
            if r.status == 200 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
