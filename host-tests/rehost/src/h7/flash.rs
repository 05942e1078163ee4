//! The STM32H743 flash interface (RM0433 rev 8 §4): its access control
//! (FLASH_ACR's wait states and programming delay feed the clock check,
//! §4.9) and the programming and erase of the two banks (§4.3.9-4.3.10,
//! registers §4.9): 2 x 8 sectors of 128K, bank 1 at 0x0800_0000 and
//! bank 2 at 0x0810_0000, each with its own KEYR, CR, SR and CCR (bank
//! 2's at +0x100).
//!
//! Programming goes through a bank's 256-bit write buffer: with PG set,
//! the core's stores fill one flash word (32 bytes, aligned); the eighth
//! word queues it (QW) and the bank programs it (BSY). A store into
//! another flash word before the buffer is full is an inconsistency
//! (INCERR, the buffer dropped), as §4.3.9 says. A flash word is
//! programmed once after an erase (its ECC is written with it): the model
//! refuses a second program, and a store into flash without PG, and
//! FLASH_CR written while locked or while its bank is busy, and a wrong
//! key sequence (silicon locks the bank's CR until reset and raises a bus
//! error).
//!
//! Time: a program or an erase keeps its bank busy for the datasheet's
//! typical time (DS12110 Table 53, `program_us`, `erase_us`).
//! The banks read while the other writes (§4.3.5): the core, which runs
//! from bank 1, waits only for operations in bank 1 (`crate::flash_array`).
//!
//! FLASH_SR is read-only: a write to it (embassy-stm32 writes back what
//! it read) changes nothing, as on silicon; flags clear through CCR.
//!
//! ECC: a read of a flash word a power cut tore (`--tear`,
//! [`crate::torn_word`]) is a double ECC error: the bank's DBECCERR is
//! set and FLASH_ECC_FA holds the word's index in the bank (256-bit
//! units, 15 bits; ST's SVD), both cleared by CLR_DBECCERR in CCR; with
//! DBECCERRIE the flash's interrupt is raised. A torn word is programmed
//! again only after its sector's erase.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};
use crate::flash_array::{self, Busy};

const ACR: u32 = 0x00;

/// RM0433 §4.9, bank 1 and bank 2's control registers (fields of ST's
/// STM32H743 SVD; CR1 and CR2 reset locked, OPTCR with OPTLOCK).
const FLASH_TABLE: &[Reg] = &[
    reg(ACR, "ACR", 0x0000_0037, 0x0000_003F, 0),
    reg(0x04, "KEYR1", 0, 0xFFFF_FFFF, 0),
    reg(0x08, "OPTKEYR", 0, 0xFFFF_FFFF, 0),
    reg(0x0C, "CR1", 0x0000_0031, 0x1FEF_87FF, 0),
    reg(0x10, "SR1", 0, 0, 0x1FEF_000F),
    reg(0x14, "CCR1", 0, 0x1FEF_0000, 0),
    reg(0x18, "OPTCR", 0x0000_0001, 0xC000_0013, 0),
    reg(0x60, "ECC_FA1R", 0, 0, 0x0000_7FFF),
    reg(0x104, "KEYR2", 0, 0xFFFF_FFFF, 0),
    reg(0x10C, "CR2", 0x0000_0031, 0x1FEF_C7FF, 0),
    reg(0x110, "SR2", 0, 0, 0x0FEF_000F),
    reg(0x114, "CCR2", 0, 0x0FEF_0000, 0),
    reg(0x160, "ECC_FA2R", 0, 0, 0x0000_7FFF),
];

const KEYR: u32 = 0x04;
const CR: u32 = 0x0C;
const SR: u32 = 0x10;
const CCR: u32 = 0x14;
const ECC_FA: u32 = 0x60;

const CR_LOCK: u32 = 1 << 0;
const CR_PG: u32 = 1 << 1;
const CR_SER: u32 = 1 << 2;
const CR_BER: u32 = 1 << 3;
const CR_FW: u32 = 1 << 6;
const CR_START: u32 = 1 << 7;
const CR_EOPIE: u32 = 1 << 16;

/// The flash's global interrupt (RM0433 Table 147, position 4): EOP with
/// EOPIE (an operation's end, embassy-stm32's async erase waits on it).
const FLASH_IRQ: u32 = 4;

const SR_BSY: u32 = 1 << 0;
const SR_WBNE: u32 = 1 << 1;
const SR_QW: u32 = 1 << 2;
const SR_EOP: u32 = 1 << 16;
const SR_INCERR: u32 = 1 << 21;
/// SR's DBECCERR; CR's DBECCERRIE, CCR's CLR_DBECCERR at the same bit.
const SR_DBECCERR: u32 = 1 << 26;

const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;

/// The banks.
pub const BANK1: u32 = 0x0800_0000;
pub const BANK_SIZE: u32 = 1024 * 1024;
const SECTOR: u32 = 128 * 1024;
/// A flash word: what the write buffer holds and one program writes.
pub const FLASH_WORD: u32 = 32;

/// DS12110 Table 53 "Flash memory programming" (typical, by
/// FLASH_CR.PSIZE: x8, x16, x32, x64): one 266-bit flash word (256 bits
/// and its ECC). embassy-stm32 programs at x32.
pub fn program_us(psize: u32) -> u64 {
    [290, 180, 130, 100][(psize & 3) as usize]
}

/// DS12110 Table 53 (typical, by PSIZE): a 128K sector erase.
/// embassy-stm32 erases with PSIZE left 0 by its last program (x8, the
/// slowest).
pub fn erase_us(psize: u32) -> u64 {
    [2_000_000, 1_800_000, 1_100_000, 1_000_000][(psize & 3) as usize]
}

/// ACR, OPTKEYR and OPTCR answer at bank 2's offsets too (0x100 on).
fn alias(offset: u32) -> u32 {
    match offset & !3 {
        0x100 | 0x108 | 0x118 => offset - 0x100,
        _ => offset,
    }
}

/// One bank's programming state.
#[derive(Clone, Debug, Default)]
struct Bank {
    /// The key sequence: 0 locked, 1 KEY1 seen, 2 open.
    keys: u8,
    busy: Option<Busy>,
    /// The write buffer: the flash word it fills and the bytes written
    /// (a bit per byte).
    buffer: Option<(u32, [u8; FLASH_WORD as usize], u32)>,
}

/// The flash interface.
pub struct Flash {
    regs: Regs,
    banks: [Bank; 2],
}

impl Flash {
    pub fn new() -> Flash {
        Flash {
            regs: Regs::new(FLASH_TABLE),
            banks: [Bank::default(), Bank::default()],
        }
    }

    /// Bank `b`'s offset of register `r` (bank 1's offset).
    fn at(b: usize, r: u32) -> u32 {
        r + 0x100 * b as u32
    }

    /// The core's reads of torn words since the last access
    /// ([`crate::torn_word`]): each bank's DBECCERR and failing address.
    fn ecc(&mut self, cx: &mut Cx) {
        if cx.flash.ecc_errors.is_empty() {
            return;
        }
        for word in std::mem::take(&mut cx.flash.ecc_errors) {
            let Some(offset) = word.checked_sub(BANK1).filter(|o| *o < 2 * BANK_SIZE) else {
                continue;
            };
            let b = (offset / BANK_SIZE) as usize;
            self.regs.set_bits(Self::at(b, SR), SR_DBECCERR, true);
            self.regs.set(
                Self::at(b, ECC_FA),
                ((offset % BANK_SIZE) / FLASH_WORD) & 0x7FFF,
            );
            if self.regs.get(Self::at(b, CR)) & SR_DBECCERR != 0 {
                cx.raise.push(FLASH_IRQ);
            }
        }
    }

    fn end(&mut self, b: usize, cx: &mut Cx) {
        if flash_array::finish(&mut self.banks[b].busy, cx) {
            self.regs.set_bits(Self::at(b, SR), SR_BSY | SR_QW, false);
            self.regs.set_bits(Self::at(b, SR), SR_EOP, true);
            if self.regs.get(Self::at(b, CR)) & CR_EOPIE != 0 {
                cx.raise.push(FLASH_IRQ);
            }
        }
    }

    fn write_cr(&mut self, b: usize, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let at = Self::at(b, CR);
        let old = self.regs.get(at);
        let written = crate::bus::widen(old, at, size, value);
        let name = if b == 0 { "FLASH_CR1" } else { "FLASH_CR2" };
        if self.banks[b].keys != 2 {
            if written & !CR_LOCK == old & !CR_LOCK {
                return Ok(());
            }
            return Err(format!(
                "{name} written ({written:#010x}) while locked: unlock it with the key sequence in FLASH_KEYR{} first (RM0433 §4.5.1)",
                b + 1
            ));
        }
        if self.banks[b].busy.is_some() {
            return Err(format!(
                "{name} written ({written:#010x}) while the bank is busy (FLASH_SR{}.BSY): wait for BSY and QW to clear (RM0433 §4.3.9)",
                b + 1
            ));
        }
        let (_, new) = self.regs.write("FLASH", at, size, value)?;
        if written & CR_LOCK != 0 {
            self.banks[b].keys = 0;
            self.regs.set_bits(at, CR_LOCK, true);
        }
        if new & CR_FW != 0 {
            return Err(format!(
                "{name}: FW (a forced write of a partial flash word) is not modelled"
            ));
        }
        if new & CR_START != 0 {
            self.regs.set_bits(at, CR_START, false);
            if new & CR_BER != 0 || new & CR_SER == 0 {
                return Err(format!(
                    "{name}: START {}",
                    if new & CR_BER != 0 {
                        "with BER: a bank erase would erase the bootloader or the update partition whole"
                    } else {
                        "without SER (RM0433 §4.3.10)"
                    }
                ));
            }
            let snb = (new >> 8) & 7;
            let base = BANK1 + b as u32 * BANK_SIZE + snb * SECTOR;
            let psize = (new >> 4) & 3;
            // The core runs from bank 1: it waits for bank 1's operations.
            self.banks[b].busy = Some(flash_array::start(
                cx,
                erase_us(psize),
                Some((base, SECTOR)),
                b == 0,
            ));
            self.regs.set_bits(Self::at(b, SR), SR_BSY | SR_QW, true);
        }
        Ok(())
    }

    fn program(
        &mut self,
        addr: u32,
        size: u32,
        value: u64,
        old: &[u8],
        cx: &mut Cx,
    ) -> Result<(), Refusal> {
        let b = ((addr - BANK1) / BANK_SIZE) as usize;
        let cr = self.regs.get(Self::at(b, CR));
        if self.banks[b].keys != 2 || cr & CR_PG == 0 {
            return Err(format!(
                "a {size}-byte store into flash bank {} without FLASH_CR{}.PG set{}: the flash is written only by programming (RM0433 §4.3.9)",
                b + 1,
                b + 1,
                if self.banks[b].keys != 2 { " (locked)" } else { "" }
            ));
        }
        if let Some(busy) = self.banks[b].busy {
            // The buffer takes no new word before the last one is
            // programmed: the bus waits.
            *cx.stall += busy.until.saturating_sub(cx.now);
            cx.now = busy.until;
            self.end(b, cx);
        }
        let word = addr & !(FLASH_WORD - 1);
        if cx.flash.torn.contains(&word) {
            return Err(format!(
                "programs {addr:#010x}, in a flash word a power cut tore (its bits and ECC disagree): it is programmed again only after its sector's erase"
            ));
        }
        if (addr + size - 1) & !(FLASH_WORD - 1) != word {
            return Err(format!(
                "a {size}-byte store at {addr:#010x} crosses a 256-bit flash word"
            ));
        }
        if let Some(at) = old.iter().position(|&x| x != 0xFF) {
            return Err(format!(
                "programs {addr:#010x}, whose flash word is not erased ({:#04x} at {:#010x}): a flash word is programmed once after an erase, its ECC with it (RM0433 §4.3.9)",
                old[at],
                addr + at as u32
            ));
        }
        let bytes = value.to_le_bytes();
        let bank = &mut self.banks[b];
        if let Some((w, _, _)) = bank.buffer {
            if w != word {
                // RM0433 §4.3.9: another flash word before the buffer is
                // full: INCERR, the buffer's content is lost.
                bank.buffer = None;
                self.regs.set_bits(Self::at(b, SR), SR_INCERR, true);
                self.regs.set_bits(Self::at(b, SR), SR_WBNE, false);
                return Ok(());
            }
        }
        let (w, mut data, mut filled) = bank.buffer.unwrap_or((word, [0xFF; 32], 0));
        for i in 0..size {
            let at = (addr - word + i) as usize;
            data[at] = bytes[i as usize];
            filled |= 1 << at;
        }
        if filled != u32::MAX {
            bank.buffer = Some((w, data, filled));
            self.regs.set_bits(Self::at(b, SR), SR_WBNE, true);
            return Ok(());
        }
        bank.buffer = None;
        self.regs.set_bits(Self::at(b, SR), SR_WBNE, false);
        cx.program.push((w, data.to_vec()));
        let psize = (cr >> 4) & 3;
        self.banks[b].busy = Some(flash_array::start(cx, program_us(psize), None, b == 0));
        self.regs.set_bits(Self::at(b, SR), SR_BSY | SR_QW, true);
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

    fn read(&mut self, offset: u32, size: u32, cx: &mut Cx) -> Result<u32, Refusal> {
        self.ecc(cx);
        self.regs.read("FLASH", alias(offset), size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let offset = alias(offset);
        let b = (offset >= 0x100) as usize;
        match offset & !3 & 0xFF {
            ACR if b == 0 => {
                let (_, new) = self.regs.write("FLASH", offset, size, value)?;
                cx.clocks.flash_latency = new & 0xF;
                cx.clocks.flash_wrhighfreq = (new >> 4) & 3;
                super::power::check(cx.clocks)
            }
            KEYR => {
                let keys = self.banks[b].keys;
                let expected = if keys == 0 { KEY1 } else { KEY2 };
                if size != 4 || keys == 2 || value != expected {
                    return Err(format!(
                        "FLASH_KEYR{}: {value:#010x} written {}: a wrong key sequence locks the bank's FLASH_CR until the next reset and raises a bus error (RM0433 §4.5.1)",
                        b + 1,
                        if keys == 2 {
                            "while the bank is unlocked".to_string()
                        } else {
                            format!("where the sequence needs {expected:#010x}")
                        }
                    ));
                }
                self.banks[b].keys = keys + 1;
                if keys + 1 == 2 {
                    self.regs.set_bits(Self::at(b, CR), CR_LOCK, false);
                }
                Ok(())
            }
            CR => self.write_cr(b, size, value, cx),
            SR => {
                // Read-only: silicon ignores the write.
                self.regs.read("FLASH", offset, size).map(|_| ())
            }
            CCR => {
                self.ecc(cx);
                let (_, new) = self.regs.write("FLASH", offset, size, value)?;
                // A 1 clears the flag of the same position in SR; the
                // failing address goes with the ECC flags (ST's SVD:
                // reset once neither SNECCERR nor DBECCERR is set).
                self.regs.set_bits(Self::at(b, SR), new, false);
                if self.regs.get(Self::at(b, SR)) & (SR_DBECCERR | SR_DBECCERR >> 1) == 0 {
                    self.regs.set(Self::at(b, ECC_FA), 0);
                }
                self.regs.set(offset & !3, 0);
                Ok(())
            }
            _ => {
                self.regs.read("FLASH", offset, size)?;
                Err(format!(
                    "FLASH_{}: written; the option bytes are not modelled",
                    self.regs.name(offset)
                ))
            }
        }
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        self.ecc(cx);
        self.end(0, cx);
        self.end(1, cx);
        Ok(())
    }

    /// FLASH_SR1/2 while its bank is busy: BSY and QW until the operation
    /// ends (DBECCERR may be set sooner only by a read of the flash, which
    /// [`crate::fast_forward`] watches for).
    fn holds_until(&self, offset: u32, _now: u64) -> Option<u64> {
        let offset = alias(offset);
        let b = usize::from(offset >= 0x100);
        if offset & !0x103 == SR {
            self.banks[b].busy.map(|busy| busy.until)
        } else {
            None
        }
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.banks
            .iter()
            .filter_map(|b| b.busy.map(|b| b.until))
            .min()
    }

    fn store(
        &mut self,
        addr: u32,
        size: u32,
        value: u64,
        old: &[u8],
        cx: &mut Cx,
    ) -> Option<Result<(), Refusal>> {
        if addr < BANK1 || addr - BANK1 >= 2 * BANK_SIZE {
            return None;
        }
        Some(self.program(addr, size, value, old, cx))
    }
}

#[cfg(test)]
mod tests;
