//! What both chips' flash arrays share, below their controllers'
//! registers (`f7/flash.rs`, `h7/flash.rs`): NOR rules (programming only
//! clears bits; only an erase sets them, a sector at a time), an
//! operation that keeps its bank busy for the datasheet's time, and what
//! that does to a core that fetches its code from the same bank.

use crate::bus::Cx;

/// An operation under way in a bank: when it ends, and the sector an
/// erase sets to all ones then.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Busy {
    pub until: u64,
    pub erase: Option<(u32, u32)>,
}

/// Core cycles for `us` microseconds at the core clock in force (at
/// least the HSI's 16 MHz, the slowest clock a flash operation runs
/// beside here).
pub fn cycles(cx: &Cx, us: u64) -> u64 {
    crate::clocks::core_cycles(cx.clocks, 16_000_000, us)
}

/// Whether programming `value` over `old` needs a bit set that is clear:
/// only an erase sets bits. The first such byte's offset.
pub fn sets_a_cleared_bit(old: &[u8], value: &[u8]) -> Option<usize> {
    old.iter().zip(value).position(|(o, v)| v & !o != 0)
}

/// Starts an operation of `us` microseconds at `cx.now`; when the core
/// fetches its code from the bank (`stalls`), it waits for the whole of
/// it: the model assumes no cache hit, the worst case (on silicon the
/// instruction cache may let a short loop run on, but any fetch that
/// misses waits).
pub fn start(cx: &mut Cx, us: u64, erase: Option<(u32, u32)>, stalls: bool) -> Busy {
    let len = cycles(cx, us);
    if stalls {
        *cx.stall += len;
    }
    Busy {
        until: cx.now + len,
        erase,
    }
}

/// Ends `busy` once its time has come: an erase's sector becomes all
/// ones. Whether it ended.
pub fn finish(busy: &mut Option<Busy>, cx: &mut Cx) -> bool {
    match *busy {
        Some(b) if cx.now >= b.until => {
            if let Some((base, len)) = b.erase {
                cx.program.push((base, vec![0xFF; len as usize]));
            }
            *busy = None;
            true
        }
        _ => false,
    }
}
