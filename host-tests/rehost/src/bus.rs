//! The peripheral side of the chip: every model answers reads and writes
//! at offsets into its block, and the bus finds the block. An access that
//! no block claims, or that a model refuses (a reserved register, a
//! reserved bit written, a clock above its limit), stops the run.

use crate::clocks::Clocks;
use crate::link::Link;
use crate::wiring::Wiring;

/// Why a model refused an access: the rule it breaks, in the chip's words.
pub type Refusal = String;

/// What a model sees of the rest of the chip during an access.
pub struct Cx<'a> {
    /// Virtual time: core clock cycles since reset (one instruction a
    /// cycle).
    pub now: u64,
    /// The clock tree as RCC, PWR and FLASH have set it.
    pub clocks: &'a mut Clocks,
    /// Interrupt lines raised by this access (the NVIC's numbering).
    pub raise: &'a mut Vec<u32>,
    /// Pins and system configuration, as GPIO and SYSCFG set them.
    pub wiring: &'a mut Wiring,
    /// The Ethernet wire.
    pub link: &'a mut Link,
    /// Memory as a DMA master sees it.
    pub dma: &'a mut dyn Dma,
    /// A model resets the chip (the watchdog expired).
    pub reset: &'a mut Option<ResetCause>,
    /// Bytes the flash controller put into the flash array (programmed,
    /// or erased to all ones), for the machine to write into the flash
    /// memory (and the F7's ITCM alias) after the access.
    pub program: &'a mut Vec<(u32, Vec<u8>)>,
    /// Core cycles the access stalls the core for (a flash operation in
    /// the bank the core fetches from), added to virtual time after it.
    pub stall: &'a mut u64,
    /// The flash operations (programs and erases) started since power-on
    /// of the first run, and the power cut to make at one of them.
    pub flash: &'a mut FlashOps,
}

/// The flash operations counted across the run (every power cycle and
/// reset included), and the one the power fails at (`--power-cut N`).
#[derive(Debug, Default, Clone)]
pub struct FlashOps {
    /// Operations started so far.
    pub started: u64,
    /// Cut the power as operation N (1-based) starts.
    pub cut_at: Option<u64>,
    /// The cut is due: the machine powers the chip off before the
    /// operation changes the array.
    pub cut: bool,
    /// How many of the bytes handed to the array in the access that
    /// started the cut operation came before it (an erase that ended
    /// just before, in the same access): those reach the array, nothing
    /// after them does.
    pub kept: Option<usize>,
    /// With `--flash-census`: each operation.
    pub census: Option<Vec<CensusOp>>,
    /// `--tear`: the cut tears the operation it falls on instead of
    /// stopping it before it starts ([`crate::torn_word`] where the flash
    /// has ECC, [`crate::torn_bits`] where it has none).
    pub tear: bool,
    /// `--tear-seed`: the seed of a torn operation's mix of bits on a
    /// flash without ECC (else the operation's number).
    pub tear_seed: Option<u64>,
    /// A torn operation's mix on a flash without ECC: its address, the
    /// bits that changed and the bits it was changing.
    pub mixed: Option<(u32, u64, u64)>,
    /// The operation the cut fell on: its address, its length, whether
    /// an erase.
    pub cut_op: Option<(u32, u32, bool)>,
    /// The flash words (their first addresses) a torn operation left
    /// with an ECC that does not match their bits, until their sector is
    /// erased. Kept across power cycles, as the array keeps them.
    pub torn: std::collections::BTreeSet<u32>,
    /// Reads of torn words the flash controller has not yet flagged
    /// (the address read), for its error flags (`FLASH_SR`'s DBECCERR).
    pub ecc_errors: Vec<u32>,
    /// Reads of torn words by the core, over the run.
    pub ecc_reads: u64,
}

/// One flash operation, as `--flash-census` lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CensusOp {
    /// Its number (1-based).
    pub n: u64,
    /// A sector erase (else a program).
    pub erase: bool,
    pub addr: u32,
    pub len: u32,
    /// The PC of the access that started it: which program did, the
    /// bootloader or the image (0 until the machine fills it in).
    pub pc: u32,
}

/// Why the chip resets: a system reset, which restarts the core and every
/// peripheral but keeps the RAM, the backup domain and RCC's reset flags
/// (RM0410 §5.1.2, RM0433 §8.4.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// SCB_AIRCR SYSRESETREQ.
    Software,
    /// The independent watchdog counted down to zero, this long after its
    /// last reload.
    Watchdog { after_ms: u64 },
}

/// Memory as a bus master other than the core sees it (the Ethernet
/// DMA): the machine refuses an address the master cannot reach on the
/// chip's bus matrix, and a write into memory the data cache may hold.
pub trait Dma {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), Refusal>;
    fn write(&mut self, addr: u32, data: &[u8]) -> Result<(), Refusal>;
}

/// No DMA (the models' unit tests, the reset state).
pub struct NoDma;

/// A `NoDma` to lend to a context (zero-sized: leaking it costs nothing).
pub fn no_dma() -> &'static mut NoDma {
    Box::leak(Box::new(NoDma))
}

impl Dma for NoDma {
    fn read(&mut self, addr: u32, _: &mut [u8]) -> Result<(), Refusal> {
        Err(format!("no DMA memory here ({addr:#010x})"))
    }
    fn write(&mut self, addr: u32, _: &[u8]) -> Result<(), Refusal> {
        Err(format!("no DMA memory here ({addr:#010x})"))
    }
}

/// What the models share besides the core: the clock tree, the lines they
/// raise, the wiring and the wire.
#[derive(Debug, Default)]
pub struct Shared {
    pub clocks: Clocks,
    pub raised: Vec<u32>,
    pub wiring: Wiring,
    pub link: Link,
    pub reset: Option<ResetCause>,
    pub program: Vec<(u32, Vec<u8>)>,
    pub stall: u64,
    pub flash: FlashOps,
}

impl Shared {
    /// The context of one access at `now`.
    pub fn cx<'a>(&'a mut self, now: u64, dma: &'a mut dyn Dma) -> Cx<'a> {
        Cx {
            now,
            clocks: &mut self.clocks,
            raise: &mut self.raised,
            wiring: &mut self.wiring,
            link: &mut self.link,
            dma,
            reset: &mut self.reset,
            program: &mut self.program,
            stall: &mut self.stall,
            flash: &mut self.flash,
        }
    }
}

/// One peripheral's registers.
pub trait Peripheral {
    /// The block's name in the reference manual (`RCC`, `GPIOA`).
    fn name(&self) -> &'static str;
    /// A read of `size` bytes (1, 2 or 4) at `offset` into the block.
    fn read(&mut self, offset: u32, size: u32, cx: &mut Cx) -> Result<u32, Refusal>;
    /// A write of `size` bytes at `offset`.
    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal>;
    /// Time moved on to `cx.now`: ready bits, counters, interrupts. Called
    /// before every access to the block and whenever the core sleeps.
    fn advance(&mut self, _cx: &mut Cx) -> Result<(), Refusal> {
        Ok(())
    }
    /// The next virtual time (cycles) at which this model has something
    /// to do by itself (a timer's compare, a ready bit), for WFI.
    /// The reset flags a system reset keeps (RCC only: RCC_CSR on the F7,
    /// RCC_RSR on the H7).
    fn reset_flags(&self) -> Option<u32> {
        None
    }

    /// After a system reset, in the model built anew: the flags kept from
    /// before with `cause`'s added (RCC only).
    fn keep_reset_flags(&mut self, _kept: u32, _cause: ResetCause) {}

    fn next_event(&self, _now: u64) -> Option<u64> {
        None
    }

    /// Until when (exclusive) the register at `offset`, read at `now`,
    /// keeps the value it has, unless the core accesses this block again:
    /// a status bit that clears when an operation under way ends. `None`
    /// (the default): no promise. [`crate::fast_forward`] moves a poll
    /// loop on to that time.
    fn holds_until(&self, _offset: u32, _now: u64) -> Option<u64> {
        None
    }

    /// A store of `size` bytes of `value` by the core into the flash
    /// memory at `addr` (whose bytes are now `old`): the flash
    /// controller's, which programs it when its rules allow (pushing the
    /// bytes to `cx.program`). `None`: not this block's.
    fn store(
        &mut self,
        _addr: u32,
        _size: u32,
        _value: u64,
        _old: &[u8],
        _cx: &mut Cx,
    ) -> Option<Result<(), Refusal>> {
        None
    }
}

/// A block on the bus.
pub struct Block {
    pub base: u32,
    pub size: u32,
    /// The name RCC's enable bit goes by, when the block has one: an
    /// access while it is clear stops the run (on silicon the block
    /// ignores writes and reads 0).
    pub clock: Option<&'static str>,
    pub model: Box<dyn Peripheral>,
}

/// Every peripheral block of the chip.
#[derive(Default)]
pub struct Bus {
    pub blocks: Vec<Block>,
}

impl Bus {
    /// Adds a block; blocks must not overlap (checked by the tests of each
    /// chip's map).
    pub fn add(
        &mut self,
        base: u32,
        size: u32,
        clock: Option<&'static str>,
        model: impl Peripheral + 'static,
    ) {
        self.blocks.push(Block {
            base,
            size,
            clock,
            model: Box::new(model),
        });
    }

    /// The soonest time any model has something to do by itself.
    pub fn next_event(&self, now: u64) -> Option<u64> {
        self.blocks
            .iter()
            .filter_map(|b| b.model.next_event(now))
            .min()
    }

    /// A store by the core into the flash memory, handed to the block
    /// that programs it (the flash controller); refused when no block
    /// takes it.
    pub fn store(
        &mut self,
        addr: u32,
        size: u32,
        value: u64,
        old: &[u8],
        cx: &mut Cx,
    ) -> Result<(), Refusal> {
        for b in &mut self.blocks {
            b.model.advance(cx)?;
            if let Some(r) = b.model.store(addr, size, value, old, cx) {
                return r.map_err(|rule| format!("{}: {rule}", b.model.name()));
            }
        }
        Err("a write into flash (read-only to the core; no flash controller programs it)".into())
    }

    /// The block holding `addr`, and the offset into it.
    pub fn find(&mut self, addr: u32) -> Option<(&mut Block, u32)> {
        self.blocks
            .iter_mut()
            .find(|b| addr >= b.base && addr - b.base < b.size)
            .map(|b| {
                let offset = addr - b.base;
                (b, offset)
            })
    }
}

/// One register: its offset, reset value, the bits software may write,
/// and the bits the hardware drives (read-only: writes to them are
/// ignored). Every other bit is reserved: "must be kept at reset value"
/// (every STM32 reference manual), so a write that changes one is refused.
#[derive(Clone, Copy, Debug)]
pub struct Reg {
    pub offset: u32,
    pub name: &'static str,
    pub reset: u32,
    pub rw: u32,
    pub ro: u32,
}

/// A register with `rw` writable bits, `ro` hardware bits.
pub const fn reg(offset: u32, name: &'static str, reset: u32, rw: u32, ro: u32) -> Reg {
    Reg {
        offset,
        name,
        reset,
        rw,
        ro,
    }
}

/// Registers as plain words: the common case of a model whose registers
/// mostly hold configuration.
#[derive(Clone, Debug)]
pub struct Regs {
    pub table: &'static [Reg],
    pub values: Vec<u32>,
}

impl Regs {
    pub fn new(table: &'static [Reg]) -> Regs {
        Regs {
            table,
            values: table.iter().map(|r| r.reset).collect(),
        }
    }

    fn index(&self, offset: u32) -> Option<usize> {
        self.table.iter().position(|r| r.offset == offset & !3)
    }

    /// The register's value, by offset.
    pub fn get(&self, offset: u32) -> u32 {
        self.index(offset).map_or(0, |i| self.values[i])
    }

    /// Sets a register's value (the hardware's own bits: no check).
    pub fn set(&mut self, offset: u32, value: u32) {
        if let Some(i) = self.index(offset) {
            self.values[i] = value;
        }
    }

    /// Sets or clears hardware bits of a register.
    pub fn set_bits(&mut self, offset: u32, bits: u32, on: bool) {
        let v = self.get(offset);
        self.set(offset, if on { v | bits } else { v & !bits });
    }

    /// A read: the register, shifted for a byte or half-word access.
    pub fn read(&self, block: &str, offset: u32, size: u32) -> Result<u32, Refusal> {
        let i = self
            .index(offset)
            .ok_or_else(|| format!("{block}: no register at offset {offset:#x} (reserved)"))?;
        Ok(narrow(self.values[i], offset, size))
    }

    /// A write: reserved bits must keep their reset value, hardware bits
    /// keep theirs. Returns the old and the new value.
    pub fn write(
        &mut self,
        block: &str,
        offset: u32,
        size: u32,
        value: u32,
    ) -> Result<(u32, u32), Refusal> {
        let i = self
            .index(offset)
            .ok_or_else(|| format!("{block}: no register at offset {offset:#x} (reserved)"))?;
        let r = self.table[i];
        let old = self.values[i];
        let written = widen(old, offset, size, value);
        let reserved = !(r.rw | r.ro);
        let changed = (written ^ r.reset) & reserved;
        if changed != 0 {
            return Err(format!(
                "{block}_{}: reserved bits {changed:#010x} written (value {written:#010x}; writable {:#010x}, reset {:#010x})",
                r.name, r.rw, r.reset
            ));
        }
        let new = (written & r.rw) | (old & !r.rw);
        self.values[i] = new;
        Ok((old, new))
    }

    /// The register's name at an offset (for messages).
    pub fn name(&self, offset: u32) -> &'static str {
        self.index(offset).map_or("?", |i| self.table[i].name)
    }
}

/// The bytes of a register a narrow read returns.
pub fn narrow(word: u32, offset: u32, size: u32) -> u32 {
    let shift = (offset & 3) * 8;
    match size {
        1 => (word >> shift) & 0xff,
        2 => (word >> shift) & 0xffff,
        _ => word,
    }
}

/// A register after a narrow write into it.
pub fn widen(old: u32, offset: u32, size: u32, value: u32) -> u32 {
    let shift = (offset & 3) * 8;
    match size {
        1 => (old & !(0xff << shift)) | ((value & 0xff) << shift),
        2 => (old & !(0xffff << shift)) | ((value & 0xffff) << shift),
        _ => value,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &[Reg] = &[
        reg(0x0, "CR", 0x0000_0083, 0x0000_00f1, 0x0000_0002),
        reg(0x4, "DR", 0, 0xffff_ffff, 0),
    ];

    #[test]
    fn a_reserved_bit_written_is_refused_and_named() {
        let mut r = Regs::new(TABLE);
        assert!(r.write("X", 0, 4, 0x0000_0081).is_ok());
        // A hardware bit written 0 keeps the hardware's 1.
        assert_eq!(r.get(0), 0x0000_0083);
        let e = r.write("X", 0, 4, 0x0001_0081).unwrap_err();
        assert!(e.contains("X_CR: reserved bits 0x00010000"), "{e}");
    }

    #[test]
    fn an_offset_with_no_register_is_refused() {
        let mut r = Regs::new(TABLE);
        assert!(r.read("X", 0x8, 4).is_err());
        assert!(r.write("X", 0x10, 4, 0).is_err());
    }

    #[test]
    fn narrow_accesses_reach_the_right_bytes() {
        let mut r = Regs::new(TABLE);
        r.write("X", 0x5, 1, 0xab).unwrap();
        assert_eq!(r.get(4), 0x0000_ab00);
        assert_eq!(r.read("X", 0x5, 1).unwrap(), 0xab);
        r.write("X", 0x6, 2, 0x1234).unwrap();
        assert_eq!(r.get(4), 0x1234_ab00);
    }
}
