//! STM32F76x/77x reset and clock control (RCC), RM0410 rev 5 §5.3: the
//! oscillators and PLLs with ready bits that follow their enables after
//! the start-up times of the datasheet (DS11532 §5.3.7-5.3.11), the
//! system clock switch that happens only once its target is ready
//! (RM0410 §5.3.3, SW/SWS), the prescalers, the reset flags, and the
//! peripheral clock enables every other model checks before it answers.
//!
//! The clock tree is computed after every write and checked against the
//! datasheet's limits ([`crate::clocks`]); PLL inputs and VCO outside
//! their ranges stop the run (DS11532 Table 39: PLL input 0.95-2.1 MHz,
//! VCO output 100-432 MHz).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs, ResetCause};
use crate::clocks::mhz;

pub const HSI_HZ: u64 = 16_000_000;
/// The NUCLEO-144's ST-LINK drives 8 MHz into OSC_IN (HSE bypass).
pub const HSE_HZ: u64 = 8_000_000;

const CR: u32 = 0x00;
const PLLCFGR: u32 = 0x04;
const CFGR: u32 = 0x08;
const CSR: u32 = 0x74;

/// RM0410 §5.3.1-§5.3.28: offsets, reset values, writable and hardware
/// bits. The peripheral reset and enable registers' masks are their
/// defined bits.
const TABLE: &[Reg] = &[
    reg(CR, "CR", 0x0000_0083, 0x150D_00F9, 0x2A02_FF02),
    reg(PLLCFGR, "PLLCFGR", 0x2400_3010, 0x7F43_7FFF, 0),
    reg(CFGR, "CFGR", 0x0000_0000, 0xFFFF_FCF3, 0x0000_000C),
    reg(0x0C, "CIR", 0x0000_0000, 0x00BF_7F00, 0x0000_00BF),
    reg(0x10, "AHB1RSTR", 0, 0x22E0_17FF, 0),
    reg(0x14, "AHB2RSTR", 0, 0x0000_00F1, 0),
    reg(0x18, "AHB3RSTR", 0, 0x0000_0003, 0),
    reg(0x20, "APB1RSTR", 0, 0xFFFF_CBFF, 0),
    reg(0x24, "APB2RSTR", 0, 0x06F7_7933, 0),
    reg(0x30, "AHB1ENR", 0x0010_0000, 0x7EF4_17FF, 0),
    reg(0x34, "AHB2ENR", 0, 0x0000_00F1, 0),
    reg(0x38, "AHB3ENR", 0, 0x0000_0003, 0),
    reg(0x40, "APB1ENR", 0, 0xFFFF_CBFF, 0),
    reg(0x44, "APB2ENR", 0, 0x06F7_7F33, 0),
    reg(0x50, "AHB1LPENR", 0x7EFF_F7FF, 0x7EFF_F7FF, 0),
    reg(0x54, "AHB2LPENR", 0x0000_00F1, 0x0000_00F1, 0),
    reg(0x58, "AHB3LPENR", 0x0000_0003, 0x0000_0003, 0),
    reg(0x60, "APB1LPENR", 0xFFFF_CBFF, 0xFFFF_CBFF, 0),
    reg(0x64, "APB2LPENR", 0x06F7_7F33, 0x06F7_7F33, 0),
    reg(0x70, "BDCR", 0, 0x0001_831D, 0x0000_0002),
    reg(CSR, "CSR", 0x0E00_0000, 0x0100_0001, 0xFE00_0002),
    reg(0x80, "SSCGR", 0, 0xCFFF_FFFF, 0),
    reg(0x84, "PLLI2SCFGR", 0x2400_3000, 0x7F0F_7FC0, 0),
    reg(0x88, "PLLSAICFGR", 0x2400_3000, 0x7F03_7FC0, 0),
    reg(0x8C, "DCKCFGR1", 0, 0x31FF_1F1F, 0),
    reg(0x90, "DCKCFGR2", 0, 0x3FFF_FFFF, 0),
];

/// Which enable bit clocks which block: (block name, enable register,
/// bit). RM0410 §5.3.10-5.3.14.
pub const ENABLES: &[(&str, u32, u32)] = &[
    ("GPIOA", 0x30, 0),
    ("GPIOB", 0x30, 1),
    ("GPIOC", 0x30, 2),
    ("GPIOD", 0x30, 3),
    ("GPIOE", 0x30, 4),
    ("GPIOF", 0x30, 5),
    ("GPIOG", 0x30, 6),
    ("GPIOH", 0x30, 7),
    ("GPIOI", 0x30, 8),
    ("GPIOJ", 0x30, 9),
    ("GPIOK", 0x30, 10),
    ("CRC", 0x30, 12),
    ("BKPSRAM", 0x30, 18),
    ("DMA1", 0x30, 21),
    ("DMA2", 0x30, 22),
    ("ETH", 0x30, 25),
    ("RNG", 0x34, 6),
    ("TIM2", 0x40, 0),
    ("TIM3", 0x40, 1),
    ("TIM4", 0x40, 2),
    ("TIM5", 0x40, 3),
    ("TIM12", 0x40, 6),
    ("UART4", 0x40, 19),
    ("PWR", 0x40, 28),
    ("ADC1", 0x44, 8),
    ("ADC", 0x44, 8),
    ("SYSCFG", 0x44, 14),
    ("TIM1", 0x44, 0),
];

/// Every oscillator and PLL: (register, enable bit, ready bit, start-up
/// time in microseconds). DS11532 §5.3.7-5.3.11: HSI 2 us; HSE in bypass
/// ready within six cycles of the external clock (1 us here); LSI 40 us
/// (tSU(LSI) max); LSE 2 s (tSU(LSE) typ.); the PLLs lock within 100 us.
const READY: &[(u32, u32, u32, u64)] = &[
    (CR, 0, 1, 2),
    (CR, 16, 17, 1),
    (CR, 24, 25, 100),
    (CR, 26, 27, 100),
    (CR, 28, 29, 100),
    (CSR, 0, 1, 40),
    (0x70, 0, 1, 2_000_000),
];

/// A ready bit that follows its enable after a start-up time.
#[derive(Clone, Copy, Debug)]
struct Settle {
    reg: u32,
    bit: u32,
    on: bool,
    at: u64,
}

pub struct Rcc {
    regs: Regs,
    settling: Vec<Settle>,
    /// Whether a clock drives OSC_IN (the ST-LINK's; a board without it
    /// never sets HSERDY).
    pub hse_present: bool,
}

impl Rcc {
    pub fn new() -> Rcc {
        Rcc {
            regs: Regs::new(TABLE),
            settling: Vec::new(),
            hse_present: true,
        }
    }

    fn cr(&self) -> u32 {
        self.regs.get(CR)
    }

    /// The clock a source selector names, if it runs (its ready bit set).
    fn source_hz(&self, sws: u32) -> Result<u64, Refusal> {
        let cr = self.cr();
        match sws {
            0 => Ok(HSI_HZ),
            1 => Ok(HSE_HZ),
            2 => self.pll_p_hz(),
            _ => Err("RCC_CFGR: SW = 11 is not allowed".into()),
        }
        .map(|hz| {
            if sws == 2 && cr & (1 << 25) == 0 {
                0
            } else {
                hz
            }
        })
    }

    /// PLL P output from PLLCFGR, with its ranges checked.
    fn pll_p_hz(&self) -> Result<u64, Refusal> {
        let v = self.regs.get(PLLCFGR);
        let input = if v & (1 << 22) != 0 { HSE_HZ } else { HSI_HZ };
        let m = u64::from(v & 0x3F);
        let n = u64::from((v >> 6) & 0x1FF);
        let p = 2 * (u64::from((v >> 16) & 3) + 1);
        if m < 2 {
            return Err(format!("RCC_PLLCFGR: PLLM = {m} (2..63 allowed)"));
        }
        if !(50..=432).contains(&n) {
            return Err(format!("RCC_PLLCFGR: PLLN = {n} (50..432 allowed)"));
        }
        let vin = input / m;
        if !(950_000..=2_100_000).contains(&vin) {
            return Err(format!(
                "the PLL input {} MHz is outside 0.95-2.1 MHz (PLLM = {m})",
                mhz(vin)
            ));
        }
        let vco = vin * n;
        if !(100_000_000..=432_000_000).contains(&vco) {
            return Err(format!(
                "the PLL's VCO {} MHz is outside 100-432 MHz (PLLN = {n})",
                mhz(vco)
            ));
        }
        Ok(vco / p)
    }

    /// Recomputes the tree into `cx.clocks` and checks it.
    fn update_clocks(&self, cx: &mut Cx) -> Result<(), Refusal> {
        let cfgr = self.regs.get(CFGR);
        let sys = self.source_hz((cfgr >> 2) & 3)?;
        let hpre = (cfgr >> 4) & 0xF;
        let ahb_div = if hpre < 8 {
            1
        } else {
            [2, 4, 8, 16, 64, 128, 256, 512][(hpre - 8) as usize]
        };
        let apb = |ppre: u32| if ppre < 4 { 1 } else { 1 << (ppre - 3) };
        let hclk = sys / ahb_div;
        cx.clocks.core_hz = sys;
        cx.clocks.hclk_hz = hclk;
        cx.clocks.apb_hz = [
            hclk / apb((cfgr >> 10) & 7),
            hclk / apb((cfgr >> 13) & 7),
            0,
            0,
        ];
        cx.clocks.enabled = ENABLES
            .iter()
            .filter(|(_, r, bit)| self.regs.get(*r) & (1 << bit) != 0)
            .map(|(name, _, _)| *name)
            .collect();
        cx.clocks.check()
    }

    fn settle(&mut self, reg: u32, bit: u32, on: bool, after: u64) {
        self.settling.retain(|s| !(s.reg == reg && s.bit == bit));
        self.settling.push(Settle {
            reg,
            bit,
            on,
            at: after,
        });
    }
}

impl Default for Rcc {
    fn default() -> Rcc {
        Rcc::new()
    }
}

/// Cycles of the core clock in `us` microseconds (at least one).
fn cycles(cx: &Cx, us: u64) -> u64 {
    crate::clocks::core_cycles(cx.clocks, HSI_HZ, us)
}

impl Peripheral for Rcc {
    fn name(&self) -> &'static str {
        "RCC"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read("RCC", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let before = self.regs.clone();
        let (old, new) = self.regs.write("RCC", offset, size, value)?;
        let changed = old ^ new;
        for &(reg, on, ready, us) in READY {
            if reg == offset & !3 && changed & (1 << on) != 0 {
                let starting = new & (1 << on) != 0;
                if starting && reg == CR && on == 16 && !self.hse_present {
                    continue;
                }
                // Stopping takes a few cycles of the oscillator itself.
                let at = cx.now + cycles(cx, if starting { us } else { 1 });
                self.settle(reg, ready, starting, at);
            }
        }
        match offset & !3 {
            CR => {
                // HSEBYP may be written only while HSE is off (RM0410 §5.3.1).
                if changed & (1 << 18) != 0 && old & (1 << 16) != 0 {
                    self.regs = before;
                    return Err(
                        "RCC_CR: HSEBYP written while HSEON is set (allowed only with the HSE off)"
                            .into(),
                    );
                }
                if changed & (1 << 24) != 0
                    && new & (1 << 24) == 0
                    && (self.regs.get(CFGR) >> 2) & 3 == 2
                {
                    self.regs = before;
                    return Err("RCC_CR: PLLON cleared while the PLL clocks the system".into());
                }
                if changed & (1 << 24) != 0 && new & (1 << 24) != 0 {
                    // The PLL's settings are checked when it starts.
                    self.pll_p_hz()?;
                }
            }
            PLLCFGR if self.cr() & (1 << 24) != 0 && changed != 0 => {
                self.regs = before;
                return Err("RCC_PLLCFGR written while the PLL is on (RM0410 §5.3.2: only while PLLON is clear)".into());
            }
            CFGR => {
                // SWS follows SW when the target clock is ready.
                self.advance(cx)?;
            }
            // RMVF clears every reset flag.
            CSR if new & (1 << 24) != 0 => self.regs.set_bits(CSR, 0xFE00_0000, false),
            _ => {}
        }
        self.update_clocks(cx)
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let now = cx.now;
        let due: Vec<Settle> = self
            .settling
            .iter()
            .copied()
            .filter(|s| s.at <= now)
            .collect();
        self.settling.retain(|s| s.at > now);
        for s in due {
            self.regs.set_bits(s.reg, 1 << s.bit, s.on);
        }
        let cfgr = self.regs.get(CFGR);
        let (sw, sws) = (cfgr & 3, (cfgr >> 2) & 3);
        if sw != sws {
            let cr = self.cr();
            let ready = match sw {
                0 => cr & (1 << 1) != 0,
                1 => cr & (1 << 17) != 0,
                2 => cr & (1 << 25) != 0,
                _ => false,
            };
            if ready {
                self.regs.set(CFGR, (cfgr & !0xC) | (sw << 2));
            }
        }
        self.update_clocks(cx)
    }

    /// RCC_CSR's flags (bits 31:25) survive a system reset; only RMVF or a
    /// power-on clears them (RM0410 §5.3.21).
    fn reset_flags(&self) -> Option<u32> {
        Some(self.regs.get(CSR) & 0xFE00_0000)
    }

    /// A system reset drives NRST low (RM0410 §5.1.2), so PINRSTF joins
    /// the cause's own flag: SFTRSTF (28) or IWDGRSTF (29).
    fn keep_reset_flags(&mut self, kept: u32, cause: ResetCause) {
        let own = match cause {
            ResetCause::Software => 1 << 28,
            ResetCause::Watchdog { .. } => 1 << 29,
        };
        let csr = self.regs.get(CSR) & !0xFE00_0000;
        self.regs.set(CSR, csr | kept | own | (1 << 26));
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.settling.iter().map(|s| s.at).min()
    }
}
