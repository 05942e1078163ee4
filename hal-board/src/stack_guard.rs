//! A stack overflow faults on every image, whatever linked it: an MPU
//! region at the stack's end that nothing may write (issue 35).
//!
//! flip-link (`.cargo/flip-link-or-lld`) puts the stack below the statics,
//! so an overflow runs off the bottom of RAM and faults; with plain
//! rust-lld (flip-link not installed) the stack sits above the statics and
//! an overflow would overwrite them silently. The guard needs no tool:
//! [`arm`] makes [`SIZE`] bytes read-only just above the stack's lowest
//! address (MPU region [`REGION`], MemManage enabled), on every board, so
//! the first write into them is a MemManage fault.
//!
//! [`RESERVE`] bytes stay writable below the guard: the core stacks the
//! fault's exception frame below the stack pointer, which is at the guard
//! when it fires; under flip-link's layout that frame would otherwise fall
//! off the bottom of RAM, a fault while stacking for HardFault, which
//! locks the core up with nothing logged.
//!
//! The fault entry (HardFault and MemManage, in assembly below) moves the
//! stack pointer back to the top of the stack before any Rust code runs
//! when it finds it within [`NEAR`] bytes of the stack's end: the handler
//! needs a stack to log from, and the board resets right after, so the
//! frames it overwrites up there are never returned to.
//!
//! What it cannot catch: a single frame larger than the guard can move
//! the stack pointer past it and write below it without touching it (Rust
//! emits no stack probes on Thumb). Under flip-link that write is below
//! RAM and faults; with plain rust-lld it lands in the statics. The
//! firmware's largest frame is far smaller than the stack's 80 KiB, but
//! not smaller than 256 bytes: flip-link stays the default link.

/// The guard's size: one MPU region, a power of two, aligned to itself.
pub const SIZE: u32 = 256;

/// Writable bytes kept below the guard for the fault's exception frame
/// (32 bytes, 104 with the FPU's state) and the fault entry.
pub const RESERVE: u32 = 256;

/// The MPU region that holds the guard: the highest of the M7's eight,
/// so it wins over the boards' cache window (region 0) where they overlap.
pub const REGION: u32 = 7;

/// How close to the stack's end the fault entry takes the stack pointer
/// for an overflow and moves it (always past the guard's end).
pub const NEAR: u32 = 1024;

// The guard's end is at most RESERVE + SIZE - 1 + SIZE past the stack's
// end: NEAR must reach past it.
const _: () = assert!(RESERVE + 2 * SIZE + 64 <= NEAR);

/// The guard for a stack whose lowest address is `stack_end`: its first
/// address and the first address past it.
pub const fn layout(stack_end: u32) -> (u32, u32) {
    let base = (stack_end + RESERVE).next_multiple_of(SIZE);
    (base, base + SIZE)
}

/// Whether a fault at stack pointer `sp` with these status registers is
/// the stack reaching a guard that ends at `end` (starting at `end -
/// SIZE`): the exception frame hit the guard (MSTKERR), the faulting
/// write was into it (DACCVIOL with MMFAR valid), or the stack pointer is
/// below the guard's end.
pub const fn is_overflow(sp: u32, end: u32, cfsr: u32, mmfar: u32) -> bool {
    const MSTKERR: u32 = 1 << 4;
    const MMARVALID: u32 = 1 << 7;
    let in_guard = cfsr & MMARVALID != 0 && mmfar >= end - SIZE && mmfar < end;
    cfsr & MSTKERR != 0 || in_guard || sp < end
}

#[cfg(app_board)]
pub(crate) use on_target::end;
#[cfg(app_board)]
pub use on_target::{arm, overflow_selftest};

#[cfg(app_board)]
mod on_target {
    #![allow(unsafe_code)]
    use super::{is_overflow, layout, NEAR, REGION, SIZE};
    use core::ptr::addr_of;
    use cortex_m::peripheral::scb::Exception;

    extern "C" {
        // cortex-m-rt's linker script (moved by flip-link): the initial
        // stack pointer and the stack's lowest address.
        static _stack_start: u32;
        static _stack_end: u32;
    }

    /// The guard of this image's stack: first address, end.
    fn bounds() -> (u32, u32) {
        layout(addr_of!(_stack_end) as u32)
    }

    /// Makes the guard read-only (MPU region [`REGION`]), turns the MPU on
    /// with the default map for everything else (if the board has not)
    /// and enables the MemManage fault; logs where the guard is. Call once
    /// at start-up, after the board's own MPU regions and before anything
    /// runs deep.
    pub fn arm(cp: &mut cortex_m::Peripherals) {
        let (base, _) = bounds();
        let (rbar, rasr) = match crate::mpu::read_only(REGION, base, SIZE) {
            Ok(r) => r,
            // `layout` aligns the guard: not reached.
            Err(e) => return defmt::error!("stack guard: not one MPU region ({}): none", e),
        };
        cortex_m::asm::dsb();
        // SAFETY: the region only takes writes away from bytes below
        // every frame the firmware uses (the stack's painting and
        // measuring skip them: `crate::stack`); the default map
        // (PRIVDEFENA) keeps everything else as it was.
        unsafe {
            cp.MPU.rbar.write(rbar);
            cp.MPU.rasr.write(rasr);
            cp.MPU.ctrl.write(crate::mpu::CTRL_ENABLE_WITH_DEFAULT_MAP);
        }
        cp.SCB.enable(Exception::MemoryManagement);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        defmt::info!(
            "stack guard: {=u32} bytes read-only at {=u32:#010x} (MPU region {=u32}): an overflow faults",
            SIZE,
            base,
            REGION
        );
    }

    /// The first address past the guard (`crate::stack` paints above it).
    pub(crate) fn end() -> usize {
        bounds().1 as usize
    }

    // The HardFault and MemManage vectors (cortex-m-rt's `PROVIDE`s give
    // way to these symbols). r0: the stack pointer the core stacked the
    // frame at (everything runs on the main stack); r1: which fault. When
    // it is near the stack's end, the stack pointer moves to the top
    // before any Rust code runs.
    core::arch::global_asm!(
        ".section .text.rri_fault_entry, \"ax\", %progbits",
        ".global HardFault",
        ".type HardFault, %function",
        ".thumb_func",
        "HardFault:",
        "    movs r1, #0",
        "    b 0f",
        ".global MemoryManagement",
        ".type MemoryManagement, %function",
        ".thumb_func",
        "MemoryManagement:",
        "    movs r1, #1",
        "0:",
        "    mrs r0, msp",
        "    ldr r2, =_stack_end + {near}",
        "    cmp r0, r2",
        "    bhs 1f",
        "    ldr r2, =_stack_start",
        "    msr msp, r2",
        "1:",
        "    b {on_fault}",
        ".ltorg",
        near = const NEAR,
        on_fault = sym on_fault,
    );

    /// Logs the fault (a stack overflow, a HardFault, another MemManage
    /// fault), notes it in the crash record and resets the board.
    unsafe extern "C" fn on_fault(sp: u32, mem_manage: u32) -> ! {
        // SAFETY: reads of the System Control Block's fault status
        // registers, which nothing else writes.
        let scb = unsafe { &*cortex_m::peripheral::SCB::PTR };
        let (cfsr, hfsr) = (scb.cfsr.read(), scb.hfsr.read());
        let (mmfar, bfar) = (scb.mmfar.read(), scb.bfar.read());
        let (low, top) = (addr_of!(_stack_end) as u32, addr_of!(_stack_start) as u32);
        const STACKING_ERRORS: u32 = (1 << 4) | (1 << 12); // MSTKERR, BSTKERR
                                                           // The frame: r0-r3, r12, LR, PC, xPSR; only where the core could
                                                           // write it, inside the stack.
        let frame = |i: u32| -> u32 {
            let whole = sp >= low && sp <= top.saturating_sub(32) && cfsr & STACKING_ERRORS == 0;
            if !whole {
                return 0;
            }
            // SAFETY: a word of the stack region, aligned (the core
            // stacks at 8-byte alignment); the guard is readable.
            unsafe { core::ptr::read_volatile((sp + 4 * i) as *const u32) }
        };
        let (lr, pc, xpsr) = (frame(5), frame(6), frame(7));
        let (guard, end) = bounds();
        let overflow = is_overflow(sp, end, cfsr, mmfar);
        // The record first, then the log (`crate::fault`): a fault inside
        // a log call cannot log, and a second fault or panic meanwhile
        // keeps this record.
        if !crate::reset::claim() {
            crate::board::reset()
        }
        if overflow {
            crate::reset::ram::note(&mut |r| r.stack_overflow(pc, lr));
        } else {
            crate::reset::ram::note(&mut |r| r.fault(pc, lr));
        }
        if overflow {
            defmt::error!(
                "stack overflow at PC {=u32:#010x} LR {=u32:#010x}: the stack reached its guard at {=u32:#010x} (SP {=u32:#010x}; CFSR {=u32:#010x} HFSR {=u32:#010x} MMFAR {=u32:#010x}); resetting",
                pc,
                lr,
                guard,
                sp,
                cfsr,
                hfsr,
                mmfar
            );
        } else {
            defmt::error!(
                "{=str} at PC {=u32:#010x} LR {=u32:#010x} xPSR {=u32:#010x}: CFSR {=u32:#010x} HFSR {=u32:#010x} MMFAR {=u32:#010x} BFAR {=u32:#010x}; resetting",
                if mem_manage != 0 { "MemManage" } else { "HardFault" },
                pc,
                lr,
                xpsr,
                cfsr,
                hfsr,
                mmfar,
                bfar
            );
        }
        crate::board::reset()
    }

    /// Recurses until the stack reaches the guard (the `fault-selftest`
    /// feature's second start: `cargo hil -- --fault`). Each frame is
    /// smaller than the guard and written whole, so the guard is hit, not
    /// jumped.
    pub fn overflow_selftest() -> ! {
        defmt::warn!("stack overflow self-test: recursing until the stack reaches its guard");
        let depth = dig(0);
        // Not reached: the guard faults first.
        defmt::error!(
            "stack overflow self-test: {=u32} frames and no fault",
            depth
        );
        crate::board::reset()
    }

    #[inline(never)]
    fn dig(depth: u32) -> u32 {
        let mut frame = [depth; 32];
        core::hint::black_box(&mut frame);
        if depth == u32::MAX {
            return 0;
        }
        dig(depth + 1).wrapping_add(frame[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guard_sits_above_a_reserve_at_the_stacks_end_aligned_to_its_size() {
        // flip-link: the stack's end is the bottom of RAM.
        assert_eq!(layout(0x2000_0000), (0x2000_0100, 0x2000_0200));
        // rust-lld: the stack's end is the end of the statics.
        let (base, end) = layout(0x2001_4a64);
        assert_eq!(base % SIZE, 0);
        assert!((0x2001_4a64 + RESERVE..0x2001_4a64 + RESERVE + SIZE).contains(&base));
        assert_eq!(end - base, SIZE);
        assert!(end < 0x2001_4a64 + NEAR);
    }

    #[test]
    fn an_overflow_is_told_from_another_fault() {
        let end = 0x2000_0200;
        // The frame could not be stacked: MSTKERR.
        assert!(is_overflow(end - 32, end, 1 << 4, 0));
        // A write into the guard, MMFAR valid.
        assert!(is_overflow(end + 40, end, (1 << 7) | (1 << 1), end - 8));
        // An undefined instruction deep in a healthy stack.
        assert!(!is_overflow(0x2001_0000, end, 1 << 16, 0xe000_ed34));
        // A MemManage elsewhere (MMFAR outside the guard).
        assert!(!is_overflow(
            0x2001_0000,
            end,
            (1 << 7) | (1 << 1),
            0x2003_0000
        ));
    }
}
