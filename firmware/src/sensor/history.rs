//! The samples a sensor's cycle half sees: the last `N`, each with the
//! device time it was taken (T2: the device stamps its own data with its
//! own clock at the moment of sampling), so a reply can carry the sample
//! of the instant the robot's data belongs to, not merely the newest.

use crate::engine::Instant;

/// One sample and the device time it was taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamped<T> {
    /// When it was sampled, on the device clock (T2).
    pub time: Instant,
    /// What the sensor's sampling half returned.
    pub value: T,
}

/// The last `N` samples, in a ring: a new one replaces the oldest. `Copy`,
/// so the sampler can publish all of it at once through a
/// [`SampleCell`](crate::sample::SampleCell); every look-up is bounded by
/// `N`.
#[derive(Clone, Copy, Debug)]
pub struct History<T, const N: usize> {
    slots: [Option<Stamped<T>>; N],
    /// Where the next sample goes.
    next: usize,
}

impl<T: Copy, const N: usize> History<T, N> {
    /// No sample yet.
    pub const EMPTY: Self = History {
        slots: [None; N],
        next: 0,
    };

    /// Adds a sample, replacing the oldest when full.
    pub fn push(&mut self, sample: Stamped<T>) {
        if let Some(slot) = self.slots.get_mut(self.next) {
            *slot = Some(sample);
        }
        self.next = self.next.wrapping_add(1).checked_rem(N).unwrap_or(0);
    }

    /// The `k`-th newest sample (0: the newest), if there is one.
    pub fn get(&self, k: usize) -> Option<&Stamped<T>> {
        if k >= N {
            return None;
        }
        let i = (self.next + N - 1 - k).checked_rem(N)?;
        self.slots.get(i)?.as_ref()
    }

    /// The newest sample.
    pub fn latest(&self) -> Option<&Stamped<T>> {
        self.get(0)
    }

    /// Every sample, newest first.
    pub fn iter(&self) -> impl Iterator<Item = &Stamped<T>> + '_ {
        (0..N).map_while(|k| self.get(k))
    }

    /// How many samples it holds (at most `N`).
    pub fn len(&self) -> usize {
        self.iter().count()
    }

    /// `true` before the first sample.
    pub fn is_empty(&self) -> bool {
        self.latest().is_none()
    }

    /// The sample taken closest to `at` (of two equally close, the newer):
    /// the one that belongs to a robot position of device time `at`.
    pub fn closest(&self, at: Instant) -> Option<&Stamped<T>> {
        let distance = |s: &Stamped<T>| s.time.micros_since(at).max(at.micros_since(s.time));
        let mut best: Option<&Stamped<T>> = None;
        for s in self.iter() {
            if best.is_none_or(|b| distance(s) < distance(b)) {
                best = Some(s);
            }
        }
        best
    }

    /// The newest sample taken at or before `at`.
    pub fn at_or_before(&self, at: Instant) -> Option<&Stamped<T>> {
        self.iter().find(|s| s.time <= at)
    }
}

impl<T: Copy, const N: usize> Default for History<T, N> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// What the firmware needs of a sensor's [`Sensor::History`](super::Sensor::History):
/// an empty start and a way to add a sample. [`History`] is the one
/// implementation; the trait only lets the plumbing name it generically.
pub trait Ring<T>: Copy + Send {
    /// No sample yet.
    const EMPTY: Self;
    /// Adds a sample, replacing the oldest when full.
    fn push(&mut self, sample: Stamped<T>);
}

impl<T: Copy + Send, const N: usize> Ring<T> for History<T, N> {
    const EMPTY: Self = History::EMPTY;

    fn push(&mut self, sample: Stamped<T>) {
        History::push(self, sample);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(us: u64, value: u32) -> Stamped<u32> {
        Stamped {
            time: Instant(us),
            value,
        }
    }

    #[test]
    fn keeps_the_last_n_newest_first() {
        let mut h = History::<u32, 3>::EMPTY;
        assert!(h.is_empty() && h.latest().is_none() && h.iter().count() == 0);
        for i in 1..=5 {
            h.push(at(i * 10, i as u32));
        }
        let values: Vec<u32> = h.iter().map(|s| s.value).collect();
        assert_eq!(values, [5, 4, 3]);
        assert_eq!(h.len(), 3);
        assert_eq!(h.get(3), None);
        assert_eq!(h.latest(), Some(&at(50, 5)));
    }

    #[test]
    fn partly_filled_history_has_only_what_was_pushed() {
        let mut h = History::<u32, 8>::EMPTY;
        h.push(at(1, 1));
        h.push(at(2, 2));
        assert_eq!(h.iter().map(|s| s.value).collect::<Vec<_>>(), [2, 1]);
        assert_eq!(h.get(2), None);
    }

    #[test]
    fn closest_picks_the_nearest_sample_either_side_t2() {
        let mut h = History::<u32, 8>::EMPTY;
        for (t, v) in [(1000, 1), (2000, 2), (3000, 3), (4000, 4)] {
            h.push(at(t, v));
        }
        assert_eq!(h.closest(Instant(2400)).map(|s| s.value), Some(2));
        assert_eq!(h.closest(Instant(2600)).map(|s| s.value), Some(3));
        assert_eq!(
            h.closest(Instant(2500)).map(|s| s.value),
            Some(3),
            "tie: the newer"
        );
        assert_eq!(h.closest(Instant(0)).map(|s| s.value), Some(1));
        assert_eq!(h.closest(Instant(9_000)).map(|s| s.value), Some(4));
        assert_eq!(h.at_or_before(Instant(2999)).map(|s| s.value), Some(2));
        assert_eq!(h.at_or_before(Instant(999)), None);
        assert_eq!(History::<u32, 4>::EMPTY.closest(Instant(5)), None);
    }

    #[test]
    fn an_empty_ring_holds_nothing() {
        let mut h = History::<u32, 0>::EMPTY;
        h.push(at(1, 1));
        assert!(h.is_empty());
        assert_eq!(h.closest(Instant(1)), None);
    }
}
