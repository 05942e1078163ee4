//! A general-purpose timer counting up (RM0410 §25/§26, RM0433 §38/§39:
//! TIMx_CR1 CEN, PSC, ARR, CNT, the capture/compare registers, SR's UIF
//! and CCxIF, DIER): the counter runs from virtual time at the timer's
//! clock (its APB clock, doubled when the APB prescaler divides, RM0410
//! §5.2 "timer clocks"), its flags rise at the update and the compares,
//! and an enabled flag raises the timer's interrupt line. Writes to
//! reserved offsets or bits stop the run.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};

const CR1: u32 = 0x00;
const DIER: u32 = 0x0C;
const SR: u32 = 0x10;
const EGR: u32 = 0x14;
const CNT: u32 = 0x24;
const PSC: u32 = 0x28;
const ARR: u32 = 0x2C;
const CCR1: u32 = 0x34;

/// TIM2-TIM5's registers (32-bit counter on TIM2/TIM5; RM0410 §25.4).
pub const TIM2_5: &[Reg] = &[
    reg(CR1, "CR1", 0, 0x0000_0BFF, 0),
    reg(0x04, "CR2", 0, 0x0000_00F8, 0),
    reg(0x08, "SMCR", 0, 0x0001_FFF7, 0),
    reg(DIER, "DIER", 0, 0x0000_5F5F, 0),
    // rc_w0: software writes 0 to clear a flag and 1 elsewhere (the whole
    // word, reserved bits included, is the usual `!flag`): the model keeps
    // old & written for the defined bits, ignores the rest.
    reg(SR, "SR", 0, 0xFFFF_FFFF, 0),
    reg(EGR, "EGR", 0, 0x0000_005F, 0),
    reg(0x18, "CCMR1", 0, 0x0107_FFFF, 0),
    reg(0x1C, "CCMR2", 0, 0x0107_FFFF, 0),
    reg(0x20, "CCER", 0, 0x0000_BBBB, 0),
    reg(CNT, "CNT", 0, 0xFFFF_FFFF, 0),
    reg(PSC, "PSC", 0, 0x0000_FFFF, 0),
    reg(ARR, "ARR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(CCR1, "CCR1", 0, 0xFFFF_FFFF, 0),
    reg(0x38, "CCR2", 0, 0xFFFF_FFFF, 0),
    reg(0x3C, "CCR3", 0, 0xFFFF_FFFF, 0),
    reg(0x40, "CCR4", 0, 0xFFFF_FFFF, 0),
    reg(0x48, "DCR", 0, 0x0000_1F1F, 0),
    reg(0x4C, "DMAR", 0, 0xFFFF_FFFF, 0),
    reg(0x50, "OR", 0, 0x0000_0CC0, 0),
];

/// TIM9/TIM12's registers (16-bit counter, two channels; RM0410 §26.4).
pub const TIM9_12: &[Reg] = &[
    reg(CR1, "CR1", 0, 0x0000_0B8F, 0),
    reg(0x08, "SMCR", 0, 0x0001_00F7, 0),
    reg(DIER, "DIER", 0, 0x0000_0047, 0),
    reg(SR, "SR", 0, 0xFFFF_FFFF, 0),
    reg(EGR, "EGR", 0, 0x0000_0047, 0),
    reg(0x18, "CCMR1", 0, 0x0107_FFFF, 0),
    reg(0x20, "CCER", 0, 0x0000_00BB, 0),
    reg(CNT, "CNT", 0, 0x0000_FFFF, 0),
    reg(PSC, "PSC", 0, 0x0000_FFFF, 0),
    reg(ARR, "ARR", 0x0000_FFFF, 0x0000_FFFF, 0),
    reg(CCR1, "CCR1", 0, 0x0000_FFFF, 0),
    reg(0x38, "CCR2", 0, 0x0000_FFFF, 0),
];

pub struct Timer {
    name: &'static str,
    regs: Regs,
    /// The NVIC line its flags raise.
    irq: u32,
    /// Which APB clock drives it (0 = APB1) and whether its counter is
    /// 32 bits wide.
    apb: usize,
    /// Core cycle at which the counter last held `base_cnt` (while CEN).
    since: u64,
    base_cnt: u64,
    /// Counter ticks since the timer started, at `since`.
    ticks: u64,
}

impl Timer {
    pub fn new(name: &'static str, table: &'static [Reg], irq: u32, apb: usize) -> Timer {
        Timer {
            name,
            regs: Regs::new(table),
            irq,
            apb,
            since: 0,
            base_cnt: 0,
            ticks: 0,
        }
    }

    /// Timer ticks per core cycle, as a ratio (numerator, denominator).
    fn rate(&self, cx: &Cx) -> (u64, u64) {
        let apb = cx.clocks.apb_hz.get(self.apb).copied().unwrap_or(0).max(1);
        // x2 when the APB is divided from HCLK.
        let tim = if apb < cx.clocks.hclk_hz {
            apb * 2
        } else {
            apb
        };
        let psc = u64::from(self.regs.get(PSC)) + 1;
        (tim, cx.clocks.core_hz.max(1) * psc)
    }

    /// Brings CNT and the flags up to `cx.now`.
    fn catch_up(&mut self, cx: &mut Cx) {
        if self.regs.get(CR1) & 1 == 0 {
            self.since = cx.now;
            return;
        }
        let (num, den) = self.rate(cx);
        let total = (cx.now - self.since) * num / den;
        if total == self.ticks {
            return;
        }
        let arr = u64::from(self.regs.get(ARR)).max(1) + 1;
        let before = self.base_cnt + self.ticks;
        let after = self.base_cnt + total;
        let mut sr = self.regs.get(SR);
        if after / arr > before / arr {
            sr |= 1; // UIF
        }
        for ch in 0..4u32 {
            let Some(r) = self.regs.table.iter().find(|r| r.offset == CCR1 + 4 * ch) else {
                continue;
            };
            let ccr = u64::from(self.regs.get(r.offset));
            // Crossed the compare value in this stretch (modulo ARR+1).
            let crossed = (before..after).contains(&(before - before % arr + ccr))
                || (before..after).contains(&(before - before % arr + arr + ccr));
            if crossed {
                sr |= 1 << (ch + 1);
            }
        }
        self.regs.set(SR, sr);
        self.regs.set(CNT, (after % arr) as u32);
        self.ticks = total;
        if self.regs.get(DIER) & sr & 0x1F != 0 {
            cx.raise.push(self.irq);
        }
    }
}

impl Peripheral for Timer {
    fn name(&self) -> &'static str {
        self.name
    }

    fn read(&mut self, offset: u32, size: u32, cx: &mut Cx) -> Result<u32, Refusal> {
        self.catch_up(cx);
        self.regs.read(self.name, offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        self.catch_up(cx);
        let old_sr = self.regs.get(SR);
        let (_, new) = self.regs.write(self.name, offset, size, value)?;
        match offset & !3 {
            // rc_w0: writing 0 clears a flag, 1 leaves it.
            SR => self.regs.set(SR, old_sr & new & 0x0000_1E5F),
            EGR => {
                if new & 1 != 0 {
                    // UG: the counter restarts, the prescaler reloads.
                    self.base_cnt = 0;
                    self.ticks = 0;
                    self.since = cx.now;
                    self.regs.set(CNT, 0);
                }
                self.regs.set(EGR, 0);
            }
            CNT | CR1 | PSC | ARR => {
                self.base_cnt = u64::from(self.regs.get(CNT));
                self.ticks = 0;
                self.since = cx.now;
            }
            _ => {}
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        self.catch_up(cx);
        Ok(())
    }
}
