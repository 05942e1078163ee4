//! The STM32H743's careful flash read, for both NUCLEO-H743ZI2 images (the
//! application's update partitions, `nucleo::update`; the bootloader's,
//! [`crate::nucleo_boot`]): a read that meets a flash word a power cut
//! tore returns [`DoubleEcc`] instead of faulting.
//!
//! Every 256-bit flash word of the H743 carries ECC bits written with it
//! (RM0433, the embedded flash's ECC). A program or an erase the power
//! stopped half-way leaves words whose bits and ECC disagree: the flash
//! answers a read of one with a bus error and sets its bank's DBECCERR
//! (FLASH_SR), the failing word in FLASH_ECC_FA. A plain load (embassy-
//! stm32's read is a `copy_from_slice`) is then a precise BusFault, and
//! the bootloader, which reads the state partition at every start, would
//! fault at every start: the board bricked by one cut.
//!
//! So the read runs with FAULTMASK set (priority -1) and SCB.CCR.BFHFNMIGN
//! set, where the Cortex-M7 ignores a precise data bus fault and the load
//! returns UNKNOWN data (ARMv7-M ARM, DDI 0403E, B3.2.8), and DBECCERR
//! says afterwards whether it happened. The flag is cleared through
//! FLASH_CCR (FLASH_SR is read-only; embassy-stm32's "write SR back" clears
//! nothing on this chip, and its program and erase return `Prog` while
//! DBECCERR is set). `rri_update::torn::TornAsProgrammed` then reads such a
//! word as programmed, which leads embassy-boot to a whole image.
//!
//! The cost: the flags cleared and read around the copy, and interrupts
//! held off (FAULTMASK masks all but NMI) for at most `WINDOW` bytes at
//! a time. The reads are off the cycle's path (the upload and the
//! confirmation run in the background executor); a window delays the
//! cycle's interrupt by about a microsecond at most.
#![allow(unsafe_code)]

use embassy_stm32::pac::FLASH;

/// Why a careful read failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadError {
    /// The range runs past the flash.
    OutOfRange,
    /// A word whose ECC reports a double error (a torn word).
    DoubleEcc,
}

/// SCB.CCR.BFHFNMIGN (B3.2.8).
const BFHFNMIGN: u32 = 1 << 8;

/// The most bytes read in one window with interrupts held off: 64 word
/// loads, about a microsecond at 400 MHz from flash.
const WINDOW: usize = 256;

/// Copies `bytes.len()` bytes of the flash from `offset` (from the
/// flash's start) into `bytes`, ignoring the bus fault of a torn word;
/// [`ReadError::DoubleEcc`] when one was met (the bytes are then
/// UNKNOWN), [`ReadError::OutOfRange`] for a range past the flash.
pub fn read(offset: u32, bytes: &mut [u8]) -> Result<(), ReadError> {
    let end = (offset as usize).checked_add(bytes.len());
    if end.is_none_or(|e| e > embassy_stm32::flash::FLASH_SIZE) {
        return Err(ReadError::OutOfRange);
    }
    let mut at = (embassy_stm32::flash::FLASH_BASE as u32).wrapping_add(offset) as usize;
    clear();
    for window in bytes.chunks_mut(WINDOW) {
        // SAFETY: `at..at + window.len()` is flash (checked above).
        unsafe { copy_ignoring_bus_faults(at, window) };
        at += window.len();
    }
    let torn = (0..2).any(|b| FLASH.bank(b).sr().read().dbeccerr());
    if torn {
        clear();
        return Err(ReadError::DoubleEcc);
    }
    Ok(())
}

/// Copies `to.len()` bytes from `from` with precise data bus faults
/// ignored: FAULTMASK set, SCB.CCR.BFHFNMIGN set, both restored after.
/// Word loads where `from` is aligned (a flash word is 32 bytes, so a
/// word load never spans two).
///
/// # Safety
/// `from..from + to.len()` is readable memory (the flash). FAULTMASK is
/// clear on entry: a caller inside a HardFault or NMI does not read the
/// flash this way.
unsafe fn copy_ignoring_bus_faults(from: usize, to: &mut [u8]) {
    // SAFETY: SCB's CCR is this core's; BFHFNMIGN only changes what a
    // fault at priority -1 or -2 does and is restored before FAULTMASK is
    // cleared; FAULTMASK is set and cleared here only. The loads are
    // within the range the caller promises.
    unsafe {
        let scb = &*cortex_m::peripheral::SCB::PTR;
        let ccr = scb.ccr.read();
        core::arch::asm!("cpsid f", options(nomem, nostack, preserves_flags));
        scb.ccr.write(ccr | BFHFNMIGN);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        let mut i = 0;
        while i < to.len() {
            let a = from + i;
            if a.is_multiple_of(4) && to.len() - i >= 4 {
                // Volatile: each load is made, in order, in the window.
                let w = core::ptr::read_volatile(a as *const u32).to_le_bytes();
                if let Some(dst) = to.get_mut(i..i + 4) {
                    dst.copy_from_slice(&w);
                }
                i += 4;
            } else {
                if let Some(dst) = to.get_mut(i) {
                    *dst = core::ptr::read_volatile(a as *const u8);
                }
                i += 1;
            }
        }
        cortex_m::asm::dsb();
        scb.ccr.write(ccr);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        core::arch::asm!("cpsie f", options(nomem, nostack, preserves_flags));
    }
}

/// Clears both banks' DBECCERR (and the failing address with it).
fn clear() {
    for b in 0..2 {
        FLASH.bank(b).ccr().write(|w| w.set_clr_dbeccerr(true));
    }
}
