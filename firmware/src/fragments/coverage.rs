//! Which 8-byte blocks of a datagram a set holds: a bit a block, read and
//! written a 64-bit word at a time. A 1,480-byte fragment is 185 blocks
//! and touches at most 4 words; block by block, the map cost the guard
//! more than copying the fragment.

const WORDS: usize = 16;
/// Blocks a map records.
pub(super) const BLOCKS: usize = WORDS * 64;

/// A set's blocks. All zeros is empty (so a `static` of them costs no
/// flash).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Coverage([u64; WORDS]);

impl Coverage {
    pub(super) const EMPTY: Coverage = Coverage([0; WORDS]);

    /// How many of blocks `first..last` are held; `None` when the range
    /// goes past the map.
    pub(super) fn held(&self, first: usize, last: usize) -> Option<usize> {
        let mut held = 0;
        for (i, mask) in words(first, last) {
            held += (self.0.get(i)? & mask).count_ones() as usize;
        }
        Some(held)
    }

    /// Marks blocks `first..last` held (those past the map are not: the
    /// reassembler refuses a set that long before it gets here).
    pub(super) fn mark(&mut self, first: usize, last: usize) {
        for (i, mask) in words(first, last) {
            if let Some(w) = self.0.get_mut(i) {
                *w |= mask;
            }
        }
    }
}

/// The words blocks `first..last` fall in, each with the mask of those
/// blocks.
fn words(first: usize, last: usize) -> impl Iterator<Item = (usize, u64)> {
    (first / 64..last.div_ceil(64)).map(move |i| {
        let base = i * 64;
        let lo = first.saturating_sub(base);
        let width = last.saturating_sub(base).min(64).saturating_sub(lo);
        // `width` ones from bit `lo`, with no shift by 64 (Rust refuses it).
        let ones = u64::MAX.checked_shr(64 - width as u32).unwrap_or(0);
        (i, ones.checked_shl(lo as u32).unwrap_or(0))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block at a time: the map as it was.
    #[derive(Clone)]
    struct Blocks(Vec<bool>);

    #[test]
    fn words_at_a_time_match_blocks_at_a_time() {
        let mut x: u32 = 7;
        let mut next = |n: usize| {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            (x >> 8) as usize % n
        };
        for _ in 0..300 {
            let (mut map, mut blocks) = (Coverage::EMPTY, Blocks(vec![false; BLOCKS]));
            for _ in 0..6 {
                let first = next(BLOCKS);
                let last = (first + 1 + next(200)).min(BLOCKS);
                let held = blocks.0[first..last].iter().filter(|b| **b).count();
                assert_eq!(map.held(first, last), Some(held), "{first}..{last}");
                map.mark(first, last);
                blocks.0[first..last].iter_mut().for_each(|b| *b = true);
                for (i, word) in map.0.iter().enumerate() {
                    for bit in 0..64 {
                        assert_eq!(word >> bit & 1 == 1, blocks.0[i * 64 + bit]);
                    }
                }
            }
        }
    }

    #[test]
    fn edges_of_words_and_of_the_map() {
        let mut map = Coverage::EMPTY;
        map.mark(63, 65);
        assert_eq!((map.0[0], map.0[1]), (1 << 63, 1));
        map.mark(0, 64);
        assert_eq!(map.0[0], u64::MAX);
        assert_eq!(map.held(0, 128), Some(65));
        assert_eq!(map.held(5, 5), Some(0));
        map.mark(BLOCKS - 1, BLOCKS);
        assert_eq!(map.held(BLOCKS - 64, BLOCKS), Some(1));
        // Past the map: no count, and nothing marked out of it.
        assert_eq!(map.held(BLOCKS - 1, BLOCKS + 1), None);
        map.mark(BLOCKS, BLOCKS + 64);
        assert_eq!(map.held(0, BLOCKS), Some(65 + 1));
    }
}
