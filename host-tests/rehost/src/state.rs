//! What every hook of the machine reaches: the chip's models, the core's
//! system control space and exception state, virtual time, and why the run
//! stopped. Plain data with no behaviour of its own beyond recording a
//! stop, so that the machine and the hooks it installs can all use it
//! without importing each other.

use crate::bus::{Bus, Shared};
use crate::chip::Chip;
use crate::fault::Fault;
use crate::image::Image;
use crate::scs::Scs;
use crate::stop::Stop;
use std::rc::Rc;

/// The private peripheral bus (the core's SCS), which the machine maps to
/// the models.
pub(crate) const PPB: (u64, u64) = (0xE000_0000, 0x10_0000);

/// The exceptions the core is handling, innermost last, with their
/// priorities.
#[derive(Clone, Debug, Default)]
pub struct Active {
    pub stack: Vec<(u32, i32)>,
}

/// Everything the hooks reach.
pub struct State {
    pub chip: Chip,
    pub image: Rc<Image>,
    pub bus: Bus,
    pub scs: Scs,
    /// What the models share: clocks, raised lines, wiring, the wire.
    pub shared: Lent<Shared>,
    /// Retired instructions (= core cycles).
    pub now: u64,
    /// Accesses to the models (reads, writes, flash stores) so far.
    pub accesses: u64,
    /// Poll loops watched and fast-forwarded ([`crate::fast_forward`]).
    pub poll: crate::poll_watch::Watch,
    /// The run ends when `now` reaches this.
    pub deadline: u64,
    pub stop: Option<Stop>,
    /// The exceptions being handled.
    pub active: Active,
    pub exceptions_taken: u64,
    /// A YIELD the core stopped at, to be stepped over
    /// ([`crate::hooks::step_over_yield`]).
    pub yield_at: Option<u32>,
    /// The handler branched to this EXC_RETURN value.
    pub exception_return: Option<u32>,
    /// A fault to take before the next instruction.
    pub fault: Option<Fault>,
    /// The ranges the MPU forbids writes to, and the pages of RAM
    /// protected in unicorn so that every store into them is checked
    /// ([`crate::mpu`]); the MPU registers they were computed from.
    pub mpu_denied: Vec<crate::mpu::Denied>,
    pub mpu_pages: Vec<u64>,
    pub mpu_seen: (u32, [crate::scs::MpuRegion; 16]),
    /// The core reached WFI or WFE: (its address, its size, WFE?).
    pub sleeping: Option<(u32, u32, bool)>,
    /// The event register (SEV, exception return) that WFE consumes.
    pub event: bool,
    /// Cycles the core spent asleep.
    pub slept: u64,
    /// The last peripheral accesses: (PC, address, size, written value or
    /// None for a read, value read).
    pub recent: std::collections::VecDeque<(u32, u32, u32, Option<u32>, u32)>,
    /// Times the emulator was started (slices run).
    pub slices: u64,
    /// The core reached the address of [`Machine::stop_at`].
    pub reached: bool,
    /// Instructions in each translated block, by its address.
    pub block_sizes: rustc_hash::FxHashMap<u64, u64>,
    /// The hooks on the instructions the model must see, by address, as
    /// the memory now holds them ([`crate::hooks`]).
    pub instruction_hooks: std::collections::BTreeMap<u64, unicorn_engine::UcHookId>,
    /// Flash written since the hooks last followed it: (start, end).
    pub code_changed: Vec<(u64, u64)>,
    /// The read hook on the torn flash words and the span it watches
    /// ([`crate::torn_word::watch`]).
    pub torn_hook: Option<(unicorn_engine::UcHookId, u64, u64)>,
}

/// A value the hooks lend out for one access (the models' shared state,
/// while a model's DMA reaches the chip's memory through unicorn), moved
/// as a pointer: a box swapped with a spare, whose defaults are what
/// anything reading the field meanwhile sees. Moving the value itself (a
/// copy out, a default in, a copy back per register read) made a power-cut
/// run of the H743's swap, which polls its flash controller, take 80 s
/// instead of 57 s.
pub struct Lent<T> {
    here: Box<T>,
    spare: Option<Box<T>>,
}

impl<T: Default> Lent<T> {
    pub fn new(value: T) -> Lent<T> {
        Lent {
            here: Box::new(value),
            spare: Some(Box::default()),
        }
    }

    /// The value, for one access; [`Lent::give_back`] returns it.
    pub fn lend(&mut self) -> Box<T> {
        let spare = self.spare.take().unwrap_or_default();
        std::mem::replace(&mut self.here, spare)
    }

    /// The value lent, back in place.
    pub fn give_back(&mut self, value: Box<T>) {
        self.spare = Some(std::mem::replace(&mut self.here, value));
    }
}

impl<T> std::ops::Deref for Lent<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.here
    }
}

impl<T> std::ops::DerefMut for Lent<T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.here
    }
}

impl State {
    /// Records the first stop; later ones are consequences of it.
    pub(crate) fn refuse(&mut self, rule: String, addr: Option<u64>, pc: u64) {
        if self.stop.is_none() {
            self.stop = Some(Stop {
                rule,
                addr,
                pc,
                function: self.image.describe(pc),
                cycles: self.now,
            });
        }
    }
}
