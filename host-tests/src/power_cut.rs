//! `cargo power-cut` (issue 43): the power cut at a flash operation of an
//! update, on a rehosted NUCLEO (the H743; the F767 with `--board f767`,
//! its flash in dual-bank mode), and what the board does when it comes
//! back.
//!
//! The engine counts every flash operation (a flash-word program, a
//! sector erase) and with `--power-cut N` cuts the power as the Nth
//! starts: nothing of it reaches the array, the chip powers up again with
//! its SRAM lost and its flash kept. With `--tear` the cut falls inside
//! the operation instead: on the H743 the words it reached are left with
//! an ECC their bits disagree with, each read of one a double ECC error
//! until the sector's erase; on the F767 (no ECC) each bit it was
//! changing changed or not, and reads back so. Two censuses find the
//! operations:
//!
//! - **the upload**: image A runs, B is sent with `PUT /firmware`; the
//!   device erases and programs the update partition, then marks the
//!   state partition, and restarts into the swap (the engine stops there,
//!   keeping the flash: B marked);
//! - **the swap**: from that flash the bootloader swaps B in page by page
//!   (recording its progress in the state partition), then B boots,
//!   answers the robot and confirms itself at OPERATING.
//!
//! Each cut is then made in a run of its own, and judged by what the
//! issue asks: the board comes back running a whole, signed image and
//! answers its controller. More precisely, after a cut in the upload A
//! must come back, answer the robot and take B (sent again, or carried
//! by the client's own retry), or B answer when the cut fell after its
//! mark (the note after it); after a cut in the
//! swap the bootloader must finish it and B answer; after a cut in B's
//! confirmation B or A (brought back: B never finished confirming
//! itself) must answer; after a torn cut, A or B. By default a few
//! operations are cut, where a design usually breaks (the state
//! partition's erase while marking, the first erase of the active
//! partition, the first program of the swap's last active page, the
//! swap's last progress mark, the confirmation's first write and its
//! erase), and on the H743 the swap's last progress mark once more,
//! torn; `--all` cuts the first and the last operation of every run of
//! operations of one kind, in one partition, by one program; `--tear`
//! tears every cut it makes.

use crate::device::Device;
use crate::setup::Setup;
use crate::update_swap::{self, Board, Images};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod census;
mod exact;

pub use census::{parse_census, points, runs, torn_point, Op, Phase, Run};

/// Robot messages after the swap, in virtual time at the 4 ms cycle:
/// long enough for B's confirmation at OPERATING (its erase of the state
/// partition, then its mark) to be in the swap's census: 4 s on the H743
/// (a 2 s erase), 10 s on the F767 (the model's 4 s for a 128K sector).
fn robot_messages(board: Board) -> u64 {
    match board {
        Board::F767 => 2500,
        _ => 1000,
    }
}

/// What a cut ended in: one line, `Err` when the board did not come back
/// as it must.
pub type Verdict = Result<String, String>;

/// The engine's name for `board`.
fn engine(board: Board) -> Result<&'static str, String> {
    board
        .rehosted()
        .ok_or_else(|| format!("{board:?}: not a rehosted board"))
}

/// Where this command keeps its files.
fn work_dir() -> Result<PathBuf, String> {
    let dir = crate::qemu::target_dir().join("power-cut");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

/// The upload's census: A boots, B is sent, the device restarts into the
/// swap and the engine stops there (no reset allowed), keeping the flash.
fn upload_census(
    setup: &Setup,
    board: Board,
    images: &Images,
    dir: &Path,
) -> Result<Vec<Op>, String> {
    let (census, marked) = (dir.join("upload.census"), dir.join("marked.flash"));
    let _ = std::fs::remove_file(&census);
    let (census_arg, marked_arg) = (census.display().to_string(), marked.display().to_string());
    let mut extra = vec![
        "--flash-census",
        &census_arg,
        "--flash-out",
        &marked_arg,
        "--resets",
        "0",
    ];
    extra.extend(board.engine_options());
    let (mut d, _to, http) = crate::rehost::boot_elf(engine(board)?, setup, &images.a, &extra)?;
    for (needle, within) in crate::rehost::ready() {
        d.wait_for(needle, within)?;
    }
    let http = http.ok_or("the board's diagnostics are not forwarded")?;
    let (status, said) = update_swap::send_file(http, &images.b_file)?;
    if !(status == 200 && said.contains("checked and marked")) {
        return Err(format!("B's upload: {status} {said}"));
    }
    let end = Instant::now() + Duration::from_secs(120);
    while d.stopped().is_none() {
        if Instant::now() > end {
            return Err("the device did not restart into the swap within 120 s".into());
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let text =
        std::fs::read_to_string(&census).map_err(|e| format!("{}: {e}", census.display()))?;
    parse_census(&text)
}

/// How the power fails at a cut: before the operation starts (nothing
/// of it reaches the flash), or inside it (`--tear`, the engine's: the
/// H743's words it reached torn, each read of one a double ECC error
/// until the sector's erase; on the F767 a mix of the bits it was
/// changing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CutKind {
    Before,
    Tearing,
}

impl CutKind {
    /// The engine's options for it.
    fn options(self) -> &'static [&'static str] {
        match self {
            CutKind::Before => &[],
            CutKind::Tearing => &["--tear"],
        }
    }
}

/// The engine starting the board from the marked flash: A's image (its
/// log is read with A's table throughout: B is A with a newer version
/// string, so their RTT blocks and defmt tables are the same), the
/// bootloader.
fn from_marked_flash(board: Board, images: &Images, dir: &Path) -> Result<Command, String> {
    let engine = crate::rehost::build_engine()?;
    let boot = crate::rehost::boot_image(self::engine(board)?)?;
    let mut cmd = Command::new(engine);
    cmd.current_dir(crate::workspace())
        .args(["--board", self::engine(board)?, "--elf"])
        .arg(&images.a)
        .args(board.engine_options())
        .arg("--boot")
        .arg(&boot)
        .arg("--flash-in")
        .arg(dir.join("marked.flash"));
    Ok(cmd)
}

/// A deterministic run from the marked flash: the bootloader's swap,
/// then B and the engine's robot ([`robot_messages`] in virtual time,
/// started again after a cut). With `cut`, the power fails at that
/// operation, as `kind` says. The engine's exit status and output.
fn swap_run(
    setup: &Setup,
    board: Board,
    images: &Images,
    dir: &Path,
    cut: Option<(u64, CutKind)>,
    census: Option<&Path>,
) -> Result<(i32, String), String> {
    let mut cmd = from_marked_flash(board, images, dir)?;
    cmd.arg("--device")
        .arg(format!(
            "{}:{}",
            setup.device.network.address, setup.device.channel.port
        ))
        .arg("--gsi")
        .arg(&setup.gsi)
        .args([
            "--robot",
            &robot_messages(board).to_string(),
            "--log-prefix",
            "device: ",
        ])
        // A swap and a swap back at the reset clock are about 6e9
        // cycles: a bootloader that never starts an image ends the run
        // here, not never.
        .args(["--cycles", "40000000000"]);
    if let Some((n, kind)) = cut {
        cmd.args(["--power-cut", &n.to_string()]);
        cmd.args(kind.options());
    }
    if let Some(c) = census {
        cmd.arg("--flash-census").arg(c);
    }
    let out = cmd
        .output()
        .map_err(|e| format!("the rehosting engine: {e}"))?;
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    Ok((out.status.code().unwrap_or(-1), text))
}

/// The version the last start logged after the cut (`rri-sensor X on`).
fn version_after_cut(log: &str) -> Option<String> {
    let after = &log[log.find("rehost: power cut at flash operation")?..];
    after
        .lines()
        .filter_map(|l| {
            let i = l.find("rri-sensor ")?;
            let rest = &l[i + "rri-sensor ".len()..];
            rest.split_whitespace()
                .next()
                .filter(|_| rest.contains(" on "))
        })
        .next_back()
        .map(String::from)
}

/// Whether the image running at the end of the log after the cut is not
/// left on trial: every "is on trial" line after the cut is followed by
/// its confirmation (`update: version X confirmed`). An image left on
/// trial would be rolled back at the next reset.
fn ends_confirmed(log: &str) -> bool {
    let Some(cut) = log.find("rehost: power cut at flash operation") else {
        return false;
    };
    let after = &log[cut..];
    match after.rfind("and is on trial") {
        None => true,
        Some(trial) => after[trial..].contains(" confirmed: "),
    }
}

/// The last lines of a log, indented, for a failed verdict.
fn tail<'a>(lines: impl DoubleEndedIterator<Item = &'a str>) -> String {
    crate::device::tail(lines, 12)
}

/// A cut in the swap (the bootloader must finish it and B answer) or in
/// B's confirmation (B, or A brought back because B never finished
/// confirming itself, must answer).
fn swap_cut(
    setup: &Setup,
    board: Board,
    images: &Images,
    dir: &Path,
    phase: Phase,
    (n, kind): (u64, CutKind),
    what: &str,
) -> Verdict {
    let (code, log) = swap_run(setup, board, images, dir, Some((n, kind)), None)?;
    let robot = log
        .lines()
        .rev()
        .find(|l| l.starts_with("robot (virtual time"))
        .unwrap_or("no robot summary")
        .to_string();
    let version = version_after_cut(&log);
    let confirmed = ends_confirmed(&log);
    let line = format!(
        "{}, operation {n} ({what}): back running {}{}; {robot}",
        phase.name(),
        version.as_deref().unwrap_or("nothing"),
        if confirmed {
            ", confirmed"
        } else {
            ", LEFT ON TRIAL"
        }
    );
    let is = |v: &str| version.as_deref() == Some(v);
    // A torn cut in the swap may end on A: its last progress mark torn
    // reads as programmed (`rri_update::torn`), a finished swap never
    // confirmed, which the bootloader rolls back, as the host's model
    // finds (`tests/update_power_cut.rs`); the update is sent again.
    let whole = match (phase, kind) {
        (Phase::Confirm, _) | (_, CutKind::Tearing) => {
            is(&images.a_version) || is(&images.b_version)
        }
        _ => is(&images.b_version),
    };
    let n = robot_messages(board);
    let all = format!("sent {n} answered {n} late 0 lost 0 wrong 0");
    if code == 0 && whole && confirmed && robot.contains(&all) {
        Ok(line)
    } else {
        Err(format!(
            "{line} (exit {code}); the run's last lines:\n  {}",
            tail(log.lines())
        ))
    }
}

/// A cut in the upload: A must come back, answer the robot, and take B
/// again.
fn upload_cut(
    setup: &Setup,
    board: Board,
    images: &Images,
    (n, kind): (u64, CutKind),
    what: &str,
) -> Verdict {
    let cut = n.to_string();
    let mut extra = vec!["--power-cut", &cut, "--resets", "2"];
    extra.extend(board.engine_options());
    extra.extend(kind.options());
    let (mut d, to, http) = crate::rehost::boot_elf(engine(board)?, setup, &images.a, &extra)?;
    for (needle, within) in crate::rehost::ready() {
        d.wait_for(needle, within)?;
    }
    let http = http.ok_or("the board's diagnostics are not forwarded")?;
    // The power fails during the upload: its connection dies with it.
    let first = update_swap::send_file(http, &images.b_file);
    d.wait_for(
        &format!("power cut at flash operation {n}"),
        Duration::from_secs(120),
    )?;
    let s = update_swap::until(http, Duration::from_secs(120), &|s| !s.version.is_empty())?;
    let answered = update_swap::robot(setup, to, 300, 50_000);
    let again = update_swap::send_file(http, &images.b_file);
    let log = Box::new(d).stop();
    let line = format!(
        "upload, operation {n} ({what}): the cut upload {}; back running {} (last reset: {}); {}; B sent again: {}",
        match &first {
            Ok((status, said)) => format!("answered {status} {said}"),
            Err(e) => format!("got no answer ({})", e.lines().next().unwrap_or("")),
        },
        s.version,
        s.last_reset.as_deref().unwrap_or("?"),
        match &answered {
            Ok((a, sent)) => format!("{a} of {sent} robot messages answered"),
            Err(e) => format!("the robot: {e}"),
        },
        match &again {
            Ok((status, said)) => format!("{status} {said}"),
            Err(e) => e.clone(),
        }
    );
    let ok = matches!(answered, Ok((a, sent)) if a == sent && sent > 0)
        && upload_cut_ended_well(
            &s.version,
            (&images.a_version, &images.b_version),
            &first,
            &again,
        );
    if ok {
        Ok(line)
    } else {
        Err(format!(
            "{line}; the device's last lines:\n  {}",
            tail(log.iter().map(|l| l.as_str()))
        ))
    }
}

/// What a cut in the upload may end in: B running, when the cut fell
/// after the mark (the note of the replaced version is the upload's last
/// operation: the bootloader swapped B in at the power-on, as
/// `tests/update_power_cut.rs` finds on the host's model); or A, which
/// then took B ([`b_taken`]).
fn upload_cut_ended_well(
    running: &str,
    (a, b): (&str, &str),
    first: &Result<(u16, String), String>,
    again: &Result<(u16, String), String>,
) -> bool {
    running == b || (running == a && b_taken(first, again))
}

/// After a cut in the upload and A back: B was taken. Either the cut
/// upload died with the power and B, sent again, is checked and marked;
/// or the client tried the upload again (`update_device::upload` does,
/// up to five times 300 ms apart, when the device ends a connection
/// without a byte of answer, as the rebooted device does to the old
/// one) and A, back by then, took the whole file: B is marked, and the
/// second sending is refused as marked already. Seen with `--all` at the
/// upload's first operations, where the tool called it a failure.
fn b_taken(first: &Result<(u16, String), String>, again: &Result<(u16, String), String>) -> bool {
    let marked = |r: &Result<(u16, String), String>| matches!(r, Ok((200, said)) if said.contains("checked and marked"));
    marked(again)
        || (marked(first) && matches!(again, Ok((409, said)) if said.contains("marked already")))
}

/// The census's runs, one line each.
fn summary(ops: &[Op], runs: &[Run]) {
    println!("   {} flash operations in {} runs:", ops.len(), runs.len());
    for r in runs {
        let by = if r.by_bootloader {
            "bootloader"
        } else {
            "image"
        };
        println!("   {:>6}-{:<6} {} (by the {by})", r.first, r.last, r.what());
    }
}

/// Both censuses, then every cut; each verdict printed as it comes. `Err`
/// when a cut did not end as it must (every cut is still made).
pub fn run_all(setup: &Setup, board: Board, all: bool, kind: CutKind) -> Result<(), String> {
    let nucleo = board
        .nucleo()
        .ok_or_else(|| format!("{board:?}: the power is cut on a rehosted NUCLEO only"))?;
    let images = update_swap::build(setup, board)?;
    let dir = work_dir()?.join(engine(board)?);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let map = crate::boards::flash_map(nucleo)?;
    let partitions = crate::flash_map::partitions(&map)?;
    println!(
        "== census of the upload: A ({}) boots, B ({}) is sent and marked",
        images.a_version, images.b_version
    );
    let upload = upload_census(setup, board, &images, &dir)?;
    let upload_runs = runs(&upload, &partitions);
    summary(&upload, &upload_runs);
    println!(
        "== census of the swap: from that flash, the bootloader swaps B in, B answers the robot and confirms itself"
    );
    let census = dir.join("swap.census");
    let (code, log) = swap_run(setup, board, &images, &dir, None, Some(&census))?;
    if code != 0 {
        return Err(format!(
            "the swap without a cut failed (exit {code}):\n  {}",
            tail(log.lines())
        ));
    }
    let text =
        std::fs::read_to_string(&census).map_err(|e| format!("{}: {e}", census.display()))?;
    let swap = parse_census(&text)?;
    let swap_runs = runs(&swap, &partitions);
    summary(&swap, &swap_runs);
    println!(
        "== the engine's fast-forward: {}",
        exact::check(board, &images, &dir)?
    );
    let (mut cuts, mut failed) = (0, 0);
    let mut judge = |verdict: Verdict| {
        cuts += 1;
        match verdict {
            Ok(line) => println!("power-cut: ok   {line}"),
            Err(line) => {
                failed += 1;
                println!("power-cut: FAIL {line}");
            }
        }
    };
    for (n, what) in points(&upload_runs, Phase::Upload, all) {
        judge(upload_cut(setup, board, &images, (n, kind), &what));
    }
    for phase in [Phase::Swap, Phase::Confirm] {
        for (n, what) in points(&swap_runs, phase, all) {
            judge(swap_cut(
                setup,
                board,
                &images,
                &dir,
                phase,
                (n, kind),
                &what,
            ));
        }
    }
    // The default set tears one cut too, where a torn word bricks a board
    // that reads the state partition plainly (the H743's ECC).
    if !all && kind == CutKind::Before && board == Board::H743 {
        if let Some((n, what)) = torn_point(&swap_runs) {
            let cut = (n, CutKind::Tearing);
            judge(swap_cut(
                setup,
                board,
                &images,
                &dir,
                Phase::Swap,
                cut,
                &what,
            ));
        }
    }
    if failed == 0 {
        println!(
            "power-cut: all {cuts} {}cuts ended on a board running a whole, signed image that answers its robot",
            if kind == CutKind::Tearing { "torn " } else { "" }
        );
        Ok(())
    } else {
        Err(format!("{failed} of {cuts} cuts did not end as they must"))
    }
}

#[cfg(test)]
mod tests;
