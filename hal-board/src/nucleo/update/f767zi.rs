//! The F767's erase: `crate::f7_erase` (embassy-stm32's would erase bank
//! 1 for bank 2, and waits without a break), each sector waited for
//! asleep with the watchdog fed meanwhile (`super::wait_fed`); reads and
//! programs stay embassy-stm32's blocking ones.
//!
//! Updates need the dual-bank mode (option byte nDBANK = 0, set once with
//! the probe: the README's "Put it on a board"): in the factory's single
//! bank every fetch from flash stalls while a sector erases, the cycle's
//! included. A chip still in single-bank mode runs its image, but takes
//! no update ([`driver`] says so, and embassy-stm32's driver, built for
//! dual-bank, would panic there).

use embassy_stm32::flash::{Blocking, Error, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;

/// The driver the partitions go through.
pub type Driver = Flash<'static, Blocking>;

/// The watchdog the erase feeds.
pub const IWDG: embassy_stm32::pac::iwdg::Iwdg = embassy_stm32::pac::IWDG;

/// The longest erase of one 128K unit: bank 2's first is four 16K
/// sectors and a 64K one. DS11532's table was not at hand; these are the
/// largest public figures (800 ms a small sector, 2.4 s the 64K one, 4 s
/// a 128K one, as the rehosted chip's model takes them), with a margin.
pub const UNIT_MAX_MS: u64 = 6_000;

/// The driver, if the chip's flash is in dual-bank mode.
pub fn driver(flash: Peri<'static, FLASH>) -> Result<Driver, &'static str> {
    if embassy_stm32::pac::FLASH.optcr().read().n_dbank() {
        return Err("the flash is in the factory's single-bank mode (option byte nDBANK = 1), where an erase would stall the running code past the watchdog: no update is taken. Set nDBANK = 0 once with the probe, then flash the bootloader and this image again (README, \"Put it on a board\")");
    }
    Ok(Flash::new_blocking(flash))
}

/// Erases `[from, to)` (offsets from the flash's start), feeding the
/// watchdog for at most `bound`. The driver is held (exclusive use of the
/// flash), its erase not used.
pub fn erase(
    _driver: &mut Driver,
    from: u32,
    to: u32,
    bound: embassy_time::Duration,
) -> Result<(), Error> {
    let started = embassy_time::Instant::now();
    crate::f7_erase::erase(from, to, &mut || super::wait_fed(started, bound))
}
