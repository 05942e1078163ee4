//! Numbers read from the wire (M5): any decimal notation the controller
//! writes, as `u32` Ids, `f32` reals and exact-microsecond times. Writing
//! numbers is [`super::format`]'s.
//!
//! One scanner (`split_decimal`) reads every time and every real that is
//! not in the robot's own notation; `parse_f32` first tries `plain`, which
//! reads that notation (`1620.000`, `-12345.678901`) with the same sign
//! and digit loop (`sign`, `digit_run`) and checks only what it can hold.
//! Every function here does bounded work, linear in the text (at most
//! [`MAX_NUMBER_LEN`] characters).

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

impl core::fmt::Display for NumberError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Syntax => "not a decimal number (M5)",
            Self::OutOfRange => "number beyond the range of its type (M5)",
            Self::TooLong => "number text too long to read (M5)",
        })
    }
}

impl core::error::Error for NumberError {}

/// The longest number text accepted (whitespace around it aside): what
/// the generated `MAX_RECEIVE_LEN` allows each value (`sizes.rs` in
/// gsi-codegen), far more than the 9 significant digits of an `f32` a
/// controller writes. A longer text is refused before any arithmetic, so
/// a number's cost is bounded whatever the datagram holds.
pub const MAX_NUMBER_LEN: usize = 48;

/// XML whitespace: space, tab, CR, LF. The one definition the number
/// parsers and the decoder's text handling share.
pub const fn is_xml_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n')
}

/// [`is_xml_space`] for `str` patterns (`trim_start_matches`).
pub fn is_xml_space_char(c: char) -> bool {
    u8::try_from(c).is_ok_and(is_xml_space)
}

/// Strips XML whitespace ([`is_xml_space`]) from both ends.
pub fn trim(s: &[u8]) -> &[u8] {
    // Whitespace is at most b' ': most texts have none at either end.
    if let [first, .., last] = s {
        if *first > b' ' && *last > b' ' {
            return s;
        }
    }
    let mut t = s;
    while let [b, rest @ ..] = t {
        if !is_xml_space(*b) {
            break;
        }
        t = rest;
    }
    while let [rest @ .., b] = t {
        if !is_xml_space(*b) {
            break;
        }
        t = rest;
    }
    t
}

/// Only XML whitespace (or nothing): the indentation between a message's
/// elements, which every datagram of a pretty-printing controller has.
pub fn blank(s: &[u8]) -> bool {
    s.iter().all(|&b| is_xml_space(b))
}

/// Splits off a leading sign: whether it was `-`, and the rest.
fn sign(t: &[u8]) -> (bool, &[u8]) {
    match t.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, t),
    }
}

/// The value of an ASCII digit, or `None`.
#[inline]
fn digit(b: u8) -> Option<u8> {
    let d = b.wrapping_sub(b'0');
    (d <= 9).then_some(d)
}

/// The robot's message `Id`: an unsigned 32-bit decimal (S3), optional `+`.
pub fn parse_u32(text: &[u8]) -> Result<u32, NumberError> {
    let (negative, digits) = sign(trim(text));
    if negative || digits.is_empty() {
        return Err(NumberError::Syntax);
    }
    let mut v: u32 = 0;
    for &b in digits {
        let d = digit(b).ok_or(NumberError::Syntax)?;
        v = v
            .checked_mul(10)
            .and_then(|v| v.checked_add(u32::from(d)))
            .ok_or(NumberError::OutOfRange)?;
    }
    Ok(v)
}

/// Exact powers of ten in `f32` (10^10 = 2^10 × 5^10 still fits 24 bits).
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// Exact powers of ten in `f64` (up to 10^22); `codec::exact` scales by
/// them too.
pub(super) const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A decimal number as `±mantissa × 10^exponent`, exact up to 19 digits.
struct Decimal<'t> {
    negative: bool,
    /// The number's while it has at most 19 digits ([`SAFE_DIGITS`]).
    mantissa: u64,
    /// The written exponent with the fraction digits' in it; like
    /// `mantissa`, the number's only while `long` is `None`.
    exponent: i32,
    /// More than 19 digits: `mantissa` and `exponent` are not the
    /// number's; [`Decimal::kept`] and [`Decimal::parts`] are.
    long: bool,
    /// The digits after the sign, how many there are before the point and
    /// after it: where `codec::exact` and [`Decimal::kept`] read them
    /// again, without scanning the text for them a second time.
    digits: &'t [u8],
    whole: usize,
    fraction: usize,
    /// The exponent as written (`0` without one).
    written_exponent: i32,
}

impl<'t> Decimal<'t> {
    /// The first 19 significant digits, the power of ten that goes with
    /// them and the first digit dropped (for rounding).
    fn kept(&self) -> (u64, i32, Option<u8>) {
        if !self.long {
            return (self.mantissa, self.exponent, None);
        }
        let (m, e, first_dropped) = long_mantissa(self.digits, self.whole, self.fraction);
        (m, e + self.written_exponent, first_dropped)
    }

    /// The number's digits before and after the point, and its written
    /// exponent, for `codec::exact`.
    fn parts(&self) -> super::exact::Parts<'t> {
        let (int, rest) = self
            .digits
            .split_at_checked(self.whole)
            .unwrap_or((self.digits, &[]));
        // After the integer digits: the point, then the fraction digits.
        let fraction = rest
            .get(1..)
            .and_then(|r| r.get(..self.fraction))
            .unwrap_or(&[]);
        super::exact::Parts {
            int,
            fraction,
            exponent: self.written_exponent,
        }
    }
}

/// Digits a `u64` mantissa takes without any check: 10^19 − 1 fits.
const SAFE_DIGITS: usize = 19;

/// How many digits `s` starts with, what follows them, and `m` with
/// those digits appended (wrapping, so exact only while the digits taken
/// in all are at most [`SAFE_DIGITS`]). One tight loop, nine instructions
/// a digit on x86-64 (each byte widened before the subtraction saves a
/// tenth): a robot's reals are 3 to 13 characters, and this loop is most
/// of their cost. (Four digits a word at a time, SWAR, measured slower on
/// the robot's short runs: a failed word test costs more than it saves.)
#[inline(always)]
fn digit_run(s: &[u8], mut m: u64) -> (usize, &[u8], u64) {
    let mut rest = s;
    while let [b, tail @ ..] = rest {
        let v = u64::from(*b).wrapping_sub(u64::from(b'0'));
        if v > 9 {
            break;
        }
        m = m.wrapping_mul(10).wrapping_add(v);
        rest = tail;
    }
    (s.len() - rest.len(), rest, m)
}

/// The exponent after a mantissa: `e` or `E`, an optional sign, at
/// least one digit, and nothing after them. Clamped at ±100 000: anything
/// that large is out of range anyway. Out of line: a robot writes none.
#[cold]
#[inline(never)]
fn exponent_part(rest: &[u8]) -> Option<i32> {
    let [b'e' | b'E', exp_text @ ..] = rest else {
        return None;
    };
    let (negative, exp) = sign(exp_text);
    if exp.is_empty() {
        return None;
    }
    let mut e: i32 = 0;
    for &b in exp {
        e = (e * 10 + i32::from(digit(b)?)).min(100_000);
    }
    Some(if negative { -e } else { e })
}

/// The first half of a decimal number: `[sign] digits [. digits]`.
struct Mantissa<'t> {
    negative: bool,
    /// The text after the sign.
    digits: &'t [u8],
    /// Digits before the point, and after it.
    whole: usize,
    fraction: usize,
    /// All those digits as one integer; exact while there are at most
    /// [`SAFE_DIGITS`] of them.
    value: u64,
    /// What follows the digits.
    rest: &'t [u8],
}

/// Reads the mantissa at the start of `t`: the first half of the one
/// decimal scanner.
#[inline(always)]
fn mantissa(t: &[u8]) -> Mantissa<'_> {
    let (negative, digits) = sign(t);
    let (whole, rest, value) = digit_run(digits, 0);
    let (fraction, rest, value) = match rest {
        [b'.', after @ ..] => digit_run(after, value),
        _ => (0, rest, value),
    };
    Mantissa {
        negative,
        digits,
        whole,
        fraction,
        value,
        rest,
    }
}

/// The one decimal scanner: splits trimmed text into a [`Decimal`], or
/// `None` when it is not `[sign] digits [. digits] [e [sign] digits]` with
/// at least one mantissa digit (so no `inf`, `nan` or hex, which
/// `f32::from_str` would take).
// Out of line: the robot's reals take `parse_f32`'s plain path (`plain`);
// times and everything else come here.
#[inline(never)]
fn split_decimal(t: &[u8]) -> Option<Decimal<'_>> {
    // A text longer than 19 digits, a sign and a point: its digits are
    // counted, not added up (a hostile message holds dozens of 48-digit
    // reals, and `codec::exact` folds their digits once anyway); when it
    // holds no more than 19 after all (an exponent made it long), they are
    // read again with their value, which costs at most 19 digits.
    let m = match t.len() > SAFE_DIGITS + 2 {
        true => match counted(t) {
            m if m.whole + m.fraction > SAFE_DIGITS => m,
            _ => mantissa(t),
        },
        false => mantissa(t),
    };
    let taken = m.whole + m.fraction;
    if taken == 0 {
        return None;
    }
    // After the digits: an exponent, or the end.
    let written_exponent = match m.rest {
        [] => 0,
        rest => exponent_part(rest)?,
    };
    Some(Decimal {
        negative: m.negative,
        mantissa: m.value,
        // While at most 19 digits: `fraction` ≤ 19 fits an i32.
        exponent: written_exponent - (m.fraction.min(SAFE_DIGITS) as i32),
        long: taken > SAFE_DIGITS,
        digits: m.digits,
        whole: m.whole,
        fraction: m.fraction,
        written_exponent,
    })
}

/// Clinger's fast paths: `mantissa × 10^exponent` correctly rounded with
/// one exact float operation, or `None` where that does not hold. A
/// mantissa of at most 24 bits and a power of ten up to 10^10 is one exact
/// `f32` operation (a robot's `1620.000` or `-0.0877707`); at most 53 bits
/// and 10^22 is one exact `f64` operation, rounded once more to `f32`
/// unless the `f64` result sits exactly on an `f32` midpoint (the only
/// case where two roundings can differ from one). Both results are finite
/// (below 2^53 × 10^22, under `f32::MAX`).
#[inline(always)]
fn clinger(mantissa: u64, exponent: i32) -> Option<f32> {
    let exp = exponent.unsigned_abs() as usize;
    if let (true, Some(&p)) = (mantissa < 1 << 24, POW10_F32.get(exp)) {
        let m = mantissa as f32;
        Some(if exponent < 0 { m / p } else { m * p })
    } else if let (true, Some(&p)) = (mantissa < 1 << 53, POW10_F64.get(exp)) {
        let m = mantissa as f64;
        let v = if exponent < 0 { m / p } else { m * p };
        // The 29 bits of an f64 mantissa below f32 precision; exactly half
        // means the value sits on an f32 midpoint.
        let midpoint = v.to_bits() & ((1 << 29) - 1) == 1 << 28;
        (!midpoint).then_some(v as f32)
    } else {
        None
    }
}

/// An RRI `real` (M5): any decimal float text, with sign and exponent,
/// surrounded by whitespace or not (`1.21592e-06`, ` -12345.678901 `),
/// correctly rounded; a finite text beyond `f32`'s range is
/// [`NumberError::OutOfRange`].
///
/// The robot's own notation (`1620.000`, `-12345.678901`: no whitespace,
/// no exponent, at most 19 digits) is one scan of its digits and one
/// float operation (Clinger's fast paths); anything else goes through the
/// whole scanner and, where no fast path holds, `codec::exact`, exact with
/// bounded work and no tables.
pub fn parse_f32(text: &[u8]) -> Result<f32, NumberError> {
    match plain(text) {
        Some(v) => Ok(v),
        None => parse_f32_general(text),
    }
}

/// The robot's plain notation, `[sign] digits [. digits]` with at most 19
/// digits and nothing else, by Clinger's fast paths; `None` for anything
/// else, or where no fast path holds.
#[inline(always)]
fn plain(text: &[u8]) -> Option<f32> {
    // Longer than 19 digits, a sign and a point: not plain (refused before
    // any digit is read, so a long hostile text costs nothing here).
    if text.len() > SAFE_DIGITS + 2 {
        return None;
    }
    match plain_scan(text)? {
        (negative, m, fraction, []) => plain_value(negative, m, fraction),
        _ => None,
    }
}

/// [`parse_f32`]'s plain path at the start of `text`, for the compiled
/// decode path (`codec::compiled`), which reads a value in place up to its
/// closing quote: the value and how many bytes it took. When the byte
/// after them cannot continue a number (a quote, `<`), `parse_f32` of
/// exactly those bytes gives the same value: both are [`plain_scan`] and
/// [`plain_value`] over the same digits. `None` where the plain path does
/// not hold.
#[inline(always)]
pub(crate) fn plain_prefix(text: &[u8]) -> Option<(f32, usize)> {
    let (negative, m, fraction, rest) = plain_scan(text)?;
    Some((plain_value(negative, m, fraction)?, text.len() - rest.len()))
}

/// The one plain scanner behind [`plain`] and [`plain_prefix`]: `[sign]
/// digits [. digits]` with 1 to 19 digits at the start of `text` (so at
/// most 21 bytes, though a longer digit run is read to its end before it
/// is refused): the sign, the digits as one integer, how many follow the
/// point, and what follows the number.
#[inline(always)]
fn plain_scan(text: &[u8]) -> Option<(bool, u64, usize, &[u8])> {
    let (negative, t) = sign(text);
    let (whole, rest, m) = digit_run(t, 0);
    let (m, fraction, rest) = match rest {
        [b'.', after @ ..] => {
            let (fraction, rest, m) = digit_run(after, m);
            (m, fraction, rest)
        }
        _ => (m, 0, rest),
    };
    (1..=SAFE_DIGITS)
        .contains(&(whole + fraction))
        .then_some((negative, m, fraction, rest))
}

/// A plain number's value by Clinger's fast paths (`fraction` ≤ 19).
#[inline(always)]
fn plain_value(negative: bool, m: u64, fraction: usize) -> Option<f32> {
    // `fraction` ≤ 19 fits an i32.
    let v = clinger(m, -(fraction as i32))?;
    Some(if negative { -v } else { v })
}

/// [`parse_f32`] for whatever is not the robot's plain notation:
/// whitespace, exponents, long mantissas, midpoints. Out of line, so the
/// plain path keeps its registers.
#[inline(never)]
pub(crate) fn parse_f32_general(text: &[u8]) -> Result<f32, NumberError> {
    let t = trim(text);
    if t.len() > MAX_NUMBER_LEN {
        return Err(NumberError::TooLong);
    }
    let d = split_decimal(t).ok_or(NumberError::Syntax)?;
    // More than 19 digits: straight to the exact path, which takes the
    // digits where the scan found them.
    let fast = match d.long {
        false => clinger(d.mantissa, d.exponent),
        true => None,
    };
    let v = match fast {
        Some(v) => v,
        None => exact_magnitude(d.parts())?,
    };
    Ok(if d.negative { -v } else { v })
}

/// The magnitude of a decimal where no fast path applies, by
/// `codec::exact`, with a result beyond `f32` refused. Out of line, so the
/// common path keeps its registers; not `#[cold]`, which would have it
/// built for size: it is the hostile worst case's path.
#[inline(never)]
fn exact_magnitude(parts: super::exact::Parts<'_>) -> Result<f32, NumberError> {
    let v = super::exact::parse_parts(parts)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(NumberError::OutOfRange)
    }
}

mod long;
mod time;
pub(crate) use long::digit_count;
use long::{counted, long_mantissa};
pub use time::parse_time;

#[cfg(test)]
#[path = "number_tests.rs"]
mod tests;
