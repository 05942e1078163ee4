//! The bench's view of the frames the guard takes in and sends
//! ([`crate::bench::Probe`] in `bench` builds: where a message's
//! instructions go, per layer). In every other build it is an empty type
//! whose calls compile to nothing.

/// The moments a probe notes around one frame, after its start (the guard
/// asking the driver for a frame), in the order they come.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mark {
    /// The driver has offered the frame (it has read its bytes from the
    /// NIC).
    Given = 0,
    /// The stack consumes the frame's token.
    Taken = 1,
    /// The guard asks the driver for the frame's bytes.
    Calling = 2,
    /// The driver hands them to the guard.
    Opened = 3,
    /// The guard gives them back.
    Closed = 4,
    /// The driver is done with them.
    After = 5,
}

/// How many [`Mark`]s there are.
#[cfg_attr(not(feature = "bench"), allow(dead_code))]
pub(crate) const MARKS: usize = 6;

#[cfg(feature = "bench")]
pub(crate) use crate::bench::Probe;

/// Measures nothing (no `bench` feature).
#[cfg(not(feature = "bench"))]
pub(crate) struct Probe;

#[cfg(not(feature = "bench"))]
impl Probe {
    #[inline(always)]
    pub(crate) fn start() -> Probe {
        Probe
    }

    #[inline(always)]
    pub(crate) fn mark(&mut self, _at: Mark) {}

    #[inline(always)]
    pub(crate) fn smoltcp<R>(&mut self, frame: &mut [u8], f: impl FnOnce(&mut [u8]) -> R) -> R {
        f(frame)
    }

    #[inline(always)]
    pub(crate) fn end(self) {}

    #[inline(always)]
    pub(crate) fn sent(_reply: bool) {}

    #[inline(always)]
    pub(crate) fn hold_starts() {}

    #[inline(always)]
    pub(crate) fn held(_out: bool) {}
}
