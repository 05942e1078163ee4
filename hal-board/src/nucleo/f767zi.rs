//! NUCLEO-F767ZI: STM32F767ZI (Cortex-M7, 2 MiB flash, 512 KiB RAM), the
//! root `memory.x`.

use embassy_stm32::adc::SampleTime;
use embassy_stm32::time::Hertz;

pub const NAME: &str = "NUCLEO-F767ZI";
/// The core clock: 216 MHz, the chip's maximum.
pub const SYSCLK_HZ: u32 = 216_000_000;

pub type Iwdg = embassy_stm32::peripherals::IWDG;
/// Takes the independent watchdog out of the chip's peripherals.
macro_rules! iwdg {
    ($p:ident) => {
        $p.IWDG
    };
}
pub(super) use iwdg;
/// 112 ADC clock cycles (ADC clock 27 MHz): about 4 µs per conversion.
pub const SAMPLE_TIME: SampleTime = SampleTime::CYCLES112;
/// 12-bit conversions.
pub const ADC_FULL_SCALE: f32 = 4095.0;

/// 216 MHz from the ST-LINK's 8 MHz clock output (HSE bypass, the NUCLEO's
/// default solder bridges): 8 / 4 × 216 / 2. AHB 216 MHz, APB1 54 MHz,
/// APB2 108 MHz (the maxima).
pub fn config() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL216,
        divp: Some(PllPDiv::DIV2),
        divq: None,
        divr: None,
    });
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config.rcc.sys = Sysclk::PLL1_P;
    config
}
