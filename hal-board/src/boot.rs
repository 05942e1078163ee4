//! What every board's bootloader does the same way: tell an image from
//! erased or foreign flash by its vector table, and start it.
//!
//! [`looks_like_image`] is plain arithmetic (tested on the host); the
//! jump ([`start`]) exists on the chip alone.

/// Whether a vector table's first two words could be an image's that is
/// linked at `origin` and `len` bytes long: an initial stack pointer in
/// `ram` (word aligned) and a reset vector in Thumb state inside the
/// image. Erased flash (all ones), zeroed memory and an image linked for
/// another partition all fail.
pub fn looks_like_image(sp: u32, reset: u32, origin: u32, len: u32, ram: (u32, u32)) -> bool {
    (ram.0..=ram.1).contains(&sp)
        && sp.is_multiple_of(4)
        && reset & 1 == 1
        && (origin..origin.saturating_add(len)).contains(&(reset & !1))
}

/// Starts the image whose vector table is at `origin`: VTOR, its initial
/// stack pointer, its reset handler.
///
/// # Safety
/// `origin` holds an image's vector table ([`looks_like_image`]), a
/// multiple of 128 (VTOR's alignment, and the table's size rounded up to
/// a power of two: every board's map places it so), and the bootloader
/// enabled no interrupt and left nothing running that the image could
/// meet.
#[cfg(all(feature = "boot", target_os = "none"))]
pub unsafe fn start(origin: u32) -> ! {
    // SAFETY: as the caller promises.
    unsafe {
        let scb = &*cortex_m::peripheral::SCB::PTR;
        scb.vtor.write(origin);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        cortex_m::asm::bootload(origin as usize as *const u32)
    }
}

#[cfg(test)]
mod tests {
    use super::looks_like_image;

    const DTCM: (u32, u32) = (0x2000_0000, 0x2002_0000);
    const ACTIVE: u32 = 0x0808_0000;
    const LEN: u32 = 512 * 1024;

    #[test]
    fn an_image_linked_at_the_partition_is_one() {
        assert!(looks_like_image(
            0x2001_0000,
            ACTIVE + 0x2a1,
            ACTIVE,
            LEN,
            DTCM
        ));
    }

    #[test]
    fn erased_zeroed_and_foreign_flash_is_none() {
        // Erased NOR flash, zeroed RAM (QEMU's SSRAM at power-on).
        assert!(!looks_like_image(u32::MAX, u32::MAX, ACTIVE, LEN, DTCM));
        assert!(!looks_like_image(0, 0, ACTIVE, LEN, DTCM));
        // An image linked at the flash's start (before issue 43): its
        // reset vector is outside the partition.
        assert!(!looks_like_image(
            0x2001_0000,
            0x0800_02a1,
            ACTIVE,
            LEN,
            DTCM
        ));
        // The reset vector in ARM state, a stack outside RAM or unaligned.
        assert!(!looks_like_image(
            0x2001_0000,
            ACTIVE + 0x2a0,
            ACTIVE,
            LEN,
            DTCM
        ));
        assert!(!looks_like_image(
            0x2400_0000,
            ACTIVE + 0x2a1,
            ACTIVE,
            LEN,
            DTCM
        ));
        assert!(!looks_like_image(
            0x2001_0002,
            ACTIVE + 0x2a1,
            ACTIVE,
            LEN,
            DTCM
        ));
        // Just past the partition's end.
        assert!(!looks_like_image(
            0x2001_0000,
            ACTIVE + LEN + 1,
            ACTIVE,
            LEN,
            DTCM
        ));
    }
}
