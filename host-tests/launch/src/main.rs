//! `cargo demo`'s launcher (issue 42 #17: the first run on a fresh
//! machine). The demo's own binary needs the host tools built (about two
//! minutes the first time) and then builds the firmware (about 50 s): one
//! after the other. This builds in a second (no dependencies), starts the
//! firmware build for the plain QEMU demo in the background, in the QEMU
//! board's own target directory (a second cargo in the same directory
//! would wait for the first's lock), and runs the demo, which builds the
//! same image in the same directory: up to date by then, or waited for.
//!
//! Only when the image is the one the demo will build: no `--board` (a
//! NUCLEO image on the model), no `--tcp` (another GSI folder), not
//! `--help` or `--version`. Its output goes to
//! `target/mps2-an500/prebuild.log`; a failure there is the demo's to
//! report (it builds the image again and shows cargo's errors).

use rri_launch::{the_plain_demo, FIRMWARE_BUILD, QEMU_TARGET_DIR};
use std::ffi::OsString;
use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};

fn main() -> ExitCode {
    let args: Vec<OsString> = std::env::args_os().skip(1).collect();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let workspace = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap_or_else(|_| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.."));
    if the_plain_demo(&args) {
        start_firmware_build(&cargo, &workspace);
    }
    let mut demo = Command::new(&cargo);
    demo.current_dir(&workspace)
        .args([
            "run",
            "--release",
            "-p",
            "host-tests",
            "--bin",
            "demo",
            "--",
        ])
        .args(&args);
    run(demo, &cargo)
}

/// Becomes the demo (as `cargo run` itself does on Unix): Ctrl-C, the
/// exit status and the terminal are then the demo's alone. The build
/// started ahead goes on in the background; the demo waits for it (it
/// builds the same image in the same directory), and if the demo stops
/// early the build ends on its own.
#[cfg(unix)]
fn run(mut demo: Command, cargo: &OsString) -> ExitCode {
    use std::os::unix::process::CommandExt;
    let e = demo.exec();
    eprintln!("error: cannot run {}: {e}", cargo.to_string_lossy());
    ExitCode::from(2)
}

#[cfg(not(unix))]
fn run(mut demo: Command, cargo: &OsString) -> ExitCode {
    match demo.status() {
        Ok(s) => ExitCode::from(s.code().and_then(|c| u8::try_from(c).ok()).unwrap_or(1)),
        Err(e) => {
            eprintln!("error: cannot run {}: {e}", cargo.to_string_lossy());
            ExitCode::from(2)
        }
    }
}

/// Starts the firmware build the demo will ask for (the same arguments
/// as `host_tests::qemu::build_firmware`, whose tests hold the two
/// equal), its output to a log file.
fn start_firmware_build(
    cargo: &OsString,
    workspace: &std::path::Path,
) -> Option<std::process::Child> {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join("target"));
    let dir = target.join(QEMU_TARGET_DIR);
    std::fs::create_dir_all(&dir).ok()?;
    let log = std::fs::File::create(dir.join("prebuild.log")).ok()?;
    let err = log.try_clone().ok()?;
    println!(
        "== building the firmware for QEMU beside the host tools (log: {})",
        dir.join("prebuild.log").display()
    );
    Command::new(cargo)
        .current_dir(workspace)
        .args(FIRMWARE_BUILD)
        .arg("--target-dir")
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(err)
        .spawn()
        .ok()
}
