//! NUCLEO-H743ZI: STM32H743ZI (Cortex-M7, 2 MiB flash), linked with
//! `memory/nucleo-h743zi.x`: all RAM in the 512 KiB AXI SRAM, which the
//! Ethernet DMA can reach (the DTCM at 0x2000_0000 it cannot).

use embassy_stm32::adc::SampleTime;
use embassy_stm32::time::Hertz;

pub const NAME: &str = "NUCLEO-H743ZI";
/// The core clock: 400 MHz (voltage scale 1; 480 MHz would need VOS0 and a
/// revision V chip).
pub const SYSCLK_HZ: u32 = 400_000_000;

pub type Iwdg = embassy_stm32::peripherals::IWDG1;
/// Takes the independent watchdog out of the chip's peripherals.
macro_rules! iwdg {
    ($p:ident) => {
        $p.IWDG1
    };
}
pub(super) use iwdg;
/// 32.5 ADC clock cycles: well under a microsecond per conversion.
pub const SAMPLE_TIME: SampleTime = SampleTime::CYCLES32_5;
/// embassy-stm32's default resolution on the H7: 16 bits.
pub const ADC_FULL_SCALE: f32 = 65535.0;

/// 400 MHz from the ST-LINK's 8 MHz clock output (HSE bypass, the NUCLEO's
/// default solder bridges): PLL1 8 / 4 × 400 / 2; AHB 200 MHz, APBs
/// 100 MHz. PLL2 P (100 MHz) clocks the ADC, HSI48 the RNG.
pub fn config() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    config.rcc.hsi48 = Some(Default::default());
    config.rcc.pll1 = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL400,
        fracn: None,
        divp: Some(PllDiv::DIV2),
        divq: None,
        divr: None,
    });
    config.rcc.pll2 = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV4,
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
