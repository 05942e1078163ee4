//! The HardFault handler, the same on every board: it logs where the fault
//! happened and why, then resets the board.
//!
//! cortex-m-rt's default handler loops forever: a fault before the
//! watchdog starts would hang the board silently, and one after it would
//! end in a watchdog reset with nothing in the log. Here every fault (the
//! configurable ones escalate to HardFault: they are not enabled) logs the
//! stacked PC, LR and xPSR and the fault status registers, then resets as
//! the board does (`board::reset`: after the log has had time to leave,
//! on the NUCLEO boards).
//!
//! The PC and LR are also kept across the reset
//! ([`crate::reset`]): the next start reports them (the diagnostics
//! page's "last reset").
//!
//! What it cannot catch: a fault while the core stacks the exception
//! frame for HardFault itself (a stack overflow past the bottom of RAM,
//! which flip-link's layout turns into a fault) locks the core up; the
//! watchdog, once running, resets it.
//!
//! The `fault-selftest` feature makes the board execute an undefined
//! instruction at the end of its `init`, so that `cargo hil -- --fault`
//! can check the handler end to end (on QEMU in CI, on a NUCLEO by hand):
//! once, unless the last reset was that HardFault, so that the start
//! after it goes on and logs what the crash record kept across the reset
//! (`hal_board::reset`).
#![allow(unsafe_code)]

use cortex_m_rt::{exception, ExceptionFrame};

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    // SAFETY: reads of the System Control Block's fault status registers,
    // which nothing else writes.
    let scb = unsafe { &*cortex_m::peripheral::SCB::PTR };
    defmt::error!(
        "HardFault at PC {=u32:#010x} LR {=u32:#010x} xPSR {=u32:#010x}: CFSR {=u32:#010x} HFSR {=u32:#010x} MMFAR {=u32:#010x} BFAR {=u32:#010x}; resetting",
        frame.pc(),
        frame.lr(),
        frame.xpsr(),
        scb.cfsr.read(),
        scb.hfsr.read(),
        scb.mmfar.read(),
        scb.bfar.read()
    );
    crate::reset::ram::note(&mut |r| r.fault(frame.pc(), frame.lr()));
    crate::board::reset()
}

/// Executes a permanently undefined instruction (the boards call it at the
/// end of `init` with the `fault-selftest` feature, unless they start
/// after a HardFault).
pub fn selftest() -> ! {
    defmt::warn!("fault self-test: executing an undefined instruction");
    cortex_m::asm::udf()
}
