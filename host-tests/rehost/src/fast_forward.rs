//! Poll loops fast-forwarded. A core waiting for its flash controller
//! spins on FLASH_SR.BSY: hundreds of iterations per 256-bit program, each
//! a register read the models answer, which made up three quarters of the
//! engine's time in an H743 swap (perf). When an iteration is seen to leave
//! the core exactly as it found it, every later one until the register's
//! value changes is the same, so virtual time is moved on by whole
//! iterations instead of running them.
//!
//! Exact, not approximate. A skip happens only when
//! - a run of reads of one register, each the next access to any model,
//!   all returned the same value, with no exception, no slice boundary
//!   (where the outside and the DMA reach the chip) and no read of a torn
//!   flash word during it; the run's first instruction read it twice;
//! - the core's registers (R0-R12, SP, LR, xPSR) were the same at those
//!   two reads;
//! - every instruction the core ran between them writes nothing but core
//!   registers ([`pure`]: no store, no system instruction, no coprocessor,
//!   no sleep), so memory is unchanged too;
//! - the model says until when the register holds its value
//!   ([`crate::bus::Peripheral::holds_until`]), and has nothing else to
//!   do before then (its next event).
//!
//! Then each later iteration starts in the state the last one started in,
//! except for time, and the reads skipped would all have returned the same
//! value. Time moves on by whole iterations, to before the value changes
//! and before the slice's end, so everything after happens at the same
//! cycle as without the skip. `rri-rehost --no-fast-forward` runs every
//! iteration: the unit tests below compare the two on a tiny program, and
//! the README gives the figures of a whole swap run both ways.

use crate::poll_watch::{Run, MAX_BLOCKS};
use crate::state::State;
use unicorn_engine::{RegisterARM, Unicorn};

const REGS: [RegisterARM; 16] = [
    RegisterARM::R0,
    RegisterARM::R1,
    RegisterARM::R2,
    RegisterARM::R3,
    RegisterARM::R4,
    RegisterARM::R5,
    RegisterARM::R6,
    RegisterARM::R7,
    RegisterARM::R8,
    RegisterARM::R9,
    RegisterARM::R10,
    RegisterARM::R11,
    RegisterARM::R12,
    RegisterARM::SP,
    RegisterARM::LR,
    RegisterARM::XPSR,
];

/// After a read by the core at `pc` of `size` bytes at `addr` that
/// returned `value` (counted in [`State::accesses`] already): the watch
/// moves on, and time skips over the iterations of a poll loop that
/// cannot change anything.
pub fn after_read(uc: &mut Unicorn<State>, pc: u64, addr: u64, size: usize, value: u32) {
    let s = uc.get_data_mut();
    if !s.poll.enabled {
        return;
    }
    let read = Run {
        pc,
        addr,
        size,
        value,
        slices: s.slices,
        exceptions: s.exceptions_taken,
        ecc_reads: s.shared.flash.ecc_reads,
        accesses: s.accesses,
    };
    let go_on = s.poll.run.is_some_and(|r| {
        Run {
            pc,
            accesses: r.accesses + 1,
            ..r
        } == read
    });
    if !go_on {
        s.poll.drop_run();
        s.poll.run = Some(read);
        return;
    }
    let Some(run) = &mut s.poll.run else {
        return;
    };
    run.accesses = read.accesses;
    if run.pc != pc {
        // Another read of the unrolled loop's.
        return;
    }
    let now = s.now;
    // Not past the block's own next event either: a read brings the
    // whole block up to date (the other bank's operation ending), which
    // the reads skipped would have done at their times.
    let until = s.bus.find(addr as u32).and_then(|(b, offset)| {
        let holds = b.model.holds_until(offset, now)?;
        Some(b.model.next_event(now).map_or(holds, |e| e.min(holds)))
    });
    let Some(until) = until else {
        // No promise from the model: nothing to skip to, and no
        // registers read.
        return;
    };
    let mut regs = [0u64; 16];
    for (r, id) in regs.iter_mut().zip(REGS) {
        *r = uc.reg_read(id).unwrap_or(u64::MAX);
    }
    let s = uc.get_data();
    let same = s
        .poll
        .anchor
        .is_some_and(|(then, r)| r == regs && now > then)
        && s.poll.blocks.len() <= MAX_BLOCKS
        && s.poll.blocks.iter().all(|&(at, len)| {
            uc.mem_read_as_vec(at, len as usize)
                .is_ok_and(|code| pure(&code))
        });
    let s = uc.get_data_mut();
    match s.poll.anchor {
        Some((then, _)) if same && s.shared.raised.is_empty() => {
            let period = now - then;
            let n = iterations(now, period, until, s.deadline);
            if n > 0 {
                s.now += n * period;
                s.poll.skipped += n * period;
                s.poll.skips += 1;
            }
            s.poll.drop_run();
        }
        _ => s.poll.anchor_at(now, regs),
    }
}

/// How many iterations of `period` cycles to skip from a read at `now`:
/// whole ones, each read in them before the value changes at `until`,
/// and ending before the slice's `deadline` (a block that ends at the
/// deadline itself stops the core after it, which a skip inside the block
/// cannot do).
fn iterations(now: u64, period: u64, until: u64, deadline: u64) -> u64 {
    let target = until.min(deadline).saturating_sub(1);
    target.saturating_sub(now) / period.max(1)
}

/// Whether `code` (whole Thumb instructions) writes nothing but core
/// registers: loads, data processing, compares, multiplies and divides,
/// branches and IT; no store, no push, no exclusive or dual access, no
/// coprocessor or floating-point instruction, no MSR/MRS/CPS, barrier,
/// hint other than NOP, SVC, BKPT or BX (ARMv7-M A5.2, A5.3). Anything
/// else, or an instruction cut off at the end, makes it not pure: the
/// loop then runs as it is.
pub fn pure(code: &[u8]) -> bool {
    let hw = |i: usize| code.get(i..i + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
    let mut i = 0;
    while i < code.len() {
        let Some(h1) = hw(i) else {
            return false;
        };
        let ok = if h1 >> 11 >= 0b11101 {
            let Some(h2) = hw(i + 2) else {
                return false;
            };
            i += 4;
            pure32(h1, h2)
        } else {
            i += 2;
            pure16(h1)
        };
        if !ok {
            return false;
        }
    }
    true
}

fn pure16(h: u16) -> bool {
    match h >> 8 {
        // Shifts, add, subtract, move, compare; data processing; the high
        // registers' add, compare and move (not BX/BLX, 0x47).
        0x00..=0x46 => true,
        // LDR literal; the register-offset loads (0x56-0x5F), not the
        // stores (0x50-0x55); LDR/LDRB/LDRH immediate and SP-relative.
        0x48..=0x4F | 0x56..=0x5F | 0x68..=0x6F | 0x78..=0x7F | 0x88..=0x8F | 0x98..=0x9F => true,
        // ADR, ADD SP; ADD/SUB SP, CBZ/CBNZ, extends, REV, POP; LDM.
        0xA0..=0xB3 | 0xB9..=0xBB | 0xBC..=0xBD | 0xC8..=0xCF => true,
        // NOP and IT, not the other hints (YIELD, WFE, WFI, SEV).
        0xBF => h == 0xBF00 || h & 0x000F != 0,
        // B<cond> (not UDF 0xDE, SVC 0xDF) and B.
        0xD0..=0xDD | 0xE0..=0xE7 => true,
        _ => false,
    }
}

fn pure32(h1: u16, h2: u16) -> bool {
    match (h1 >> 11) & 3 {
        // Load/store multiple (a load if L is set), dual and exclusive
        // (never), data processing with a shifted register, coprocessor
        // (never).
        0b01 => match (h1 >> 9) & 3 {
            0b00 => h1 & 0x0040 == 0 && h1 & 0x0010 != 0,
            0b01 => true,
            _ => false,
        },
        // Data processing with an immediate; branches and miscellaneous
        // control: B<cond>.W (not cond 111x: MSR, MRS, hints, barriers),
        // B.W and BL.
        0b10 => {
            if h2 & 0x8000 == 0 {
                return true;
            }
            match (h2 >> 12) & 0b101 {
                0b000 => (h1 >> 6) & 0xF < 0b1110,
                0b001 | 0b101 => true,
                _ => false,
            }
        }
        // Single loads (not the stores, nor the undefined 0xF9 without
        // L), data processing with registers, multiplies and divides;
        // not the coprocessor space.
        _ => match (h1 >> 8) & 7 {
            0b000 | 0b001 => h1 & 0x0010 != 0,
            0b010 | 0b011 => true,
            _ => false,
        },
    }
}

#[cfg(test)]
#[path = "fast_forward_tests.rs"]
mod tests;
