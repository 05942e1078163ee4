//! STM32H743 power control (PWR, RM0433 rev 8 §6; registers §6.8) and the
//! flash interface's wait-state rules (FLASH_ACR, RM0433 §4.9; its
//! registers: `flash.rs`).
//!
//! PWR sets the limits the clock tree is checked against (DS12110 Table 23,
//! "General operating conditions"): the core clock (sys_ck / D1CPRE), the
//! AXI/AHB clock and every APB clock at most 400, 200 and 100 MHz in
//! voltage scale 1, 300, 150 and 75 in scale 2, 200, 100 and 50 in scale 3.
//! VOS0 (480, 240, 120) needs SYSCFG_PWRCR ODEN, which is not modelled here:
//! it is never reached. The scale in force is the lower of the one PWR_D3CR
//! VOS asks for and the one the regulator has reached (VOSRDY; PWR_CSR1
//! ACTVOS), so a clock raised before VOSRDY stops the run.
//!
//! FLASH's wait states (LATENCY) and programming delay (WRHIGHFREQ) follow
//! RM0433 Table 17 for the AXI clock in the scale in force.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};
use crate::clocks::{mhz, Clocks, Limits};

const CSR1: u32 = 0x04;
const CR2: u32 = 0x08;
const CR3: u32 = 0x0C;
const CPUCR: u32 = 0x10;
const D3CR: u32 = 0x18;
const WKUPCR: u32 = 0x20;
/// The regulator's settling after a VOS change (us): DS12110 gives no
/// figure; a few microseconds, modelled as 10.
pub const VOS_US: u64 = 10;

/// RM0433 §6.8: the fields of ST's STM32H743 SVD. CR3 resets to the LDO
/// supply (LDOEN, SCUEN). CSR1 and D3CR read the reset scale (VOS3, 01)
/// reached: ACTVOSRDY and VOSRDY set ("following reset VOSRDY will be read
/// 1 by software", the SVD's note on D3CR; the default LDO supply is valid).
const PWR_TABLE: &[Reg] = &[
    reg(0x00, "CR1", 0xF000_C000, 0x0007_C3F1, 0),
    reg(CSR1, "CSR1", 0x0000_6000, 0, 0x0001_E010),
    reg(CR2, "CR2", 0, 0x0000_0011, 0x00F1_0000),
    reg(CR3, "CR3", 0x0000_0006, 0x0300_0307, 0x0400_0000),
    reg(CPUCR, "CPUCR", 0, 0x0000_0A07, 0x0000_01E0),
    reg(D3CR, "D3CR", 0x0000_6000, 0x0000_C000, 0x0000_2000),
    reg(WKUPCR, "WKUPCR", 0, 0x0000_003F, 0),
    reg(0x24, "WKUPFR", 0, 0, 0x0000_003F),
    reg(0x28, "WKUPEPR", 0, 0x0FFF_3F3F, 0),
];

/// RM0433 Table 17, scale 1: the fewest wait states for the AXI clock.
pub fn min_latency_vos1(hclk: u64) -> u32 {
    row(hclk, &[70, 140, 210, 225])
}

/// RM0433 Table 17, scale 2.
pub fn min_latency_vos2(hclk: u64) -> u32 {
    row(hclk, &[55, 110, 165, 225])
}

/// RM0433 Table 17, scale 3.
pub fn min_latency_vos3(hclk: u64) -> u32 {
    row(hclk, &[45, 90, 135, 180, 225])
}

/// RM0433 Table 17: the smallest FLASH_ACR WRHIGHFREQ for the AXI clock in
/// scale `vos` (as PWR_D3CR VOS: 3 scale 1, 2 scale 2, 1 scale 3). In
/// scale 1, 2 wait states take WRHIGHFREQ 1 up to 185 MHz, 2 above.
pub fn min_wrhighfreq(vos: u32, hclk: u64) -> u32 {
    match vos {
        3 => row(hclk, &[70, 185]),
        2 => row(hclk, &[55, 165]),
        _ => row(hclk, &[45, 135]),
    }
}

/// The row of a table whose rows end at `bounds` (MHz) that `hz` falls in.
fn row(hz: u64, bounds: &[u64]) -> u32 {
    bounds.iter().filter(|&&b| hz > b * 1_000_000).count() as u32
}

/// The limits in scale `vos` (as PWR_D3CR VOS; 0, reserved, is taken as
/// scale 3): DS12110 Table 23 but for the APB clocks in scale 3, which the
/// chip itself leaves reset at: every APB at the HSI's 64 MHz (RM0433 §8:
/// sys_ck = HSI, every prescaler /1), above the table's 50 MHz. The reset
/// HSI is the limit there, so that the reset state is not a violation.
pub fn limits(vos: u32) -> Limits {
    let (core, hclk, apb) = match vos {
        3 => (400, 200, 100),
        2 => (300, 150, 75),
        _ => (200, 100, 64),
    };
    let min_latency: fn(u64) -> u32 = match vos {
        3 => min_latency_vos1,
        2 => min_latency_vos2,
        _ => min_latency_vos3,
    };
    Limits {
        core_hz: core * 1_000_000,
        hclk_hz: hclk * 1_000_000,
        apb_hz: [apb * 1_000_000; 4],
        min_latency: Some(min_latency),
        label: match vos {
            3 => "in voltage scale 1 (DS12110 Table 23, RM0433 Table 17)",
            2 => "in voltage scale 2 (DS12110 Table 23, RM0433 Table 17)",
            _ => "in voltage scale 3 (DS12110 Table 23, RM0433 Table 17)",
        },
    }
}

/// RM0433 Table 17: FLASH_ACR WRHIGHFREQ at least the table's value for the
/// AXI clock in scale `vos` (as PWR_D3CR VOS: 3 is scale 1, 1 scale 3).
pub fn check_wrhighfreq(clocks: &Clocks, vos: u32) -> Result<(), String> {
    let need = min_wrhighfreq(vos, clocks.hclk_hz);
    if clocks.flash_wrhighfreq < need {
        return Err(format!(
            "FLASH_ACR WRHIGHFREQ is {} with the AXI clock at {} MHz in voltage scale {}: RM0433 Table 17 asks for at least {need}",
            clocks.flash_wrhighfreq,
            mhz(clocks.hclk_hz),
            4 - vos.clamp(1, 3)
        ));
    }
    Ok(())
}

/// Every limit, and the flash's programming delay in the scale the limits
/// are for: what RCC, PWR and FLASH check after every write.
pub fn check(clocks: &Clocks) -> Result<(), String> {
    clocks.check()?;
    match clocks.limits.core_hz / 1_000_000 {
        0 => Ok(()),
        400 => check_wrhighfreq(clocks, 3),
        300 => check_wrhighfreq(clocks, 2),
        _ => check_wrhighfreq(clocks, 1),
    }
}

pub struct Pwr {
    regs: Regs,
    /// When the regulator reaches the scale PWR_D3CR VOS asks for.
    vos_ready_at: Option<u64>,
    /// PWR_CR3's supply configuration (its lower byte) has been written:
    /// once after power-on, then it is locked (RM0433 §6.8, PWR_CR3).
    supply_written: bool,
}

impl Pwr {
    pub fn new() -> Pwr {
        Pwr {
            regs: Regs::new(PWR_TABLE),
            vos_ready_at: None,
            supply_written: false,
        }
    }

    /// The scale in force (as PWR_D3CR VOS): the lower of the one asked for
    /// and the one reached.
    fn vos(&self) -> u32 {
        let asked = (self.regs.get(D3CR) >> 14) & 3;
        let reached = (self.regs.get(CSR1) >> 14) & 3;
        asked.min(reached).max(1)
    }

    /// The rule, if any, a write from `old` to `new` breaks.
    fn forbidden(&self, offset: u32, old: u32, new: u32) -> Option<String> {
        let low_byte = offset & 3 == 0;
        match offset & !3 {
            CR3 if low_byte && self.supply_written && (old ^ new) & 7 != 0 => Some(
                "PWR_CR3: the supply configuration changed a second time: it is written once after power-on, then locked (RM0433 §6.8; silicon ignores the change)".into(),
            ),
            // The NUCLEO-H743ZI supplies VCORE from the LDO.
            CR3 if low_byte && new & 3 != 2 => Some(format!(
                "PWR_CR3: BYPASS = {}, LDOEN = {}: the board's VCORE comes from the LDO (LDOEN 1, BYPASS 0; RM0433 §6.4)",
                new & 1,
                (new >> 1) & 1
            )),
            D3CR if old != new && !self.supply_written => Some(
                "PWR_D3CR: VOS changed before the supply configuration was written to PWR_CR3 (RM0433 §6.4.1: VOS may change only once the supply is configured)".into(),
            ),
            _ => None,
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
        let before = self.regs.clone();
        let (old, new) = self.regs.write("PWR", offset, size, value)?;
        if let Some(rule) = self.forbidden(offset, old, new) {
            self.regs = before;
            return Err(rule);
        }
        match offset & !3 {
            CR3 => {
                self.supply_written |= offset & 3 == 0;
                // USB33RDY: the board supplies VDD33USB.
                self.regs.set_bits(CR3, 1 << 26, new & (1 << 24) != 0);
            }
            D3CR if old != new => {
                // VOSRDY falls until the regulator reaches the new scale.
                self.regs.set_bits(D3CR, 1 << 13, false);
                // Counted at no less than the CSI's 4 MHz (RM0433 §8.5.3),
                // as every wait of the H7's models.
                self.vos_ready_at =
                    Some(cx.now + crate::clocks::core_cycles(cx.clocks, 4_000_000, VOS_US));
            }
            // BRRDY follows BREN (the backup regulator's start-up is not
            // modelled).
            CR2 => self.regs.set_bits(CR2, 1 << 16, new & 1 != 0),
            // CSSF reads 0; the flags it clears are never set here.
            CPUCR => self.regs.set(CPUCR, new & !(1 << 9)),
            // WKUPC reads 0; no wake-up flag is ever set here.
            WKUPCR => self.regs.set(WKUPCR, 0),
            _ => {}
        }
        cx.clocks.limits = limits(self.vos());
        check(cx.clocks)
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.vos_ready_at.is_some_and(|at| cx.now >= at) {
            // ACTVOS takes the scale asked for; VOSRDY rises.
            let csr1 = (self.regs.get(CSR1) & !(3 << 14)) | (self.regs.get(D3CR) & (3 << 14));
            self.regs.set(CSR1, csr1);
            self.regs.set_bits(D3CR, 1 << 13, true);
            self.vos_ready_at = None;
        }
        cx.clocks.limits = limits(self.vos());
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.vos_ready_at
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::h7::rcc::Rcc;
    use crate::h7::testing::{access, start_pll1, to_pll1, us};

    #[test]
    fn a_scale_is_in_force_only_once_vosrdy() {
        let (_, mut c) = crate::h7::bus();
        let mut pwr = Pwr::new();
        let e = access(&mut pwr, &mut c, 0, D3CR, Some(0xC000)).unwrap_err();
        assert!(e.contains("before the supply configuration"), "{e}");
        access(&mut pwr, &mut c, 0, CR3, Some(0x06)).unwrap();
        access(&mut pwr, &mut c, 0, D3CR, Some(0xC000)).unwrap();
        let d3cr = access(&mut pwr, &mut c, us(VOS_US) - 1, D3CR, None).unwrap();
        assert_eq!((d3cr & (1 << 13), c.limits.core_hz), (0, 200_000_000));
        let d3cr = access(&mut pwr, &mut c, us(VOS_US), D3CR, None).unwrap();
        assert_eq!((d3cr & (1 << 13), c.limits.core_hz), (1 << 13, 400_000_000));
        let e = access(&mut pwr, &mut c, us(VOS_US), CR3, Some(0x02)).unwrap_err();
        assert!(e.contains("second time"), "{e}");
    }

    /// Scale 1, FLASH_ACR = `acr`, then PLL1 P (400 MHz) as the system
    /// clock with the AXI clock at 200 MHz and every APB at 100.
    fn at_400_mhz(acr: u32) -> Result<Clocks, Refusal> {
        let (_, mut c) = crate::h7::bus();
        let (mut pwr, mut flash, mut rcc) =
            (Pwr::new(), crate::h7::flash::Flash::new(), Rcc::new());
        access(&mut pwr, &mut c, 0, CR3, Some(0x06))?;
        access(&mut pwr, &mut c, 0, D3CR, Some(0xC000))?;
        access(&mut pwr, &mut c, us(VOS_US), D3CR, None)?;
        access(&mut flash, &mut c, us(VOS_US), 0, Some(acr))?;
        let locked = start_pll1(&mut rcc, &mut c, us(VOS_US), 399, 0)?;
        to_pll1(&mut rcc, &mut c, locked)?;
        Ok(c)
    }

    #[test]
    fn flash_settings_below_rm0433_table_17_are_refused_at_400_mhz() {
        let c = at_400_mhz(0x22).unwrap();
        let hz = (c.core_hz, c.hclk_hz, c.apb_hz);
        assert_eq!(hz, (400_000_000, 200_000_000, [100_000_000; 4]));
        // One wait state below the table.
        let e = at_400_mhz(0x21).unwrap_err();
        assert!(
            e.contains("LATENCY is 1") && e.contains("at least 2"),
            "{e}"
        );
        let e = at_400_mhz(0x12).unwrap_err();
        assert!(e.contains("WRHIGHFREQ is 1"), "{e}");
    }

    #[test]
    fn the_latency_tables_rows() {
        assert_eq!(min_latency_vos1(64_000_000), 0);
        assert_eq!(min_latency_vos1(200_000_000), 2);
        assert_eq!(min_latency_vos3(64_000_000), 1);
        assert_eq!(min_wrhighfreq(3, 185_000_000), 1);
        assert_eq!(min_wrhighfreq(3, 200_000_000), 2);
    }
}
