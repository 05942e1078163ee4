//! Sampling runs elsewhere (the background executor, an interrupt); the
//! cycle needs the latest consistent samples at once, without blocking.
//! This is a wait-free triple buffer for one writer and one reader: the
//! writer fills the slot nobody reads and swaps it into the middle; the
//! reader swaps the middle out when it is fresh. Neither ever waits for
//! the other, whatever their priorities, so a cycle that preempts the
//! sampler mid-write still gets a whole value, and reading costs the cycle
//! one atomic swap, never a copy.
//!
//! It holds any `Copy` value: the firmware puts a sensor's whole
//! [`History`](crate::sensor::History) of timestamped samples in it, so the
//! sample type is the sensor's choice (see [`crate::sensor`]). The three
//! slots are all the memory it takes: [`SampleWriter::publish_with`]
//! builds the next value in the writer's own slot from the last one
//! published, so the sampler keeps no copy of its own (a history costs
//! three times its size, not four).
//!
//! # Why the `unsafe` here is sound
//!
//! The three slots are `UnsafeCell`s: the only `unsafe` of the firmware
//! library, kept to this module. Each of the three slot indices belongs at
//! any moment to exactly one party: the writer's `back`, the reader's
//! `front`, or the shared `middle`. An index changes hands only through an
//! atomic swap with `middle`, which gives the caller the middle's index and
//! takes the caller's, so no two parties ever hold the same index. The
//! writer only writes the slot of `back`, the reader only reads the slot
//! of `front`; the writer also reads the slot it published last (`last`),
//! which is then the middle or the reader's front: nobody writes it until
//! it comes back to the writer as `back`, and `back` is never `last` (the
//! swap that publishes `last` hands the writer the middle's other index). The swaps are `AcqRel`: the writer's release publishes what it
//! wrote before the reader's acquire takes that slot; the reader's release
//! orders its last reads of a slot before the writer can take it back.
//! There is one writer and one reader ([`SampleCell::split`] hands them out
//! once), and each needs `&mut self`, so neither end can race itself.
#![allow(unsafe_code)]

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// Bit 2 of the shared state: the middle slot holds a value the reader has
/// not taken yet. Bits 0–1: the middle slot's index.
const FRESH: u8 = 0b100;
const INDEX: u8 = 0b011;

/// The shared part; put it in a `static` and [`SampleCell::split`] it once.
pub struct SampleCell<T> {
    slots: [UnsafeCell<T>; 3],
    middle: AtomicU8,
    split: AtomicBool,
}

// SAFETY: the slots are only reached through the one writer and the one
// reader, each owning a different slot at any time (see the module doc);
// a value moves between threads (or priorities), hence `T: Send`.
unsafe impl<T: Send> Sync for SampleCell<T> {}

impl<T: Copy> SampleCell<T> {
    /// A cell whose reader sees `initial` until the first publish (`const`,
    /// for a `static`).
    pub const fn new(initial: T) -> Self {
        SampleCell {
            slots: [
                UnsafeCell::new(initial),
                UnsafeCell::new(initial),
                UnsafeCell::new(initial),
            ],
            // Slot 0 starts in the middle, 1 with the reader, 2 with the
            // writer: the state starts at zero, so a cell whose initial
            // value is all zeroes (an empty `History`) is all zeroes, and
            // sits in `.bss` rather than in `.data` (no copy in flash, no
            // copy at start-up).
            middle: AtomicU8::new(0),
            split: AtomicBool::new(false),
        }
    }

    /// The writer and the reader. Only the first call gets them: there is
    /// exactly one of each.
    pub fn split(&self) -> Option<(SampleWriter<'_, T>, SampleReader<'_, T>)> {
        if self.split.swap(true, Ordering::AcqRel) {
            return None;
        }
        Some((
            SampleWriter {
                cell: self,
                back: 2,
                last: 0,
            },
            SampleReader {
                cell: self,
                front: 1,
            },
        ))
    }

    /// The slot of index `i` (only 0, 1 and 2 are ever handed out).
    fn slot(&self, i: u8) -> &UnsafeCell<T> {
        let [a, b, c] = &self.slots;
        match i & INDEX {
            0 => a,
            1 => b,
            _ => c,
        }
    }
}

/// The sampler's end.
pub struct SampleWriter<'a, T> {
    cell: &'a SampleCell<T>,
    back: u8,
    /// The slot published last (the initial value's middle before the
    /// first publish): read-only to everyone until it is `back` again.
    last: u8,
}

impl<T: Copy> SampleWriter<'_, T> {
    /// Publishes a copy of `value`; never waits.
    pub fn publish(&mut self, value: &T) {
        // SAFETY: `back` is the writer's own slot (module doc): the reader
        // holds another one and the middle a third.
        unsafe { *self.cell.slot(self.back).get() = *value };
        self.swap_in();
    }

    /// Publishes the last value published (the initial value before the
    /// first) changed by `change`, built in place in the writer's own
    /// slot: one copy of the value, as [`publish`](Self::publish), and no
    /// copy kept anywhere else. Never waits.
    pub fn publish_with(&mut self, change: impl FnOnce(&mut T)) {
        // SAFETY: `back` is the writer's own slot and `last` another one
        // that nobody writes meanwhile (module doc): a copy between them.
        unsafe { *self.cell.slot(self.back).get() = *self.cell.slot(self.last).get() };
        // SAFETY: the writer's own slot; no other reference to it exists
        // (the reader holds `front`, `last` was only read above).
        change(unsafe { &mut *self.cell.slot(self.back).get() });
        self.swap_in();
    }

    /// Swaps the written `back` into the middle, marked fresh.
    fn swap_in(&mut self) {
        let previous = self.cell.middle.swap(self.back | FRESH, Ordering::AcqRel);
        self.last = self.back;
        self.back = previous & INDEX;
    }
}

/// The cycle's end.
pub struct SampleReader<'a, T> {
    cell: &'a SampleCell<T>,
    front: u8,
}

impl<T: Copy> SampleReader<'_, T> {
    /// The latest whole value published (the cell's initial value before
    /// the first); never waits, never copies.
    pub fn latest(&mut self) -> &T {
        if self.cell.middle.load(Ordering::Acquire) & FRESH != 0 {
            let previous = self.cell.middle.swap(self.front, Ordering::AcqRel);
            self.front = previous & INDEX;
        }
        // SAFETY: `front` is the reader's own slot (module doc); the
        // writer cannot take it back while this borrow of `self` lives,
        // because that needs this reader's next `latest` (`&mut self`).
        unsafe { &*self.cell.slot(self.front).get() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// A new cell's own state is zero, so a zero initial value makes the
    /// whole static zero-initialised (`.bss`, no image in flash).
    #[test]
    fn a_new_cells_state_is_zero() {
        let cell = SampleCell::new(0u32);
        assert_eq!(cell.middle.load(Ordering::Relaxed), 0);
        assert!(!cell.split.load(Ordering::Relaxed));
    }

    #[test]
    fn the_initial_value_before_the_first_publish_then_always_the_latest() {
        let cell = SampleCell::new([0u64; 2]);
        let (mut w, mut r) = cell.split().expect("first split");
        assert!(cell.split().is_none(), "one writer, one reader");
        assert_eq!(*r.latest(), [0, 0]);
        w.publish(&[1, 10]);
        w.publish(&[2, 20]);
        assert_eq!(*r.latest(), [2, 20]);
        assert_eq!(*r.latest(), [2, 20], "kept until a newer one");
        w.publish(&[3, u64::MAX]);
        assert_eq!(*r.latest(), [3, u64::MAX]);
    }

    #[test]
    fn publish_with_builds_on_the_last_value_published() {
        let cell = SampleCell::new([0u32; 4]);
        let (mut w, mut r) = cell.split().expect("split");
        for i in 1..=10u32 {
            w.publish_with(|v| {
                v.rotate_left(1);
                v[3] = i;
            });
            if i % 3 == 0 {
                // The reader takes some publishes and misses others: the
                // writer builds on its own last one either way.
                assert_eq!(*r.latest(), [i - 3, i - 2, i - 1, i]);
            }
        }
        assert_eq!(*r.latest(), [7, 8, 9, 10]);
        w.publish(&[1, 2, 3, 4]);
        w.publish_with(|v| v[0] = 9);
        assert_eq!(*r.latest(), [9, 2, 3, 4], "after a whole publish too");
    }

    /// A writer that publishes 200,000 values through `publish`, each
    /// with all 16 words equal and growing, against a reader on this
    /// thread: a torn read would mix two of them.
    fn reader_sees_whole_values(publish: fn(&mut SampleWriter<'_, [u64; 16]>, u64)) {
        let cell = SampleCell::new([0u64; 16]);
        let (mut w, mut r) = cell.split().expect("split");
        std::thread::scope(|s| {
            s.spawn(move || {
                for i in 1..200_000u64 {
                    publish(&mut w, i);
                }
            });
            let mut last = 0;
            for _ in 0..200_000 {
                let x = *r.latest();
                assert!(x.iter().all(|&v| v == x[0]), "torn: {x:?}");
                assert!(x[0] >= last, "never older than before");
                last = x[0];
            }
        });
    }

    #[test]
    fn a_concurrent_reader_only_ever_sees_whole_values() {
        reader_sees_whole_values(|w, i| w.publish(&[i; 16]));
    }

    #[test]
    fn a_concurrent_reader_only_ever_sees_whole_values_built_in_place() {
        reader_sees_whole_values(|w, _| {
            w.publish_with(|v| {
                for x in v.iter_mut() {
                    *x += 1;
                }
            })
        });
    }
}
