//! STM32H743 reset and clock control (RCC), RM0433 rev 8 §8 (registers
//! §8.7): oscillators and PLLs whose ready bits follow their enables after
//! start-up times of DS12110's order, the system clock switch that happens
//! only once its target is ready (RCC_CFGR SW/SWS), the D1-D3 prescalers,
//! the reset flags (RCC_RSR) and the peripheral clock enables the other
//! models check. The tree is recomputed after every write and checked
//! against the limits PWR sets ([`super::power::check`]); a running PLL
//! with its input (1-16 MHz, within the range PLLxRGE names) or VCO (wide
//! 192-960 MHz from 2 MHz inputs up, medium 150-420 MHz) out of range
//! stops the run (DS12110 "PLL characteristics"; RM0433 §8.7).
//!
//! Fields the hardware protects are kept, as silicon keeps them (RM0433
//! §8.7): the enable of the system clock's source, or of PLL1's source
//! while PLL1 runs; DIVMx while PLLx runs, PLLSRC while any PLL does.
//! What the manual forbids outright (PLLxDIVR, PLLxVCOSEL, PLLxRGE written
//! while PLLx runs; HSEBYP with the HSE on) stops the run.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs, ResetCause};
use crate::clocks::mhz;

pub const HSI_HZ: u64 = 64_000_000;
pub const CSI_HZ: u64 = 4_000_000;
/// The NUCLEO-144's ST-LINK drives 8 MHz into OSC_IN (HSE bypass).
pub const HSE_HZ: u64 = 8_000_000;
/// Start-up times (us), of the order of DS12110's: HSE bypass ready within
/// a few of its cycles; PLL lock (tLOCK) at most about 100 us.
pub const HSE_US: u64 = 1;
pub const PLL_LOCK_US: u64 = 100;
const LSI_US: u64 = 100;
/// LSE crystal start-up, about 2 s (DS12110 LSE characteristics, tSU).
const LSE_US: u64 = 2_000_000;

const CR: u32 = 0x00;
const CFGR: u32 = 0x10;
const D1CFGR: u32 = 0x18;
const D2CFGR: u32 = 0x1C;
const D3CFGR: u32 = 0x20;
const PLLCKSELR: u32 = 0x28;
const PLLCFGR: u32 = 0x2C;
/// PLLxDIVR is at 0x30 + 8x, PLLxFRACR at 0x34 + 8x (x = 0, 1, 2).
const PLL1DIVR: u32 = 0x30;
const CIER: u32 = 0x60;
const CICR: u32 = 0x68;
const BDCR: u32 = 0x70;
const CSR: u32 = 0x74;
const RSR: u32 = 0xD0;

// RCC_CR bits.
const HSION: u32 = 0;
const HSIRDY: u32 = 2;
const HSIDIVF: u32 = 5;
const CSION: u32 = 7;
const CSIRDY: u32 = 8;
const HSI48ON: u32 = 12;
const HSI48RDY: u32 = 13;
const HSEON: u32 = 16;
const HSERDY: u32 = 17;
const HSEBYP: u32 = 18;
const PLL1ON: u32 = 24;
const PLL1RDY: u32 = 25;

/// RM0433 §8.7: offsets, reset values, writable and hardware bits: the
/// fields of ST's STM32H743 SVD; for the reset, enable, low-power enable
/// and kernel clock registers their union with the other H7 parts' fields
/// (permissive: a wrong strict mask would stop a correct image). CR resets
/// as RM0433 gives it (HSION, HSIRDY, HSIDIVF), RSR to a power-on reset's
/// flags, the LPENR registers to every field set; calibrations read 0.
#[rustfmt::skip]
const TABLE: &[Reg] = &[
    reg(CR, "CR", 0x0000_0025, 0x150D_129B, 0x2A02_E124),
    reg(0x04, "HSICFGR", 0x4000_0000, 0x7F00_0000, 0x0000_0FFF),
    reg(0x08, "CRRCR", 0, 0, 0x0000_03FF),
    reg(0x0C, "CSICFGR", 0x2000_0000, 0x3F00_0000, 0x0000_01FF),
    reg(CFGR, "CFGR", 0, 0xFFFC_FFC7, 0x0000_0038),
    reg(D1CFGR, "D1CFGR", 0, 0x0000_0F7F, 0),
    reg(D2CFGR, "D2CFGR", 0, 0x0000_0770, 0), reg(D3CFGR, "D3CFGR", 0, 0x0000_0070, 0),
    reg(PLLCKSELR, "PLLCKSELR", 0x0202_0200, 0x03F3_F3F3, 0),
    reg(PLLCFGR, "PLLCFGR", 0x01FF_0000, 0x01FF_0FFF, 0),
    reg(0x30, "PLL1DIVR", 0x0101_0280, 0x7F7F_FFFF, 0), reg(0x34, "PLL1FRACR", 0, 0xFFF8, 0),
    reg(0x38, "PLL2DIVR", 0x0101_0280, 0x7F7F_FFFF, 0), reg(0x3C, "PLL2FRACR", 0, 0xFFF8, 0),
    reg(0x40, "PLL3DIVR", 0x0101_0280, 0x7F7F_FFFF, 0), reg(0x44, "PLL3FRACR", 0, 0xFFF8, 0),
    reg(0x4C, "D1CCIPR", 0, 0x3001_0033, 0), reg(0x50, "D2CCIP1R", 0, 0xB137_71C7, 0),
    reg(0x54, "D2CCIP2R", 0, 0x70F0_333F, 0), reg(0x58, "D3CCIPR", 0, 0x7FE3_FF07, 0),
    reg(CIER, "CIER", 0, 0x0000_03FF, 0), reg(0x64, "CIFR", 0, 0, 0x0000_07FF),
    reg(CICR, "CICR", 0, 0x0000_07FF, 0),
    reg(BDCR, "BDCR", 0, 0x0001_833D, 0x0000_0042), reg(CSR, "CSR", 0, 0x0000_0001, 0x0000_0002),
    reg(0x7C, "AHB3RSTR", 0, 0x80E9_5031, 0), reg(0x80, "AHB1RSTR", 0, 0x0A00_C023, 0),
    reg(0x84, "AHB2RSTR", 0, 0x0003_0271, 0), reg(0x88, "AHB4RSTR", 0, 0x0328_07FF, 0),
    reg(0x8C, "APB3RSTR", 0, 0x0000_0018, 0), reg(0x90, "APB1LRSTR", 0, 0xEAFF_C3FF, 0),
    reg(0x94, "APB1HRSTR", 0, 0x0000_0136, 0), reg(0x98, "APB2RSTR", 0, 0x31D7_30F3, 0),
    reg(0x9C, "APB4RSTR", 0, 0x0420_FEAA, 0),
    reg(0xA0, "GCR", 0, 0x0000_0001, 0), reg(0xA8, "D3AMR", 0, 0x3529_FEA9, 0),
    reg(RSR, "RSR", 0x00FA_0000, 0x0001_0000, 0x55FA_0000),
    reg(0xD4, "AHB3ENR", 0, 0xF0E9_5031, 0), reg(0xD8, "AHB1ENR", 0, 0x1E07_C023, 0),
    reg(0xDC, "AHB2ENR", 0, 0xE003_0271, 0), reg(0xE0, "AHB4ENR", 0, 0x1328_07FF, 0),
    reg(0xE4, "APB3ENR", 0, 0x0000_0058, 0), reg(0xE8, "APB1LENR", 0, 0xEAFF_CBFF, 0),
    reg(0xEC, "APB1HENR", 0, 0x0000_0136, 0), reg(0xF0, "APB2ENR", 0, 0x31D7_30F3, 0),
    reg(0xF4, "APB4ENR", 0, 0x0421_FEAA, 0),
    reg(0xFC, "AHB3LPENR", 0xF001_5131, 0xF0E9_5131, 0),
    reg(0x100, "AHB1LPENR", 0x1E03_8023, 0x1E07_C023, 0),
    reg(0x104, "AHB2LPENR", 0xE000_0271, 0xE003_0271, 0),
    reg(0x108, "AHB4LPENR", 0x3128_07FF, 0x3328_07FF, 0),
    reg(0x10C, "APB3LPENR", 0x0000_0048, 0x0000_0058, 0),
    reg(0x110, "APB1LLPENR", 0xE8FF_C3FF, 0xEAFF_CBFF, 0),
    reg(0x114, "APB1HLPENR", 0x0000_0136, 0x0000_0136, 0),
    reg(0x118, "APB2LPENR", 0x31D7_3033, 0x31D7_30F3, 0),
    reg(0x11C, "APB4LPENR", 0x0021_DEAA, 0x0421_FEAA, 0),
];

/// Which enable bit clocks which block: (block name, enable register,
/// bit). RM0433 §8.7, RCC_AHBxENR and RCC_APBxENR.
#[rustfmt::skip]
pub const ENABLES: &[(&str, u32, u32)] = &[
    ("DMA1", 0xD8, 0), ("DMA2", 0xD8, 1), ("ADC12", 0xD8, 5), ("ADC1", 0xD8, 5),
    ("ETH", 0xD8, 15), ("ETH1MAC", 0xD8, 15), ("ETH1TX", 0xD8, 16), ("ETH1RX", 0xD8, 17),
    ("RNG", 0xDC, 6), ("D2SRAM1", 0xDC, 29), ("D2SRAM2", 0xDC, 30), ("D2SRAM3", 0xDC, 31),
    ("GPIOA", 0xE0, 0), ("GPIOB", 0xE0, 1), ("GPIOC", 0xE0, 2), ("GPIOD", 0xE0, 3),
    ("GPIOE", 0xE0, 4), ("GPIOF", 0xE0, 5), ("GPIOG", 0xE0, 6), ("GPIOH", 0xE0, 7),
    ("GPIOI", 0xE0, 8), ("GPIOJ", 0xE0, 9), ("GPIOK", 0xE0, 10), ("CRC", 0xE0, 19),
    ("BKPRAM", 0xE0, 28), ("TIM2", 0xE8, 0), ("TIM3", 0xE8, 1), ("TIM4", 0xE8, 2),
    ("TIM5", 0xE8, 3), ("TIM12", 0xE8, 6), ("UART4", 0xE8, 19), ("SYSCFG", 0xF4, 1),
];

/// Enable bit, ready bit and start-up time (us) of RCC_CR's oscillators
/// and PLLs: HSI, CSI and HSI48 a few microseconds, HSE, PLL1-3.
#[rustfmt::skip]
const STARTUPS: &[(u32, u32, u64)] = &[
    (HSION, HSIRDY, 4), (CSION, CSIRDY, 2), (HSI48ON, HSI48RDY, 4), (HSEON, HSERDY, HSE_US),
    (PLL1ON, PLL1RDY, PLL_LOCK_US), (26, 27, PLL_LOCK_US), (28, 29, PLL_LOCK_US),
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

    fn on(&self, reg: u32, bit: u32) -> bool {
        self.regs.get(reg) & (1 << bit) != 0
    }

    /// PLLx (x = 0, 1, 2 for PLL1-3) is on or not yet stopped: its
    /// settings may not change (RM0433 §8.7: only with PLLxON and PLLxRDY
    /// clear).
    fn pll_running(&self, x: u32) -> bool {
        self.regs.get(CR) & (3 << (PLL1ON + 2 * x)) != 0
    }

    /// hsi_ck: 64 MHz / 2^HSIDIV.
    fn hsi_hz(&self) -> u64 {
        HSI_HZ >> ((self.regs.get(CR) >> 3) & 3)
    }

    /// The CR enables the hardware will not clear: the system clock's
    /// source, and PLL1's source while PLL1 runs (RM0433 §8.7, RCC_CR).
    fn kept_on(&self, cr: u32) -> u32 {
        const SOURCE: [u32; 4] = [1 << HSION, 1 << CSION, 1 << HSEON, 1 << PLL1ON];
        let sys = SOURCE[((self.regs.get(CFGR) >> 3) & 3) as usize];
        let pll = (self.regs.get(PLLCKSELR) & 3) as usize;
        if (cr | sys) & (1 << PLL1ON) != 0 && pll < 3 {
            sys | SOURCE[pll]
        } else {
            sys
        }
    }

    /// PLLx's VCO frequency, every range checked (RM0433 §8.7 RCC_PLLCKSELR,
    /// RCC_PLLCFGR, RCC_PLLxDIVR; DS12110 "PLL characteristics"); for PLL1
    /// also DIVP1, of which only odd values (even divisions) exist.
    fn pll_vco(&self, x: u32) -> Result<u64, Refusal> {
        let n = x + 1;
        let (sel, cfg) = (self.regs.get(PLLCKSELR), self.regs.get(PLLCFGR));
        // PLLSRC = 3 names no clock: CR bit 31, reserved, reads 0.
        let (src, name, en) = match sel & 3 {
            0 => (self.hsi_hz(), "HSI", HSION),
            1 => (CSI_HZ, "CSI", CSION),
            2 => (HSE_HZ, "HSE", HSEON),
            _ => (0, "no clock", 31),
        };
        let divm = u64::from((sel >> (4 + 8 * x)) & 0x3F);
        let input = src / divm.max(1);
        let rge = (cfg >> (2 + 4 * x)) & 3;
        let (lo, hi) = [(1, 2), (2, 4), (4, 8), (8, 16)][rge as usize];
        let divn = u64::from(self.regs.get(PLL1DIVR + 8 * x) & 0x1FF) + 1;
        let frac = if cfg & (1 << (4 * x)) != 0 {
            u64::from((self.regs.get(PLL1DIVR + 4 + 8 * x) >> 3) & 0x1FFF)
        } else {
            0
        };
        let vco = input * divn + input * frac / 8192;
        let medium = cfg & (1 << (1 + 4 * x)) != 0;
        let divp1 = (self.regs.get(PLL1DIVR) >> 9) & 0x7F;
        let (kind, vlo, vhi) = if medium {
            ("medium", 150, 420)
        } else {
            ("wide", 192, 960)
        };
        let fault = if !self.on(CR, en) {
            format!(
                "RCC_PLLCKSELR: PLL{n} on with its source ({name}, PLLSRC = {}) off",
                sel & 3
            )
        } else if divm == 0 || !(1_000_000..=16_000_000).contains(&input) {
            format!(
                "RCC_PLLCKSELR: DIVM{n} = {divm} gives PLL{n} an input of {} MHz from the {name}, outside 1-16 MHz",
                mhz(input)
            )
        } else if !(lo * 1_000_000..=hi * 1_000_000).contains(&input) {
            format!(
                "RCC_PLLCFGR: PLL{n}RGE = {rge} ({lo}-{hi} MHz) with a PLL{n} input of {} MHz",
                mhz(input)
            )
        } else if !(4..=512).contains(&divn) {
            format!(
                "RCC_PLL{n}DIVR: DIVN{n} = {} (x{divn}), outside x4-x512",
                divn - 1
            )
        } else if !medium && input < 2_000_000 {
            format!(
                "RCC_PLLCFGR: PLL{n}VCOSEL = 0 (wide VCO) with a PLL{n} input of {} MHz: the wide VCO needs 2 MHz or more",
                mhz(input)
            )
        } else if x == 0 && cfg & (1 << 16) != 0 && divp1.is_multiple_of(2) {
            format!(
                "RCC_PLL1DIVR: DIVP1 = {divp1} (/{}): PLL1 P divides by 2, 4 ... 128 only",
                divp1 + 1
            )
        } else if !(vlo * 1_000_000..=vhi * 1_000_000).contains(&vco) {
            format!(
                "RCC_PLL{n}DIVR: DIVN{n} = {} gives a VCO of {} MHz, outside the {kind} VCO's {vlo}-{vhi} MHz (RCC_PLLCFGR PLL{n}VCOSEL = {})",
                divn - 1,
                mhz(vco),
                u32::from(medium)
            )
        } else {
            return Ok(vco);
        };
        Err(format!(
            "{fault} (RM0433 §8.7; DS12110 PLL characteristics)"
        ))
    }

    /// Recomputes the tree into `cx.clocks` and checks it.
    fn update_clocks(&self, cx: &mut Cx) -> Result<(), Refusal> {
        for x in (0..3).filter(|&x| self.on(CR, PLL1ON + 2 * x)) {
            self.pll_vco(x)?;
        }
        let sys = match (self.regs.get(CFGR) >> 3) & 7 {
            0 => self.hsi_hz(),
            1 => CSI_HZ,
            2 => HSE_HZ,
            _ => {
                if !self.on(PLLCFGR, 16) {
                    return Err("RCC_PLLCFGR: DIVP1EN clear while PLL1 P clocks the system".into());
                }
                let divp1 = (self.regs.get(PLL1DIVR) >> 9) & 0x7F;
                self.pll_vco(0)? / u64::from(divp1 + 1)
            }
        };
        let d1 = self.regs.get(D1CFGR);
        let core = sys / ahb_div((d1 >> 8) & 0xF);
        let hclk = core / ahb_div(d1 & 0xF);
        let pclk = |reg: u32, shift: u32| hclk / apb_div((self.regs.get(reg) >> shift) & 7);
        cx.clocks.core_hz = core;
        cx.clocks.hclk_hz = hclk;
        cx.clocks.apb_hz = [
            pclk(D2CFGR, 4),
            pclk(D2CFGR, 8),
            pclk(D1CFGR, 4),
            pclk(D3CFGR, 4),
        ];
        cx.clocks.enabled = ENABLES
            .iter()
            .filter(|(_, r, bit)| self.on(*r, *bit))
            .map(|(name, _, _)| *name)
            .collect();
        super::power::check(cx.clocks)
    }

    /// SWS follows SW once the target clock is ready (RM0433 §8.7, RCC_CFGR).
    fn switch(&mut self) {
        let cfgr = self.regs.get(CFGR);
        let sw = cfgr & 7;
        let rdy = [HSIRDY, CSIRDY, HSERDY, PLL1RDY][sw.min(3) as usize];
        if sw <= 3 && (cfgr >> 3) & 7 != sw && self.on(CR, rdy) {
            self.regs.set(CFGR, (cfgr & !0x38) | (sw << 3));
        }
    }

    /// The rule, if any, a write of `reg` from `old` to `new` breaks.
    fn forbidden(&self, reg: u32, old: u32, new: u32) -> Option<String> {
        let changed = old ^ new;
        let running = |what: &str, x: u32| {
            format!(
                "RCC_{what} written while PLL{0} is on (only with PLL{0}ON and PLL{0}RDY clear)",
                x + 1
            )
        };
        match reg {
            CR if changed & (1 << HSEBYP) != 0 && old & (1 << HSEON) != 0 => {
                Some("RCC_CR: HSEBYP written while HSEON is set (only with the HSE off)".into())
            }
            CFGR if new & 7 > 3 => Some(format!(
                "RCC_CFGR: SW = {} is reserved (0 HSI, 1 CSI, 2 HSE, 3 PLL1)",
                new & 7
            )),
            // PLLxVCOSEL and PLLxRGE; FRACEN and the DIVxEN output enables
            // may change while the PLL runs.
            PLLCFGR => (0..3)
                .find(|&x| self.pll_running(x) && changed & (0xE << (4 * x)) != 0)
                .map(|x| running(&format!("PLLCFGR: PLL{0}VCOSEL or PLL{0}RGE", x + 1), x)),
            0x30 | 0x38 | 0x40 if changed != 0 && self.pll_running((reg - PLL1DIVR) / 8) => {
                let x = (reg - PLL1DIVR) / 8;
                Some(running(&format!("PLL{}DIVR", x + 1), x))
            }
            CIER if new != 0 => {
                Some("RCC_CIER: the clock ready interrupts are not modelled yet".into())
            }
            _ => None,
        }
    }

    fn settle(&mut self, reg: u32, bit: u32, on: bool, at: u64) {
        self.settling.retain(|s| !(s.reg == reg && s.bit == bit));
        self.settling.push(Settle { reg, bit, on, at });
    }

    /// Ready bit `rdy` of `reg` follows enable `en` after `us` (on) or about
    /// a microsecond (off).
    fn follow(&mut self, cx: &Cx, reg: u32, bits: (u32, u32, u64), old: u32, new: u32) {
        let (en, rdy, us) = bits;
        if (old ^ new) & (1 << en) != 0 {
            let on = new & (1 << en) != 0;
            let at = cx.now + cycles(cx, if on { us } else { 1 });
            self.settle(reg, rdy, on, at);
        }
    }
}

impl Default for Rcc {
    fn default() -> Rcc {
        Rcc::new()
    }
}

/// HPRE and D1CPRE: 0xxx /1, 1000-1111 /2, /4, /8, /16, /64, /128, /256,
/// /512 (no /32).
fn ahb_div(v: u32) -> u64 {
    let k = v.saturating_sub(7);
    let shift = if k > 4 { k + 1 } else { k };
    1 << shift
}

/// D1PPRE, D2PPRE1, D2PPRE2, D3PPRE: 0xx /1, 100-111 /2, /4, /8, /16.
fn apb_div(v: u32) -> u64 {
    1 << v.saturating_sub(3)
}

/// Cycles of the core clock in `us` microseconds (at least one; counted
/// at the CSI's 4 MHz at the least).
pub fn cycles(cx: &Cx, us: u64) -> u64 {
    crate::clocks::core_cycles(cx.clocks, CSI_HZ, us)
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
        let reg = offset & !3;
        if let Some(rule) = self.forbidden(reg, old, new) {
            self.regs = before;
            return Err(format!("{rule} (RM0433 §8.7)"));
        }
        match reg {
            CR => {
                let new = new | self.kept_on(new);
                self.regs.set(CR, new);
                for &startup in STARTUPS {
                    if startup.0 != HSEON || self.hse_present || new & (1 << HSEON) == 0 {
                        self.follow(cx, CR, startup, old, new);
                    }
                }
                if (old ^ new) & (3 << 3) != 0 {
                    // HSIDIVF: the new divider reaches hsi_ck a little later.
                    self.regs.set_bits(CR, 1 << HSIDIVF, false);
                    let at = cx.now + cycles(cx, 1);
                    self.settle(CR, HSIDIVF, true, at);
                }
            }
            CFGR => self.switch(),
            PLLCKSELR => {
                let hold = (0..3)
                    .filter(|&x| self.pll_running(x))
                    .fold(0, |hold, x| hold | (0x3F << (4 + 8 * x)) | 3);
                self.regs.set(PLLCKSELR, (new & !hold) | (old & hold));
            }
            CICR => self.regs.set(CICR, 0),
            BDCR if new & (1 << 16) != 0 => {
                // BDRST: the backup domain back to its reset state.
                self.regs.set(BDCR, 1 << 16);
                self.settling.retain(|s| s.reg != BDCR);
            }
            BDCR => self.follow(cx, BDCR, (0, 1, LSE_US), old, new),
            CSR => self.follow(cx, CSR, (0, 1, LSI_US), old, new),
            // RMVF clears every reset flag.
            RSR if new & (1 << 16) != 0 => self.regs.set_bits(RSR, 0x55FA_0000, false),
            _ => {}
        }
        self.update_clocks(cx)
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let (due, pending): (Vec<Settle>, Vec<Settle>) =
            self.settling.drain(..).partition(|s| s.at <= cx.now);
        self.settling = pending;
        for s in due {
            self.regs.set_bits(s.reg, 1 << s.bit, s.on);
        }
        self.switch();
        self.update_clocks(cx)
    }

    /// RCC_RSR's flags (bits 30:17) survive a system reset; only RMVF or a
    /// power-on clears them (RM0433 §8.4.4, §8.7.37).
    fn reset_flags(&self) -> Option<u32> {
        Some(self.regs.get(RSR) & 0x7FFE_0000)
    }

    /// A system reset drives NRST low and resets the CPU (RM0433 §8.4.2,
    /// "reset source identification"): PINRSTF (22) and CPURSTF (17) join
    /// the cause's own flag, SFTRSTF (24) or IWDG1RSTF (26).
    fn keep_reset_flags(&mut self, kept: u32, cause: ResetCause) {
        let own = match cause {
            ResetCause::Software => 1 << 24,
            ResetCause::Watchdog { .. } => 1 << 26,
        };
        let rsr = self.regs.get(RSR) & !0x7FFE_0000;
        self.regs.set(RSR, rsr | kept | own | (1 << 22) | (1 << 17));
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.settling.iter().map(|s| s.at).min()
    }
}
