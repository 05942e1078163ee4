//! What the engine keeps to find a poll loop it may fast-forward
//! (`fast_forward.rs`): the run of reads under way, its anchor and
//! the blocks entered since. Plain data, apart from the block hook's part,
//! so that the machine's state holds it without importing the
//! fast-forward itself.

/// The most blocks one iteration may enter (a longer loop is not a poll).
pub(crate) const MAX_BLOCKS: usize = 8;

/// A run of reads of one register, each the next access to any model,
/// all returning the same value, in one slice with no exception taken
/// and no torn word read: a poll loop's, unrolled or not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Run {
    pub(crate) pc: u64,
    pub(crate) addr: u64,
    pub(crate) size: usize,
    pub(crate) value: u32,
    pub(crate) slices: u64,
    pub(crate) exceptions: u64,
    pub(crate) ecc_reads: u64,
    /// The accesses counted at the run's last read.
    pub(crate) accesses: u64,
}

/// What the watch keeps between reads.
#[derive(Debug)]
pub struct Watch {
    /// Off with `--no-fast-forward`.
    pub enabled: bool,
    /// The translated block the core is in: its address and size.
    pub current: (u64, u32),
    /// The run of reads under way.
    pub(crate) run: Option<Run>,
    /// The last read of the run at its first read's instruction: its time
    /// and the core's registers then. Blocks are recorded from it.
    pub(crate) anchor: Option<(u64, [u64; 16])>,
    /// The blocks entered since the anchor, the anchor's own first.
    pub(crate) blocks: Vec<(u64, u32)>,
    /// Cycles moved on, and how many times.
    pub skipped: u64,
    pub skips: u64,
}

impl Default for Watch {
    fn default() -> Watch {
        Watch {
            enabled: true,
            current: (0, 0),
            run: None,
            anchor: None,
            blocks: Vec::with_capacity(MAX_BLOCKS + 1),
            skipped: 0,
            skips: 0,
        }
    }
}

impl Watch {
    /// The block hook's part: the block entered (cheap: the hook runs at
    /// every block).
    pub fn entered(&mut self, addr: u64, size: u32) {
        self.current = (addr, size);
        if self.anchor.is_some() && self.blocks.len() <= MAX_BLOCKS {
            self.blocks.push((addr, size));
        }
    }

    /// The run's first instruction read again at `now` with the core's
    /// registers `regs`: blocks are recorded from here.
    pub(crate) fn anchor_at(&mut self, now: u64, regs: [u64; 16]) {
        self.anchor = Some((now, regs));
        self.blocks.clear();
        self.blocks.push(self.current);
    }

    pub(crate) fn drop_run(&mut self) {
        self.run = None;
        self.anchor = None;
        self.blocks.clear();
    }
}
