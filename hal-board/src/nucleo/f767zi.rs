//! NUCLEO-F767ZI: STM32F767ZI (Cortex-M7, 2 MiB flash, 512 KiB RAM), the
//! root `memory.x`: the DTCM for the stack and the statics, SRAM1 + SRAM2
//! for the Ethernet DMA rings (see `memory.rs`).

use super::clock::Source;
use embassy_stm32::adc::SampleTime;
use embassy_stm32::time::Hertz;

/// The board an update file must name (`cargo sign-image -- sign
/// --board f767`).
pub const UPDATE_BOARD: &str = "nucleo-f767zi";
/// Where the image is linked: the active partition's start
/// (`memory/nucleo-f767zi-flash.x`; `init` checks it against the map's
/// symbol, and an update file linked elsewhere is refused).
pub const UPDATE_ORIGIN: u32 = 0x0802_0000;

pub const NAME: &str = "NUCLEO-F767ZI";
/// The core clock: 216 MHz, the chip's maximum.
pub const SYSCLK_HZ: u32 = 216_000_000;
/// The HSI's frequency, which the core runs at out of reset.
pub const RESET_HSI_HZ: u32 = 16_000_000;

pub type Iwdg = embassy_stm32::peripherals::IWDG;
/// Takes the independent watchdog out of the chip's peripherals.
macro_rules! iwdg {
    ($p:ident) => {
        $p.IWDG
    };
}
pub(super) use iwdg;
/// LD2 (blue) on the NUCLEO-F767ZI (MB1137).
macro_rules! ld2 {
    ($p:ident) => {
        $p.PB7
    };
}
pub(super) use ld2;
/// 112 ADC clock cycles (ADC clock 27 MHz): about 4 µs per conversion.
pub const SAMPLE_TIME: SampleTime = SampleTime::CYCLES112;
/// 12-bit conversions.
pub const ADC_FULL_SCALE: f32 = 4095.0;

/// 216 MHz from a 2 MHz PLL input: the ST-LINK's 8 MHz (HSE bypass, the
/// NUCLEO's default solder bridges) / 4, or the 16 MHz HSI / 8 when that
/// clock is missing (see `clock.rs`); × 216 = 432 MHz, P / 2 = 216 MHz
/// for the core, Q / 9 = 48 MHz for the 48 MHz domain (the RNG; RM0410
/// requires 48 MHz there, and PLLQ's reset value would give 108). AHB
/// 216 MHz, APB1 54 MHz, APB2 108 MHz (the maxima).
pub fn config(source: Source) -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    let prediv = match source {
        Source::Hse => {
            config.rcc.hse = Some(Hse {
                freq: Hertz(8_000_000),
                mode: HseMode::Bypass,
            });
            config.rcc.pll_src = PllSource::HSE;
            PllPreDiv::DIV4
        }
        Source::Hsi => {
            config.rcc.pll_src = PllSource::HSI;
            PllPreDiv::DIV8
        }
    };
    config.rcc.pll = Some(Pll {
        prediv,
        mul: PllMul::MUL216,
        divp: Some(PllPDiv::DIV2),
        divq: Some(PllQDiv::DIV9),
        divr: None,
    });
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config.rcc.sys = Sysclk::PLL1_P;
    config
}

/// Why the chip reset, from RCC_CSR's flags (then cleared, so the next
/// reset reads only its own). Every reset sets the pin flag too, so the
/// pin counts only when nothing else is set; a power-on sets BOR as well.
pub fn reset_flags() -> crate::reset::Cause {
    use crate::reset::Cause;
    use embassy_stm32::pac::RCC;
    let csr = RCC.csr().read();
    let cause = if csr.wdgrstf() || csr.wwdgrstf() {
        Cause::Watchdog
    } else if csr.sftrstf() {
        Cause::Software
    } else if csr.porrstf() {
        Cause::PowerOn
    } else if csr.borrstf() {
        Cause::BrownOut
    } else if csr.padrstf() {
        Cause::Pin
    } else {
        // Low-power management reset, or none set: nothing to trust.
        Cause::PowerOn
    };
    RCC.csr().modify(|w| w.set_rmvf(true));
    cause
}

/// Frames the Ethernet DMA missed since the last call: ETH_DMAMFBOCR's
/// MFC (16 bits: no receive descriptor free) and MFA (11 bits: receive
/// FIFO overflow), each with its overflow flag (OMFC bit 16, OFOC bit 28,
/// RM0410): with a flag set the count is a lower bound (`true`). The
/// register clears when read: only ever `read()` it (a `modify` would
/// lose the counts). Not yet checked on silicon.
pub fn missed_frames() -> (u32, bool) {
    let r = embassy_stm32::pac::ETH.ethernet_dma().dmamfbocr().read().0;
    let (mfc, a) = crate::missed(r, 16, r & (1 << 16) != 0);
    let (mfa, b) = crate::missed(r >> 17, 11, r & (1 << 28) != 0);
    (mfc.saturating_add(mfa), a || b)
}
