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
//! The `fault-selftest` feature checks the handlers end to end (`cargo
//! hil -- --fault`: on QEMU in CI, on a NUCLEO by hand), one start at a
//! time, each reading what the crash record kept across the last reset
//! (`hal_board::reset`): an undefined instruction at the end of `init`;
//! after that HardFault, a recursion until the stack reaches its guard;
//! after that overflow, the firmware goes on.
#![allow(unsafe_code)]

use crate::reset::{Cause, Report};

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
        Cause::StackOverflow => {}
        Cause::HardFault => {
            // The firmware logs the last reset after `init`: this start
            // ends before, so it says it here.
            log_reset(last);
            crate::stack_guard::overflow_selftest()
        }
        _ => {
            defmt::warn!("fault self-test: executing an undefined instruction");
            cortex_m::asm::udf()
        }
    }
}
