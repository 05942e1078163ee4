//! Blocks that only hold configuration, as register tables: what the
//! image writes is kept and read back, reserved bits refused. Each table
//! names its reference-manual section.

use crate::bus::{Cx, Peripheral, Refusal, Reg, Regs};

/// A block of plain registers.
pub struct Plain {
    name: &'static str,
    regs: Regs,
}

impl Plain {
    pub fn new(name: &'static str, table: &'static [Reg]) -> Plain {
        Plain {
            name,
            regs: Regs::new(table),
        }
    }
}

impl Peripheral for Plain {
    fn name(&self) -> &'static str {
        self.name
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        self.regs.read(self.name, offset, size)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, _cx: &mut Cx) -> Result<(), Refusal> {
        self.regs.write(self.name, offset, size, value).map(|_| ())
    }
}
