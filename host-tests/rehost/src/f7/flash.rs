//! The STM32F76x/77x flash interface (RM0410 rev 5 §3): its access
//! control (FLASH_ACR's wait states feed the clock check, §3.7.1) and the
//! programming and erase of the main flash (§3.3.6-3.3.8, §3.7), in the
//! board's single-bank mode (OPTCR nDBANK = 1, the reset value here):
//! 12 sectors, 4 x 32K, 128K, 7 x 256K from 0x0800_0000.
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
//! datasheet's table was not at hand), and in single-bank mode the core, which fetches
//! its code from that flash, waits for it (`crate::flash_array`).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};
use crate::flash_array::{self, Busy};

const ACR: u32 = 0x00;
const KEYR: u32 = 0x04;
const SR: u32 = 0x0C;
const CR: u32 = 0x10;

const FLASH_TABLE: &[Reg] = &[
    reg(ACR, "ACR", 0, 0x0000_0B0F, 0),
    reg(KEYR, "KEYR", 0, 0xFFFF_FFFF, 0),
    reg(0x08, "OPTKEYR", 0, 0xFFFF_FFFF, 0),
    // EOP, OPERR, WRPERR, PGAERR, PGPERR, ERSERR (rc_w1); BSY.
    reg(SR, "SR", 0, 0x0000_00F3, 0x0001_0000),
    // PG, SER, MER, SNB, PSIZE, MER2, STRT, EOPIE, ERRIE; LOCK.
    reg(CR, "CR", 0x8000_0000, 0x0301_87FF, 0x8000_0000),
    reg(0x14, "OPTCR", 0xFFFF_AAFD, 0xFFFF_FFFF, 0),
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

/// A word program. DS11532's "Flash memory programming" table was not
/// at hand when this model was written: the F7's times here are the
/// largest the public sources give (a programmer's table: 100 us a word,
/// 800 ms, 2.4 s and 4 s for a 32K, 128K and 256K sector; Zephyr's
/// driver: "a maximum erase time of 4s for a 256K sector"), so the
/// stalls measured on this model are a worst case.
pub const PROGRAM_US: u64 = 100;

/// The sector `snb` in single-bank mode (RM0410 Table 4): its start and
/// size.
pub fn sector(snb: u32) -> Option<(u32, u32)> {
    const K: u32 = 1024;
    match snb {
        0..=3 => Some((BASE + snb * 32 * K, 32 * K)),
        4 => Some((BASE + 128 * K, 128 * K)),
        5..=11 => Some((BASE + 256 * K * (snb - 4), 256 * K)),
        _ => None,
    }
}

/// A sector erase by the sector's size ([`PROGRAM_US`] says where the
/// figures come from: the largest public ones, whatever FLASH_CR.PSIZE;
/// embassy-stm32 erases with PSIZE 0, x8, the slowest).
pub fn erase_us(size: u32) -> u64 {
    match size / 1024 {
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
    pub fn new() -> Flash {
        Flash {
            regs: Regs::new(FLASH_TABLE),
            keys: Keys::Locked,
            busy: None,
        }
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
                    let Some((base, len)) = sector(snb) else {
                        return Err(format!(
                            "FLASH_CR: STRT with SER for sector {snb}, which single-bank mode does not have (0-11, RM0410 Table 4)"
                        ));
                    };
                    self.busy = Some(flash_array::start(
                        cx,
                        erase_us(len),
                        Some((base, len)),
                        true,
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
        self.busy = Some(flash_array::start(cx, PROGRAM_US, None, true));
        self.regs.set_bits(SR, SR_BSY, true);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Bench = crate::flash_array::testing::Bench<Flash>;

    fn bench() -> Bench {
        Bench::new(Flash::new(), 16_000_000)
    }

    fn unlock(b: &mut Bench) {
        b.unlock_at(KEYR, [KEY1, KEY2]);
    }

    #[test]
    fn the_key_sequence_unlocks_and_a_wrong_key_is_refused() {
        let mut b = bench();
        assert_ne!(b.r(CR) & CR_LOCK, 0);
        let e = b.w(CR, CR_PG).unwrap_err();
        assert!(e.contains("while locked"), "{e}");
        unlock(&mut b);
        assert_eq!(b.r(CR) & CR_LOCK, 0);
        b.w(CR, CR_LOCK).unwrap();
        assert_ne!(b.r(CR) & CR_LOCK, 0);
        let e = b.w(KEYR, KEY2).unwrap_err();
        assert!(e.contains("bus error"), "{e}");
    }

    #[test]
    fn a_word_is_programmed_at_x32_and_a_wrong_size_is_flagged() {
        let mut b = bench();
        unlock(&mut b);
        b.w(CR, CR_PG | (2 << 8)).unwrap();
        b.store(0x0808_0000, 4, 0x1234_5678, &[0xFF; 4]).unwrap();
        assert_eq!(
            b.shared.program,
            vec![(0x0808_0000, vec![0x78, 0x56, 0x34, 0x12])]
        );
        // Busy for the program time, and the core stalled that long.
        assert_ne!(b.r(SR) & SR_BSY, 0);
        assert_eq!(b.shared.stall, 16 * PROGRAM_US);
        b.now += 16 * PROGRAM_US;
        assert_eq!(b.r(SR) & SR_BSY, 0);
        // A half-word at x32: PGPERR, nothing written.
        b.shared.program.clear();
        b.store(0x0808_0004, 2, 0, &[0xFF; 2]).unwrap();
        assert!(b.shared.program.is_empty());
        assert_ne!(b.r(SR) & SR_PGPERR, 0);
        b.w(SR, SR_PGPERR).unwrap();
        assert_eq!(b.r(SR) & SR_PGPERR, 0);
    }

    #[test]
    fn stores_without_pg_and_over_cleared_bits_are_refused() {
        let mut b = bench();
        let e = b.store(0x0808_0000, 4, 0, &[0xFF; 4]).unwrap_err();
        assert!(e.contains("without FLASH_CR.PG"), "{e}");
        unlock(&mut b);
        b.w(CR, CR_PG | (2 << 8)).unwrap();
        // 0x0F over 0xF0: sets bits, which only an erase does.
        let e = b
            .store(0x0808_0000, 4, 0x0F, &[0xF0, 0xFF, 0xFF, 0xFF])
            .unwrap_err();
        assert!(e.contains("only an erase sets"), "{e}");
        // Clearing more bits of a programmed word is allowed.
        b.store(0x0808_0000, 4, 0x00, &[0xF0, 0xFF, 0xFF, 0xFF])
            .unwrap();
    }

    #[test]
    fn a_sector_erase_takes_its_time_and_leaves_all_ones() {
        let mut b = bench();
        unlock(&mut b);
        b.w(CR, CR_SER | (6 << 3)).unwrap();
        b.w(CR, CR_SER | (6 << 3) | CR_STRT).unwrap();
        assert_ne!(b.r(SR) & SR_BSY, 0);
        // 4 s for 256K, at 16 MHz.
        let len = 16 * 4_000_000;
        assert_eq!(b.shared.stall, len);
        let e = b.w(CR, 0).unwrap_err();
        assert!(e.contains("while an operation is under way"), "{e}");
        b.now += len;
        assert_eq!(b.r(SR) & SR_BSY, 0);
        assert_eq!(b.shared.program.len(), 1);
        assert_eq!(b.shared.program[0].0, 0x0808_0000);
        assert_eq!(b.shared.program[0].1.len(), 256 * 1024);
        assert!(b.shared.program[0].1.iter().all(|&x| x == 0xFF));
        // A sector single-bank mode does not have.
        b.w(CR, CR_SER | (12 << 3)).unwrap();
        let e = b.w(CR, CR_SER | (12 << 3) | CR_STRT).unwrap_err();
        assert!(e.contains("sector 12"), "{e}");
    }

    #[test]
    fn the_sectors_are_rm0410s() {
        assert_eq!(sector(0), Some((0x0800_0000, 32 * 1024)));
        assert_eq!(sector(4), Some((0x0802_0000, 128 * 1024)));
        assert_eq!(sector(5), Some((0x0804_0000, 256 * 1024)));
        assert_eq!(sector(11), Some((0x081C_0000, 256 * 1024)));
        assert_eq!(sector(12), None);
    }
}
