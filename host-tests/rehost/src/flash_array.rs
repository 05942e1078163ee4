//! What both chips' flash arrays share, below their controllers'
//! registers (`f7/flash.rs`, `h7/flash.rs`): NOR rules (programming only
//! clears bits; only an erase sets them, a sector at a time), an
//! operation that keeps its bank busy for the datasheet's time, and what
//! that does to a core that fetches its code from the same bank.

use crate::bus::Cx;

/// An operation under way in a bank: when it ends, and the sector an
/// erase sets to all ones then.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Busy {
    pub until: u64,
    pub erase: Option<(u32, u32)>,
}

/// Core cycles for `us` microseconds at the core clock in force (at
/// least the HSI's 16 MHz, the slowest clock a flash operation runs
/// beside here).
pub fn cycles(cx: &Cx, us: u64) -> u64 {
    crate::clocks::core_cycles(cx.clocks, 16_000_000, us)
}

/// Whether programming `value` over `old` needs a bit set that is clear:
/// only an erase sets bits. The first such byte's offset.
pub fn sets_a_cleared_bit(old: &[u8], value: &[u8]) -> Option<usize> {
    old.iter().zip(value).position(|(o, v)| v & !o != 0)
}

/// Starts an operation of `us` microseconds at `cx.now`; when the core
/// fetches its code from the bank (`stalls`), it waits for the whole of
/// it: the model assumes no cache hit, the worst case (on silicon the
/// instruction cache may let a short loop run on, but any fetch that
/// misses waits).
///
/// Counted in `cx.flash`: when this is the operation the power is to fail
/// at, the cut is flagged and the machine powers the chip off before
/// anything of it reaches the array ([`crate::bus::FlashOps`]).
pub fn start(cx: &mut Cx, us: u64, erase: Option<(u32, u32)>, stalls: bool) -> Busy {
    cx.flash.started += 1;
    // A program's bytes are handed over just before it starts.
    let (addr, len) = match erase {
        Some(e) => e,
        None => cx
            .program
            .last()
            .map(|(a, b)| (*a, b.len() as u32))
            .unwrap_or_default(),
    };
    if cx.flash.cut_at == Some(cx.flash.started) {
        cx.flash.cut = true;
        let own = usize::from(erase.is_none());
        cx.flash.kept = Some(cx.program.len().saturating_sub(own));
        cx.flash.cut_op = Some((addr, len, erase.is_some()));
    }
    if let Some(census) = &mut cx.flash.census {
        // The PC is the machine's to fill in after the access.
        census.push(crate::bus::CensusOp {
            n: cx.flash.started,
            erase: erase.is_some(),
            addr,
            len,
            pc: 0,
        });
    }
    let len = cycles(cx, us);
    if stalls {
        *cx.stall += len;
    }
    Busy {
        until: cx.now + len,
        erase,
    }
}

/// Ends `busy` once its time has come: an erase's sector becomes all
/// ones. Whether it ended.
pub fn finish(busy: &mut Option<Busy>, cx: &mut Cx) -> bool {
    match *busy {
        Some(b) if cx.now >= b.until => {
            if let Some((base, len)) = b.erase {
                cx.program.push((base, vec![0xFF; len as usize]));
                // An erase gives every word of its sector a matching ECC
                // again: a torn word is mended.
                let end = base.saturating_add(len);
                cx.flash.torn.retain(|&w| w < base || w >= end);
            }
            *busy = None;
            true
        }
        _ => false,
    }
}

/// A flash controller's model on a bench of its own, for its unit tests
/// (`f7/flash.rs`, `h7/flash.rs`): register writes and reads at a time
/// the test moves, and core stores into the flash.
#[cfg(test)]
pub(crate) mod testing {
    use crate::bus::{Peripheral, Refusal, Shared};

    pub(crate) struct Bench<F> {
        pub flash: F,
        pub shared: Shared,
        pub now: u64,
    }

    impl<F: Peripheral> Bench<F> {
        /// `flash` with the core at `core_hz`.
        pub fn new(flash: F, core_hz: u64) -> Bench<F> {
            let mut shared = Shared::default();
            shared.clocks.core_hz = core_hz;
            Bench {
                flash,
                shared,
                now: 0,
            }
        }
        /// A register write at `offset`, the model brought up to `now`.
        pub fn w(&mut self, offset: u32, value: u32) -> Result<(), Refusal> {
            let mut cx = self.shared.cx(self.now, crate::bus::no_dma());
            self.flash.advance(&mut cx)?;
            self.flash.write(offset, 4, value, &mut cx)
        }
        /// A register read at `offset`.
        pub fn r(&mut self, offset: u32) -> u32 {
            let mut cx = self.shared.cx(self.now, crate::bus::no_dma());
            self.flash.advance(&mut cx).unwrap();
            self.flash.read(offset, 4, &mut cx).unwrap()
        }
        /// A core store of `size` bytes of `value` into the flash at
        /// `addr`, whose bytes are `old`.
        pub fn store(
            &mut self,
            addr: u32,
            size: u32,
            value: u64,
            old: &[u8],
        ) -> Result<(), Refusal> {
            let mut cx = self.shared.cx(self.now, crate::bus::no_dma());
            self.flash.store(addr, size, value, old, &mut cx).unwrap()
        }
        /// The key sequence written to the key register at `keyr`.
        pub fn unlock_at(&mut self, keyr: u32, keys: [u32; 2]) {
            self.w(keyr, keys[0]).unwrap();
            self.w(keyr, keys[1]).unwrap();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::Shared;

    #[test]
    fn operations_are_counted_and_the_power_fails_at_the_nth() {
        let mut shared = Shared::default();
        shared.clocks.core_hz = 64_000_000;
        shared.flash.cut_at = Some(3);
        shared.flash.census = Some(Vec::new());
        for n in 1..=4u64 {
            let mut cx = shared.cx(0, crate::bus::no_dma());
            if n % 2 == 0 {
                start(&mut cx, 10, Some((0x0810_0000, 128 * 1024)), false);
            } else {
                cx.program.push((0x0810_0000 + 32 * n as u32, vec![0; 32]));
                start(&mut cx, 10, None, false);
            }
            // Flagged at the third, and it stays flagged for the machine.
            assert_eq!(shared.flash.cut, n >= 3, "operation {n}");
            if n == 3 {
                // The first program's bytes came before it, its own not.
                assert_eq!(shared.flash.kept, Some(1));
            }
        }
        assert_eq!(shared.flash.started, 4);
        let census = shared.flash.census.unwrap();
        let op = |c: &crate::bus::CensusOp| (c.n, c.erase, c.addr, c.len);
        assert_eq!(op(&census[1]), (2, true, 0x0810_0000, 128 * 1024));
        assert_eq!(op(&census[2]), (3, false, 0x0810_0060, 32));
    }
}
