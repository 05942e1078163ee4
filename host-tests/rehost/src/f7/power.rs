//! STM32F76x/77x power control (PWR, RM0410 rev 5 §4.4); the flash
//! interface's wait-state table (its registers: `flash.rs`).
//!
//! PWR sets the limits the clock tree is checked against (DS11532
//! Table 17, "General operating conditions", VDD 2.7-3.6 V): HCLK 144 MHz
//! in scale 3, 168 (180 with over-drive) in scale 2, 180 (216 with
//! over-drive) in scale 1; PCLK1 45 MHz and PCLK2 90 MHz, 54 and 108 with
//! over-drive. FLASH's wait states follow RM0410 Table 7 (2.7-3.6 V):
//! one more for every 30 MHz of HCLK.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};
use crate::clocks::Limits;

const CR1: u32 = 0x00;
const CSR1: u32 = 0x04;

const PWR_TABLE: &[Reg] = &[
    reg(CR1, "CR1", 0x0000_C000, 0x000F_EFFB, 0),
    reg(CSR1, "CSR1", 0x0000_0000, 0x0000_0300, 0x000F_400F),
    reg(0x08, "CR2", 0, 0x0000_3F3F, 0),
    reg(0x0C, "CSR2", 0, 0x0000_3F00, 0x0000_003F),
];

/// RM0410 Table 7 (2.7-3.6 V): the fewest wait states for HCLK.
pub fn min_latency(hclk: u64) -> u32 {
    (hclk.saturating_sub(1) / 30_000_000) as u32
}

pub struct Pwr {
    regs: Regs,
    /// Over-drive ready (ODRDY) and switched (ODSWRDY), and when.
    od_ready_at: Option<u64>,
    odsw_ready_at: Option<u64>,
}

impl Pwr {
    pub fn new() -> Pwr {
        Pwr {
            regs: Regs::new(PWR_TABLE),
            od_ready_at: None,
            odsw_ready_at: None,
        }
    }

    fn limits(&self) -> Limits {
        let cr1 = self.regs.get(CR1);
        let od = self.regs.get(CSR1) & (1 << 17) != 0;
        let (hclk, label) = match ((cr1 >> 14) & 3, od) {
            (3, true) => (216, "in voltage scale 1 with over-drive"),
            (3, false) => (
                180,
                "in voltage scale 1 without over-drive (216 MHz needs it)",
            ),
            (2, true) => (180, "in voltage scale 2 with over-drive"),
            (2, false) => (168, "in voltage scale 2"),
            _ => (144, "in voltage scale 3"),
        };
        let (p1, p2) = if od { (54, 108) } else { (45, 90) };
        Limits {
            core_hz: hclk * 1_000_000,
            hclk_hz: hclk * 1_000_000,
            apb_hz: [p1 * 1_000_000, p2 * 1_000_000, 0, 0],
            min_latency: Some(min_latency),
            label,
        }
    }
}

impl Default for Pwr {
    fn default() -> Pwr {
        Pwr::new()
    }
}

impl Peripheral for Pwr {
    fn name(&self) -> &'static str {
        "PWR"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read("PWR", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let (old, new) = self.regs.write("PWR", offset, size, value)?;
        if offset & !3 == CR1 {
            let changed = old ^ new;
            // RM0410 §4.1.4: ODEN, then wait ODRDY, then ODSWEN; the
            // over-drive is entered with the system clock from HSI or HSE.
            if changed & (1 << 16) != 0 && new & (1 << 16) != 0 {
                // tOD_swen: about 100 us.
                self.od_ready_at = Some(cx.now + cx.clocks.core_hz.max(16_000_000) / 10_000);
            }
            if changed & (1 << 17) != 0 && new & (1 << 17) != 0 {
                if self.regs.get(CSR1) & (1 << 16) == 0 {
                    return Err("PWR_CR1: ODSWEN set before ODRDY (RM0410 §4.1.4: wait for the over-drive to be ready)".into());
                }
                self.odsw_ready_at = Some(cx.now + cx.clocks.core_hz.max(16_000_000) / 20_000);
            }
            if changed & (3 << 14) != 0 && new & (3 << 14) != 0 {
                // VOSRDY: the scale is reached.
                self.regs.set_bits(CSR1, 1 << 14, true);
            }
        }
        cx.clocks.limits = self.limits();
        cx.clocks.check()
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if let Some(at) = self.od_ready_at {
            if cx.now >= at {
                self.regs.set_bits(CSR1, 1 << 16, true);
                self.od_ready_at = None;
            }
        }
        if let Some(at) = self.odsw_ready_at {
            if cx.now >= at {
                self.regs.set_bits(CSR1, 1 << 17, true);
                self.odsw_ready_at = None;
            }
        }
        cx.clocks.limits = self.limits();
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.od_ready_at.into_iter().chain(self.odsw_ready_at).min()
    }
}
