//! Numbers on the wire (M5): parsing any decimal notation the controller
//! writes, and writing fixed decimals without `core::fmt` float formatting
//! (which costs ~25k instructions per message and ~16 KB of flash).
//!
//! Every function here does bounded work: parsing is linear in the text,
//! writing at most 40 integer digits plus the decimals.

use crate::value::Time;

/// Most decimals the fixed-point writers support (time is held in µs).
pub const MAX_DECIMALS: u8 = 6;

const POW10: [u64; 7] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000];

/// A number that could not be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumberError {
    /// Not a decimal number.
    Syntax,
    /// A number, but outside what the type can hold.
    OutOfRange,
    /// Longer than [`MAX_NUMBER_LEN`] characters.
    TooLong,
}

/// The longest number text accepted (whitespace around it aside): what
/// the generated `MAX_RECEIVE_LEN` allows each value (`sizes.rs` in
/// gsi-codegen), far more than the 9 significant digits of an `f32` a
/// controller writes. A longer text is refused before any arithmetic, so
/// a number's cost is bounded whatever the datagram holds.
pub const MAX_NUMBER_LEN: usize = 48;

/// Strips XML whitespace (space, tab, CR, LF) from both ends.
pub fn trim(s: &[u8]) -> &[u8] {
    let is_ws = |b: &u8| matches!(b, b' ' | b'\t' | b'\r' | b'\n');
    let start = s.iter().position(|b| !is_ws(b)).unwrap_or(s.len());
    let end = s.iter().rposition(|b| !is_ws(b)).map_or(start, |e| e + 1);
    s.get(start..end).unwrap_or(&[])
}

/// The robot's message `Id`: an unsigned 32-bit decimal (S3), optional `+`.
pub fn parse_u32(text: &[u8]) -> Result<u32, NumberError> {
    let t = trim(text);
    let digits = t.strip_prefix(b"+").unwrap_or(t);
    if digits.is_empty() {
        return Err(NumberError::Syntax);
    }
    let mut v: u32 = 0;
    for &b in digits {
        if !b.is_ascii_digit() {
            return Err(NumberError::Syntax);
        }
        v = v
            .checked_mul(10)
            .and_then(|v| v.checked_add(u32::from(b - b'0')))
            .ok_or(NumberError::OutOfRange)?;
    }
    Ok(v)
}

/// Checks the shape of a decimal float: sign, digits, optional fraction,
/// optional exponent; no `inf`, `nan` or hex (which `f32::from_str` takes).
fn is_decimal(t: &[u8]) -> bool {
    let mut i = 0;
    if matches!(t.first(), Some(b'+' | b'-')) {
        i += 1;
    }
    let int_start = i;
    while t.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    let mut digits = i - int_start;
    if t.get(i) == Some(&b'.') {
        i += 1;
        let frac_start = i;
        while t.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        digits += i - frac_start;
    }
    if digits == 0 {
        return false;
    }
    if matches!(t.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(t.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let exp_start = i;
        while t.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        if i == exp_start {
            return false;
        }
    }
    i == t.len()
}

/// Exact powers of ten in `f32` (10^10 = 2^10 × 5^10 still fits 24 bits).
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// Exact powers of ten in `f64` (up to 10^22).
const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A decimal number split into `±mantissa × 10^exponent`, or why not.
struct Decimal {
    negative: bool,
    mantissa: u64,
    exponent: i32,
    /// More than 19 significant digits: the mantissa is cut, use the slow
    /// (exact) path.
    inexact: bool,
}

/// Splits decimal float text (already trimmed): sign, digits, optional
/// fraction, optional exponent; no `inf`, `nan` or hex.
fn split_decimal(t: &[u8]) -> Option<Decimal> {
    let (negative, rest) = match t.first() {
        Some(b'-') => (true, t.get(1..).unwrap_or(&[])),
        Some(b'+') => (false, t.get(1..).unwrap_or(&[])),
        _ => (false, t),
    };
    let mut d = Decimal {
        negative,
        mantissa: 0,
        exponent: 0,
        inexact: false,
    };
    // Integer digits, then fraction digits: up to 19 significant digits go
    // into the mantissa (another one cannot overflow a u64); the rest only
    // moves the exponent or makes the value inexact.
    const FULL: u64 = 1_000_000_000_000_000_000;
    let mut i = 0;
    while let Some(&b) = rest.get(i) {
        let digit = b.wrapping_sub(b'0');
        if digit > 9 {
            break;
        }
        if d.mantissa < FULL {
            d.mantissa = d.mantissa * 10 + u64::from(digit);
        } else {
            d.inexact |= digit != 0;
            d.exponent += 1;
        }
        i += 1;
    }
    let mut digits = i;
    if rest.get(i) == Some(&b'.') {
        i += 1;
        let start = i;
        while let Some(&b) = rest.get(i) {
            let digit = b.wrapping_sub(b'0');
            if digit > 9 {
                break;
            }
            if d.mantissa < FULL {
                d.mantissa = d.mantissa * 10 + u64::from(digit);
                d.exponent -= 1;
            } else {
                d.inexact |= digit != 0;
            }
            i += 1;
        }
        digits += i - start;
    }
    if digits == 0 {
        return None;
    }
    if let Some(b'e' | b'E') = rest.get(i) {
        i += 1;
        let negative_exp = match rest.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let start = i;
        let mut e: i32 = 0;
        while let Some(&b) = rest.get(i) {
            let digit = b.wrapping_sub(b'0');
            if digit > 9 {
                break;
            }
            // Clamp: anything this large is out of range anyway.
            e = (e * 10 + i32::from(digit)).min(100_000);
            i += 1;
        }
        if i == start {
            return None;
        }
        d.exponent += if negative_exp { -e } else { e };
    }
    (i == rest.len()).then_some(d)
}

/// The common case of a robot's number in one pass: optional sign, at
/// most 10 characters of digits and one point, no exponent (`1620.000`,
/// `-0.0877707`). When the digits make an integer below 2^24, dividing it
/// by an exact power of ten (at most 10^10) is one correctly rounded `f32`
/// operation (Clinger's fast path); anything else returns `None` and takes
/// the general path.
fn plain_decimal(t: &[u8]) -> Option<f32> {
    let (negative, digits) = match t.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, t),
    };
    if digits.is_empty() || digits.len() > 10 {
        return None;
    }
    let mut m: u64 = 0;
    let mut fraction: usize = 0;
    let mut point = false;
    let mut count = 0;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d <= 9 {
            m = m * 10 + u64::from(d);
            count += 1;
            fraction += usize::from(point);
        } else if b == b'.' && !point {
            point = true;
        } else {
            return None;
        }
    }
    if count == 0 || m >= 1 << 24 {
        return None;
    }
    let v = m as f32 / *POW10_F32.get(fraction)?;
    Some(if negative { -v } else { v })
}

/// An RRI `real` (M5): any decimal float text, with sign and exponent,
/// surrounded by whitespace or not (`1.21592e-06`, ` -12345.678901 `),
/// correctly rounded; a finite text beyond `f32`'s range is
/// [`NumberError::OutOfRange`].
///
/// Fast paths (Clinger's): a mantissa of at most 24 bits and a power of
/// ten up to 10^10 is one exact `f32` operation; at most 53 bits and 10^22
/// is one exact `f64` operation, rounded once more to `f32` unless the
/// `f64` result sits exactly on an `f32` midpoint (the only case where two
/// roundings can differ from one). Everything else goes through
/// [`super::exact`], exact with bounded work and no tables.
pub fn parse_f32(text: &[u8]) -> Result<f32, NumberError> {
    let t = trim(text);
    if t.len() > MAX_NUMBER_LEN {
        return Err(NumberError::TooLong);
    }
    if let Some(v) = plain_decimal(t) {
        return Ok(v);
    }
    let d = split_decimal(t).ok_or(NumberError::Syntax)?;
    let exp = d.exponent.unsigned_abs() as usize;
    let fast = if d.inexact {
        None
    } else if let (true, Some(&p)) = (d.mantissa < 1 << 24, POW10_F32.get(exp)) {
        let m = d.mantissa as f32;
        Some(if d.exponent < 0 { m / p } else { m * p })
    } else if let (true, Some(&p)) = (d.mantissa < 1 << 53, POW10_F64.get(exp)) {
        let m = d.mantissa as f64;
        let v = if d.exponent < 0 { m / p } else { m * p };
        // The 29 bits of an f64 mantissa below f32 precision; exactly half
        // means the value sits on an f32 midpoint.
        let midpoint = v.to_bits() & ((1 << 29) - 1) == 1 << 28;
        (!midpoint).then_some(v as f32)
    } else if d.mantissa == 0 {
        Some(0.0)
    } else {
        None
    };
    let v = match fast {
        Some(v) if d.negative => -v,
        Some(v) => v,
        None => {
            let v = super::exact::parse_magnitude(t)?;
            if d.negative {
                -v
            } else {
                v
            }
        }
    };
    if v.is_finite() {
        Ok(v)
    } else {
        Err(NumberError::OutOfRange)
    }
}

/// An RRI `time` (seconds) as exact microseconds: decimal digits are taken
/// as written, never through a float, so `86400.123` is exactly
/// 86 400 123 000 µs. More than 6 decimals round half away from zero.
///
/// ```
/// use rri_firmware::codec::number::parse_time;
/// assert_eq!(parse_time(b"86400.123").map(|t| t.as_micros()), Ok(86_400_123_000));
/// assert_eq!(parse_time(b" 1.5e-3 ").map(|t| t.as_micros()), Ok(1_500));
/// ```
pub fn parse_time(text: &[u8]) -> Result<Time, NumberError> {
    let t = trim(text);
    if t.len() > MAX_NUMBER_LEN {
        return Err(NumberError::TooLong);
    }
    if !is_decimal(t) {
        return Err(NumberError::Syntax);
    }
    let (negative, rest) = match t.first() {
        Some(b'-') => (true, t.get(1..).unwrap_or(&[])),
        Some(b'+') => (false, t.get(1..).unwrap_or(&[])),
        _ => (false, t),
    };
    // Mantissa digits (up to 19 significant) and the power of ten they
    // are scaled by.
    let mut mantissa: u64 = 0;
    let mut scale: i32 = 0;
    let mut significant = 0u32;
    // The first digit past 19 significant ones, for rounding.
    let mut round_digit: Option<u8> = None;
    let mut seen_dot = false;
    let mut i = 0;
    while let Some(&b) = rest.get(i) {
        match b {
            b'0'..=b'9' => {
                let d = b - b'0';
                if significant < 19 {
                    if mantissa != 0 || d != 0 {
                        significant += 1;
                    }
                    mantissa = mantissa * 10 + u64::from(d);
                    if seen_dot {
                        scale -= 1;
                    }
                } else {
                    // Digits past 19 significant: only the first one
                    // matters for rounding (the rest is below it).
                    if round_digit.is_none() {
                        round_digit = Some(d);
                    }
                    if !seen_dot {
                        scale += 1;
                    }
                }
            }
            b'.' => seen_dot = true,
            _ => break,
        }
        i += 1;
    }
    if matches!(rest.get(i), Some(b'e' | b'E')) {
        let exp = rest.get(i + 1..).unwrap_or(&[]);
        let (eneg, edigits) = match exp.first() {
            Some(b'-') => (true, exp.get(1..).unwrap_or(&[])),
            Some(b'+') => (false, exp.get(1..).unwrap_or(&[])),
            _ => (false, exp),
        };
        let mut e: i32 = 0;
        for &b in edigits {
            // Clamp: anything this large is out of range anyway.
            e = (e * 10 + i32::from(b - b'0')).min(10_000);
        }
        scale += if eneg { -e } else { e };
    }
    // micros = mantissa × 10^(scale + 6)
    let shift = scale + 6;
    let micros: u64 = if mantissa == 0 {
        0
    } else if shift >= 0 {
        let mut v = mantissa;
        for _ in 0..shift {
            v = v.checked_mul(10).ok_or(NumberError::OutOfRange)?;
        }
        v
    } else {
        let drop = (-shift) as u32;
        if drop > 19 {
            // Smaller than 0.5 µs unless the mantissa rounds up, which it
            // cannot with 19 digits dropped below the unit.
            0
        } else {
            // 10^drop ≤ 10^19 fits; checked so no division by zero path
            // exists at all (cargo panic-check).
            let div = 10u64.checked_pow(drop).ok_or(NumberError::OutOfRange)?;
            let q = mantissa.checked_div(div).ok_or(NumberError::OutOfRange)?;
            let r = mantissa.checked_rem(div).ok_or(NumberError::OutOfRange)?;
            // Half away from zero (on the magnitude); digits dropped past
            // the 19th are below `r`'s unit and cannot change the outcome.
            if r >= div / 2 {
                q + 1
            } else {
                q
            }
        }
    };
    // With nothing dropped below the microsecond, a 20th significant digit
    // is the next one (with more integer digits it is out of range anyway).
    let micros = if shift >= 0 && round_digit.is_some_and(|d| d >= 5) {
        micros.checked_add(1).ok_or(NumberError::OutOfRange)?
    } else {
        micros
    };
    let micros = i64::try_from(micros).map_err(|_| NumberError::OutOfRange)?;
    Ok(Time::from_micros(if negative { -micros } else { micros }))
}

/// Decimal digits of `v` (at least one).
fn digit_count(v: u64) -> usize {
    let mut n = 1;
    let mut t = v;
    while t >= 10_000 {
        t /= 10_000;
        n += 4;
    }
    while t >= 10 {
        t /= 10;
        n += 1;
    }
    n
}

/// 10^n for n ≤ 6 (larger n is clamped).
fn pow10(n: u8) -> u64 {
    POW10.get(usize::from(n)).copied().unwrap_or(1_000_000)
}

/// Digits assembled right to left in a fixed buffer: 40 bytes hold the
/// 39 digits of `f32::MAX` and a sign, or a u64, a point, 6 decimals and a
/// sign. A push past the front is dropped (cannot happen with these sizes,
/// and is never a panic).
struct Backward {
    buf: [u8; 48],
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
        let [hi, lo] = DIGIT_PAIRS
            .get((v % 100) as usize)
            .copied()
            .unwrap_or([b'0'; 2]);
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

/// A byte sink with a fixed capacity that never panics: a write that does
/// not fit sets `overflow` and is dropped. Buffers are sized by the
/// generated maxima, so in the firmware it never overflows; the flag makes
/// sure a wrong size is an error, not memory corruption.
pub struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
    overflow: bool,
}

impl<'a> Writer<'a> {
    pub fn new(buf: &'a mut [u8]) -> Self {
        Writer {
            buf,
            len: 0,
            overflow: false,
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn overflowed(&self) -> bool {
        self.overflow
    }

    /// The bytes written so far.
    pub fn written(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    #[inline]
    pub fn bytes(&mut self, b: &[u8]) {
        let end = self.len + b.len();
        match self.buf.get_mut(self.len..end) {
            // Equal lengths by construction; zipped so no length-mismatch
            // panic path is left (cargo panic-check).
            Some(dst) if dst.len() == b.len() => {
                for (d, s) in dst.iter_mut().zip(b) {
                    *d = *s;
                }
                self.len = end;
            }
            _ => self.overflow = true,
        }
    }

    #[inline]
    pub fn byte(&mut self, b: u8) {
        match self.buf.get_mut(self.len) {
            Some(dst) => {
                *dst = b;
                self.len += 1;
            }
            None => self.overflow = true,
        }
    }

    /// Decimal digits of `v`.
    pub fn u64(&mut self, v: u64) {
        let mut d = Backward::new();
        d.integer(v);
        self.bytes(d.as_slice());
    }

    /// An `f32` with exactly `decimals` decimals, never exponent notation
    /// (M5), rounded half to even on the exact binary value. Non-finite
    /// values are written as zero; the return value says so, for counting.
    ///
    /// ```
    /// use rri_firmware::codec::number::Writer;
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
            // 2^24 and above: an integer of up to 39 digits, zero fraction.
            let mut v = u128::from(m) << e;
            let mut d = Backward::new();
            for _ in 0..decimals {
                d.push(b'0');
            }
            if decimals > 0 {
                d.push(b'.');
            }
            while v >= 1 << 64 {
                d.digit((v % 10) as u64);
                v /= 10;
            }
            d.integer(v as u64);
            if negative {
                d.push(b'-');
            }
            self.bytes(d.as_slice());
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

    /// `q / 10^decimals` with exactly `decimals` decimals, written straight
    /// into the output from its last digit backwards, two digits per
    /// division (the hot path of every sent real: no temporary, no copy).
    fn fixed(&mut self, negative: bool, q: u64, decimals: u8) {
        let frac = decimals.min(MAX_DECIMALS);
        let p = pow10(frac);
        let mut int = q / p;
        let mut f = q % p;
        let frac = usize::from(frac);
        let point = usize::from(frac > 0);
        let total = usize::from(negative) + digit_count(int) + point + frac;
        let start = self.len;
        let Some(dst) = self.buf.get_mut(start..start + total) else {
            self.overflow = true;
            return;
        };
        // `total` is exact, so the iterator ends exactly at the sign; a
        // miscount would drop digits, never panic.
        let mut out = dst.iter_mut().rev();
        macro_rules! put {
            ($b:expr) => {
                if let Some(x) = out.next() {
                    *x = $b;
                }
            };
        }
        macro_rules! pair {
            ($v:expr) => {
                let [hi, lo] = DIGIT_PAIRS.get($v as usize).copied().unwrap_or([b'0'; 2]);
                put!(lo);
                put!(hi);
            };
        }
        for _ in 0..frac / 2 {
            pair!(f % 100);
            f /= 100;
        }
        if frac % 2 == 1 {
            put!(b'0' + (f % 10) as u8);
        }
        if point == 1 {
            put!(b'.');
        }
        while int >= 100 {
            pair!(int % 100);
            int /= 100;
        }
        if int >= 10 {
            pair!(int);
        } else {
            put!(b'0' + int as u8);
        }
        if negative {
            put!(b'-');
        }
        self.len = start + total;
    }

    /// A time in seconds with exactly `decimals` decimals, rounded half
    /// away from zero from the exact microseconds.
    pub fn time(&mut self, t: Time, decimals: u8) {
        let decimals = decimals.min(MAX_DECIMALS);
        let micros = t.as_micros();
        let magnitude = micros.unsigned_abs();
        let unit = pow10(MAX_DECIMALS - decimals);
        let q = (magnitude + unit / 2) / unit;
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
        let mut x: u32 = 0x1234_5678;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let v = f32::from_bits(x);
            if !v.is_finite() {
                continue;
            }
            for d in [0u8, 3, 6] {
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
        assert_eq!(time(i64::MIN, 3), "-9223372036854.776");
        assert_eq!(time(7, 0), "0");
    }

    #[test]
    fn m5_reals_parse_in_any_decimal_notation() {
        assert_eq!(parse_f32(b"1620.0"), Ok(1620.0));
        assert_eq!(parse_f32(b" -12345.678901\n"), Ok(-12345.678901));
        assert_eq!(parse_f32(b"1.21592e-06"), Ok(1.21592e-06));
        assert_eq!(parse_f32(b"+.5E+1"), Ok(5.0));
        assert_eq!(parse_f32(b"7."), Ok(7.0));
        assert_eq!(parse_f32(b"1e39"), Err(NumberError::OutOfRange));
        for bad in [
            &b""[..],
            b" ",
            b"abc",
            b"1.2.3",
            b"inf",
            b"NaN",
            b"0x10",
            b"1e",
            b"--1",
            b"1 2",
            b".",
        ] {
            assert_eq!(
                parse_f32(bad),
                Err(NumberError::Syntax),
                "{:?}",
                core::str::from_utf8(bad)
            );
        }
    }

    #[test]
    fn m5_fast_paths_round_exactly_like_core() {
        // core's parser is the oracle: correctly rounded. Texts of every
        // shape the fast paths take or refuse.
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for _ in 0..300_000 {
            let r = next();
            let digits = 1 + (r % 20) as usize;
            let mut text = String::new();
            if r & 1 << 20 != 0 {
                text.push('-');
            }
            let mut m = next();
            for i in 0..digits {
                if i == (r >> 24) as usize % (digits + 1) {
                    text.push('.');
                }
                text.push((b'0' + (m % 10) as u8) as char);
                m /= 10;
            }
            if r & 1 << 21 != 0 {
                let e = (r >> 32) as i32 % 45;
                text.push_str(&format!("e{e}"));
            }
            let want = text.parse::<f32>().ok().filter(|v| v.is_finite());
            let got = parse_f32(text.as_bytes()).ok();
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{text}");
        }
        // Values printed by core (shortest round-trip) read back exactly.
        let mut y: u32 = 1;
        for _ in 0..200_000 {
            y ^= y << 13;
            y ^= y >> 17;
            y ^= y << 5;
            let v = f32::from_bits(y);
            if v.is_finite() {
                for text in [format!("{v}"), format!("{v:e}"), format!("{v:.6}")] {
                    let want: f32 = text.parse().unwrap();
                    assert_eq!(
                        parse_f32(text.as_bytes()).map(f32::to_bits),
                        Ok(want.to_bits()),
                        "{text}"
                    );
                }
            }
        }
    }

    #[test]
    fn m5_times_parse_exactly_in_any_notation() {
        let t = |s: &[u8]| parse_time(s).map(Time::as_micros);
        assert_eq!(t(b"86400.123"), Ok(86_400_123_000));
        assert_eq!(t(b"765.315969"), Ok(765_315_969));
        assert_eq!(t(b" 1.200 "), Ok(1_200_000));
        assert_eq!(t(b"-0.5"), Ok(-500_000));
        assert_eq!(t(b"1.5e-3"), Ok(1_500));
        assert_eq!(t(b"2E3"), Ok(2_000_000_000));
        assert_eq!(t(b"0.0000005"), Ok(1), "half a µs rounds away from zero");
        assert_eq!(t(b"0.00000049"), Ok(0));
        assert_eq!(t(b"-0.0000005"), Ok(-1));
        assert_eq!(t(b"12345678901234567890123"), Err(NumberError::OutOfRange));
        assert_eq!(t(b"1e300"), Err(NumberError::OutOfRange));
        assert_eq!(t(b"1e-300"), Ok(0));
        assert_eq!(t(b"9223372036854.775807"), Ok(i64::MAX));
        assert_eq!(t(b"9223372036854.775808"), Err(NumberError::OutOfRange));
        assert_eq!(t(b"x"), Err(NumberError::Syntax));
        assert_eq!(t(b"inf"), Err(NumberError::Syntax));
    }

    #[test]
    fn s3_ids_are_u32() {
        assert_eq!(parse_u32(b"111"), Ok(111));
        assert_eq!(parse_u32(b" 4294967295 "), Ok(u32::MAX));
        assert_eq!(parse_u32(b"4294967296"), Err(NumberError::OutOfRange));
        assert_eq!(parse_u32(b"-1"), Err(NumberError::Syntax));
        assert_eq!(parse_u32(b"1.0"), Err(NumberError::Syntax));
        assert_eq!(parse_u32(b""), Err(NumberError::Syntax));
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
