//! RAM the board prepares before the firmware touches it: `.diag_ram`,
//! the diagnostics service's buffers (NOLOAD in every memory map: in the
//! NUCLEO boards' DMA SRAM, beside the Ethernet rings, so that they take
//! nothing from the DTCM the stack and the cycle's statics share).
//! cortex-m-rt zeroes `.bss` only (the memory maps insert this section
//! before `.bss`, so `__ebss` stays `.bss`'s end: `cargo boards` checks
//! it, and an image whose reset handler zeroes more is a broken variant
//! `cargo rehost -- --broken` must stop); the board zeroes this section in its
//! `init`, so every static placed there (byte buffers, all-zero at
//! start) holds its initial value before it is first used.
#![allow(unsafe_code)]

extern "C" {
    static mut __sdiag_ram: u32;
    static mut __ediag_ram: u32;
}

/// Zeroes `.diag_ram`. Called once by the board's `init`, before any
/// task exists.
pub(crate) fn zero_diag_ram() {
    // SAFETY: the memory map's symbols bound the section, word-aligned;
    // nothing uses it before this runs (the firmware's statics there are
    // only reached after `init`).
    unsafe {
        let mut p = core::ptr::addr_of_mut!(__sdiag_ram);
        let end = core::ptr::addr_of_mut!(__ediag_ram);
        while p < end {
            core::ptr::write_volatile(p, 0);
            p = p.add(1);
        }
    }
}

/// Bytes in `.diag_ram` (for the start-up log).
pub fn diag_ram_bytes() -> usize {
    // Only the symbols' addresses are taken.
    (core::ptr::addr_of!(__ediag_ram) as usize)
        .saturating_sub(core::ptr::addr_of!(__sdiag_ram) as usize)
}
