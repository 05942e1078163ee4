//! The core's accesses to the peripheral window and the private
//! peripheral bus, handed to the models; and memory as a model's DMA sees
//! it, checked against the chip's bus matrix and the data cache.

use crate::bus::{Bus, Dma, Refusal};
use crate::state::{State, PPB};
use unicorn_engine::{RegisterARM, Unicorn};

fn remember(s: &mut State, pc: u64, addr: u64, size: u32, write: Option<u32>, value: u32) {
    s.accesses += 1;
    if s.recent.len() == 32 {
        s.recent.pop_front();
    }
    s.recent
        .push_back((pc as u32, addr as u32, size, write, value));
}

pub(crate) fn bus_read(uc: &mut Unicorn<State>, addr: u64, size: usize) -> u64 {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
    match access(uc, addr, size as u32, None) {
        Ok(v) => {
            let s = uc.get_data_mut();
            remember(s, pc, addr, size as u32, None, v);
            if !s.shared.raised.is_empty() {
                s.deadline = s.now;
            }
            crate::fast_forward::after_read(uc, pc, addr, size, v);
            u64::from(v)
        }
        Err(rule) => {
            uc.get_data_mut().refuse(rule, Some(addr), pc);
            let _ = uc.emu_stop();
            0
        }
    }
}

pub(crate) fn bus_write(uc: &mut Unicorn<State>, addr: u64, size: usize, value: u64) {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
    if let Err(rule) = access(uc, addr, size as u32, Some(value as u32)) {
        uc.get_data_mut().refuse(rule, Some(addr), pc);
        let _ = uc.emu_stop();
    } else {
        let s = uc.get_data_mut();
        remember(s, pc, addr, size as u32, Some(value as u32), 0);
        if addr >= PPB.0 || !s.shared.raised.is_empty() {
            // The NVIC or a line changed: an exception may be due now. Not
            // emu_stop here: inside an MMIO callback it leaves the PC on
            // the store, which would run again; the block hook stops at
            // the next block instead.
            s.deadline = s.now;
        }
    }
}

/// After an access or an advance: what the flash controller put into
/// the flash array is written into the flash memory (and the F7's ITCM
/// alias, which shows the same array), and its stall added to virtual
/// time (the core waits for a flash operation in the bank it fetches
/// from).
fn settle(uc: &mut Unicorn<State>) {
    let s = uc.get_data();
    let f = &s.shared.flash;
    if s.shared.program.is_empty()
        && s.shared.stall == 0
        && !f.cut
        && f.census
            .as_ref()
            .is_none_or(|c| c.last().is_none_or(|op| op.pc != 0))
    {
        // Nothing to settle: the common case of a register access (a
        // poll loop's), which this keeps cheap.
        return;
    }
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
    let s = uc.get_data_mut();
    if let Some(census) = &mut s.shared.flash.census {
        for op in census.iter_mut().rev().take_while(|op| op.pc == 0) {
            op.pc = pc;
        }
    }
    let mut writes = std::mem::take(&mut s.shared.program);
    let stall = std::mem::take(&mut s.shared.stall);
    // A torn program's own bytes (`None` for an erase), on a flash
    // without ECC: mixed once the rest is in the array.
    let mut torn = None;
    if s.shared.flash.cut {
        // The power fails as the operation starts: nothing of it gets to
        // the array, nor anything after it; what ended before it in the
        // same access (an erase) does. The machine powers the chip off
        // before the next block. With `--tear` it fails inside the
        // operation: its words are torn, and a program's bytes reach the
        // array half-made ([`crate::torn_word`] on a flash with ECC,
        // [`crate::torn_bits`] on one without).
        // Torn once, at the first settle after the cut (`kept` is taken
        // there); a later access before the power goes adds nothing.
        let first = s.shared.flash.kept.take();
        let kept = first.unwrap_or(0);
        let tear = s.shared.flash.tear && first.is_some();
        let ecc = s.chip.flash_ecc;
        let own = tear && ecc && crate::torn_word::tear(&mut s.shared.flash);
        let mixed = tear && !ecc;
        s.deadline = s.now;
        if mixed {
            torn = Some(writes.get(kept).map(|(_, bytes)| bytes.clone()));
            writes.truncate(kept);
        } else {
            writes.truncate(kept + usize::from(own));
        }
    } else {
        s.now += stall;
    }
    for (addr, bytes) in writes {
        to_array(uc, addr, &bytes);
    }
    // The mix is made over what the array holds once the operations
    // before it in the access have reached it (an erase that ended just
    // before the cut program, say).
    if let Some((addr, bytes)) = torn.and_then(|own| crate::torn_bits::tear(uc, own)) {
        to_array(uc, addr, &bytes);
    }
}

/// `bytes` written into the flash array at `addr` (and the F7's ITCM
/// alias, which shows the same array); the instruction hooks follow.
fn to_array(uc: &mut Unicorn<State>, addr: u32, bytes: &[u8]) {
    let alias = uc.get_data().chip.flash_alias;
    let _ = uc.mem_write(u64::from(addr), bytes);
    let len = bytes.len() as u64;
    let s = uc.get_data_mut();
    s.code_changed
        .push((u64::from(addr), u64::from(addr) + len));
    // The hooks follow the new code before the core runs on (a swap
    // writes the image the bootloader then jumps to).
    s.deadline = s.now;
    if let Some((alias, flash, size)) = alias {
        if addr >= flash && addr - flash < size {
            let at = u64::from(addr - flash + alias);
            let _ = uc.mem_write(at, bytes);
            uc.get_data_mut().code_changed.push((at, at + len));
        }
    }
}

/// A store by the core into the flash memory (write-protected in
/// unicorn, so every one arrives here): the flash controller's to program.
/// Returns whether it was taken; a refusal stops the run on the store.
pub(crate) fn flash_store(uc: &mut Unicorn<State>, addr: u64, size: usize, value: i64) -> bool {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
    let mut old = vec![0; size.min(8)];
    let _ = uc.mem_read(addr, &mut old);
    let s = uc.get_data_mut();
    let mut bus = std::mem::take(&mut s.bus);
    let mut shared = s.shared.lend();
    let now = s.now;
    let result = {
        let mut cx = shared.cx(now, crate::bus::no_dma());
        bus.store(addr as u32, size as u32, value as u64, &old, &mut cx)
    };
    let s = uc.get_data_mut();
    s.bus = bus;
    s.shared.give_back(shared);
    match result {
        Ok(()) => {
            remember(s, pc, addr, size as u32, Some(value as u32), 0);
            settle(uc);
            // An operation under way may end at a time of its own: look
            // for it at the next block.
            let s = uc.get_data_mut();
            s.deadline = s.now;
            true
        }
        Err(rule) => {
            uc.get_data_mut().refuse(rule, Some(addr), pc);
            let _ = uc.emu_stop();
            false
        }
    }
}

/// Brings every model up to `now` (with the DMA reaching memory) and
/// pends the lines they raise.
pub(crate) fn advance_models(uc: &mut Unicorn<State>) -> Result<(), String> {
    let s = uc.get_data_mut();
    let mut bus = std::mem::take(&mut s.bus);
    let mut shared = s.shared.lend();
    let now = s.now;
    let result = {
        let mut dma = UcDma { uc: &mut *uc };
        let mut cx = shared.cx(now, &mut dma);
        bus.blocks.iter_mut().try_for_each(|b| {
            b.model
                .advance(&mut cx)
                .map_err(|rule| format!("{}: {rule}", b.model.name()))
        })
    };
    let s = uc.get_data_mut();
    s.bus = bus;
    s.shared.give_back(shared);
    settle(uc);
    let s = uc.get_data_mut();
    for irq in s.shared.raised.drain(..) {
        if let Some(p) = s.scs.pending.get_mut(irq as usize) {
            *p = true;
        }
    }
    result
}

/// One access to a peripheral or the system control space. The bus and
/// the shared state are taken out of the machine for the access, so that
/// a model's DMA can reach the chip's memory through unicorn.
fn access(
    uc: &mut Unicorn<State>,
    addr: u64,
    size: u32,
    write: Option<u32>,
) -> Result<u32, String> {
    let a = addr as u32;
    let kind = if write.is_some() { "write" } else { "read" };
    let s = uc.get_data_mut();
    if s.bus.find(a).is_none() {
        if addr < PPB.0 {
            return Err(format!(
                "a {size}-byte {kind} that no memory or model claims"
            ));
        }
        let mut cx = s.shared.cx(s.now, crate::bus::no_dma());
        return match write {
            Some(v) => s.scs.write(a, size, v, &mut cx).map(|()| 0),
            None => s.scs.read(a, size, &mut cx),
        };
    }
    let mut bus = std::mem::take(&mut s.bus);
    let mut shared = s.shared.lend();
    let now = s.now;
    let result = {
        let mut dma = UcDma { uc: &mut *uc };
        let mut cx = shared.cx(now, &mut dma);
        block_access(&mut bus, &mut cx, a, size, write)
    };
    let s = uc.get_data_mut();
    s.bus = bus;
    s.shared.give_back(shared);
    settle(uc);
    result
}

fn block_access(
    bus: &mut Bus,
    cx: &mut crate::bus::Cx,
    a: u32,
    size: u32,
    write: Option<u32>,
) -> Result<u32, String> {
    let kind = if write.is_some() { "write" } else { "read" };
    let Some((block, offset)) = bus.find(a) else {
        return Err(format!(
            "a {size}-byte {kind} that no memory or model claims"
        ));
    };
    let name = block.model.name();
    if let Some(clock) = block.clock {
        if !cx.clocks.enabled.contains(&clock) {
            return Err(format!(
                "{name} {kind} at offset {offset:#x} with its clock off (RCC enable bit for {clock} clear): silicon ignores it"
            ));
        }
    }
    block
        .model
        .advance(cx)
        .map_err(|rule| format!("{name}: {rule}"))?;
    let result = match write {
        Some(v) => block.model.write(offset, size, v, cx).map(|()| 0),
        None => block.model.read(offset, size, cx),
    };
    result.map_err(|rule| {
        if rule.starts_with(name) {
            rule
        } else {
            format!("{name}: {rule}")
        }
    })
}

/// The chip's memory as the Ethernet DMA sees it: only what the bus
/// matrix connects it to, and never memory the data cache may hold while
/// the cache is on (the core would read stale data, or the DMA would).
struct UcDma<'u, 'a> {
    uc: &'u mut Unicorn<'a, State>,
}

impl UcDma<'_, '_> {
    fn check(&self, addr: u32, len: usize, what: &str) -> Result<(), Refusal> {
        let s = self.uc.get_data();
        let end = u64::from(addr) + len as u64;
        let reach = s
            .chip
            .eth_dma_reaches
            .iter()
            .any(|&(lo, hi)| u64::from(addr) >= u64::from(lo) && end <= u64::from(hi));
        if !reach {
            let mem = s
                .chip
                .memory_at(u64::from(addr))
                .map_or("no memory", |m| m.name);
            return Err(format!(
                "the Ethernet DMA {what} {addr:#010x}..+{len} ({mem}), which it cannot reach on {}'s bus matrix",
                s.chip.name
            ));
        }
        if let Some(region) = cacheable(s, addr) {
            return Err(format!(
                "the Ethernet DMA {what} {addr:#010x}..+{len}, which the data cache may hold ({region}): make it non-cacheable in the MPU"
            ));
        }
        Ok(())
    }
}

impl Dma for UcDma<'_, '_> {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), Refusal> {
        self.check(addr, buf.len(), "reads")?;
        self.uc
            .mem_read(u64::from(addr), buf)
            .map_err(|e| format!("DMA read at {addr:#010x}: {e:?}"))
    }
    fn write(&mut self, addr: u32, data: &[u8]) -> Result<(), Refusal> {
        self.check(addr, data.len(), "writes")?;
        self.uc
            .mem_write(u64::from(addr), data)
            .map_err(|e| format!("DMA write at {addr:#010x}: {e:?}"))
    }
}

/// Why `addr` may be in the data cache, if it may: the D-cache on
/// (CCR.DC) and the address cacheable by the MPU region that covers it,
/// or by the default memory map (ARMv7-M B3.1, Table B3-1: SRAM and
/// external RAM write-back) where no region does. The TCMs are never
/// cached.
fn cacheable(s: &State, addr: u32) -> Option<String> {
    if s.scs.ccr & (1 << 16) == 0 {
        return None;
    }
    if s.chip
        .tightly_coupled
        .iter()
        .any(|&(lo, hi)| addr >= lo && addr < hi)
    {
        return None;
    }
    let a = u64::from(addr);
    let mpu_on = s.scs.mpu_ctrl & 1 != 0;
    if mpu_on {
        if let Some((i, r)) = s
            .scs
            .mpu
            .iter()
            .enumerate()
            .rev()
            .find(|(_, r)| r.range().is_some_and(|(lo, hi)| a >= lo && a < hi))
        {
            return r
                .cacheable()
                .then(|| format!("MPU region {i} is cacheable"));
        }
    }
    let default_cached =
        (0x2000_0000..0x4000_0000).contains(&addr) || (0x6000_0000..0xA000_0000).contains(&addr);
    default_cached.then(|| {
        if mpu_on {
            "no MPU region covers it: the default map caches it".to_string()
        } else {
            "the MPU is off: the default map caches it".to_string()
        }
    })
}

#[cfg(test)]
#[path = "access_tests.rs"]
mod tests;
