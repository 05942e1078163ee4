//! The broken variants of the NUCLEO images (hal-board's `rehost-broken-*`
//! features, Cargo.toml), built by `cargo rehost -- --broken` alone. Each
//! puts into the image one defect that silicon would punish, at the point
//! of `init` where such a defect would be made, so that the test can prove
//! the chip's model (host-tests/rehost) stops it with the defect named.
//! Never flashed: every write here is wrong on purpose. With no such
//! feature every hook is empty.
//!
//! The registers are written by address (RM0410 for the F767, RM0433 for
//! the H743), not through embassy-stm32: embassy refuses most of these
//! settings, which is exactly what a hand-written start-up would not do.
#![allow(unsafe_code)]

/// The chip's registers these variants write.
#[cfg(feature = "nucleo-f767zi")]
mod reg {
    /// RCC_CR (RM0410 §5.3.1): PLLON is bit 24.
    pub const RCC_CR: usize = 0x4002_3800;
    /// FLASH_ACR (RM0410 §3.7.1): LATENCY in bits 3:0.
    pub const FLASH_ACR: usize = 0x4002_3C00;
    /// GPIOG_AFRH (RM0410 §6.4.10): PG13's function in bits 23:20.
    pub const GPIOG_AFRH: usize = 0x4002_1824;
}
#[cfg(feature = "nucleo-h743zi")]
mod reg {
    /// RCC_CR (RM0433 §8.7.2): PLL1ON is bit 24.
    pub const RCC_CR: usize = 0x5802_4400;
    /// FLASH_ACR (RM0433 §4.9.1): LATENCY in bits 3:0.
    pub const FLASH_ACR: usize = 0x5200_2000;
    /// GPIOG_AFRH (RM0433 §11.4.10): PG13's function in bits 23:20.
    pub const GPIOG_AFRH: usize = 0x5802_1824;
}

/// Reads, changes and writes back one register of the chip.
fn modify(addr: usize, f: impl FnOnce(u32) -> u32) {
    let r = addr as *mut u32;
    // SAFETY: a register of the chip, written on purpose wrongly; this
    // image is never flashed.
    unsafe { r.write_volatile(f(r.read_volatile())) };
}

/// Before embassy-stm32 sets the clocks (`rehost-broken-pll`): the main
/// PLL started from the HSI with its VCO above the datasheet's limit (F767:
/// 2 MHz x 240 = 480 MHz, above 432 MHz; H743: 2 MHz x 500 = 1000 MHz,
/// above the wide VCO's 960 MHz).
pub fn before_clocks() {
    #[cfg(all(feature = "rehost-broken-pll", feature = "nucleo-f767zi"))]
    // RCC_PLLCFGR (RM0410 §5.3.2): PLLM bits 5:0, PLLN bits 14:6.
    modify(reg::RCC_CR + 0x04, |v| (v & !0x7FFF) | (240 << 6) | 8);
    #[cfg(all(feature = "rehost-broken-pll", feature = "nucleo-h743zi"))]
    // RCC_PLL1DIVR (RM0433 §8.7.12): DIVN1 (multiplier - 1) in bits 8:0;
    // DIVM1 = 32 at reset gives 2 MHz from the 64 MHz HSI.
    modify(reg::RCC_CR + 0x30, |v| (v & !0x1FF) | 499);
    if cfg!(feature = "rehost-broken-pll") {
        modify(reg::RCC_CR, |v| v | (1 << 24));
    }
}

/// After embassy-stm32 set the clocks (`rehost-broken-latency`): one flash
/// wait state fewer than the chip's table wants at that clock (RM0410
/// Table 7, RM0433 Table 17).
pub fn after_clocks() {
    if cfg!(feature = "rehost-broken-latency") {
        modify(reg::FLASH_ACR, |v| v - 1);
    }
}

/// After the Ethernet MAC started (`rehost-broken-rmii`,
/// `rehost-broken-mdc`, `rehost-broken-stack`).
pub fn after_ethernet() {
    if cfg!(feature = "rehost-broken-rmii") {
        // PG13, RMII_TXD0, moved from AF11 to AF10: every frame garbled.
        modify(reg::GPIOG_AFRH, |v| (v & !(0xF << 20)) | (10 << 20));
    }
    if cfg!(feature = "rehost-broken-mdc") {
        mdio_read_with_a_fast_mdc();
    }
    #[cfg(feature = "rehost-broken-stack")]
    crate::stack_guard::overflow_selftest();
}

/// One MDIO read of the PHY's BSR with the clock range for a slower HCLK:
/// HCLK / 62, meant for 100-150 MHz, drives MDC at 3.5 MHz from the F767's
/// 216 MHz and 3.2 MHz from the H743's 200 MHz AXI clock, above the 2.5 MHz
/// of IEEE 802.3 22.2.2.13.
fn mdio_read_with_a_fast_mdc() {
    // F7: ETH_MACMIIAR (RM0410 §42.8.1): MB bit 0, CR bits 4:2 (001 =
    // HCLK/62), MR bits 10:6, PA bits 15:11.
    #[cfg(feature = "nucleo-f767zi")]
    let (at, frame) = (0x4002_8010usize, (1 << 6) | (0b001 << 2) | 1);
    // H7: ETH_MACMDIOAR (RM0433 §58.11.4): GB bit 0, GOC bits 3:2 (11 =
    // read), CR bits 11:8 (0001 = HCLK/62), RDA bits 20:16, PA bits 25:21.
    #[cfg(feature = "nucleo-h743zi")]
    let (at, frame) = (
        0x4002_8200usize,
        (1 << 16) | (0b0001 << 8) | (0b11 << 2) | 1,
    );
    // The busy bit of an MDIO frame still under way, bounded.
    for _ in 0..1_000_000 {
        // SAFETY: a register of the chip.
        if unsafe { (at as *const u32).read_volatile() } & 1 == 0 {
            break;
        }
    }
    modify(at, |_| frame);
}
