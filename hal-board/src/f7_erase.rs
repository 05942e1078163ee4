//! The STM32F767's sector erase in dual-bank mode, for both NUCLEO-F767ZI
//! images (the application's upload, `nucleo::update`; the bootloader's
//! swap, [`crate::nucleo_boot`]): started through the flash's registers
//! and waited for by the caller's `wait`.
//!
//! Not embassy-stm32's erase, for two reasons:
//! - **It erases the wrong bank.** RM0410 §3.7.5 gives FLASH_CR.SNB five
//!   bits (7:3), bit 4 the bank in dual-bank mode (bank 2's sectors 12-23
//!   are SNB 16-27). stm32-metapac 21's F7 register block has SNB four
//!   bits wide, and its setter drops bit 4, so embassy-stm32 0.6's erase
//!   of a bank-2 sector (`(bank << 4) + index`) erases bank 1's sector of
//!   the same index instead: the bootloader and the running image. The
//!   rehosted chip's flash model (RM0410's field) caught it: the first
//!   upload erased 0x0800_0000. SNB is written here whole.
//! - **It waits without a break** (its blocking erase; it has no
//!   interrupt-driven one for this family): up to 4 s a 128K sector,
//!   twice the watchdog's timeout. The application's `wait` feeds the
//!   watchdog while it sleeps; the bootloader's, with no watchdog running,
//!   spins.
//!
//! The sectors are embassy-stm32's (its flash regions in dual-bank mode).

use embassy_stm32::flash::{Error, FlashBank};
use embassy_stm32::pac::flash::regs::Cr;
use embassy_stm32::pac::flash::vals::Psize;
use embassy_stm32::pac::FLASH as REGS;

/// The flash's key sequence (RM0410 §3.7.2).
const KEYS: [u32; 2] = [0x4567_0123, 0xCDEF_89AB];

/// Erases `[from, to)` (offsets from the flash's start, whole sectors),
/// one sector at a time, calling `wait` while each is under way.
pub fn erase(from: u32, to: u32, wait: &mut dyn FnMut()) -> Result<(), Error> {
    let base = embassy_stm32::flash::FLASH_BASE as u32;
    let (start, end) = (base + from, base + to);
    let mut at = start;
    while at < end {
        let (snb, size) = sector(at).ok_or(Error::Unaligned)?;
        erase_sector(snb, wait)?;
        at += size;
    }
    Ok(())
}

/// The sector that starts at `addr`: its SNB (bit 4 the bank, the low
/// bits its index in the bank) and its size; `None` if no sector starts
/// there.
///
/// The banks are where the dual-bank map puts them unswapped: bank 2 at
/// the flash's second half. embassy-stm32's `FlashRegion::base` would
/// read SYSCFG_MEMRMP's bank swap for it, and the bootloader runs with
/// SYSCFG's clock off (a read then gives 0 on silicon and stops the
/// rehosted chip, which refuses a read of an unclocked peripheral).
/// Nothing here swaps the banks.
fn sector(addr: u32) -> Option<(u8, u32)> {
    let flash = embassy_stm32::flash::FLASH_BASE as u32;
    let bank2 = flash + embassy_stm32::flash::FLASH_SIZE as u32 / 2;
    let mut bank = FlashBank::Bank1;
    let mut index = 0u8;
    for region in embassy_stm32::flash::get_flash_regions() {
        if region.bank != bank {
            bank = region.bank;
            index = 0;
        }
        let (bank_base, bank_bit) = match region.bank {
            FlashBank::Bank1 => (flash, 0),
            FlashBank::Bank2 => (bank2, 1 << 4),
            _ => return None,
        };
        let base = bank_base + region.offset;
        if (base..base + region.size).contains(&addr) {
            let offset = addr - base;
            if !offset.is_multiple_of(region.erase_size) {
                return None;
            }
            let n = u8::try_from(offset / region.erase_size).ok()?;
            return Some((bank_bit | (index + n), region.erase_size));
        }
        index += region.sectors();
    }
    None
}

/// One sector's erase, waited for with `wait`.
fn erase_sector(snb: u8, wait: &mut dyn FnMut()) -> Result<(), Error> {
    // The flags of an earlier operation (rc_w1: written back, cleared).
    REGS.sr().modify(|_| {});
    if REGS.cr().read().lock() {
        for key in KEYS {
            REGS.keyr().write_value(key);
        }
    }
    // x32: the NUCLEO's 3.3 V allows it (RM0410 Table 7), and it erases
    // faster than embassy-stm32's x8.
    let mut cr = Cr(0);
    cr.set_ser(true);
    cr.set_psize(Psize::PSIZE32);
    // SNB[4:0] at bits 7:3 (the register block's setter keeps four).
    cr.0 |= u32::from(snb & 0x1F) << 3;
    REGS.cr().write_value(cr);
    cr.set_strt(true);
    REGS.cr().write_value(cr);
    let sr = loop {
        let sr = REGS.sr().read();
        if !sr.bsy() {
            break sr;
        }
        wait();
    };
    REGS.cr().write(|w| w.set_lock(true));
    if sr.erserr() {
        Err(Error::Seq)
    } else if sr.wrperr() {
        Err(Error::Protected)
    } else if sr.operr() {
        Err(Error::Prog)
    } else {
        Ok(())
    }
}
