//! Sampling runs elsewhere (a lower-priority task, an interrupt); the cycle
//! needs the latest consistent reading at once, without blocking. This is a
//! wait-free triple buffer for one writer and one reader, built on atomics
//! only (no locks, no `unsafe`): the writer fills the slot nobody reads and
//! swaps it into the middle; the reader swaps the middle out when it is
//! fresh. Neither ever waits for the other, whatever their priorities, so a
//! cycle that preempts the sampler mid-write still gets a whole reading.

use crate::engine::Instant;
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

/// A reading: `N` values and when the sampler took them (T2: the device's
/// own clock, at the moment of sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading<const N: usize> {
    /// The sensor's values, in the application's order and units.
    pub values: [f32; N],
    /// When they were sampled, on the device clock (T2).
    pub time: Instant,
}

/// One slot: values as `f32` bits and the time in two halves (the MCU has
/// no 64-bit atomics).
struct Slot<const N: usize> {
    values: [AtomicU32; N],
    time_lo: AtomicU32,
    time_hi: AtomicU32,
}

impl<const N: usize> Slot<N> {
    const fn new() -> Self {
        Slot {
            values: [const { AtomicU32::new(0) }; N],
            time_lo: AtomicU32::new(0),
            time_hi: AtomicU32::new(0),
        }
    }

    fn store(&self, r: &Reading<N>) {
        for (a, v) in self.values.iter().zip(r.values) {
            a.store(v.to_bits(), Ordering::Relaxed);
        }
        self.time_lo.store(r.time.0 as u32, Ordering::Relaxed);
        self.time_hi
            .store((r.time.0 >> 32) as u32, Ordering::Relaxed);
    }

    fn load(&self) -> Reading<N> {
        let mut values = [0.0; N];
        for (v, a) in values.iter_mut().zip(&self.values) {
            *v = f32::from_bits(a.load(Ordering::Relaxed));
        }
        let lo = u64::from(self.time_lo.load(Ordering::Relaxed));
        let hi = u64::from(self.time_hi.load(Ordering::Relaxed));
        Reading {
            values,
            time: Instant(hi << 32 | lo),
        }
    }
}

/// Bit 2 of the shared state: the middle slot holds a reading the reader
/// has not taken yet. Bits 0–1: the middle slot's index.
const FRESH: u8 = 0b100;
const INDEX: u8 = 0b011;

/// The shared part; put it in a `static` and [`SampleCell::split`] it once.
pub struct SampleCell<const N: usize> {
    slots: [Slot<N>; 3],
    middle: AtomicU8,
    split: AtomicBool,
}

impl<const N: usize> Default for SampleCell<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleCell<N> {
    /// An empty cell, not split yet (`const`, for a `static`).
    pub const fn new() -> Self {
        SampleCell {
            slots: [const { Slot::new() }; 3],
            middle: AtomicU8::new(1),
            split: AtomicBool::new(false),
        }
    }

    /// The writer and the reader. Only the first call gets them: there is
    /// exactly one of each.
    pub fn split(&self) -> Option<(SampleWriter<'_, N>, SampleReader<'_, N>)> {
        if self.split.swap(true, Ordering::AcqRel) {
            return None;
        }
        Some((
            SampleWriter {
                cell: self,
                back: 2,
            },
            SampleReader {
                cell: self,
                front: 0,
                has_reading: false,
            },
        ))
    }

    fn slot(&self, i: u8) -> Option<&Slot<N>> {
        self.slots.get(usize::from(i & INDEX))
    }
}

/// The sampler's end.
pub struct SampleWriter<'a, const N: usize> {
    cell: &'a SampleCell<N>,
    back: u8,
}

impl<const N: usize> SampleWriter<'_, N> {
    /// Publishes a reading; never waits.
    pub fn publish(&mut self, reading: &Reading<N>) {
        if let Some(slot) = self.cell.slot(self.back) {
            slot.store(reading);
        }
        let previous = self.cell.middle.swap(self.back | FRESH, Ordering::AcqRel);
        self.back = previous & INDEX;
    }
}

/// The cycle's end.
pub struct SampleReader<'a, const N: usize> {
    cell: &'a SampleCell<N>,
    front: u8,
    has_reading: bool,
}

impl<const N: usize> SampleReader<'_, N> {
    /// The latest whole reading, `None` before the first; never waits.
    pub fn latest(&mut self) -> Option<Reading<N>> {
        if self.cell.middle.load(Ordering::Acquire) & FRESH != 0 {
            let previous = self.cell.middle.swap(self.front, Ordering::AcqRel);
            self.front = previous & INDEX;
            self.has_reading = true;
        }
        if !self.has_reading {
            return None;
        }
        self.cell.slot(self.front).map(Slot::load)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    fn reading(v: f32, t: u64) -> Reading<2> {
        Reading {
            values: [v, -v],
            time: Instant(t),
        }
    }

    #[test]
    fn nothing_before_the_first_reading_then_always_the_latest() {
        let cell = SampleCell::<2>::new();
        let (mut w, mut r) = cell.split().expect("first split");
        assert!(cell.split().is_none(), "one writer, one reader");
        assert_eq!(r.latest(), None);
        w.publish(&reading(1.0, 10));
        w.publish(&reading(2.0, 20));
        assert_eq!(r.latest(), Some(reading(2.0, 20)));
        assert_eq!(r.latest(), Some(reading(2.0, 20)), "kept until a newer one");
        w.publish(&reading(3.0, u64::MAX));
        assert_eq!(r.latest(), Some(reading(3.0, u64::MAX)));
    }

    #[test]
    fn a_concurrent_reader_only_ever_sees_whole_readings() {
        // values[1] == -values[0] and time == values[0] in every reading
        // published; a torn read would break one of them.
        static CELL: SampleCell<2> = SampleCell::new();
        let (mut w, mut r) = CELL.split().expect("split");
        std::thread::scope(|s| {
            s.spawn(move || {
                for i in 1..200_000u32 {
                    w.publish(&reading(i as f32, u64::from(i) << 20));
                }
            });
            let mut last = 0.0;
            for _ in 0..200_000 {
                if let Some(x) = r.latest() {
                    assert_eq!(x.values[1], -x.values[0]);
                    assert_eq!(x.time.0, (x.values[0] as u64) << 20);
                    assert!(x.values[0] >= last, "never older than before");
                    last = x.values[0];
                }
            }
        });
    }
}
