//! `cargo update-swap` (issue 43): an update's whole course on the QEMU
//! board, through its bootloader, judged from the outside (the robot's
//! replies and the device's `/status.json`):
//!
//! 1. image A (this checkout's) boots and serves the robot;
//! 2. image B (the same, `RRI_IMAGE_VERSION` one patch newer) is sent with
//!    `cargo update-device` while the robot runs: marked, and every robot
//!    message still answered (no restart while OPERATING);
//! 3. the robot stops: the device restarts into the bootloader's swap,
//!    and `update-device` sees it come back running B, on trial;
//! 4. the robot runs again: B answers every message and confirms itself
//!    at OPERATING;
//! 5. image C (another GSI layout: the robot's messages are not its own,
//!    one patch newer again) is sent and swapped in; the robot's messages
//!    reach it and it never reaches OPERATING, so after its trial it stops
//!    feeding the watchdog, and the watchdog's reset brings B back;
//! 6. the robot runs once more and B answers every message;
//! 7. the controller's configuration changes: C is sent again and
//!    swapped in, answers a robot that speaks its layout, and confirms
//!    itself at OPERATING.
//!
//! The device's log is decoded with A's table throughout: C's lines may
//! come out garbled (their table differs), which judges nothing here.
//!
//! `--board h743` and `--board f767` run the same course on a rehosted
//! NUCLEO (`cargo rehost`'s engine, paced to the wall clock while the
//! image's MAC receives: the chip's flash model takes the datasheet's
//! times, so a swap is tens of seconds of the chip's time, which the
//! engine runs free, no frame reaching the chip then; the seconds the
//! course prints are the wall clock's, the chip's own are in the
//! engine's notes printed at the end; the F767's flash in dual-bank
//! mode, as its README has the user
//! set it, after a check of A in the factory's single-bank mode, where it
//! must serve the robot and refuse the upload with 405, saying why). A product board takes no demonstration key: the three images
//! are built with a key pair made for this run
//! (`target/update-swap/<board>-key`, never the user's).

mod images;
mod single_bank;

pub use images::{build, Board, Images};

use crate::device::Device;
use crate::qemu;
use crate::robot::{run, RobotOptions};
use crate::setup::Setup;
use crate::update_device::{self, Status};
use std::net::SocketAddr;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// One step's verdict.
pub type Step = Result<String, String>;

/// The robot for `cycles` against the device; its summary's answered and
/// sent counts.
pub(crate) fn robot(
    setup: &Setup,
    to: SocketAddr,
    cycles: u64,
    first_id: u32,
) -> Result<(u64, u64), String> {
    let mut opts = RobotOptions::new(setup.gsi.clone(), to);
    opts.device = setup.device_name.clone();
    opts.cycles = cycles;
    opts.first_id = first_id;
    let mut sink = std::io::sink();
    let (summary, _) = run(&opts, &setup.device, &mut sink)?;
    Ok((summary.answered, summary.sent))
}

/// Every message answered: the step's line, or why not.
fn all_answered(what: &str, got: Result<(u64, u64), String>) -> Step {
    match got {
        Ok((answered, sent)) if answered == sent && sent > 0 => Ok(format!(
            "{what}: {answered} of {sent} robot messages answered"
        )),
        Ok((answered, sent)) => Err(format!(
            "{what}: {answered} of {sent} robot messages answered"
        )),
        Err(e) => Err(format!("{what}: the robot: {e}")),
    }
}

/// `file` sent whole with `PUT /firmware`: the device's status and its
/// one-line answer.
pub(crate) fn send_file(http: SocketAddr, file: &Path) -> Result<(u16, String), String> {
    let bytes = std::fs::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let r = update_device::upload(
        &format!("http://{http}/"),
        &bytes,
        bytes.len(),
        false,
        &mut |_| {},
    )?;
    Ok((r.status, update_device::answer(&r)))
}

/// Polls `/status.json` until `done` holds, up to `wait`.
pub(crate) fn until(
    http: SocketAddr,
    wait: Duration,
    done: &dyn Fn(&Status) -> bool,
) -> Result<Status, String> {
    let to = format!("http://{http}/");
    let end = Instant::now() + wait;
    let mut last = Err("no answer".to_string());
    while Instant::now() < end {
        last = update_device::status(&to);
        if let Ok(s) = &last {
            if done(s) {
                return Ok(s.clone());
            }
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    Err(match last {
        Ok(s) => format!("after {wait:?} the device says {s:?}"),
        Err(e) => format!("after {wait:?} the device does not answer: {e}"),
    })
}

/// `cargo update-device` (the user's command, built beside this one) on
/// `file`: its exit status and output.
fn update_device_command(
    http: SocketAddr,
    file: &Path,
    wait: u64,
) -> Result<(i32, String), String> {
    crate::cargo(
        &[
            "build",
            "--release",
            "-p",
            "host-tests",
            "--bin",
            "update-device",
        ],
        "building update-device",
    )?;
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let tool = exe.with_file_name("update-device");
    let out = Command::new(&tool)
        .args(["--to", &format!("http://{http}/"), "--image"])
        .arg(file)
        .args(["--wait", &wait.to_string()])
        .output()
        .map_err(|e| {
            format!(
                "{}: {e} (cargo build --release -p host-tests --bin update-device)",
                tool.display()
            )
        })?;
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    Ok((out.status.code().unwrap_or(-1), text))
}

/// Runs the course on a booted board; each step's line, `Err` at the
/// first that fails.
pub fn course(
    setup: &Setup,
    board: Board,
    images: &Images,
    to: SocketAddr,
    http: SocketAddr,
    say: &mut dyn FnMut(&str),
) -> Result<(), String> {
    let mut step = |r: Step| -> Result<(), String> {
        match r {
            Ok(line) => {
                say(&format!("ok   {line}"));
                Ok(())
            }
            Err(line) => {
                say(&format!("FAIL {line}"));
                Err(line)
            }
        }
    };
    let s = until(http, Duration::from_secs(20), &|s| {
        s.version == images.a_version
    })?;
    step(Ok(format!(
        "image A runs: version {}, this image {}",
        s.version,
        s.image.as_deref().unwrap_or("?")
    )))?;
    // 2. B sent while the robot runs: marked, no restart mid-run.
    let robot_run = {
        let (setup, to) = (setup.clone(), to);
        std::thread::spawn(move || robot(&setup, to, 1000, 1))
    };
    std::thread::sleep(Duration::from_secs(1));
    let sending = std::time::Instant::now();
    let (status, said) = send_file(http, &images.b_file)?;
    // How long an upload takes on this board (the device writes, hashes
    // and checks it as it comes), for the README's figures.
    let line = format!(
        "B sent while the robot runs ({} KB in {:.1} s): {status} {said}",
        std::fs::metadata(&images.b_file).map_or(0, |m| m.len() / 1000),
        sending.elapsed().as_secs_f64()
    );
    step(if status == 200 && said.contains("checked and marked") {
        Ok(line)
    } else {
        Err(line)
    })?;
    let ran = robot_run
        .join()
        .map_err(|_| "the robot's thread panicked")?;
    step(all_answered(
        "the run B was sent during (no restart while OPERATING)",
        ran,
    ))?;
    // 3. The robot stopped: the device restarts into the swap.
    let stopped = Instant::now();
    let s = until(http, board.swap_wait(), &|s| s.version == images.b_version)?;
    let back = stopped.elapsed().as_secs_f64();
    step(
        if s.image.as_deref() == Some("on trial")
            && s.last_reset.as_deref() == Some("software")
            && s.previous.as_deref() == Some(images.a_version.as_str())
        {
            Ok(format!(
                "the robot stopped: {back:.1} s later (wall clock) the device answered again, restarted (last reset: software) into B, version {}, on trial, replacing {}",
                s.version, images.a_version
            ))
        } else {
            Err(format!("after the swap to B: {s:?}"))
        },
    )?;
    // 4. B confirms itself at OPERATING.
    step(all_answered(
        "B serves the robot",
        robot(setup, to, 300, 10_000),
    ))?;
    let s = until(http, board.flash_wait(), &|s| {
        s.image.as_deref() == Some("confirmed")
    })?;
    step(Ok(format!(
        "B confirmed itself at OPERATING: version {}, {}",
        s.version,
        s.image.as_deref().unwrap_or("?")
    )))?;
    // 5. C: another layout, never OPERATING, rolled back by the watchdog.
    let (code, text) = update_device_command(http, &images.c_file, board.swap_wait().as_secs())?;
    step(
        // Its answer came before the restart (the device waits
        // `ANSWER_MS` after the mark), then the new version.
        if code == 0
            && text.contains(&format!(
                "device: 200 version {} checked and marked",
                images.c_version
            ))
            && text.contains(&format!(
                "device: running {}, replacing {}",
                images.c_version, images.b_version
            ))
        {
            Ok(format!(
                "C sent with cargo update-device: swapped in, running {} on trial, replacing {}",
                images.c_version, images.b_version
            ))
        } else {
            Err(format!(
                "C sent with cargo update-device: exit {code}:\n{text}"
            ))
        },
    )?;
    let heard = Instant::now();
    // C takes none of these as its own; the robot gives up on it.
    let _ = robot(setup, to, 250, 20_000);
    // The trial (30 s), the watchdog's 2 s, then the bootloader's swap
    // back.
    let back = until(http, board.swap_wait() + Duration::from_secs(40), &|s| {
        s.version == images.b_version
    })?;
    step(
        if back.last_reset.as_deref() == Some("watchdog")
            && back.image.as_deref() == Some("confirmed")
        {
            Ok(format!(
                "C never reached OPERATING: {:.0} s (wall clock) after the robot first reached it, the watchdog reset it and the bootloader brought B back ({}, confirmed)",
                heard.elapsed().as_secs_f64(),
                back.version
            ))
        } else {
            Err(format!("after C's trial: {back:?}"))
        },
    )?;
    // 6. B serves the robot again.
    step(all_answered(
        "B serves the robot after the rollback",
        robot(setup, to, 300, 30_000),
    ))?;
    // 7. The controller's configuration changed: C for good.
    step(new_layout(setup, board, images, to, http))?;
    Ok(())
}

/// The course's last step: the controller's configuration changed; C, built from it, is sent
/// again, swapped in, answers a robot that speaks its layout, and
/// confirms itself at OPERATING: the image for the new layout, on the
/// board's own flash, answering the robot that speaks it.
fn new_layout(
    setup: &Setup,
    board: Board,
    images: &Images,
    to: SocketAddr,
    http: SocketAddr,
) -> Step {
    let (status, said) = send_file(http, &images.c_file)?;
    if status != 200 {
        return Err(format!("C sent again: {status} {said}"));
    }
    until(http, board.swap_wait(), &|s| s.version == images.c_version)?;
    let mut changed = setup.clone();
    changed.gsi = images.c_gsi.clone();
    changed.device = gsi_config::load(&changed.gsi, setup.device_name.as_deref())
        .map_err(|f| f.to_string())?
        .device;
    let (answered, of) = robot(&changed, to, 300, 40_000)?;
    let s = until(http, board.flash_wait(), &|s| {
        s.image.as_deref() == Some("confirmed")
    })?;
    if answered == of && of > 0 && s.version == images.c_version {
        Ok(format!(
            "the controller's configuration changed: C sent again, swapped in, {answered} of {of} messages in its layout answered, version {} confirmed at OPERATING",
            s.version
        ))
    } else {
        Err(format!(
            "after C was sent again: {answered} of {of} messages in its layout answered; the device says {s:?}"
        ))
    }
}

/// Boots A on `board` and runs the course; every step's line printed.
pub fn run_all(setup: &Setup, board: Board) -> Result<(), String> {
    let images = build(setup, board)?;
    println!(
        "== images: A {} ({}), B {} ({}), C {} ({}, another layout)",
        images.a_version,
        images.a.display(),
        images.b_version,
        images.b_file.display(),
        images.c_version,
        images.c_file.display()
    );
    let (mut device, to, http): (Box<dyn Device>, SocketAddr, Option<SocketAddr>) = match board {
        Board::Qemu => {
            println!("== the QEMU board's flash (hal-board/memory/mps2-an500-flash.x):");
            let boot = crate::qemu_flash::bootloader()?;
            for line in crate::qemu_flash::table(&boot, &images.a)? {
                println!("   {line}");
            }
            let (d, to, http) = qemu::boot_local(images.a.clone(), &setup.device)?;
            (Box::new(d), to, http)
        }
        Board::H743 | Board::F767 => {
            let (Some(b), Some(engine)) = (board.nucleo(), board.rehosted()) else {
                return Err(format!("{board:?}: not a rehosted board"));
            };
            println!(
                "== the {}'s flash ({}), rehosted:",
                b.name.to_uppercase(),
                b.flash_map
            );
            let boot = crate::boards::build_boot(b)?;
            for line in crate::flash_map::table(&crate::boards::flash_map(b)?, &boot, &images.a)? {
                println!("   {line}");
            }
            if board == Board::F767 {
                match single_bank::check(setup, &images) {
                    Ok(line) => println!("update-swap: ok   {line}"),
                    Err(line) => {
                        println!("update-swap: FAIL {line}");
                        return Err(line);
                    }
                }
            }
            // Four restarts: B's swap, C's, the watchdog's reset of C and
            // C's second swap; one more allowed (a stray restart shows in
            // the steps), so that a sixth stops the run.
            let mut options = vec!["--resets", "5"];
            options.extend(board.engine_options());
            let (d, to, http) = crate::rehost::boot_elf(engine, setup, &images.a, &options)?;
            let mut d: Box<dyn Device> = Box::new(d);
            for (needle, within) in crate::rehost::ready() {
                d.wait_for(needle, within)?;
            }
            (d, to, http)
        }
    };
    let http = http.ok_or("the board's diagnostics are not forwarded")?;
    let result = course(setup, board, &images, to, http, &mut |l| {
        println!("update-swap: {l}")
    });
    let exited = device.stopped();
    let log = device.stop();
    if board != Board::Qemu {
        println!(
            "== the chip's own time (the engine's notes: from each reset until the image's MAC receives it runs free of the wall clock):"
        );
        for line in log.iter().filter(|l| {
            l.contains("system reset at cycle") || l.contains("the image's MAC receives")
        }) {
            println!("   {line}");
        }
    }
    if result.is_err() {
        if let Some(exited) = exited {
            println!("== {exited}");
        }
        println!("== the device's log (decoded with A's table):");
        for line in log
            .iter()
            .rev()
            .take(60)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
        {
            println!("device: {line}");
        }
    }
    result
}
