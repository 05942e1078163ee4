//! Update in the cell (issue 43) on the NUCLEO-H743ZI2 (the F767's
//! single flash bank cannot take one yet: `nucleo::update` there says
//! why): the update and state partitions the firmware's receiver writes
//! (`memory/nucleo-*-flash.x`, read through [`crate::nucleo_flash`]),
//! over embassy-stm32's flash driver: its blocking reads and writes (a
//! flash word's program takes 130 us), its interrupt-driven erase.
//!
//! Who may touch the flash: the background executor alone, in thread
//! mode (the diagnostics service's upload, housekeeping's confirmation).
//! The driver sits behind a thread-mode mutex, so a use from an interrupt
//! (the urgent executor, the cycle) would stop at once instead of racing.
//! Not a critical section: a sector erase takes seconds, and the cycle's
//! interrupts go on meanwhile: both partitions are in bank 2, and the
//! code runs from bank 1, which reads while bank 2 is written (RM0433
//! §4.3.5; `cargo rehost` models it).
//!
//! The erase is embassy-stm32's interrupt-driven one, polled here at
//! every interrupt until it ends (the core asleep in between), with the
//! watchdog fed meanwhile, for at most the datasheet's longest erase per
//! sector: a 128K erase takes about 2 s (DS12110 Table
//! 53, at the x8 parallelism embassy-stm32 erases with), as long as the
//! watchdog's timeout, and the blocking wait would hold the background
//! executor, housekeeping's feeding included, for all of it. `cargo
//! rehost` showed the watchdog resetting the chip at an upload's first
//! erase before this. A flash that never ends its erase is still reset:
//! the feeding stops at the bound.
//!
//! They are products: the demonstration key must never be built into
//! them (the firmware's build refuses it), and without `RRI_UPDATE_KEY`
//! an image takes no update at all (its diagnostics stay read-only).

use core::cell::RefCell;
use core::future::Future;
use core::task::{Context, Poll, Waker};
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Async, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use embassy_sync::blocking_mutex::raw::ThreadModeRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

pub use super::chip::{UPDATE_BOARD as BOARD, UPDATE_ORIGIN as ORIGIN};

/// The bootloader (firmware/rri-boot) swaps a marked image in at the
/// next reset, and this image restarts into it once its controller is
/// not OPERATING (`rri_update::lifecycle`).
pub const SWAPS: bool = true;
/// The demonstration key, which anyone can sign with, may not be built
/// in.
pub const DEMO_KEY_ALLOWED: bool = false;

/// The chip's flash, once the board's `init` gave it its controller.
pub struct BoardFlash(Option<Flash<'static, Async>>);

/// A flash operation before `init`, or the driver's own error.
#[derive(Clone, Copy, Debug)]
pub enum Error {
    NotStarted,
    Flash(embassy_stm32::flash::Error),
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Error::NotStarted => NorFlashErrorKind::Other,
            Error::Flash(e) => e.kind(),
        }
    }
}

impl ErrorType for BoardFlash {
    type Error = Error;
}

impl BoardFlash {
    fn driver(&mut self) -> Result<&mut Flash<'static, Async>, Error> {
        self.0.as_mut().ok_or(Error::NotStarted)
    }
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = <Flash<'static, Async> as ReadNorFlash>::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        self.driver()?
            .blocking_read(offset, bytes)
            .map_err(Error::Flash)
    }

    fn capacity(&self) -> usize {
        embassy_stm32::flash::FLASH_SIZE
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = <Flash<'static, Async> as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Flash<'static, Async> as NorFlash>::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        let driver = self.driver()?;
        let sectors = u64::from(to.saturating_sub(from)).div_ceil(128 * 1024);
        let bound = embassy_time::Duration::from_millis(ERASE_MAX_MS * sectors.max(1));
        let started = embassy_time::Instant::now();
        let mut erase = core::pin::pin!(driver.erase(from, to));
        let mut cx = Context::from_waker(Waker::noop());
        loop {
            if let Poll::Ready(r) = erase.as_mut().poll(&mut cx) {
                return r.map_err(Error::Flash);
            }
            if started.elapsed() < bound {
                feed_watchdog();
            }
            // Asleep until the next interrupt: the erase's end (EOP), the
            // cycle's, or the time driver's timer, which interrupts every
            // 32.8 ms (TIM12, 16 bits at embassy-time's 1 MHz: its
            // half-period) and so bounds the wait between two feeds. Not
            // a spin on the flash's status for seconds.
            cortex_m::asm::wfi();
        }
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        self.driver()?
            .blocking_write(offset, bytes)
            .map_err(Error::Flash)
    }
}

/// DS12110 Table 53: the longest 128K sector erase (x8), with a margin.
const ERASE_MAX_MS: u64 = 4_500;

/// Reloads the independent watchdog (a key write: whoever else feeds it,
/// housekeeping's `Watchdog`, is not disturbed).
fn feed_watchdog() {
    embassy_stm32::pac::IWDG1
        .kr()
        .write(|w| w.set_key(embassy_stm32::pac::iwdg::vals::Key::RESET));
}

embassy_stm32::bind_interrupts!(struct Irqs {
    FLASH => embassy_stm32::flash::InterruptHandler;
});

static DRIVER: Mutex<ThreadModeRawMutex, RefCell<BoardFlash>> =
    Mutex::new(RefCell::new(BoardFlash(None)));

/// Gives the flash controller to the partitions (the board's `init`).
pub(crate) fn start(flash: Peri<'static, FLASH>) {
    DRIVER.lock(|d| d.borrow_mut().0 = Some(Flash::new(flash, Irqs)));
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
