//! The STM32F767ZI's peripherals, as a table of blocks (RM0410 rev 5
//! §2.2.2, Table 1 "STM32F76xxx and STM32F77xxx register boundary
//! addresses"): every block the NUCLEO-F767ZI image touches has a model;
//! every other address stops the run.

pub mod power;
pub mod rcc;

use crate::bus::Bus;
use crate::clocks::Clocks;

/// The chip's peripheral blocks and its clocks at reset.
pub fn bus() -> (Bus, Clocks) {
    let mut bus = Bus::default();
    bus.add(0x4002_3800, 0x400, None, rcc::Rcc::new());
    bus.add(0x4002_3C00, 0x400, None, power::Flash::new());
    bus.add(0x4000_7000, 0x400, Some("PWR"), power::Pwr::new());
    let mut clocks = Clocks {
        core_hz: rcc::HSI_HZ,
        hclk_hz: rcc::HSI_HZ,
        apb_hz: [rcc::HSI_HZ, rcc::HSI_HZ, 0, 0],
        ..Clocks::default()
    };
    let mut raise = Vec::new();
    let mut cx = crate::bus::Cx {
        now: 0,
        clocks: &mut clocks,
        raise: &mut raise,
    };
    // The limits at reset (scale 1, no over-drive), from PWR's reset value.
    let _ = crate::bus::Peripheral::advance(&mut power::Pwr::new(), &mut cx);
    (bus, clocks)
}
