//! The engine's poll-loop fast-forward checked on the real images: the
//! start of the swap from the marked flash, run twice, once with every
//! iteration of every poll loop (`--no-fast-forward`), must make the same
//! flash operations from the same instructions and end at the same cycle
//! and instruction. Every cut of `cargo power-cut` is judged on
//! fast-forwarded runs, so this is what says they are the board's runs.

use crate::update_swap::{Board, Images};
use std::path::Path;
use std::time::Instant;

/// Virtual time compared: on the H743 about a fifth of the swap, about
/// 11 s of the host's time with every iteration run.
const CYCLES: u64 = 400_000_000;

/// One run: its census, its end ("N cycles ...; now at PC ..."), its
/// host time.
fn run(
    board: Board,
    images: &Images,
    dir: &Path,
    every_iteration: bool,
) -> Result<(String, String, f64), String> {
    let census = dir.join(if every_iteration {
        "exact-slow.census"
    } else {
        "exact-fast.census"
    });
    let mut cmd = super::from_marked_flash(board, images, dir)?;
    cmd.args(["--cycles", &CYCLES.to_string()])
        .arg("--flash-census")
        .arg(&census);
    if every_iteration {
        cmd.arg("--no-fast-forward");
    }
    let started = Instant::now();
    let out = cmd
        .output()
        .map_err(|e| format!("the rehosting engine: {e}"))?;
    let secs = started.elapsed().as_secs_f64();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!(
            "the engine stopped (exit {:?}):\n{}",
            out.status.code(),
            super::tail(text.lines())
        ));
    }
    let end = text
        .lines()
        .find_map(|l| {
            let rest = l.strip_prefix("rehost: ran ")?;
            let (cycles, at) = rest.split_once(" cycles in ")?;
            Some(format!("{cycles} cycles; {}", at.split_once("; ")?.1))
        })
        .ok_or_else(|| {
            format!(
                "no end in the engine's output:\n{}",
                super::tail(text.lines())
            )
        })?;
    let census =
        std::fs::read_to_string(&census).map_err(|e| format!("{}: {e}", census.display()))?;
    Ok((census, end, secs))
}

/// Runs the check; the line to print when the two runs agree.
pub fn check(board: Board, images: &Images, dir: &Path) -> Result<String, String> {
    let (fast_census, fast_end, fast_secs) = run(board, images, dir, false)?;
    let (slow_census, slow_end, slow_secs) = run(board, images, dir, true)?;
    if fast_census != slow_census || fast_end != slow_end {
        let ops = |c: &str| c.lines().count();
        return Err(format!(
            "the engine's fast-forward changed the run: every iteration run, {} flash operations and {slow_end}; fast-forwarded, {} and {fast_end}",
            ops(&slow_census),
            ops(&fast_census)
        ));
    }
    Ok(format!(
        "the swap's first {CYCLES} cycles fast-forwarded ({fast_secs:.1} s) and with every poll iteration run ({slow_secs:.1} s): the same {} flash operations, the same end ({fast_end})",
        fast_census.lines().count()
    ))
}
