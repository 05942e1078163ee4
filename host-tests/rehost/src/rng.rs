//! The random number generator (RM0410 rev 5 §22, RM0433 rev 8 §34; the
//! same registers on both chips): DRDY rises a short time after RNGEN and
//! after every read of DR, with numbers from a fixed-seed generator so
//! that runs repeat. Its interrupt is not modelled: enabling it stops the
//! run.

use crate::bus::{reg, Cx, Peripheral, Refusal, Reg, Regs};

const CR: u32 = 0x00;
const SR: u32 = 0x04;
const DR: u32 = 0x08;

const TABLE: &[Reg] = &[
    reg(CR, "CR", 0, 0x0000_002C, 0),
    reg(SR, "SR", 0, 0x0000_0060, 0x0000_0007),
    reg(DR, "DR", 0, 0, 0xFFFF_FFFF),
];

pub struct Rng {
    regs: Regs,
    state: u64,
    ready_at: Option<u64>,
}

impl Rng {
    pub fn new() -> Rng {
        Rng {
            regs: Regs::new(TABLE),
            state: 0x9E37_79B9_7F4A_7C15,
            ready_at: None,
        }
    }

    fn schedule(&mut self, now: u64) {
        // 42 RNG clock cycles at 48 MHz: about 1 us (RM0410 §22.3.4).
        self.ready_at = Some(now + 500);
    }
}

impl Default for Rng {
    fn default() -> Rng {
        Rng::new()
    }
}

impl Peripheral for Rng {
    fn name(&self) -> &'static str {
        "RNG"
    }

    fn read(&mut self, offset: u32, size: u32, cx: &mut Cx) -> Result<u32, Refusal> {
        if offset & !3 == DR {
            if self.regs.get(SR) & 1 == 0 {
                return Err("RNG_DR read while SR.DRDY is clear: the value is not valid".into());
            }
            // xorshift64*.
            self.state ^= self.state >> 12;
            self.state ^= self.state << 25;
            self.state ^= self.state >> 27;
            let v = (self.state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 32) as u32;
            self.regs.set_bits(SR, 1, false);
            self.schedule(cx.now);
            return Ok(v);
        }
        self.regs.read("RNG", offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let (old, new) = self.regs.write("RNG", offset, size, value)?;
        if offset & !3 == CR {
            if new & (1 << 3) != 0 {
                return Err("RNG_CR.IE: the RNG's interrupt is not modelled".into());
            }
            if new & 4 != 0 && old & 4 == 0 {
                self.schedule(cx.now);
            }
            if new & 4 == 0 {
                self.ready_at = None;
                self.regs.set_bits(SR, 1, false);
            }
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.ready_at.is_some_and(|t| cx.now >= t) {
            self.ready_at = None;
            self.regs.set_bits(SR, 1, true);
        }
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.ready_at
    }
}
