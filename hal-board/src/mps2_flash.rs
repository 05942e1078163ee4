//! QEMU mps2-an500's flash partitions (issue 43), as both of its images
//! see them: the bootloader ([`crate::mps2_an500_boot`]) and the
//! application ([`crate::mps2_an500`]'s `update`). The addresses are the
//! memory map's (`memory/mps2-an500-flash.x`, which both images link
//! with); each handle keeps a NOR flash's rules over that RAM
//! ([`crate::ram_flash`]).
#![allow(unsafe_code)]

use crate::ram_flash::RamFlash;

extern "C" {
    static __factory: u8;
    static __factory_len: u8;
    static mut __update_active: u8;
    static __update_active_len: u8;
    static mut __update_state: u8;
    static __update_state_len: u8;
    static mut __update_dfu: u8;
    static __update_dfu_len: u8;
}

/// The active partition's start: where the application is linked.
pub fn active_origin() -> u32 {
    // A linker symbol's address, never read through; the board's
    // addresses are 32-bit.
    core::ptr::addr_of!(__update_active) as usize as u32
}

/// The active partition's bytes: the most an image may have.
pub fn active_len() -> usize {
    core::ptr::addr_of!(__update_active_len) as usize
}

/// The active partition.
///
/// # Safety
/// No other handle on it is used while this one is, and no code runs from
/// it while it is written (the bootloader's alone).
pub unsafe fn active() -> RamFlash {
    // SAFETY: linker symbols: a partition's start and length, in no
    // section of either image (`memory/mps2-an500-flash.x`).
    unsafe {
        RamFlash::new(
            core::ptr::addr_of_mut!(__update_active),
            core::ptr::addr_of!(__update_active_len) as usize,
        )
    }
}

/// The update (DFU) and state partitions.
///
/// # Safety
/// No other handle on either is used while these are (the application's
/// update desk holds one pair at a time; the bootloader runs alone).
pub unsafe fn dfu_and_state() -> (RamFlash, RamFlash) {
    // SAFETY: as for `active`.
    unsafe {
        (
            RamFlash::new(
                core::ptr::addr_of_mut!(__update_dfu),
                core::ptr::addr_of!(__update_dfu_len) as usize,
            ),
            RamFlash::new(
                core::ptr::addr_of_mut!(__update_state),
                core::ptr::addr_of!(__update_state_len) as usize,
            ),
        )
    }
}

/// The factory image QEMU loads at every start and reset (`-device
/// loader`, host-tests' `qemu.rs`): read only, by the bootloader.
pub fn factory() -> &'static [u8] {
    // SAFETY: linker symbols: the FACTORY region's start and length;
    // nothing writes it but QEMU's loader, before any code runs.
    unsafe {
        core::slice::from_raw_parts(
            core::ptr::addr_of!(__factory),
            core::ptr::addr_of!(__factory_len) as usize,
        )
    }
}
