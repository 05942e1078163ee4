//! [`Big`]: the fixed-size integer `codec::exact` compares a decimal with
//! an `f32` midpoint in. Apart from the conversion's logic, so that each
//! reads in one sitting.

use super::WORDS;
use core::cmp::Ordering;

/// A non-negative integer of at most [`WORDS`] 32-bit words, little end
/// first. Operations that would not fit set `overflow` instead.
#[derive(Clone)]
pub(super) struct Big {
    words: [u32; WORDS],
    len: usize,
    /// An operation did not fit: the result is not to be trusted.
    pub(super) overflow: bool,
}

impl Big {
    pub(super) fn from_u64(v: u64) -> Self {
        let mut b = Big {
            words: [0; WORDS],
            len: 0,
            overflow: false,
        };
        b.words[0] = v as u32;
        b.words[1] = (v >> 32) as u32;
        b.len = 2;
        b.trim();
        b
    }

    fn trim(&mut self) {
        while self.len > 0 && self.words.get(self.len - 1) == Some(&0) {
            self.len -= 1;
        }
    }

    fn push(&mut self, w: u32) {
        match self.words.get_mut(self.len) {
            Some(slot) => {
                *slot = w;
                self.len += 1;
            }
            None => self.overflow = true,
        }
    }

    /// The words in use.
    #[inline(always)]
    fn used(&self) -> &[u32] {
        self.words.get(..self.len).unwrap_or(&[])
    }

    /// `self = self × m + a`.
    #[inline(always)]
    pub(super) fn mul_add(&mut self, m: u32, a: u32) {
        let mut carry = u64::from(a);
        if let Some(used) = self.words.get_mut(..self.len) {
            for w in used {
                let v = u64::from(*w) * u64::from(m) + carry;
                *w = v as u32;
                carry = v >> 32;
            }
        }
        if carry != 0 {
            self.push(carry as u32);
        }
    }

    pub(super) fn mul_pow5(&mut self, mut k: u32) {
        const POW5: [u32; 14] = [
            1,
            5,
            25,
            125,
            625,
            3_125,
            15_625,
            78_125,
            390_625,
            1_953_125,
            9_765_625,
            48_828_125,
            244_140_625,
            1_220_703_125,
        ];
        while k > 0 {
            // `step <= 13`: always in the table (the fallback is dead).
            let step = k.min(13);
            self.mul_add(POW5.get(step as usize).copied().unwrap_or(1), 0);
            k -= step;
        }
    }

    /// `self <<= bits`, in place from the top down: the word that lands
    /// at `i + words` is made of words `i` and `i - 1`, which are not
    /// written yet.
    pub(super) fn shl(&mut self, bits: u32) {
        if self.len == 0 {
            return;
        }
        let (words, bits) = ((bits / 32) as usize, bits % 32);
        let old = self.len;
        let len = old + words + 1;
        if len > WORDS {
            self.overflow = true;
            return;
        }
        let mut above = 0u32;
        for i in (0..old).rev() {
            let w = self.words.get(i).copied().unwrap_or(0);
            if let Some(slot) = self.words.get_mut(i + words + 1) {
                // `bits == 0`: `w >> 32` would overflow; nothing moves up.
                *slot = above << bits | w.checked_shr(32 - bits).unwrap_or(0);
            }
            above = w;
        }
        if let Some(slot) = self.words.get_mut(words) {
            *slot = above << bits;
        }
        if let Some(low) = self.words.get_mut(..words) {
            low.fill(0);
        }
        self.len = len;
        self.trim();
    }

    pub(super) fn cmp(&self, other: &Big) -> Ordering {
        self.len
            .cmp(&other.len)
            .then_with(|| self.used().iter().rev().cmp(other.used().iter().rev()))
    }
}
