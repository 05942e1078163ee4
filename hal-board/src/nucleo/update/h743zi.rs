//! The H743's erase: embassy-stm32's interrupt-driven one, polled at
//! every interrupt until it ends (the core asleep in between), with the
//! watchdog fed meanwhile (`super::wait_fed`).

use core::future::Future;
use core::task::{Context, Poll, Waker};
use embassy_stm32::flash::{Async, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;

/// The driver the partitions go through.
pub type Driver = Flash<'static, Async>;

/// The watchdog the erase feeds.
pub const IWDG: embassy_stm32::pac::iwdg::Iwdg = embassy_stm32::pac::IWDG1;

/// DS12110 Table 53: the longest 128K sector erase (x8, the parallelism
/// embassy-stm32 erases with: about 2 s typical), with a margin.
pub const UNIT_MAX_MS: u64 = 4_500;

embassy_stm32::bind_interrupts!(struct Irqs {
    FLASH => embassy_stm32::flash::InterruptHandler;
});

/// The driver; the H743's flash always has its two banks.
pub fn driver(flash: Peri<'static, FLASH>) -> Result<Driver, &'static str> {
    Ok(Flash::new(flash, Irqs))
}

/// Erases `[from, to)` (offsets from the flash's start), feeding the
/// watchdog for at most `bound`.
pub fn erase(
    driver: &mut Driver,
    from: u32,
    to: u32,
    bound: embassy_time::Duration,
) -> Result<(), embassy_stm32::flash::Error> {
    let started = embassy_time::Instant::now();
    let mut erase = core::pin::pin!(driver.erase(from, to));
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(r) = erase.as_mut().poll(&mut cx) {
            return r;
        }
        super::wait_fed(started, bound);
    }
}
