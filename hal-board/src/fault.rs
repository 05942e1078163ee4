//! The fault handlers, the same on every board: they log where the fault
//! happened and why, then reset the board.
//!
//! cortex-m-rt's default handler loops forever: a fault before the
//! watchdog starts would hang the board silently, and one after it would
//! end in a watchdog reset with nothing in the log. Here every fault (the
//! configurable ones escalate to HardFault: they are not enabled, but for
//! MemManage, which the stack guard raises) logs the stacked PC, LR and
//! xPSR and the fault status registers, then resets as the board does
//! (`board::reset`: after the log has had time to leave, on the NUCLEO
//! boards). A stack overflow is logged and kept as one. The entry and the
//! handler are in [`crate::stack_guard`]: the entry moves the stack
//! pointer off the guard before any Rust code runs.
//!
//! The PC and LR are also kept across the reset
//! ([`crate::reset`]): the next start reports them (the diagnostics
//! page's "last reset").
//!
//! What it cannot catch: a fault while the core stacks the exception
//! frame for HardFault itself (a single frame that jumps past the guard
//! and below RAM, under flip-link's layout) locks the core up; the
//! watchdog, once running, resets it.
//!
//! **Record first, and never log through a held logger** (issue 42 #13).
//! A fault can strike while the logger is held (inside a `defmt` call, a
//! stack overflow included): logging from the handler then panics in the
//! logger ("taken reentrantly"), and a panic handler that writes its own
//! record and logs again names the wrong cause and recurses until the
//! core locks up, which only the watchdog ends, and nothing during
//! `init`. So every handler writes the crash record before it logs, and
//! the first handler to run claims the record ([`crate::reset::claim`]): a panic or fault while one is
//! being handled (the logger's own panic among them) keeps the first
//! record, logs nothing and resets at once.
//!
//! The `fault-selftest` feature checks the handlers end to end (`cargo
//! hil -- --fault`: on QEMU in CI, on a NUCLEO by hand), one start at a
//! time, each reading what the crash record kept across the last reset
//! (`hal_board::reset`): an undefined instruction at the end of `init`;
//! after that HardFault, a recursion until the stack reaches its guard;
//! after that overflow, an undefined instruction inside a log call (the
//! logger held); after that HardFault, the firmware goes on.
#![allow(unsafe_code)]

use crate::reset::{Cause, Report};

/// A value whose formatting executes an undefined instruction: a fault
/// with the logger held (the self-test's third start).
struct FaultWhileLogging;

impl defmt::Format for FaultWhileLogging {
    fn format(&self, _f: defmt::Formatter<'_>) {
        cortex_m::asm::udf()
    }
}

/// Logs why the board started (the crash record `crate::reset` kept
/// across the reset: a fault's PC, a panic's file and line).
pub fn log_reset(r: &Report) {
    let cause = r.cause.name();
    match r.pc {
        Some((pc, lr)) if pc != 0 => defmt::warn!(
            "last reset: {=str} at PC {=u32:#010x} LR {=u32:#010x} (start {=u32})",
            cause,
            pc,
            lr,
            r.boots
        ),
        // A stack overflow whose frame could not be stacked.
        Some(_) => defmt::warn!(
            "last reset: {=str}, PC unknown (start {=u32})",
            cause,
            r.boots
        ),
        None => defmt::info!("last reset: {=str} (start {=u32})", cause, r.boots),
    }
}

/// The `fault-selftest` feature's step for a start after `last` (the
/// boards call it at the end of `init`): returns only after the stack
/// overflow's start.
pub fn selftest(last: &Report) {
    match last.cause {
        Cause::StackOverflow => {
            // The firmware logs the last reset after `init`: this start
            // ends before, so it says it here.
            log_reset(last);
            defmt::warn!("fault self-test: an undefined instruction inside a log call");
            defmt::info!("{}", FaultWhileLogging);
        }
        // The start after the fault inside a log call: the firmware goes
        // on (and reports that HardFault after `init`).
        Cause::HardFault if last.boots > 2 => {}
        Cause::HardFault => {
            log_reset(last);
            crate::stack_guard::overflow_selftest()
        }
        _ => {
            defmt::warn!("fault self-test: executing an undefined instruction");
            cortex_m::asm::udf()
        }
    }
}
