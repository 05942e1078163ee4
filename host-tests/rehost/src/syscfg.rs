//! System configuration (SYSCFG): the Ethernet interface selection (F7:
//! PMC.MII_RMII_SEL, RM0410 rev 5 §7.2.2; H7: PMCR.EPIS, RM0433 rev 8
//! §12.3.2) that the wiring records, and the I/O compensation cell whose
//! READY rises a short time after it is enabled (RM0410 §7.2.8 CMPCR,
//! RM0433 §12.3.8 CCCSR).

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};

/// Which chip's SYSCFG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    F7,
    H7,
}

const F7_TABLE: &[Reg] = &[
    reg(0x00, "MEMRMP", 0, 0x0000_0E01, 0),
    reg(0x04, "PMC", 0, 0x0087_0000, 0),
    reg(0x08, "EXTICR1", 0, 0x0000_FFFF, 0),
    reg(0x0C, "EXTICR2", 0, 0x0000_FFFF, 0),
    reg(0x10, "EXTICR3", 0, 0x0000_FFFF, 0),
    reg(0x14, "EXTICR4", 0, 0x0000_FFFF, 0),
    reg(0x1C, "CBR", 0, 0x0000_0003, 0),
    reg(0x20, "CMPCR", 0, 0x0000_0001, 0x0000_0100),
];

const H7_TABLE: &[Reg] = &[
    reg(0x04, "PMCR", 0, 0x0FE0_F1FF, 0),
    reg(0x08, "EXTICR1", 0, 0x0000_FFFF, 0),
    reg(0x0C, "EXTICR2", 0, 0x0000_FFFF, 0),
    reg(0x10, "EXTICR3", 0, 0x0000_FFFF, 0),
    reg(0x14, "EXTICR4", 0, 0x0000_FFFF, 0),
    reg(0x18, "CFGR", 0, 0x0000_F0FF, 0),
    reg(0x20, "CCCSR", 0, 0x0001_0003, 0x0000_0100),
    reg(0x24, "CCVR", 0, 0, 0x0000_00FF),
    reg(0x28, "CCCR", 0, 0x0000_00FF, 0),
    reg(0x2C, "PWRCR", 0, 0x0000_0001, 0),
    reg(0x124, "PKGR", 0x0000_000A, 0, 0x0000_000F),
];

pub struct Syscfg {
    kind: Kind,
    regs: Regs,
    ready_at: Option<u64>,
}

impl Syscfg {
    pub fn new(kind: Kind) -> Syscfg {
        Syscfg {
            kind,
            regs: Regs::new(if kind == Kind::F7 { F7_TABLE } else { H7_TABLE }),
            ready_at: None,
        }
    }

    /// The compensation cell's register (F7 CMPCR, H7 CCCSR: both 0x20).
    fn cell(&self) -> u32 {
        0x20
    }
}

impl Peripheral for Syscfg {
    fn name(&self) -> &'static str {
        "SYSCFG"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read("SYSCFG", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let (old, new) = self.regs.write("SYSCFG", offset, size, value)?;
        let word = offset & !3;
        match (self.kind, word) {
            (Kind::F7, 0x04) => cx.wiring.rmii = new & (1 << 23) != 0,
            (Kind::H7, 0x04) => cx.wiring.rmii = (new >> 21) & 7 == 0b100,
            (_, w) if w == self.cell() => {
                // F7 CMP_PD / H7 EN: READY about 10 us later.
                if new & 1 != 0 && old & 1 == 0 {
                    self.ready_at = Some(cx.now + cx.clocks.core_hz / 100_000);
                } else if new & 1 == 0 {
                    self.ready_at = None;
                    self.regs.set_bits(w, 1 << 8, false);
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.ready_at.is_some_and(|t| cx.now >= t) {
            self.ready_at = None;
            let cell = self.cell();
            self.regs.set_bits(cell, 1 << 8, true);
        }
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.ready_at
    }
}
