//! The STM32F767ZI's peripherals, as a table of blocks (RM0410 rev 5
//! §2.2.2, Table 1 "STM32F76xxx and STM32F77xxx register boundary
//! addresses"): every block the NUCLEO-F767ZI image touches has a model;
//! every other address stops the run.

pub mod adc;
pub mod eth;
pub mod flash;
pub mod power;
pub mod rcc;

use crate::bus::{reg, Bus, Reg};
use crate::simple::Plain;

/// DBGMCU (RM0410 §40.16): the device ID (DEV_ID 0x451, revision Z
/// 0x1001) and the debug freeze bits.
const DBGMCU: &[Reg] = &[
    reg(0x00, "IDCODE", 0x1001_0451, 0, 0xFFFF_0FFF),
    reg(0x04, "CR", 0, 0x0000_00E7, 0),
    reg(0x08, "APB1_FZ", 0, 0x07E0_1DFF, 0),
    reg(0x0C, "APB2_FZ", 0, 0x0007_0003, 0),
];
use crate::clocks::Clocks;

/// The chip's peripheral blocks and its clocks at reset, its flash in
/// the factory's single-bank mode.
pub fn bus() -> (Bus, Clocks) {
    chip(flash::Flash::new())
}

/// The same, with the option byte nDBANK cleared: the flash in dual-bank
/// mode (`--dual-bank`), as the README has the user set it once.
pub fn bus_dual_bank() -> (Bus, Clocks) {
    chip(flash::Flash::dual_bank())
}

fn chip(flash: flash::Flash) -> (Bus, Clocks) {
    let mut bus = Bus::default();
    bus.add(0x4002_3800, 0x400, None, rcc::Rcc::new());
    bus.add(0x4002_3C00, 0x400, None, flash);
    bus.add(0x4000_7000, 0x400, Some("PWR"), power::Pwr::new());
    bus.add(0xE004_2000, 0x400, None, Plain::new("DBGMCU", DBGMCU));
    crate::gpio::ports(
        &mut bus,
        0x4002_0000,
        'K',
        crate::gpio::F7_A,
        crate::gpio::F7_B,
        crate::gpio::F7_OTHER,
    );
    bus.add(
        0x4001_3800,
        0x400,
        Some("SYSCFG"),
        crate::syscfg::Syscfg::new(crate::syscfg::Kind::F7),
    );
    bus.add(0x5006_0800, 0x400, Some("RNG"), crate::rng::Rng::new());
    bus.add(0x4000_3000, 0x400, None, crate::iwdg::Iwdg::new("IWDG"));
    // The Ethernet MAC, MMC and DMA (IRQ 61), clocked by ETHMAC.
    bus.add(0x4002_8000, 0x1400, Some("ETH"), eth::Eth::new(61));
    bus.add(0x4001_2000, 0x100, Some("ADC1"), adc::Adc::new());
    bus.add(0x4001_2300, 0x100, Some("ADC1"), adc::Common::new());
    // TIM12: the timer embassy-time's driver takes on this chip (IRQ 43,
    // TIM8_BRK_TIM12; RM0410 Table 46).
    bus.add(
        0x4000_1800,
        0x400,
        Some("TIM12"),
        crate::timer::Timer::new("TIM12", crate::timer::TIM9_12, 43, 0),
    );
    let mut clocks = Clocks {
        core_hz: rcc::HSI_HZ,
        hclk_hz: rcc::HSI_HZ,
        apb_hz: [rcc::HSI_HZ, rcc::HSI_HZ, 0, 0],
        ..Clocks::default()
    };
    let mut shared = crate::bus::Shared::default();
    let mut cx = shared.cx(0, crate::bus::no_dma());
    cx.clocks = &mut clocks;
    // The limits at reset (scale 1, no over-drive), from PWR's reset value.
    let _ = crate::bus::Peripheral::advance(&mut power::Pwr::new(), &mut cx);
    (bus, clocks)
}
