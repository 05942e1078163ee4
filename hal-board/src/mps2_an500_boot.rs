//! The bootloader's side of QEMU's mps2-an500 (hal-board's `boot`
//! feature; the bootloader is `firmware/rri-boot`): its partitions, the
//! factory image, the jump into the application, and how it fails.
//!
//! Nothing of the application's board comes with it (no executor, no
//! network, no defmt logger, no fault handlers: cortex-m-rt's defaults):
//! the bootloader runs alone, before the application, from its own
//! partition (`memory/mps2-an500-boot.x`).
//!
//! It says nothing when all is well. A bootloader that cannot start the
//! application writes one line to QEMU's standard error (semihosting; the
//! application's defmt log is on standard output) and ends QEMU with
//! exit status 1, so that a harness or a user sees why at once instead of
//! a board that never answers.
#![allow(unsafe_code)]

use crate::mps2_flash::{active_origin, factory};
use crate::ram_flash::RamFlash;
use core::sync::atomic::{AtomicBool, Ordering};
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};

/// The name bootloader messages carry.
pub const NAME: &str = "QEMU mps2-an500";

/// The bootloader's copy buffer (embassy-boot's `aligned_buf`: a
/// divisor of its swap page, which is the largest erase unit): the flash
/// model's sector ([`crate::ram_flash::SECTOR`]).
pub const COPY_BUFFER: usize = crate::ram_flash::SECTOR;

/// The partitions the bootloader works on, each handed out once.
pub struct Flash {
    /// The image that runs.
    pub active: RamFlash,
    /// The update partition.
    pub dfu: RamFlash,
    /// embassy-boot's state partition.
    pub state: RamFlash,
}

static TAKEN: AtomicBool = AtomicBool::new(false);

impl Flash {
    /// The partitions, the first time; `None` after.
    pub fn take() -> Option<Flash> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: handed out once (TAKEN), and the bootloader runs alone:
        // no other handle on these partitions exists while it runs.
        let (active, (dfu, state)) = unsafe {
            (
                crate::mps2_flash::active(),
                crate::mps2_flash::dfu_and_state(),
            )
        };
        Some(Flash { active, dfu, state })
    }
}

/// Whether `flash` starts with a Cortex-M vector table that could be the
/// application's: an initial stack pointer in RAM (SSRAM2/3,
/// `0x2000_0000..=0x2040_0000`, word aligned) and a reset vector in
/// Thumb state inside the partition starting at `origin`. After QEMU's
/// power-on the partition reads all zero, which is none.
pub fn holds_image(flash: &mut RamFlash, origin: u32) -> bool {
    let mut words = [0u8; 8];
    if flash.read(0, &mut words).is_err() {
        return false;
    }
    let [a, b, c, d, e, f, g, h] = words;
    crate::boot::looks_like_image(
        u32::from_le_bytes([a, b, c, d]),
        u32::from_le_bytes([e, f, g, h]),
        origin,
        flash.capacity() as u32,
        (0x2000_0000, 0x2040_0000),
    )
}

/// Copies the factory image into the active partition, as a probe
/// flashes a board's first image: erased first, then programmed. Only
/// while the active partition holds no image ([`holds_image`]): the
/// caller checks.
fn install_factory(active: &mut RamFlash) -> Result<(), crate::ram_flash::Error> {
    let image = factory();
    let len = image.len().min(active.capacity());
    let len = len - len % crate::ram_flash::SECTOR;
    active.erase(0, len as u32)?;
    active.write(0, image.get(..len).unwrap_or(&[]))
}

/// Puts the first image into an active partition that holds none: the
/// factory image QEMU's loader wrote ([`install_factory`]). Why it cannot,
/// in the bootloader's words.
pub fn install_first_image(active: &mut RamFlash) -> Result<(), &'static str> {
    install_factory(active)
        .map_err(|_| "cannot write the factory image into the active partition")?;
    if active_holds_image(active) {
        Ok(())
    } else {
        Err("no image in the active partition, and none in the factory region to install")
    }
}

/// Whether the active partition holds an image ([`holds_image`]).
pub fn active_holds_image(active: &mut RamFlash) -> bool {
    holds_image(active, active_origin())
}

/// Starts the image in the active partition (its handle given up): its
/// vector table for the core (VTOR), its initial stack pointer, its reset
/// handler. Fails when the partition holds no image.
pub fn start_active(mut active: RamFlash) -> ! {
    if !active_holds_image(&mut active) {
        fail("no image in the active partition to start");
    }
    // SAFETY: the partition holds a vector table (checked); the bootloader
    // enabled no interrupt and set nothing up that the image could meet;
    // the partition's start is a multiple of 128
    // (`memory/mps2-an500-flash.x`).
    unsafe { crate::boot::start(active_origin()) }
}

/// Ends the run with `why` on QEMU's standard error and exit status 1.
pub fn fail(why: &str) -> ! {
    use semihosting::io::Write as _;
    if let Ok(mut err) = semihosting::io::stderr() {
        let _ = err.write_all(b"rri-boot on ");
        let _ = err.write_all(NAME.as_bytes());
        let _ = err.write_all(b": ");
        let _ = err.write_all(why.as_bytes());
        let _ = err.write_all(b"\n");
    }
    semihosting::process::exit(1)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    fail("panicked (the bootloader has no panic path by design: a bug)")
}
