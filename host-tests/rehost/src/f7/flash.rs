//! The STM32F76x/77x flash interface (RM0410 rev 5 §3): its access
//! control (FLASH_ACR's wait states feed the clock check, §3.7.1) and the
//! programming and erase of the main flash (§3.3.6-3.3.8, §3.7), in
//! either of its modes, as the option byte nDBANK sets it (OPTCR reads
//! it back):
//! - single-bank (nDBANK = 1, the factory's): 12 sectors, 4 x 32K, 128K,
//!   7 x 256K from 0x0800_0000 (Table 4); every operation stalls the
//!   core's fetches;
//! - dual-bank (nDBANK = 0, `cargo rehost -- --dual-bank`): two banks of
//!   4 x 16K, 64K, 7 x 128K, bank 1 (sectors 0-11) at 0x0800_0000 and
//!   bank 2 (sectors 12-23, SNB 16-27: bit 4 selects the bank) at
//!   0x0810_0000 (Table 5); each bank reads while the other writes
//!   (§3.3.3), so only bank 1's operations stall the core, which runs
//!   from bank 1 here (bootloader and image).
//!
//! Strict where a mistake would corrupt the flash or hang: FLASH_CR
//! written while locked or while an operation is under way, a wrong key
//! sequence (silicon locks FLASH_CR until reset and raises a bus error),
//! a store into flash without PG, a program that would set a bit only an
//! erase sets, an erase of a sector that does not exist. What silicon
//! flags without stopping is flagged the same way: a store whose size is
//! not PSIZE's parallelism (PGPERR, nothing written), one that crosses a
//! 128-bit row (PGAERR). EOP is set only with EOPIE, as §3.7.5 says.
//!
//! Time: a program or an erase keeps the flash busy (SR.BSY) for the
//! largest time the public sources give ([`PROGRAM_US`] says which: the
//! datasheet's table was not at hand), and the core, which fetches its
//! code from bank 1, waits for it where it shares the bank
//! (`crate::flash_array`).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};
use crate::flash_array::{self, Busy};

const ACR: u32 = 0x00;
const KEYR: u32 = 0x04;
const SR: u32 = 0x0C;
const CR: u32 = 0x10;
const OPTCR: u32 = 0x14;
/// OPTCR's nDBANK: 1, a single bank (RM0410 §3.7.6).
const OPTCR_NDBANK: u32 = 1 << 29;

const FLASH_TABLE: &[Reg] = &[
    reg(ACR, "ACR", 0, 0x0000_0B0F, 0),
    reg(KEYR, "KEYR", 0, 0xFFFF_FFFF, 0),
    reg(0x08, "OPTKEYR", 0, 0xFFFF_FFFF, 0),
    // EOP, OPERR, WRPERR, PGAERR, PGPERR, ERSERR (rc_w1); BSY.
    reg(SR, "SR", 0, 0x0000_00F3, 0x0001_0000),
    // PG, SER, MER, SNB, PSIZE, MER2, STRT, EOPIE, ERRIE; LOCK.
    reg(CR, "CR", 0x8000_0000, 0x0301_87FF, 0x8000_0000),
    // The factory's option bytes (nDBANK = 1); `Flash::dual_bank`
    // clears nDBANK.
    reg(OPTCR, "OPTCR", 0xFFFF_AAFD, 0xFFFF_FFFF, 0),
    reg(0x18, "OPTCR1", 0x0040_0080, 0xFFFF_FFFF, 0),
];

const SR_EOP: u32 = 1 << 0;
const SR_PGAERR: u32 = 1 << 5;
const SR_PGPERR: u32 = 1 << 6;
const SR_BSY: u32 = 1 << 16;
const SR_W1C: u32 = 0x0000_00F3;

const CR_PG: u32 = 1 << 0;
const CR_SER: u32 = 1 << 1;
const CR_MER: u32 = 1 << 2;
const CR_STRT: u32 = 1 << 16;
const CR_EOPIE: u32 = 1 << 24;
const CR_LOCK: u32 = 1 << 31;

/// The unlock sequence (RM0410 §3.7.2).
const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;

/// The main flash.
pub const BASE: u32 = 0x0800_0000;
/// Bank 2 in dual-bank mode.
pub const BANK2: u32 = 0x0810_0000;

/// A word program. DS11532's "Flash memory programming" table was not
/// at hand when this model was written: the F7's times here are the
/// largest the public sources give (a programmer's table: 100 us a word,
/// 800 ms, 2.4 s and 4 s for a 32K, 128K and 256K sector; Zephyr's
/// driver: "a maximum erase time of 4s for a 256K sector"), so the
/// stalls measured on this model are a worst case.
pub const PROGRAM_US: u64 = 100;

/// The sector FLASH_CR.SNB `snb` selects: its start and size, in
/// single-bank mode (RM0410 Table 4) or dual-bank mode (Table 5: SNB
/// 0-11 bank 1's sectors 0-11, 16-27 bank 2's sectors 12-23).
pub fn sector(snb: u32, dual: bool) -> Option<(u32, u32)> {
    const K: u32 = 1024;
    if !dual {
        return match snb {
            0..=3 => Some((BASE + snb * 32 * K, 32 * K)),
            4 => Some((BASE + 128 * K, 128 * K)),
            5..=11 => Some((BASE + 256 * K * (snb - 4), 256 * K)),
            _ => None,
        };
    }
    let (bank, i) = match snb {
        0..=11 => (BASE, snb),
        16..=27 => (BANK2, snb - 16),
        _ => return None,
    };
    match i {
        0..=3 => Some((bank + i * 16 * K, 16 * K)),
        4 => Some((bank + 64 * K, 64 * K)),
        _ => Some((bank + 128 * K * (i - 4), 128 * K)),
    }
}

/// A sector erase by the sector's kind: the small, the 64K/128K one or
/// a large one ([`PROGRAM_US`] says where the figures come from: the
/// largest public ones, whatever FLASH_CR.PSIZE). In dual-bank mode each
/// sector is half its single-bank twin (Tables 4 and 5 side by side) and
/// takes its twin's time, as the F4's same-sized dual-bank sectors do
/// (16K, 64K, 128K: 800 ms, 2.4 s, 4 s at x8).
pub fn erase_us(size: u32, dual: bool) -> u64 {
    let twin = if dual { size * 2 } else { size };
    match twin / 1024 {
        0..=32 => 800_000,
        33..=128 => 2_400_000,
        _ => 4_000_000,
    }
}

/// Where the key sequence is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Keys {
    /// FLASH_CR locked, waiting for KEY1.
    Locked,
    /// KEY1 seen.
    First,
    /// Unlocked (LOCK clear).
    Open,
}

/// The flash interface.
pub struct Flash {
    regs: Regs,
    keys: Keys,
    busy: Option<Busy>,
}

impl Flash {
    /// The factory's single bank.
    pub fn new() -> Flash {
        Flash {
            regs: Regs::new(FLASH_TABLE),
            keys: Keys::Locked,
            busy: None,
        }
    }

    /// The dual-bank mode: the option byte nDBANK cleared (with a probe,
    /// before the images were flashed).
    pub fn dual_bank() -> Flash {
        let mut f = Flash::new();
        f.regs.set_bits(OPTCR, OPTCR_NDBANK, false);
        f
    }

    fn dual(&self) -> bool {
        self.regs.get(OPTCR) & OPTCR_NDBANK == 0
    }

    /// Whether an operation at `addr` stalls the core's fetches: always
    /// in the single bank, in dual-bank mode only in bank 1, where the
    /// code runs.
    fn stalls(&self, addr: u32) -> bool {
        !self.dual() || addr < BANK2
    }

    fn cr(&self) -> u32 {
        self.regs.get(CR)
    }

    /// An operation ended: BSY clear, EOP set when EOPIE is.
    fn end(&mut self, cx: &mut Cx) {
        if flash_array::finish(&mut self.busy, cx) {
            self.regs.set_bits(SR, SR_BSY, false);
            if self.cr() & CR_EOPIE != 0 {
                self.regs.set_bits(SR, SR_EOP, true);
            }
        }
    }

    fn write_cr(&mut self, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let old = self.cr();
        let written = crate::bus::widen(old, CR, size, value);
        if self.keys != Keys::Open {
            if written & !CR_LOCK == old & !CR_LOCK {
                return Ok(());
            }
            return Err(format!(
                "FLASH_CR written ({written:#010x}) while locked: unlock it with the key sequence in FLASH_KEYR first (RM0410 §3.7.2)"
            ));
        }
        if self.busy.is_some() {
            return Err(format!(
                "FLASH_CR written ({written:#010x}) while an operation is under way (FLASH_SR.BSY): wait for BSY to clear (RM0410 §3.3.7)"
            ));
        }
        let (_, new) = self.regs.write("FLASH", CR, size, value)?;
        if written & CR_LOCK != 0 {
            // LOCK is set by software, cleared only by the key sequence.
            self.regs.set_bits(CR, CR_LOCK, true);
            self.keys = Keys::Locked;
        }
        if new & CR_STRT != 0 {
            // STRT starts the erase and reads back clear once it ends;
            // here it is never kept.
            self.regs.set_bits(CR, CR_STRT, false);
            match (new & CR_SER != 0, new & CR_MER != 0) {
                (true, false) => {
                    let snb = (new >> 3) & 0x1F;
                    let dual = self.dual();
                    let Some((base, len)) = sector(snb, dual) else {
                        return Err(if dual {
                            format!("FLASH_CR: STRT with SER for SNB {snb}, which dual-bank mode does not have (0-11 for bank 1, 16-27 for bank 2's sectors 12-23, RM0410 Table 5)")
                        } else {
                            format!("FLASH_CR: STRT with SER for sector {snb}, which single-bank mode does not have (0-11, RM0410 Table 4)")
                        });
                    };
                    let stalls = self.stalls(base);
                    self.busy = Some(flash_array::start(
                        cx,
                        erase_us(len, dual),
                        Some((base, len)),
                        stalls,
                    ));
                    self.regs.set_bits(SR, SR_BSY, true);
                }
                (false, true) => {
                    return Err(
                        "FLASH_CR: a mass erase (MER) would erase the bootloader and the image running it"
                            .into(),
                    )
                }
                _ => {
                    return Err(format!(
                        "FLASH_CR: STRT with SER and MER {} (RM0410 §3.3.7: neither erase is done)",
                        if new & CR_SER != 0 { "both set" } else { "both clear" }
                    ))
                }
            }
        }
        Ok(())
    }
}

impl Default for Flash {
    fn default() -> Flash {
        Flash::new()
    }
}

impl Peripheral for Flash {
    fn name(&self) -> &'static str {
        "FLASH"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read("FLASH", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        match offset & !3 {
            ACR => {
                let (_, new) = self.regs.write("FLASH", offset, size, value)?;
                cx.clocks.flash_latency = new & 0xF;
                cx.clocks.check()
            }
            KEYR => {
                let expected = match self.keys {
                    Keys::Locked => KEY1,
                    Keys::First => KEY2,
                    Keys::Open => 0,
                };
                if size != 4 || value != expected || self.keys == Keys::Open {
                    return Err(format!(
                        "FLASH_KEYR: {value:#010x} written {}: a wrong key sequence locks FLASH_CR until the next reset and raises a bus error (RM0410 §3.7.2)",
                        match self.keys {
                            Keys::Open => "while FLASH_CR is unlocked".to_string(),
                            _ => format!("where the sequence needs {expected:#010x}"),
                        }
                    ));
                }
                if self.keys == Keys::Locked {
                    self.keys = Keys::First;
                } else {
                    self.keys = Keys::Open;
                    self.regs.set_bits(CR, CR_LOCK, false);
                }
                Ok(())
            }
            SR => {
                let written = crate::bus::widen(self.regs.get(SR), offset, size, value);
                let reserved = written & !(SR_W1C | SR_BSY);
                if reserved != 0 {
                    return Err(format!("FLASH_SR: reserved bits {reserved:#010x} written"));
                }
                // rc_w1: a 1 clears the flag.
                self.regs.set_bits(SR, written & SR_W1C, false);
                Ok(())
            }
            CR => self.write_cr(size, value, cx),
            _ => Err(format!(
                "FLASH_{}: written; the option bytes are not modelled",
                self.regs.name(offset)
            )),
        }
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        self.end(cx);
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.busy.map(|b| b.until)
    }

    /// FLASH_SR while the flash is busy: BSY until the operation ends.
    fn holds_until(&self, offset: u32, _now: u64) -> Option<u64> {
        if offset & !3 == SR {
            self.busy.map(|b| b.until)
        } else {
            None
        }
    }

    fn store(
        &mut self,
        addr: u32,
        size: u32,
        value: u64,
        old: &[u8],
        cx: &mut Cx,
    ) -> Option<Result<(), Refusal>> {
        if addr < BASE || addr - BASE >= 2048 * 1024 {
            return None;
        }
        Some(self.program(addr, size, value, old, cx))
    }
}

impl Flash {
    fn program(
        &mut self,
        addr: u32,
        size: u32,
        value: u64,
        old: &[u8],
        cx: &mut Cx,
    ) -> Result<(), Refusal> {
        let cr = self.cr();
        if self.keys != Keys::Open || cr & CR_PG == 0 {
            return Err(format!(
                "a {size}-byte store into flash without FLASH_CR.PG set{}: the flash is written only by programming (RM0410 §3.3.7)",
                if self.keys != Keys::Open { " (FLASH_CR locked)" } else { "" }
            ));
        }
        // A store while the flash is busy waits for it (the bus stalls).
        if let Some(b) = self.busy {
            *cx.stall += b.until.saturating_sub(cx.now);
            cx.now = b.until;
            self.end(cx);
        }
        let parallelism = 1u32 << ((cr >> 8) & 3);
        if size != parallelism {
            self.regs.set_bits(SR, SR_PGPERR, true);
            return Ok(());
        }
        if !addr.is_multiple_of(size) || addr / 16 != (addr + size - 1) / 16 {
            self.regs.set_bits(SR, SR_PGAERR, true);
            return Ok(());
        }
        let bytes = value.to_le_bytes();
        let bytes = &bytes[..size as usize];
        if let Some(at) = flash_array::sets_a_cleared_bit(old, bytes) {
            return Err(format!(
                "programs {:#04x} over {:#04x} at {:#010x}: only an erase sets a flash bit (RM0410 §3.3.7: successive programs may only clear bits)",
                bytes[at],
                old[at],
                addr + at as u32
            ));
        }
        cx.program.push((addr, bytes.to_vec()));
        let stalls = self.stalls(addr);
        self.busy = Some(flash_array::start(cx, PROGRAM_US, None, stalls));
        self.regs.set_bits(SR, SR_BSY, true);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
