//! The NUCLEO boards' flash partitions (issue 43), as both of their
//! images see them: the bootloader ([`crate::nucleo_boot`]) and the
//! application (`nucleo::update`). The addresses are the flash map's
//! (`memory/nucleo-*-flash.x`, which both images link with), read from
//! its linker symbols so that neither image can disagree with it.
#![allow(unsafe_code)]

extern "C" {
    static __flash: u8;
    static __update_active: u8;
    static __update_active_len: u8;
    static __update_state: u8;
    static __update_state_len: u8;
    static __update_dfu: u8;
    static __update_dfu_len: u8;
}

/// A linker symbol's address (never read through; the chip's addresses
/// are 32-bit).
fn symbol(s: &u8) -> u32 {
    core::ptr::from_ref(s) as usize as u32
}

/// A partition: its offset from the flash's start (as embassy-stm32's
/// driver counts) and its length.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub offset: u32,
    pub len: u32,
}

fn part(at: u32, len: u32) -> Part {
    // SAFETY: a linker symbol's address.
    let base = symbol(unsafe { &__flash });
    Part {
        offset: at.wrapping_sub(base),
        len,
    }
}

/// The active partition's start: where the application is linked.
pub fn active_origin() -> u32 {
    // SAFETY: a linker symbol's address.
    symbol(unsafe { &__update_active })
}

/// The active partition.
pub fn active() -> Part {
    // SAFETY: linker symbols' addresses.
    part(active_origin(), symbol(unsafe { &__update_active_len }))
}

/// The update (DFU) partition.
pub fn dfu() -> Part {
    // SAFETY: linker symbols' addresses.
    unsafe { part(symbol(&__update_dfu), symbol(&__update_dfu_len)) }
}

/// embassy-boot's state partition.
pub fn state() -> Part {
    // SAFETY: linker symbols' addresses.
    unsafe { part(symbol(&__update_state), symbol(&__update_state_len)) }
}
