//! Numbers written with a fixed number of decimals (M5), without
//! `core::fmt` float formatting (which costs ~25k instructions per message
//! and ~16 KB of flash): the number-writing methods of [`Writer`].
//!
//! Bounded work: at most 40 integer digits plus the decimals.

use super::writer::Writer;
use crate::value::Time;

/// Most decimals the fixed-point writers support (time is held in µs).
pub use rri_vocabulary::MAX_DECIMALS;

/// 10^0 to 10^19, every power of ten a `u64` holds: the decimals' scales
/// ([`pow10`]) and the bounds of [`digit_count`].
#[allow(clippy::indexing_slicing)] // evaluated at compile time
const POW10: [u64; 20] = {
    let mut t = [1u64; 20];
    let mut i = 1;
    while i < 20 {
        t[i] = t[i - 1] * 10;
        i += 1;
    }
    t
};

/// Decimal digits of `v` (at least one): the bit length gives ⌊log10⌋
/// within one (1233 / 4096 ≈ log10 2), and one comparison settles it; no
/// division, which a Cortex-M7 has no instruction for on a `u64`.
fn digit_count(v: u64) -> usize {
    let v = v | 1;
    let guess = (((u64::BITS - v.leading_zeros()) * 1233) >> 12) as usize;
    // `guess` ≤ 19 (64 bits × 1233 >> 12): the lookup always hits.
    let below = POW10.get(guess).is_some_and(|&p| v < p);
    guess + 1 - usize::from(below)
}

/// 10^n for n ≤ [`MAX_DECIMALS`] (larger n is clamped).
fn pow10(n: u8) -> u64 {
    POW10
        .get(usize::from(n.min(MAX_DECIMALS)))
        .copied()
        .unwrap_or(1_000_000)
}

/// Digits assembled right to left in a fixed buffer: 40 bytes hold the
/// 39 digits of `f32::MAX` and a sign, or a u64, a point, 6 decimals and a
/// sign. A push past the front is dropped (cannot happen with these sizes,
/// and is never a panic).
///
/// Invariant: `start <= buf.len()`. It starts at the end, and `push` only
/// moves it down onto a slot that exists; `as_slice` is the one place that
/// relies on it.
struct Backward {
    buf: [u8; 48],
    /// Where the digits begin; they run to the end of `buf`.
    start: usize,
}

impl Backward {
    fn new() -> Self {
        Backward {
            buf: [0; 48],
            start: 48,
        }
    }

    #[inline]
    fn push(&mut self, b: u8) {
        if let Some(i) = self.start.checked_sub(1) {
            if let Some(slot) = self.buf.get_mut(i) {
                *slot = b;
                self.start = i;
            }
        }
    }

    #[inline]
    fn digit(&mut self, v: u64) {
        self.push(b'0' + (v % 10) as u8);
    }

    /// Two digits of `v < 100`.
    #[inline]
    fn pair(&mut self, v: u64) {
        let [hi, lo] = digit_pair(v % 100);
        self.push(lo);
        self.push(hi);
    }

    /// All digits of `v`, at least one.
    fn integer(&mut self, mut v: u64) {
        while v >= 100 {
            self.pair(v % 100);
            v /= 100;
        }
        if v >= 10 {
            self.pair(v);
        } else {
            self.digit(v);
        }
    }

    fn as_slice(&self) -> &[u8] {
        // `start <= buf.len()` (the type's invariant): the empty fallback is
        // never taken; it only keeps a panic path out of the image.
        self.buf.get(self.start..).unwrap_or(&[])
    }
}

/// "00", "01", … "99": two digits per division.
#[allow(clippy::indexing_slicing)] // evaluated at compile time
const DIGIT_PAIRS: [[u8; 2]; 100] = {
    let mut t = [[0u8; 2]; 100];
    let mut i = 0;
    while i < 100 {
        t[i] = [b'0' + (i / 10) as u8, b'0' + (i % 10) as u8];
        i += 1;
    }
    t
};

/// The two digits of `v`, for `v < 100`: every caller passes a remainder
/// of 100 or a value it has just found below 100, so the lookup always
/// hits (the optimizer drops the check) and the `"00"` fallback is never
/// written. The one lookup of [`DIGIT_PAIRS`].
#[inline(always)]
pub(super) fn digit_pair(v: u64) -> [u8; 2] {
    DIGIT_PAIRS.get(v as usize).copied().unwrap_or([b'0'; 2])
}

/// [`fixed_u32`]'s window: 16 positions, and spare bytes after them so
/// that a digit pair at the last position (bytes 15 and 16) is in bounds
/// without a check.
const WINDOW: usize = 18;

/// The text of `v / 10^frac` with exactly `frac` decimals (and a sign),
/// `total` characters, at the start of `out`: right to left, two digits
/// per division by a constant, each position masked to the window so no
/// store needs a bounds check (`total` ≤ 12 for a `u32` at up to six
/// decimals, and exact; a miscount would misplace digits, never panic).
#[inline(always)]
fn fixed_u32(out: &mut [u8; WINDOW], negative: bool, mut v: u32, frac: usize, total: usize) {
    let mut at = total;
    macro_rules! put {
        ($b:expr) => {
            at = at.wrapping_sub(1);
            if let Some(x) = out.get_mut(at % 16) {
                *x = $b;
            }
        };
    }
    macro_rules! pair {
        ($v:expr) => {
            at = at.wrapping_sub(2);
            let i = at % 16;
            if let Some(two) = out.get_mut(i..i + 2) {
                two.copy_from_slice(&digit_pair(u64::from($v)));
            }
        };
    }
    for _ in 0..frac / 2 {
        pair!(v % 100);
        v /= 100;
    }
    if frac % 2 == 1 {
        put!(b'0' + (v % 10) as u8);
        v /= 10;
    }
    if frac > 0 {
        put!(b'.');
    }
    while v >= 100 {
        pair!(v % 100);
        v /= 100;
    }
    if v >= 10 {
        pair!(v);
    } else {
        put!(b'0' + v as u8);
    }
    if negative {
        put!(b'-');
    }
}

impl Writer<'_> {
    /// Decimal digits of `v`: a fixed-point value without decimals.
    pub fn u64(&mut self, v: u64) {
        self.fixed(false, v, 0);
    }

    /// An `f32` with exactly `decimals` decimals, never exponent notation
    /// (M5), rounded half to even on the exact binary value. Non-finite
    /// values are written as zero; the return value says so, for counting.
    ///
    /// ```
    /// use rri_firmware::codec::writer::Writer;
    /// let mut buf = [0u8; 32];
    /// let mut w = Writer::new(&mut buf);
    /// assert!(w.real(1.21592e-06, 3));
    /// w.byte(b' ');
    /// assert!(!w.real(f32::NAN, 3)); // written as zero, reported
    /// assert_eq!(w.written(), b"0.000 0.000");
    /// ```
    ///
    /// Integer arithmetic only: the f32 is `m × 2^e` with a 24-bit `m`, so
    /// `m × 10^decimals` fits a `u64` and one shift gives the rounded
    /// fixed-point value; values of 2^24 and more are integers (`m << e`).
    pub fn real(&mut self, x: f32, decimals: u8) -> bool {
        let decimals = decimals.min(MAX_DECIMALS);
        if !x.is_finite() {
            self.fixed(false, 0, decimals);
            return false;
        }
        let bits = x.to_bits();
        let negative = bits >> 31 == 1;
        let biased = ((bits >> 23) & 0xff) as i32;
        let frac = u64::from(bits & 0x007f_ffff);
        let (m, e) = if biased == 0 {
            (frac, -149)
        } else {
            (frac | 0x0080_0000, biased - 150)
        };
        if e >= 0 {
            // 2^24 and above: the integer m × 2^e, zero fraction; below
            // 2^64 / 10^decimals a fixed-point value like any other.
            let v = u128::from(m) << e;
            match u64::try_from(v)
                .ok()
                .and_then(|v| v.checked_mul(pow10(decimals)))
            {
                Some(q) => self.fixed(negative, q, decimals),
                None => self.long(negative, v, 0, usize::from(decimals)),
            }
            return true;
        }
        let scaled = m * pow10(decimals);
        let shift = (-e) as u32;
        let q = if shift >= 64 {
            0
        } else {
            let q = scaled >> shift;
            let r = scaled & ((1u64 << shift) - 1);
            let half = 1u64 << (shift - 1);
            if r > half || (r == half && q & 1 == 1) {
                q + 1
            } else {
                q
            }
        };
        self.fixed(negative && q != 0, q, decimals);
        true
    }

    /// `q / 10^decimals` with exactly `decimals` decimals (the hot path
    /// of every sent real), written by [`fixed_u32`] straight into the
    /// next bytes of the buffer ([`Writer::fill`]): no temporary, no
    /// copy, no per-byte bounds check. Values of 2^32 and more, and texts
    /// near the end of the buffer, take [`Writer::long`].
    fn fixed(&mut self, negative: bool, q: u64, decimals: u8) {
        let frac = usize::from(decimals.min(MAX_DECIMALS));
        let point = usize::from(frac > 0);
        // All of `q`'s digits, and at least one before the point.
        let digits = digit_count(q).max(frac + 1);
        let total = usize::from(negative) + digits + point;
        // Below 2^32 (every real a robot exchanges, at up to 6 decimals
        // below 4294.967296): 32-bit divisions, one instruction on a
        // Cortex-M7 where a `u64` one is a library call.
        let Ok(v) = u32::try_from(q) else {
            self.long(negative, 0, q, frac);
            return;
        };
        if !self.fill(total, |out: &mut [u8; WINDOW]| {
            fixed_u32(out, negative, v, frac, total)
        }) {
            self.long(negative, 0, q, frac);
        }
    }

    /// `whole + scaled / 10^decimals` with exactly `decimals` decimals:
    /// the fixed-point values [`Writer::fixed`] leaves (`whole` 0: 2^32
    /// and more, or too near the end of the buffer for its window), and integers of up to 39 digits (`f32` values from
    /// about 10^13 up to `f32::MAX`, `scaled` 0). Nine digits at a
    /// time by long division of 32-bit limbs: `u64` arithmetic only, no
    /// `u128` division (which a Cortex-M7 has no instruction for, and
    /// which costs about a kilobyte of code inline). Rare, so out of line.
    #[cold]
    #[inline(never)]
    fn long(&mut self, negative: bool, whole: u128, scaled: u64, decimals: usize) {
        const CHUNK: u64 = 1_000_000_000;
        let mut d = Backward::new();
        let mut f = scaled;
        for _ in 0..decimals {
            d.digit(f);
            f /= 10;
        }
        if decimals > 0 {
            d.push(b'.');
        }
        // What is left of `scaled` is whole units.
        let whole = whole + u128::from(f);
        let mut limbs = [
            (whole >> 96) as u32,
            (whole >> 64) as u32,
            (whole >> 32) as u32,
            whole as u32,
        ];
        // 2^128 < 10^45: five chunks of nine digits hold any `whole`.
        for _ in 0..5 {
            let mut r = 0u64;
            for limb in &mut limbs {
                let cur = r << 32 | u64::from(*limb);
                *limb = (cur / CHUNK) as u32;
                r = cur % CHUNK;
            }
            if limbs == [0; 4] {
                // The leading chunk: no leading zeros.
                d.integer(r);
                break;
            }
            for _ in 0..9 {
                d.digit(r % 10);
                r /= 10;
            }
        }
        if negative {
            d.push(b'-');
        }
        self.bytes(d.as_slice());
    }

    /// A time in seconds with exactly `decimals` decimals, rounded half
    /// away from zero from the exact microseconds; towards zero where away
    /// would leave the range a `Time` holds (the first and last 0.5 ms of
    /// it at 3 decimals), so that what we send, we accept.
    pub fn time(&mut self, t: Time, decimals: u8) {
        let decimals = decimals.min(MAX_DECIMALS);
        let micros = t.as_micros();
        let magnitude = micros.unsigned_abs();
        let unit = pow10(MAX_DECIMALS - decimals);
        // The largest magnitude a time of this sign holds, in µs.
        let limit = if micros < 0 {
            i64::MIN.unsigned_abs()
        } else {
            i64::MAX.unsigned_abs()
        };
        let q = magnitude.saturating_add(unit / 2) / unit;
        let q = if q.saturating_mul(unit) > limit {
            q.saturating_sub(1)
        } else {
            q
        };
        self.fixed(micros < 0 && q != 0, q, decimals);
    }
}

#[cfg(test)]
#[path = "format_tests.rs"]
mod tests;
