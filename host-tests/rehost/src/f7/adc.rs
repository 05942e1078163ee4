//! The F767's ADC1 and the common registers (RM0410 rev 5 §15.13): ADON
//! with its stabilisation time (DS11532 tSTAB 3 us), software-started
//! regular conversions (SWSTART, EOC, DR clearing EOC), the board's A0
//! (PA3 = ADC123_IN3) read at half scale, and the ADC clock (PCLK2 /
//! ADCPRE) checked against its 36 MHz limit (DS11532 Table 77, VDDA
//! 2.4-3.6 V).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};

const SR: u32 = 0x00;
const CR2: u32 = 0x08;
const DR: u32 = 0x4C;

const TABLE: &[Reg] = &[
    // rc_w0 flags: the model keeps old & written.
    reg(SR, "SR", 0, 0xFFFF_FFFF, 0),
    reg(0x04, "CR1", 0, 0x07C0_FFFF, 0),
    reg(CR2, "CR2", 0, 0x7F7F_0F03, 0),
    reg(0x0C, "SMPR1", 0, 0x07FF_FFFF, 0),
    reg(0x10, "SMPR2", 0, 0x3FFF_FFFF, 0),
    reg(0x14, "JOFR1", 0, 0x0FFF, 0),
    reg(0x18, "JOFR2", 0, 0x0FFF, 0),
    reg(0x1C, "JOFR3", 0, 0x0FFF, 0),
    reg(0x20, "JOFR4", 0, 0x0FFF, 0),
    reg(0x24, "HTR", 0x0FFF, 0x0FFF, 0),
    reg(0x28, "LTR", 0, 0x0FFF, 0),
    reg(0x2C, "SQR1", 0, 0x00FF_FFFF, 0),
    reg(0x30, "SQR2", 0, 0x3FFF_FFFF, 0),
    reg(0x34, "SQR3", 0, 0x3FFF_FFFF, 0),
    reg(0x38, "JSQR", 0, 0x003F_FFFF, 0),
    reg(DR, "DR", 0, 0, 0xFFFF),
];

/// The common registers (RM0410 §15.13.16-18).
pub const COMMON: &[Reg] = &[
    reg(0x00, "CSR", 0, 0, 0x003F_3F3F),
    reg(0x04, "CCR", 0, 0x00C3_EF1F, 0),
    reg(0x08, "CDR", 0, 0, 0xFFFF_FFFF),
];

/// What the board's A0 reads: half of full scale (12 bits).
pub const A0_VALUE: u32 = 0x800;

pub struct Adc {
    regs: Regs,
    on_at: Option<u64>,
    eoc_at: Option<u64>,
}

impl Adc {
    pub fn new() -> Adc {
        Adc {
            regs: Regs::new(TABLE),
            on_at: None,
            eoc_at: None,
        }
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
            self.regs.set_bits(SR, 1 << 1, false);
            return Ok(A0_VALUE);
        }
        self.regs.read("ADC1", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let old_sr = self.regs.get(SR);
        let (old, new) = self.regs.write("ADC1", offset, size, value)?;
        match offset & !3 {
            SR => self.regs.set(SR, old_sr & new & 0x3F),
            CR2 => {
                let set = new & !old;
                let us = (cx.clocks.core_hz / 1_000_000).max(1);
                if set & 1 != 0 {
                    self.on_at = Some(cx.now + 3 * us);
                }
                if new & 1 == 0 {
                    self.on_at = None;
                }
                if new & (1 << 30) != 0 {
                    if new & 1 == 0 {
                        return Err(
                            "ADC1_CR2: SWSTART with ADON clear: no conversion starts".into()
                        );
                    }
                    if self.on_at.is_some_and(|t| cx.now < t) {
                        return Err("ADC1_CR2: SWSTART within tSTAB (3 us) of ADON: the result is not valid (DS11532)".into());
                    }
                    // SWSTART clears itself as the conversion starts, and
                    // SR.STRT says it started (RM0410 §15.13.1).
                    self.regs.set_bits(CR2, 1 << 30, false);
                    self.regs.set_bits(SR, 1 << 4, true);
                    self.eoc_at = Some(cx.now + us);
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.eoc_at.is_some_and(|t| cx.now >= t) {
            self.eoc_at = None;
            self.regs.set_bits(SR, 1 << 1, true);
        }
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.eoc_at
    }
}

/// The ADC clock: PCLK2 / ADCPRE (CCR[17:16]: /2, /4, /6, /8) at most
/// 36 MHz.
pub struct Common {
    regs: Regs,
}

impl Common {
    pub fn new() -> Common {
        Common {
            regs: Regs::new(COMMON),
        }
    }
}

impl Default for Common {
    fn default() -> Common {
        Common::new()
    }
}

impl Peripheral for Common {
    fn name(&self) -> &'static str {
        "ADC_COMMON"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read("ADC_COMMON", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let (_, new) = self.regs.write("ADC_COMMON", offset, size, value)?;
        if offset & !3 == 0x04 {
            let div = 2 * (u64::from((new >> 16) & 3) + 1);
            let adc = cx.clocks.apb_hz[1] / div;
            if adc > 36_000_000 {
                return Err(format!(
                    "ADC_CCR: ADCPRE /{div} gives an ADC clock of {} MHz from PCLK2 {} MHz, above 36 MHz (DS11532 Table 77)",
                    crate::clocks::mhz(adc),
                    crate::clocks::mhz(cx.clocks.apb_hz[1])
                ));
            }
        }
        Ok(())
    }
}
