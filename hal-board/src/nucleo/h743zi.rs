//! NUCLEO-H743ZI2 (and the older NUCLEO-H743ZI): STM32H743ZI (Cortex-M7,
//! 2 MiB flash), linked with `memory/nucleo-h743zi.x`: the DTCM for the
//! stack and the statics, the AXI SRAM for the Ethernet DMA rings (the
//! Ethernet DMA cannot reach the DTCM; see `memory.rs`).
//!
//! The two boards differ, for this firmware, in one pin: LD2 is on PE1
//! (yellow) on the NUCLEO-H743ZI2 (MB1364), the board sold today, and on
//! PB7 (blue) on the older NUCLEO-H743ZI (MB1137). The ZI2's is driven;
//! on the older board LD2 stays dark and PE1, wired to a header pin
//! there, is driven low/high with the cycle LED.

use super::clock::Source;
use embassy_stm32::adc::SampleTime;
use embassy_stm32::time::Hertz;

/// The board an update file must name (`cargo sign-image -- sign
/// --board h743`).
pub const UPDATE_BOARD: &str = "nucleo-h743zi";
/// Where the image is linked: the active partition's start
/// (`memory/nucleo-h743zi-flash.x`; `init` checks it against the map's
/// symbol, and an update file linked elsewhere is refused).
pub const UPDATE_ORIGIN: u32 = 0x0802_0000;

pub const NAME: &str = "NUCLEO-H743ZI2";
/// The core clock: 400 MHz (voltage scale 1; 480 MHz would need VOS0 and a
/// revision V chip).
pub const SYSCLK_HZ: u32 = 400_000_000;
/// The HSI's frequency, which the core runs at out of reset.
pub const RESET_HSI_HZ: u32 = 64_000_000;

pub type Iwdg = embassy_stm32::peripherals::IWDG1;
/// Takes the independent watchdog out of the chip's peripherals.
macro_rules! iwdg {
    ($p:ident) => {
        $p.IWDG1
    };
}
pub(super) use iwdg;
/// LD2 (yellow) on the NUCLEO-H743ZI2 (MB1364); PB7 on the older ZI.
macro_rules! ld2 {
    ($p:ident) => {
        $p.PE1
    };
}
pub(super) use ld2;
/// 32.5 ADC clock cycles: well under a microsecond per conversion.
pub const SAMPLE_TIME: SampleTime = SampleTime::CYCLES32_5;
/// embassy-stm32's default resolution on the H7: 16 bits.
pub const ADC_FULL_SCALE: f32 = 65535.0;

/// 400 MHz from a 2 MHz PLL input: the ST-LINK's 8 MHz (HSE bypass, the
/// NUCLEO's default solder bridges) / 4, or the 64 MHz HSI / 32 when that
/// clock is missing (see `clock.rs`). PLL1 × 400 / 2 for the core; AHB
/// 200 MHz, APBs 100 MHz. PLL2 P (100 MHz) clocks the ADC, HSI48 the RNG.
/// The CSI is on so that embassy-stm32 enables the I/O compensation cell,
/// which the Ethernet pins at very high speed need (RM0433; embassy's own
/// H7 examples and tests turn it on the same way).
pub fn config(source: Source) -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    let (pll_source, prediv) = match source {
        Source::Hse => {
            config.rcc.hse = Some(Hse {
                freq: Hertz(8_000_000),
                mode: HseMode::Bypass,
            });
            (PllSource::HSE, PllPreDiv::DIV4)
        }
        Source::Hsi => {
            config.rcc.hsi = Some(HSIPrescaler::DIV1);
            (PllSource::HSI, PllPreDiv::DIV32)
        }
    };
    config.rcc.csi = true;
    config.rcc.hsi48 = Some(Default::default());
    config.rcc.pll1 = Some(Pll {
        source: pll_source,
        prediv,
        mul: PllMul::MUL400,
        fracn: None,
        divp: Some(PllDiv::DIV2),
        divq: None,
        divr: None,
    });
    config.rcc.pll2 = Some(Pll {
        source: pll_source,
        prediv,
        mul: PllMul::MUL200,
        fracn: None,
        divp: Some(PllDiv::DIV4),
        divq: None,
        divr: None,
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV2;
    config.rcc.apb1_pre = APBPrescaler::DIV2;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config.rcc.apb3_pre = APBPrescaler::DIV2;
    config.rcc.apb4_pre = APBPrescaler::DIV2;
    config.rcc.voltage_scale = VoltageScale::Scale1;
    config.rcc.mux.adcsel = mux::Adcsel::PLL2_P;
    config
}

/// Why the chip reset, from RCC_RSR's flags (then cleared, so the next
/// reset reads only its own). Every reset sets the pin flag too, so the
/// pin counts only when nothing else is set; a power-on sets BOR as well.
pub fn reset_flags() -> crate::reset::Cause {
    use crate::reset::Cause;
    use embassy_stm32::pac::RCC;
    let rsr = RCC.rsr().read();
    let cause = if rsr.iwdg1rstf() || rsr.wwdg1rstf() {
        Cause::Watchdog
    } else if rsr.sftrstf() {
        Cause::Software
    } else if rsr.porrstf() {
        Cause::PowerOn
    } else if rsr.borrstf() {
        Cause::BrownOut
    } else if rsr.pinrstf() {
        Cause::Pin
    } else {
        Cause::PowerOn
    };
    // RMVF clears the flags; written back to 0 so later resets set them.
    RCC.rsr().modify(|w| w.set_rmvf(true));
    RCC.rsr().modify(|w| w.set_rmvf(false));
    cause
}

/// Frames the Ethernet receive path missed since the last call: the DMA
/// channel's DMACMFCR (MFC, 11 bits, overflow MFCO bit 15) and the MTL
/// receive queue's MTLRXQMPOCR (OVFPKTCNT 11 bits with OVFCNTOVF bit 11,
/// MISPKTCNT bits 16-26 with MISCNTOVF bit 27; RM0433): with an overflow
/// flag set the count is a lower bound (`true`). Both clear when read.
/// Not yet checked on silicon.
pub fn missed_frames() -> (u32, bool) {
    let eth = embassy_stm32::pac::ETH;
    let dma = eth.ethernet_dma().dmacmfcr().read().0;
    let mtl = eth.ethernet_mtl().mtlrx_qmpocr().read().0;
    let (mfc, a) = crate::missed(dma, 11, dma & (1 << 15) != 0);
    let (ovf, b) = crate::missed(mtl, 11, mtl & (1 << 11) != 0);
    let (mis, c) = crate::missed(mtl >> 16, 11, mtl & (1 << 27) != 0);
    (mfc.saturating_add(ovf).saturating_add(mis), a || b || c)
}
