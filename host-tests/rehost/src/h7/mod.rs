//! The STM32H743ZI's peripherals, as a table of blocks (RM0433 rev 8
//! §2.3.2, "Memory map and register boundary addresses"): the blocks
//! modelled so far, the clock tree's (RCC, PWR, FLASH); every other
//! address stops the run.

pub mod adc;
pub mod eth;
pub mod flash;
pub mod power;
pub mod rcc;

use crate::bus::{reg, Bus, Reg};
use crate::simple::Plain;

/// DBGMCU (RM0433 §60.5.8): the device ID (0x450, revision V 0x2003)
/// and the debug configuration and freeze bits.
const DBGMCU: &[Reg] = &[
    reg(0x00, "IDC", 0x2003_6450, 0, 0xFFFF_0FFF),
    reg(0x04, "CR", 0, 0x0070_0007, 0),
    reg(0x34, "APB3FZ1", 0, 0x0000_0040, 0),
    reg(0x3C, "APB1LFZ1", 0, 0x00E0_03FF, 0),
    reg(0x44, "APB1HFZ1", 0, 0x0000_0020, 0),
    reg(0x4C, "APB2FZ1", 0, 0x2007_0003, 0),
    reg(0x54, "APB4FZ1", 0, 0x0004_1F80, 0),
];
use crate::clocks::Clocks;

/// The chip's peripheral blocks and its clocks at reset: the HSI's 64 MHz
/// everywhere (RM0433 §8: sys_ck = HSI, every prescaler /1), FLASH_ACR at
/// its reset 0x37 (7 wait states, WRHIGHFREQ 3), voltage scale 3.
pub fn bus() -> (Bus, Clocks) {
    let mut bus = Bus::default();
    bus.add(0x5802_4400, 0x400, None, rcc::Rcc::new());
    // PWR has no clock enable on the H7: it is always clocked.
    bus.add(0x5802_4800, 0x400, None, power::Pwr::new());
    bus.add(0x5200_2000, 0x1000, None, flash::Flash::new());
    bus.add(0x5C00_1000, 0x400, None, Plain::new("DBGMCU", DBGMCU));
    crate::gpio::ports(
        &mut bus,
        0x5802_0000,
        'K',
        crate::gpio::H7_A,
        crate::gpio::H7_B,
        crate::gpio::H7_OTHER,
    );
    bus.add(
        0x5800_0400,
        0x400,
        Some("SYSCFG"),
        crate::syscfg::Syscfg::new(crate::syscfg::Kind::H7),
    );
    bus.add(0x4802_1800, 0x400, Some("RNG"), crate::rng::Rng::new());
    bus.add(0x5800_4800, 0x400, None, crate::iwdg::Iwdg::new("IWDG1"));
    // The Ethernet MAC, MTL and DMA (IRQ 61), clocked by ETH1MAC.
    bus.add(0x4002_8000, 0x1400, Some("ETH1MAC"), eth::Eth::new(61));
    bus.add(0x4002_2000, 0x100, Some("ADC12"), adc::Adc::new());
    bus.add(
        0x4002_2300,
        0x100,
        Some("ADC12"),
        Plain::new("ADC12_COMMON", adc::COMMON),
    );
    // TIM12: the timer embassy-time's driver takes on this chip (IRQ 43,
    // TIM8_BRK_TIM12; RM0433 Table 147).
    bus.add(
        0x4000_1800,
        0x400,
        Some("TIM12"),
        crate::timer::Timer::new("TIM12", crate::timer::TIM9_12, 43, 0),
    );
    let mut clocks = Clocks {
        core_hz: rcc::HSI_HZ,
        hclk_hz: rcc::HSI_HZ,
        apb_hz: [rcc::HSI_HZ; 4],
        flash_latency: 7,
        flash_wrhighfreq: 3,
        ..Clocks::default()
    };
    let mut shared = crate::bus::Shared::default();
    let mut cx = shared.cx(0, crate::bus::no_dma());
    cx.clocks = &mut clocks;
    // The limits at reset (scale 3), from PWR's reset value.
    let _ = crate::bus::Peripheral::advance(&mut power::Pwr::new(), &mut cx);
    (bus, clocks)
}

/// What the clock models' tests share: accesses as the bus makes them, and
/// the sequences that start PLL1 and switch the system clock to it.
#[cfg(test)]
pub(crate) mod testing {
    use super::rcc::{Rcc, HSE_US, HSI_HZ, PLL_LOCK_US};
    use crate::bus::{Peripheral, Refusal};
    use crate::clocks::Clocks;

    // RCC offsets and RCC_CR bits (RM0433 §8.7).
    pub(crate) const CR: u32 = 0x00;
    pub(crate) const CFGR: u32 = 0x10;
    pub(crate) const PLLCKSELR: u32 = 0x28;
    pub(crate) const HSEON: u32 = 16;
    pub(crate) const HSEBYP: u32 = 18;
    pub(crate) const PLL1ON: u32 = 24;
    pub(crate) const PLL1RDY: u32 = 25;

    /// One access at `now`, after the model's advance, as the bus makes it.
    pub(crate) fn access(
        model: &mut dyn Peripheral,
        clocks: &mut Clocks,
        now: u64,
        offset: u32,
        write: Option<u32>,
    ) -> Result<u32, Refusal> {
        let mut shared = crate::bus::Shared::default();
        let mut cx = shared.cx(now, crate::bus::no_dma());
        cx.clocks = clocks;
        model.advance(&mut cx)?;
        match write {
            Some(v) => model.write(offset, 4, v, &mut cx).map(|()| 0),
            None => model.read(offset, 4, &mut cx),
        }
    }

    /// `n` microseconds in cycles at the reset clock (64 MHz).
    pub(crate) fn us(n: u64) -> u64 {
        HSI_HZ / 1_000_000 * n
    }

    /// At `now`, HSE bypass on; once it is ready, PLL1 from HSE / 4 (2 MHz,
    /// PLL1RGE 2-4 MHz) x (`divn` + 1), P /2, VCO range `vcosel`, turned
    /// on. Returns the time it locks.
    pub(crate) fn start_pll1(
        rcc: &mut Rcc,
        c: &mut Clocks,
        now: u64,
        divn: u32,
        vcosel: u32,
    ) -> Result<u64, Refusal> {
        let cr = access(rcc, c, now, CR, None)?;
        access(rcc, c, now, CR, Some(cr | (1 << HSEBYP)))?;
        access(rcc, c, now, CR, Some(cr | (1 << HSEBYP) | (1 << HSEON)))?;
        let t = now + us(HSE_US);
        let sel = access(rcc, c, t, PLLCKSELR, None)?;
        access(rcc, c, t, PLLCKSELR, Some((sel & !0x3F3) | (4 << 4) | 2))?;
        access(rcc, c, t, 0x2C, Some(0x01FF_0004 | (vcosel << 1)))?;
        access(
            rcc,
            c,
            t,
            0x30,
            Some(divn | (1 << 9) | (1 << 16) | (1 << 24)),
        )?;
        let cr = access(rcc, c, t, CR, None)?;
        access(rcc, c, t, CR, Some(cr | (1 << PLL1ON)))?;
        Ok(t + us(PLL_LOCK_US))
    }

    /// The AXI clock and every APB at /2 (D1CFGR, D2CFGR, D3CFGR), then
    /// the system clock to PLL1 P.
    pub(crate) fn to_pll1(rcc: &mut Rcc, c: &mut Clocks, now: u64) -> Result<u32, Refusal> {
        access(rcc, c, now, 0x18, Some(0x48))?;
        access(rcc, c, now, 0x1C, Some(0x440))?;
        access(rcc, c, now, 0x20, Some(0x40))?;
        access(rcc, c, now, CFGR, Some(3))
    }
}

/// The map's tests and RCC's (RCC with PWR's reset limits in force, as on
/// the chip; here rather than in rcc.rs, which is at its line budget).
#[cfg(test)]
mod tests {
    use super::rcc::{Rcc, HSE_HZ, HSE_US, HSI_HZ};
    use super::testing::*;

    #[test]
    fn no_two_blocks_overlap() {
        let (bus, _) = super::bus();
        for (i, a) in bus.blocks.iter().enumerate() {
            for b in &bus.blocks[i + 1..] {
                assert!(a.base + a.size <= b.base || b.base + b.size <= a.base);
            }
        }
    }

    #[test]
    fn a_pll_is_ready_only_after_its_lock_time() {
        let (_, mut c) = super::bus();
        let mut rcc = Rcc::new();
        let locked = start_pll1(&mut rcc, &mut c, 0, 399, 0).unwrap();
        let cr = access(&mut rcc, &mut c, locked - 1, CR, None).unwrap();
        assert_eq!(cr & (1 << PLL1RDY), 0);
        let cr = access(&mut rcc, &mut c, locked, CR, None).unwrap();
        assert_ne!(cr & (1 << PLL1RDY), 0);
    }

    #[test]
    fn sws_follows_sw_only_once_the_target_is_ready() {
        let (_, mut c) = super::bus();
        let mut rcc = Rcc::new();
        access(&mut rcc, &mut c, 0, CR, Some(0x25 | (1 << HSEBYP))).unwrap();
        access(&mut rcc, &mut c, 0, CR, Some(0x25 | (5 << HSEON))).unwrap();
        access(&mut rcc, &mut c, 1, CFGR, Some(2)).unwrap();
        let cfgr = access(&mut rcc, &mut c, 2, CFGR, None).unwrap();
        assert_eq!(((cfgr >> 3) & 7, c.core_hz), (0, HSI_HZ));
        let cfgr = access(&mut rcc, &mut c, us(HSE_US), CFGR, None).unwrap();
        assert_eq!(((cfgr >> 3) & 7, c.core_hz), (2, HSE_HZ));
        // The HSE clocks the system now: HSEON cannot be cleared.
        let cr = 0x25 | (1 << HSEBYP);
        access(&mut rcc, &mut c, us(HSE_US), CR, Some(cr)).unwrap();
        let cr = access(&mut rcc, &mut c, us(2 * HSE_US), CR, None).unwrap();
        assert_ne!(cr & (1 << HSEON), 0);
    }

    #[test]
    fn a_vco_out_of_its_range_is_refused() {
        for (divn, vcosel, range) in [(499, 0, "192-960"), (49, 0, "192-960"), (399, 1, "150-420")]
        {
            let (_, mut c) = super::bus();
            let e = start_pll1(&mut Rcc::new(), &mut c, 0, divn, vcosel).unwrap_err();
            assert!(e.contains("RCC_PLL1DIVR") && e.contains(range), "{e}");
        }
    }

    #[test]
    fn divm1_and_pllsrc_hold_while_pll1_runs() {
        let (_, mut c) = super::bus();
        let mut rcc = Rcc::new();
        let locked = start_pll1(&mut rcc, &mut c, 0, 399, 0).unwrap();
        access(&mut rcc, &mut c, locked, PLLCKSELR, Some(0)).unwrap();
        let sel = access(&mut rcc, &mut c, locked, PLLCKSELR, None).unwrap();
        // DIVM1 = 4 and PLLSRC = HSE kept; DIVM2 and DIVM3 (off) cleared.
        assert_eq!(sel, (4 << 4) | 2);
    }
}
