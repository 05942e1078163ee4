//! General-purpose I/O ports (RM0410 rev 5 §6.4, RM0433 rev 8 §11.4; the
//! same register layout on both chips): the configuration registers are
//! kept and checked for reserved bits, BSRR sets and resets ODR bits, IDR
//! reads back what an output pin drives (nothing external is wired: an
//! input reads 0), and every MODER/AFR write updates the wiring the
//! Ethernet model checks its RMII pins against.

use crate::bus::{reg, widen, Cx, Peripheral, Refusal, Reg, Regs};

const MODER: u32 = 0x00;
const IDR: u32 = 0x10;
const ODR: u32 = 0x14;
const BSRR: u32 = 0x18;
const AFRL: u32 = 0x20;
const AFRH: u32 = 0x24;

/// Reset values of one port: MODER, OSPEEDR, PUPDR.
#[derive(Clone, Copy, Debug)]
pub struct Reset {
    pub moder: u32,
    pub ospeedr: u32,
    pub pupdr: u32,
}

/// Ports other than A and B reset to this on the F7 (input) ...
pub const F7_OTHER: Reset = Reset {
    moder: 0,
    ospeedr: 0,
    pupdr: 0,
};
/// ... and to analog on the H7 (RM0433 §11.4.1).
pub const H7_OTHER: Reset = Reset {
    moder: 0xFFFF_FFFF,
    ospeedr: 0,
    pupdr: 0,
};
/// Port A and B's debug pins (JTAG/SWD) at reset, per chip.
pub const F7_A: Reset = Reset {
    moder: 0xA800_0000,
    ospeedr: 0x0C00_0000,
    pupdr: 0x6400_0000,
};
pub const F7_B: Reset = Reset {
    moder: 0x0000_0280,
    ospeedr: 0x0000_00C0,
    pupdr: 0x0000_0100,
};
pub const H7_A: Reset = Reset {
    moder: 0xABFF_FFFF,
    ospeedr: 0x0C00_0000,
    pupdr: 0x6400_0000,
};
pub const H7_B: Reset = Reset {
    moder: 0xFFFF_FEBF,
    ospeedr: 0x0000_00C0,
    pupdr: 0x0000_0100,
};

pub struct Gpio {
    name: &'static str,
    port: usize,
    regs: Regs,
}

impl Gpio {
    /// Port `letter` ('A'..='K') with its reset values.
    pub fn new(name: &'static str, reset: Reset) -> Gpio {
        let table: &'static [Reg] = Box::leak(
            vec![
                reg(MODER, "MODER", reset.moder, 0xFFFF_FFFF, 0),
                reg(0x04, "OTYPER", 0, 0x0000_FFFF, 0),
                reg(0x08, "OSPEEDR", reset.ospeedr, 0xFFFF_FFFF, 0),
                reg(0x0C, "PUPDR", reset.pupdr, 0xFFFF_FFFF, 0),
                reg(IDR, "IDR", 0, 0, 0x0000_FFFF),
                reg(ODR, "ODR", 0, 0x0000_FFFF, 0),
                reg(BSRR, "BSRR", 0, 0xFFFF_FFFF, 0),
                reg(0x1C, "LCKR", 0, 0x0001_FFFF, 0),
                reg(AFRL, "AFRL", 0, 0xFFFF_FFFF, 0),
                reg(AFRH, "AFRH", 0, 0xFFFF_FFFF, 0),
            ]
            .into_boxed_slice(),
        );
        let port = (name.as_bytes()[4] - b'A') as usize;
        Gpio {
            name,
            port,
            regs: Regs::new(table),
        }
    }

    fn publish(&self, cx: &mut Cx) {
        let moder = self.regs.get(MODER);
        let afr = u64::from(self.regs.get(AFRL)) | (u64::from(self.regs.get(AFRH)) << 32);
        if let Some(pins) = cx.wiring.pins.get_mut(self.port) {
            for (n, pin) in pins.iter_mut().enumerate() {
                *pin = (
                    ((moder >> (2 * n)) & 3) as u8,
                    ((afr >> (4 * n)) & 0xF) as u8,
                );
            }
        }
    }
}

impl Peripheral for Gpio {
    fn name(&self) -> &'static str {
        self.name
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        match offset & !3 {
            // Write-only: reads 0.
            BSRR => Ok(0),
            IDR => {
                // Outputs read back what they drive.
                let moder = self.regs.get(MODER);
                let outputs = (0..16)
                    .filter(|n| (moder >> (2 * n)) & 3 == 1)
                    .fold(0, |m, n| m | (1 << n));
                Ok(crate::bus::narrow(
                    self.regs.get(ODR) & outputs,
                    offset,
                    size,
                ))
            }
            _ => self.regs.read(self.name, offset, size),
        }
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        if offset & !3 == BSRR {
            let v = widen(0, offset, size, value);
            let odr = self.regs.get(ODR);
            // Set wins over reset (RM0410 §6.4.7).
            self.regs.set(ODR, (odr & !(v >> 16)) | (v & 0xFFFF));
            return Ok(());
        }
        self.regs.write(self.name, offset, size, value)?;
        self.publish(cx);
        Ok(())
    }
}

/// The ports of a chip, A..=last, at their bases (0x400 apart from
/// `first`), each gated by its RCC enable (named like the port).
pub fn ports(bus: &mut crate::bus::Bus, first: u32, last: char, a: Reset, b: Reset, other: Reset) {
    const NAMES: [&str; 11] = [
        "GPIOA", "GPIOB", "GPIOC", "GPIOD", "GPIOE", "GPIOF", "GPIOG", "GPIOH", "GPIOI", "GPIOJ",
        "GPIOK",
    ];
    for (i, name) in NAMES
        .iter()
        .enumerate()
        .take((last as u8 - b'A' + 1) as usize)
    {
        let reset = match i {
            0 => a,
            1 => b,
            _ => other,
        };
        bus.add(
            first + 0x400 * i as u32,
            0x400,
            Some(name),
            Gpio::new(name, reset),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::Shared;

    #[test]
    fn bsrr_sets_and_resets_and_idr_reads_outputs() {
        let mut shared = Shared::default();
        let mut cx = shared.cx(0, crate::bus::no_dma());
        let mut g = Gpio::new("GPIOB", F7_B);
        // PB0 output.
        g.write(MODER, 4, 0x0000_0281, &mut cx).unwrap();
        g.write(BSRR, 4, 1, &mut cx).unwrap();
        assert_eq!(g.read(IDR, 4, &mut cx).unwrap(), 1);
        g.write(BSRR, 4, 1 << 16, &mut cx).unwrap();
        assert_eq!(g.read(IDR, 4, &mut cx).unwrap(), 0);
    }

    #[test]
    fn alternate_functions_reach_the_wiring() {
        let mut shared = Shared::default();
        let mut g = Gpio::new("GPIOG", F7_OTHER);
        {
            let mut cx = shared.cx(0, crate::bus::no_dma());
            g.write(MODER, 4, 2 << 26, &mut cx).unwrap();
            g.write(AFRH, 4, 11 << 20, &mut cx).unwrap();
        }
        assert_eq!(shared.wiring.pins[6][13], (2, 11));
    }
}
