//! The bootloader's side of the NUCLEO boards (hal-board's `boot`
//! feature; the bootloader is `firmware/rri-boot`): its partitions over
//! embassy-stm32's blocking flash driver, the jump into the application,
//! and how it fails.
//!
//! Nothing of the application's board comes with it: no clocks set up
//! (the chip runs on its reset clock, the HSI, which the flash needs no
//! wait states for), no executor, no network, no handlers
//! (cortex-m-rt's defaults). The bootloader runs alone, before the
//! application, from its own partition (`memory/nucleo-*-boot.x`), and
//! leaves the chip as it found it but for the flash it wrote.
//!
//! It says nothing when all is well. A bootloader that cannot start the
//! application lights the red user LED (LD3, PB14 on every NUCLEO-144),
//! logs why over RTT (`probe-rs attach --chip … rri-boot` shows it) and
//! sleeps with every interrupt off.
#![allow(unsafe_code)]

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};
use defmt_rtt as _;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Blocking, Flash as Driver};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};

use crate::nucleo_flash as flash;

/// The name bootloader messages carry.
#[cfg(feature = "nucleo-f767zi")]
pub const NAME: &str = "NUCLEO-F767ZI";
/// The name bootloader messages carry.
#[cfg(feature = "nucleo-h743zi")]
pub const NAME: &str = "NUCLEO-H743ZI2";

/// The bootloader's copy buffer (embassy-boot's `aligned_buf`: a
/// divisor of its swap page, the largest sector, and a multiple of the
/// flash's write size: 16 bytes on the F767, 32 on the H743).
pub const COPY_BUFFER: usize = 4096;

/// The DTCM, where every NUCLEO image's stack is (its initial stack
/// pointer lies there).
const DTCM: (u32, u32) = (0x2000_0000, 0x2002_0000);

/// One partition of the chip's flash.
pub type Partition = BlockingPartition<'static, NoopRawMutex, BootFlash>;

/// embassy-stm32's blocking flash driver, but for the F767's erase,
/// which is [`crate::f7_erase`]'s (embassy-stm32's erases bank 1 for
/// bank 2 there); the bootloader runs with no watchdog, so it polls.
pub struct BootFlash(Driver<'static, Blocking>);

impl ErrorType for BootFlash {
    type Error = embassy_stm32::flash::Error;
}

impl ReadNorFlash for BootFlash {
    const READ_SIZE: usize = <Driver<'static, Blocking> as ReadNorFlash>::READ_SIZE;

    /// The F767's plain; the H743's careful ([`crate::h743_ecc`]): a
    /// word a power cut tore is `Prog` (embassy-stm32's own word for a
    /// DBECCERR), not a fault, so `rri_update::boot` reads it as
    /// programmed.
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        #[cfg(feature = "nucleo-f767zi")]
        return self.0.blocking_read(offset, bytes);
        #[cfg(feature = "nucleo-h743zi")]
        crate::h743_ecc::read(offset, bytes).map_err(|e| match e {
            crate::h743_ecc::ReadError::OutOfRange => embassy_stm32::flash::Error::Size,
            crate::h743_ecc::ReadError::DoubleEcc => embassy_stm32::flash::Error::Prog,
        })
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl NorFlash for BootFlash {
    const WRITE_SIZE: usize = <Driver<'static, Blocking> as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Driver<'static, Blocking> as NorFlash>::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        // A bare poll of FLASH_SR (the register read is volatile): no
        // interrupt could wake a WFI here, and YIELD buys nothing on a
        // single core.
        #[cfg(feature = "nucleo-f767zi")]
        return crate::f7_erase::erase(from, to, &mut || {});
        #[cfg(feature = "nucleo-h743zi")]
        return self.0.blocking_erase(from, to);
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.blocking_write(offset, bytes)
    }
}

/// The partitions the bootloader works on, each handed out once.
pub struct Flash {
    /// The image that runs.
    pub active: Partition,
    /// The update partition.
    pub dfu: Partition,
    /// embassy-boot's state partition.
    pub state: Partition,
}

static TAKEN: AtomicBool = AtomicBool::new(false);

impl Flash {
    /// The partitions, the first time; `None` after.
    pub fn take() -> Option<Flash> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        #[cfg(feature = "nucleo-f767zi")]
        if embassy_stm32::pac::FLASH.optcr().read().n_dbank() {
            start_single_bank();
        }
        static DRIVER: static_cell::StaticCell<Mutex<NoopRawMutex, RefCell<BootFlash>>> =
            static_cell::StaticCell::new();
        // SAFETY: the flash controller is handed out once (TAKEN) and the
        // bootloader runs alone: nothing else drives it.
        let controller = unsafe { embassy_stm32::peripherals::FLASH::steal() };
        let driver = DRIVER.init(Mutex::new(RefCell::new(BootFlash(Driver::new_blocking(
            controller,
        )))));
        // The map's ASSERTs keep each partition whole erase units (the
        // partition's own rule, which panics otherwise).
        let [active, dfu, state] = [flash::active(), flash::dfu(), flash::state()]
            .map(|p| Partition::new(driver, p.offset, p.len));
        Some(Flash { active, dfu, state })
    }
}

/// Whether the active partition starts with a vector table of an image
/// linked there ([`crate::boot::looks_like_image`]). Erased flash is
/// none.
pub fn active_holds_image(active: &mut Partition) -> bool {
    let mut words = [0u8; 8];
    if active.read(0, &mut words).is_err() {
        return false;
    }
    let [a, b, c, d, e, f, g, h] = words;
    is_vector_table(
        u32::from_le_bytes([a, b, c, d]),
        u32::from_le_bytes([e, f, g, h]),
        active.capacity() as u32,
    )
}

/// Whether `sp` and `reset`, the active partition's first two words, are
/// the vector table of an image linked there, in a partition of
/// `capacity` bytes ([`crate::boot::looks_like_image`]).
fn is_vector_table(sp: u32, reset: u32, capacity: u32) -> bool {
    crate::boot::looks_like_image(sp, reset, flash::active_origin(), capacity, DTCM)
}

/// Why a board with an empty active partition fails: its first image
/// goes on with a probe.
#[cfg(feature = "nucleo-f767zi")]
const NO_IMAGE: &str = "no image in the active partition: flash one with `cargo f767` (probe-rs)";
#[cfg(feature = "nucleo-h743zi")]
const NO_IMAGE: &str = "no image in the active partition: flash one with `cargo h743` (probe-rs)";

/// A NUCLEO's first image is flashed by a probe into the active
/// partition: the bootloader has none to install.
pub fn install_first_image(_: &mut Partition) -> Result<(), &'static str> {
    Err(NO_IMAGE)
}

/// Starts the image in the active partition (its handle given up).
/// Fails when the partition holds no image.
pub fn start_active(mut active: Partition) -> ! {
    if !active_holds_image(&mut active) {
        fail("no image in the active partition to start");
    }
    // SAFETY: the partition holds a vector table (checked); the bootloader
    // enabled no interrupt and started no clock or peripheral (the flash
    // controller is locked again after every operation); the partition's
    // start is a multiple of 128 (whole sectors: the flash maps' ASSERTs).
    unsafe { crate::boot::start(flash::active_origin()) }
}

/// An F767 whose flash is still in the factory's single-bank mode
/// (option byte nDBANK = 1): embassy-stm32's driver, built for the dual-
/// bank map, would panic, and no update can be pending (the application
/// takes none in this mode and says why in its log). The active image
/// starts as it is, read straight from the flash, silently as on every
/// start that needs nothing; without one, the board fails.
#[cfg(feature = "nucleo-f767zi")]
fn start_single_bank() -> ! {
    let origin = flash::active_origin();
    // SAFETY: the active partition's first two words, in the flash the
    // core reads anyway.
    let (sp, reset) = unsafe {
        (
            core::ptr::read_volatile(origin as *const u32),
            core::ptr::read_volatile((origin + 4) as *const u32),
        )
    };
    if !is_vector_table(sp, reset, flash::active().len) {
        fail(NO_IMAGE);
    }
    // SAFETY: as in `start_active`: a vector table is there (checked), and
    // nothing was started or enabled.
    unsafe { crate::boot::start(origin) }
}

/// Lights the red LED, logs `why` and stops, with interrupts off.
pub fn fail(why: &str) -> ! {
    cortex_m::interrupt::disable();
    defmt::error!("rri-boot on {=str}: {=str}", NAME, why);
    red_led_on();
    loop {
        cortex_m::asm::wfi();
    }
}

/// LD3 (PB14, active high on every NUCLEO-144), driven through the
/// registers: the bootloader has no HAL set up.
fn red_led_on() {
    use embassy_stm32::pac;
    #[cfg(feature = "nucleo-f767zi")]
    pac::RCC.ahb1enr().modify(|w| w.set_gpioben(true));
    #[cfg(feature = "nucleo-h743zi")]
    pac::RCC.ahb4enr().modify(|w| w.set_gpioben(true));
    // The clock reaches the port two cycles after the enable (RM0410
    // §5.2.2, RM0433 §8.5.10): read it back first.
    #[cfg(feature = "nucleo-f767zi")]
    let _ = pac::RCC.ahb1enr().read();
    #[cfg(feature = "nucleo-h743zi")]
    let _ = pac::RCC.ahb4enr().read();
    pac::GPIOB.bsrr().write(|w| w.set_bs(14, true));
    pac::GPIOB
        .moder()
        .modify(|w| w.set_moder(14, pac::gpio::vals::Moder::OUTPUT));
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    fail("panicked (the bootloader has no panic path by design: a bug)")
}

/// embassy-stm32's own checks (`defmt::unwrap!`, `defmt::panic!`) end
/// here, as every other panic does.
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    fail("panicked in embassy-stm32 (a check of its own failed)")
}

// The bootloader's log lines carry no time: it keeps none.
defmt::timestamp!("");
