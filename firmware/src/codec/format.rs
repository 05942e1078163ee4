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
#[allow(clippy::excessive_precision)] // the robot writes such texts
mod tests {
    use super::*;
    extern crate std;
    use std::format;
    use std::string::String;

    fn real(x: f32, d: u8) -> String {
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        w.real(x, d);
        String::from_utf8(w.written().to_vec()).unwrap()
    }

    #[test]
    fn digit_count_is_exact_at_every_power_of_ten() {
        assert_eq!(digit_count(0), 1);
        assert_eq!(digit_count(u64::MAX), 20);
        let mut p = 1u64;
        for n in 1..=19 {
            assert_eq!(digit_count(p), n, "10^{}", n - 1);
            assert_eq!(
                digit_count(p - 1).max(1),
                (n - 1).max(1),
                "10^{} - 1",
                n - 1
            );
            assert_eq!(digit_count(p * 10 - 1), n, "10^{n} - 1");
            p *= 10;
        }
    }

    fn time(micros: i64, d: u8) -> String {
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        w.time(Time::from_micros(micros), d);
        String::from_utf8(w.written().to_vec()).unwrap()
    }

    #[test]
    fn m5_reals_have_fixed_decimals_and_no_exponent() {
        assert_eq!(real(232.661, 3), "232.661");
        assert_eq!(real(1620.293, 3), "1620.293");
        assert_eq!(real(0.0, 3), "0.000");
        assert_eq!(real(1.21592e-06, 3), "0.000");
        assert_eq!(real(-12345.678901, 3), "-12345.679");
        assert_eq!(real(1.5, 0), "2");
        assert_eq!(real(2.5, 0), "2");
        assert_eq!(real(1e20, 3), "100000002004087734272.000");
        assert_eq!(real(f32::MAX, 3).len(), 39 + 4);
        assert_eq!(real(f32::MIN, 3).len(), 1 + 39 + 4);
        assert_eq!(real(-0.0, 3), "0.000");
        assert_eq!(real(-0.0001, 3), "0.000");
        assert_eq!(real(f32::from_bits(1), 6), "0.000000");
    }

    #[test]
    fn m5_non_finite_is_written_as_zero_and_reported() {
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf);
        assert!(!w.real(f32::NAN, 3));
        assert!(!w.real(f32::INFINITY, 2));
        assert_eq!(w.written(), b"0.0000.00");
    }

    #[test]
    fn m5_reals_match_core_fmt_on_many_values() {
        // core::fmt is the oracle here (host test only): same digits,
        // except that we never write "-0.000".
        let mut next = crate::codec::xorshift32(0x1234_5678);
        for _ in 0..200_000 {
            let v = f32::from_bits(next());
            if !v.is_finite() {
                continue;
            }
            for d in 0..=MAX_DECIMALS {
                let mut want = format!("{:.*}", usize::from(d), v);
                if want.starts_with('-') && want.bytes().all(|b| matches!(b, b'-' | b'0' | b'.')) {
                    want.remove(0);
                }
                assert_eq!(real(v, d), want, "{v:e} with {d} decimals");
            }
        }
    }

    #[test]
    fn m5_times_are_exact() {
        assert_eq!(time(1_234_000, 3), "1.234");
        assert_eq!(time(765_315_969, 3), "765.316");
        assert_eq!(time(765_315_969, 6), "765.315969");
        assert_eq!(time(86_400_123_000, 3), "86400.123");
        assert_eq!(time(-1_500, 3), "-0.002");
        assert_eq!(time(-499, 3), "0.000");
        assert_eq!(time(7, 0), "0");
    }

    /// What we send, we accept: at the ends of the range, rounding half
    /// away from zero would write a time no `Time` holds (the decoder,
    /// exact, refuses `-9223372036854.776`), so there it rounds towards
    /// zero. Found by the `decode_manual` fuzz corpus once the least time
    /// was accepted (issue 36).
    #[test]
    fn the_ends_of_the_range_round_to_a_time_that_is_accepted() {
        for (micros, d, want) in [
            (i64::MIN, 3, "-9223372036854.775"),
            (i64::MAX, 3, "9223372036854.775"),
            (i64::MIN, 6, "-9223372036854.775808"),
            (i64::MAX, 0, "9223372036854"),
            (i64::MIN + 500, 3, "-9223372036854.775"),
            (i64::MAX - 1_000, 3, "9223372036854.775"),
        ] {
            let text = time(micros, d);
            assert_eq!(text, want);
            assert!(
                crate::codec::number::parse_time(text.as_bytes()).is_ok(),
                "{text} is refused"
            );
        }
        // Short of the ends, half away from zero as before.
        assert_eq!(time(-9_223_372_036_854_774_500, 3), "-9223372036854.775");
        assert_eq!(time(9_223_372_036_854_774_500, 3), "9223372036854.775");
        assert_eq!(time(9_223_372_036_854_774_499, 3), "9223372036854.774");
    }

    /// Times of ±(10^k − 1) and ±10^k µs with 6 decimals, 8 to 21
    /// characters: every length, below 2^32 µs through `fixed_u32`, above
    /// it through `long`.
    #[test]
    fn m5_times_of_every_length_through_both_paths() {
        for k in 0..=18 {
            let p = 10i64.pow(k);
            for micros in [p - 1, p, 1 - p, -p] {
                let m = micros.unsigned_abs();
                let sign = if micros < 0 { "-" } else { "" };
                let want = format!("{sign}{}.{:06}", m / 1_000_000, m % 1_000_000);
                assert_eq!(time(micros, 6), want);
            }
        }
    }

    /// A real needs its own length of room, not `fixed`'s whole window:
    /// with less than the window left it is written by the long path,
    /// the same text; with less than its length, nothing, and flagged.
    /// The window's bytes past the text are left as they were.
    #[test]
    fn a_real_fits_exactly_at_the_end_of_the_buffer() {
        let text = b"-1234.567";
        for room in 0..=WINDOW + 2 {
            let mut buf = [b'#'; 32];
            let mut w = Writer::new(&mut buf[..room]);
            w.real(-1234.567, 3);
            let fits = room >= text.len();
            let want: &[u8] = if fits { text } else { b"" };
            assert_eq!((w.written(), w.overflowed()), (want, !fits), "room {room}");
            let end = want.len();
            assert!(buf[end..].iter().all(|&b| b == b'#'), "room {room}");
        }
    }

    #[test]
    fn writer_never_overruns() {
        let mut buf = [0u8; 4];
        let mut w = Writer::new(&mut buf);
        w.real(1234.5, 3);
        assert!(w.overflowed());
        assert!(w.len() <= 4);
    }
}
