//! Which oscillator the NUCLEO's clocks come from, decided before
//! embassy-stm32 configures them.
//!
//! The boards run from the ST-LINK's 8 MHz clock output on OSC_IN (HSE
//! bypass, the default solder bridges). Without it (the board powered
//! without a running ST-LINK, or the bridges changed) embassy-stm32 would
//! wait for HSE forever, before the watchdog runs: a dark board. So the
//! clock is looked for first, for [`HSE_WAIT_MS`], and when it is not
//! there the board runs from the internal HSI instead, at the same
//! frequencies, and says so in the log. Everything works on HSI: the
//! Ethernet's RMII clock comes from the PHY's own 25 MHz crystal, the RNG
//! and the ADC from the PLLs. What suffers is the time base (embassy-time
//! and the timestamps sent to the robot): the HSI is factory-trimmed to
//! about ±1 % at 25 °C, the ST-LINK's output follows its crystal.
#![allow(unsafe_code)]

use embassy_stm32::pac::RCC;

/// The clock source the PLLs run from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Source {
    /// The ST-LINK's 8 MHz output on OSC_IN (HSE bypass).
    Hse,
    /// The internal RC oscillator: the ST-LINK's clock did not come.
    Hsi,
}

/// How long the HSE gets to show up. A clock that is there is ready within
/// a few of its cycles; the margin covers an ST-LINK that starts its clock
/// output after the target leaves reset (STM32Cube waits 100 ms).
pub const HSE_WAIT_MS: u32 = 500;

/// Turns HSE (bypass) on and waits up to [`HSE_WAIT_MS`] for it to be
/// ready, then turns it off again (HSEBYP stays set, as the boards'
/// configuration wants it): embassy-stm32's `init` configures the clocks
/// from the source found here. Call before `init`, while the
/// core still runs from the HSI at its reset frequency (`reset_hsi_hz`).
pub fn probe(reset_hsi_hz: u32) -> Source {
    // HSEBYP may only be written while the HSE is off (RM0410, RM0433).
    RCC.cr().modify(|w| w.set_hseon(false));
    RCC.cr().modify(|w| w.set_hsebyp(true));
    RCC.cr().modify(|w| w.set_hseon(true));
    let mut found = Source::Hsi;
    for _ in 0..=HSE_WAIT_MS {
        if RCC.cr().read().hserdy() {
            found = Source::Hse;
            break;
        }
        cortex_m::asm::delay(reset_hsi_hz / 1000);
    }
    RCC.cr().modify(|w| w.set_hseon(false));
    // HSERDY falls within six HSE cycles of HSEON; bounded anyway.
    for _ in 0..1000 {
        if !RCC.cr().read().hserdy() {
            break;
        }
    }
    found
}
