//! A flash operation torn by a power cut (`--tear`) on a flash with ECC
//! (the H743; the F767's, without, is [`crate::torn_bits`]).
//!
//! A cut falls inside an operation, not between two. On the H743 every
//! 256-bit flash word carries 10 ECC bits, written with it (RM0433, the
//! embedded flash's ECC): a program the power stopped half-way, or an
//! erase, leaves words whose bits and ECC disagree. The flash reads such
//! a word as a double error, which it cannot correct: the bank's FLASH_SR
//! DBECCERR is set, FLASH_ECC_FA holds the failing word (the fields of
//! ST's SVD), and the read itself returns a bus error to the AXI master
//! (RM0433), which the Cortex-M7 takes as a precise
//! BusFault (ARMv7-M ARM, DDI 0403E, B3.2.15 BFSR PRECISERR) unless it
//! runs at priority -1 or -2 with SCB.CCR.BFHFNMIGN set, when the fault
//! is ignored (B3.2.8) and the load returns UNKNOWN data. The word stays
//! so until its sector is erased; a program of it is refused.
//!
//! The model: at a torn cut, a program's word takes the bytes it was
//! being given (its bits then hardly matter: every read of it faults)
//! and joins [`crate::bus::FlashOps::torn`]; an erase's whole sector does,
//! its bytes left as they were. When the power comes back, a read hook
//! watches the span the torn words lie in (no hook, and no cost, in a run
//! that tore nothing). The load itself completes in unicorn (its hook
//! runs before the access, and only an invalid access can be refused):
//! a handler that returned to it would find its register written. Ours
//! never return from a HardFault, and the ignored case is UNKNOWN data on
//! silicon too.

use crate::bus::FlashOps;
use crate::fault::{Fault, BFARVALID, BUS_FAULT, PRECISERR};
use crate::state::State;
use unicorn_engine::{HookType, RegisterARM, Unicorn};

/// The H743's flash word: what one program writes, with its ECC.
pub const WORD: u32 = 32;

/// SCB.CCR.BFHFNMIGN (B3.2.8): precise data bus faults ignored at
/// priority -1 and -2.
const BFHFNMIGN: u32 = 1 << 8;

/// At a torn cut: the words the operation the cut fell on leaves torn
/// (its program's word, or its erase's whole sector). Returns whether the
/// program's own bytes reach the array (they do: half-programmed).
pub fn tear(flash: &mut FlashOps) -> bool {
    let Some((addr, len, erase)) = flash.cut_op else {
        return false;
    };
    let first = addr & !(WORD - 1);
    let end = addr.saturating_add(len.max(1));
    flash
        .torn
        .extend((first..end).step_by(WORD as usize).map(|w| w & !(WORD - 1)));
    !erase
}

/// Whether `addr..addr + size` touches a torn word: the first such word.
pub fn hit(flash: &FlashOps, addr: u32, size: u32) -> Option<u32> {
    let first = addr & !(WORD - 1);
    let last = addr.saturating_add(size.max(1) - 1) & !(WORD - 1);
    flash.torn.range(first..=last).next().copied()
}

/// Watches the core's reads of torn words (after a power cycle that
/// left some): one read hook over the span they lie in, installed again
/// only when the span grows.
pub fn watch(uc: &mut Unicorn<State>) -> Result<(), String> {
    let torn = &uc.get_data().shared.flash.torn;
    let (Some(&lo), Some(&hi)) = (torn.first(), torn.last()) else {
        return Ok(());
    };
    let (lo, hi) = (u64::from(lo), u64::from(hi) + u64::from(WORD) - 1);
    if let Some((_, a, b)) = uc.get_data().torn_hook {
        if a <= lo && hi <= b {
            return Ok(());
        }
    }
    if let Some((id, _, _)) = uc.get_data_mut().torn_hook.take() {
        uc.remove_hook(id)
            .map_err(|e| format!("unicorn: removing the torn words' hook: {e:?}"))?;
    }
    let id = uc
        .add_mem_hook(HookType::MEM_READ, lo, hi, |uc, _kind, addr, size, _| {
            on_read(uc, addr as u32, size as u32);
            true
        })
        .map_err(|e| format!("unicorn: the torn words' hook: {e:?}"))?;
    uc.get_data_mut().torn_hook = Some((id, lo, hi));
    // Code translated before the hook reads without it.
    uc.ctl_flush_tb()
        .map_err(|e| format!("unicorn: dropping translated code: {e:?}"))?;
    Ok(())
}

/// The run's torn words in a line (`--tear` runs only): reads of them,
/// and how many are left.
pub fn summary(flash: &FlashOps) -> Option<String> {
    flash.tear.then(|| {
        format!(
            "{} reads of torn flash words (double ECC errors), {} torn words left",
            flash.ecc_reads,
            flash.torn.len()
        )
    })
}

/// A read by the core: a torn word's is flagged for the flash controller
/// and faults, unless the core ignores bus faults where it runs.
fn on_read(uc: &mut Unicorn<State>, addr: u32, size: u32) {
    let Some(word) = hit(&uc.get_data().shared.flash, addr, size) else {
        return;
    };
    let ignored =
        crate::exceptions::execution_priority(uc) < 0 && uc.get_data().scs.ccr & BFHFNMIGN != 0;
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
    let s = uc.get_data_mut();
    s.shared.flash.ecc_errors.push(word);
    s.shared.flash.ecc_reads += 1;
    if ignored || s.fault.is_some() {
        return;
    }
    s.fault = Some(Fault {
        exc: BUS_FAULT,
        at: pc,
        why: format!(
            "a {size}-byte read at {addr:#010x}, in the flash word {word:#010x} a power cut tore (a double ECC error, which the flash answers with a bus error)"
        ),
        cfsr: PRECISERR | BFARVALID,
        mmfar: None,
        bfar: Some(addr),
    });
    let _ = uc.emu_stop();
}

#[cfg(test)]
#[path = "torn_word_tests.rs"]
mod tests;
