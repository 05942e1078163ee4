//! Update in the cell (issue 43) on the NUCLEO boards: the update and
//! state partitions the firmware's receiver writes
//! (`memory/nucleo-*-flash.x`, read through [`crate::nucleo_flash`]),
//! over embassy-stm32's flash driver: its blocking reads and writes (a
//! program takes 130 us on the H743, a few 16 us words on the F767), and
//! an erase whose wait feeds the watchdog (below).
//!
//! Who may touch the flash: the background executor alone, in thread
//! mode (the diagnostics service's upload, housekeeping's confirmation).
//! The driver sits behind a thread-mode mutex, so a use from an interrupt
//! (the urgent executor, the cycle) would stop at once instead of racing.
//! Not a critical section: a sector erase takes seconds, and the cycle's
//! interrupts go on meanwhile: both partitions are in bank 2, and the
//! code runs from bank 1, which reads while bank 2 is written (RM0433
//! §4.3.5, RM0410 §3.3.3 in dual-bank mode; `cargo rehost` models it).
//!
//! The erase waits asleep until the next interrupt, polling the flash at
//! each, with the watchdog fed meanwhile for at most the datasheet's
//! longest erase of the unit: an erase unit (128K) takes seconds, as long
//! as the watchdog's timeout or longer, and a blocking wait would hold the
//! background executor, housekeeping's feeding included, for all of it.
//! `cargo rehost` showed the watchdog resetting the chip at an upload's
//! first erase before this. A flash that never ends its erase is still
//! reset: the feeding stops at the bound. How each chip erases is its
//! own (`update/*.rs`).
//!
//! They are products: the demonstration key must never be built into
//! them (the firmware's build refuses it), and without `RRI_UPDATE_KEY`
//! an image takes no update at all (its diagnostics stay read-only).

#[cfg_attr(feature = "nucleo-f767zi", path = "update/f767zi.rs")]
#[cfg_attr(feature = "nucleo-h743zi", path = "update/h743zi.rs")]
mod erase;

use core::cell::RefCell;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, ThreadModeRawMutex};
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

pub use super::chip::{UPDATE_BOARD as BOARD, UPDATE_ORIGIN as ORIGIN};
use erase::Driver;

/// The bootloader (firmware/rri-boot) swaps a marked image in at the
/// next reset, and this image restarts into it once its controller is
/// not OPERATING (`rri_update::lifecycle`).
pub const SWAPS: bool = true;
/// The demonstration key, which anyone can sign with, may not be built
/// in.
pub const DEMO_KEY_ALLOWED: bool = false;

/// The chip's flash, once the board's `init` gave it its controller.
pub struct BoardFlash(Option<Driver>);

/// A flash operation before `init` (or on a chip whose flash is not set
/// up for updates: [`unavailable`]), or the driver's own error.
#[derive(Clone, Copy, Debug)]
pub enum Error {
    NotStarted,
    Flash(embassy_stm32::flash::Error),
    /// A word a power cut tore (the H743's double ECC error,
    /// [`crate::h743_ecc`]): read as programmed by the update's state
    /// reads (`rri_update::torn`).
    DoubleEcc,
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Error::NotStarted | Error::DoubleEcc => NorFlashErrorKind::Other,
            Error::Flash(e) => e.kind(),
        }
    }
}

impl ErrorType for BoardFlash {
    type Error = Error;
}

impl BoardFlash {
    fn driver(&mut self) -> Result<&mut Driver, Error> {
        self.0.as_mut().ok_or(Error::NotStarted)
    }
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = <Driver as ReadNorFlash>::READ_SIZE;

    /// The F767's plain; the H743's careful ([`crate::h743_ecc`]): a word
    /// a power cut tore is [`Error::DoubleEcc`], not a fault.
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        let driver = self.driver()?;
        #[cfg(feature = "nucleo-f767zi")]
        return driver.blocking_read(offset, bytes).map_err(Error::Flash);
        #[cfg(feature = "nucleo-h743zi")]
        {
            // The driver's presence was the check (`NotStarted` before
            // `init`); the careful read goes past it, to the flash.
            let _ = driver;
            crate::h743_ecc::read(offset, bytes).map_err(|e| match e {
                crate::h743_ecc::ReadError::OutOfRange => {
                    Error::Flash(embassy_stm32::flash::Error::Size)
                }
                crate::h743_ecc::ReadError::DoubleEcc => Error::DoubleEcc,
            })
        }
    }

    fn capacity(&self) -> usize {
        embassy_stm32::flash::FLASH_SIZE
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = <Driver as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Driver as NorFlash>::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        let driver = self.driver()?;
        let units = u64::from(to.saturating_sub(from)).div_ceil(Self::ERASE_SIZE as u64);
        let bound = embassy_time::Duration::from_millis(erase::UNIT_MAX_MS * units.max(1));
        erase::erase(driver, from, to, bound).map_err(Error::Flash)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        self.driver()?
            .blocking_write(offset, bytes)
            .map_err(Error::Flash)
    }
}

/// Asleep until the next interrupt, with the watchdog fed while the erase
/// that `started` is within its `bound`: the erase's end (EOP, where the
/// chip's driver enables it), the cycle's, or the time driver's timer,
/// which interrupts every 32.8 ms (16 bits at embassy-time's 1 MHz: its
/// half-period) and so bounds the wait between two feeds. Not a spin on
/// the flash's status for seconds.
fn wait_fed(started: embassy_time::Instant, bound: embassy_time::Duration) {
    if started.elapsed() < bound {
        // A key write reloads the independent watchdog: whoever else
        // feeds it, housekeeping's `Watchdog`, is not disturbed.
        erase::IWDG
            .kr()
            .write(|w| w.set_key(embassy_stm32::pac::iwdg::vals::Key::RESET));
    }
    cortex_m::asm::wfi();
}

static DRIVER: Mutex<ThreadModeRawMutex, RefCell<BoardFlash>> =
    Mutex::new(RefCell::new(BoardFlash(None)));

/// Why the flash takes no update, when the chip's set-up forbids it
/// (written once by `init`, before any task).
static UNAVAILABLE: Mutex<CriticalSectionRawMutex, core::cell::Cell<Option<&'static str>>> =
    Mutex::new(core::cell::Cell::new(None));

/// Gives the flash controller to the partitions (the board's `init`),
/// unless the chip's set-up forbids updates ([`unavailable`] says why).
pub(crate) fn start(flash: Peri<'static, FLASH>) {
    match erase::driver(flash) {
        Ok(driver) => DRIVER.lock(|d| d.borrow_mut().0 = Some(driver)),
        // Said by the firmware, where it has the upload's path built in
        // (an image without a key never asks).
        Err(why) => UNAVAILABLE.lock(|u| u.set(Some(why))),
    }
}

/// Why this board takes no update although its image has the upload's
/// path (`None`: it takes them): the F767 with its flash still in the
/// factory's single-bank mode. The firmware then installs no receiver
/// (`PUT` is 405) and says this in its log.
pub fn unavailable() -> Option<&'static str> {
    UNAVAILABLE.lock(|u| u.get())
}

/// One partition of the chip's flash.
pub type Partition = BlockingPartition<'static, ThreadModeRawMutex, BoardFlash>;

fn partition(p: crate::nucleo_flash::Part) -> Partition {
    // The flash map's ASSERTs keep every partition whole erase units
    // (the partition's own rule, which panics otherwise).
    Partition::new(&DRIVER, p.offset, p.len)
}

/// The active partition's bytes: the most an image may have.
pub fn active() -> usize {
    crate::nucleo_flash::active().len as usize
}

/// The update and state partitions. Every call makes new handles on the
/// same flash: the caller uses one pair at a time (the update desk's
/// mutex).
pub fn partitions() -> (Partition, Partition) {
    (
        partition(crate::nucleo_flash::dfu()),
        partition(crate::nucleo_flash::state()),
    )
}
