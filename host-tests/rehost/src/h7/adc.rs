//! The H743's ADC1 and the ADC12 common registers (RM0433 rev 8 §25.6-
//! 25.7): deep power-down and the voltage regulator (ADVREGEN with
//! LDORDY after its start-up time, DS12110 tADCVREG_STUP 10 us),
//! calibration (ADCAL clears itself), enable (ADRDY), and regular
//! conversions whose data is the board's analog input (A0, PA3 = channel
//! 15) at half scale. Starting the ADC in the wrong state stops the run
//! (RM0433 §25.4.6-25.4.9 say what each bit needs first).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};

const ISR: u32 = 0x00;
const CR: u32 = 0x08;
const DR: u32 = 0x40;

const ADEN: u32 = 1 << 0;
const ADDIS: u32 = 1 << 1;
const ADSTART: u32 = 1 << 2;
const ADVREGEN: u32 = 1 << 28;
const DEEPPWD: u32 = 1 << 29;
const ADCAL: u32 = 1 << 31;

const TABLE: &[Reg] = &[
    reg(ISR, "ISR", 0, 0x0000_07FF, 0x0000_1000),
    reg(0x04, "IER", 0, 0x0000_07FF, 0),
    reg(CR, "CR", 0x2000_0000, 0xF0C1_033F, 0x0FC0_0000),
    reg(0x0C, "CFGR", 0x8000_0000, 0xFFFF_FFFF, 0),
    reg(0x10, "CFGR2", 0, 0x03FF_07FF, 0),
    reg(0x14, "SMPR1", 0, 0x3FFF_FFFF, 0),
    reg(0x18, "SMPR2", 0, 0x3FFF_FFFF, 0),
    reg(0x1C, "PCSEL", 0, 0x000F_FFFF, 0),
    reg(0x20, "LTR1", 0, 0x03FF_FFFF, 0),
    reg(0x24, "HTR1", 0x03FF_FFFF, 0x03FF_FFFF, 0),
    reg(0x30, "SQR1", 0, 0x1F7D_F7CF, 0),
    reg(0x34, "SQR2", 0, 0x1F7D_F7DF, 0),
    reg(0x38, "SQR3", 0, 0x1F7D_F7DF, 0),
    reg(0x3C, "SQR4", 0, 0x0000_07DF, 0),
    reg(DR, "DR", 0, 0, 0xFFFF_FFFF),
    reg(0x4C, "JSQR", 0, 0xFFFF_FFFF, 0),
    reg(0xC0, "DIFSEL", 0, 0x000F_FFFF, 0),
    reg(0xC4, "CALFACT", 0, 0x07FF_07FF, 0),
    reg(0xC8, "CALFACT2", 0, 0x3FFF_FFFF, 0),
];

/// What the board's A0 reads: half of full scale (16 bits).
pub const A0_VALUE: u32 = 0x8000;

pub struct Adc {
    regs: Regs,
    /// Enabled and ready (ADRDY has risen since ADEN; software may clear
    /// the flag, the state stays).
    ready: bool,
    /// Pending completions: (when, ISR bits to set, CR bits to clear).
    due: Vec<(u64, u32, u32)>,
}

impl Adc {
    pub fn new() -> Adc {
        Adc {
            regs: Regs::new(TABLE),
            ready: false,
            due: Vec::new(),
        }
    }

    fn after(&mut self, cx: &Cx, us: u64, set_isr: u32, clear_cr: u32) {
        let at = cx.now + (cx.clocks.core_hz / 1_000_000).max(1) * us;
        self.due.push((at, set_isr, clear_cr));
    }
}

impl Default for Adc {
    fn default() -> Adc {
        Adc::new()
    }
}

impl Peripheral for Adc {
    fn name(&self) -> &'static str {
        "ADC1"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        if offset & !3 == DR {
            // Reading DR clears EOC.
            self.regs.set_bits(ISR, 1 << 2, false);
            return Ok(A0_VALUE);
        }
        self.regs.read("ADC1", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let old_isr = self.regs.get(ISR);
        let (old, new) = self.regs.write("ADC1", offset, size, value)?;
        match offset & !3 {
            // rc_w1: writing 1 clears the flag.
            ISR => self.regs.set(ISR, old_isr & !value),
            CR => {
                let set = new & !old;
                if set & ADVREGEN != 0 {
                    if new & DEEPPWD != 0 {
                        return Err("ADC1_CR: ADVREGEN set while DEEPPWD is set (RM0433 §25.4.6: leave deep power-down first)".into());
                    }
                    self.after(cx, 10, 1 << 12, 0);
                }
                if set & ADCAL != 0 {
                    if new & ADEN != 0 {
                        return Err("ADC1_CR: ADCAL set while the ADC is enabled (RM0433 §25.4.8: ADEN must be 0)".into());
                    }
                    if new & ADVREGEN == 0 {
                        return Err("ADC1_CR: ADCAL set with the voltage regulator off".into());
                    }
                    self.after(cx, 50, 0, ADCAL);
                }
                if set & ADEN != 0 {
                    if new & ADVREGEN == 0 || new & DEEPPWD != 0 {
                        return Err("ADC1_CR: ADEN set with the ADC's voltage regulator off or in deep power-down (RM0433 §25.4.9)".into());
                    }
                    self.after(cx, 2, 1, 0);
                }
                if set & ADDIS != 0 {
                    self.regs.set_bits(CR, ADEN | ADDIS, false);
                    self.regs.set_bits(ISR, 1, false);
                    self.ready = false;
                }
                if set & ADSTART != 0 {
                    if !self.ready {
                        return Err("ADC1_CR: ADSTART set before ADRDY (RM0433 §25.4.9)".into());
                    }
                    // One conversion: EOC and EOS, ADSTART clears.
                    self.after(cx, 1, (1 << 2) | (1 << 3), ADSTART);
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let now = cx.now;
        let due: Vec<_> = self.due.iter().copied().filter(|d| d.0 <= now).collect();
        self.due.retain(|d| d.0 > now);
        for (_, isr, cr) in due {
            if isr & 1 != 0 {
                self.ready = true;
            }
            self.regs.set_bits(ISR, isr, true);
            self.regs.set_bits(CR, cr, false);
        }
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.due.iter().map(|d| d.0).min()
    }
}

/// The ADC12 common registers (RM0433 §25.7): CCR's clock mode and
/// prescaler are kept.
pub const COMMON: &[Reg] = &[
    reg(0x00, "CSR", 0, 0, 0x07FF_07FF),
    reg(0x08, "CCR", 0, 0x01FF_CFFF, 0),
    reg(0x0C, "CDR", 0, 0, 0xFFFF_FFFF),
];
