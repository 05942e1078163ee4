//! Exact decimal → `f32` for the texts the fast paths in
//! [`super::number`] cannot take: more than 19 significant digits, a power
//! of ten beyond 10^22, or a value on an `f32` midpoint.
//!
//! `core`'s parser does this too, but it brings a 10 KiB table of 128-bit
//! powers of five and a 768-digit decimal buffer (14 KiB of flash in all,
//! a quarter of the boards' budget), and its slow path grows with the
//! length of the text. Here the work is bounded by a constant:
//!
//! 1. Only the first [`KEPT`] significant digits count; the rest only say
//!    whether the value is a little above them (`sticky`). That is enough
//!    because the exact decimal expansion of an `f32` midpoint (`m × 2^q`,
//!    `m < 2^25`, `q ≥ -150`) has at most 113 significant digits: a value
//!    cut after 120 digits compares with a midpoint exactly as the whole
//!    value does, the cut-off digits only breaking a tie upwards.
//! 2. An approximation in `f64` (a few `f64` ulps off, far below an `f32`
//!    ulp) gives a candidate that is right or one `f32` step away.
//! 3. The candidate is checked against the midpoints to its neighbours by
//!    comparing `D × 10^e` with `m × 2^q` exactly, in a fixed 448-bit
//!    integer (the largest operand needs about 430 bits), and moved at most
//!    a step or two. Ties round to even.

use super::number::{NumberError, POW10_F64};
use core::cmp::Ordering;

/// Significant digits taken exactly (see the module doc for why 120).
const KEPT: usize = 120;
/// 32-bit words in [`Big`]: 448 bits, for the largest operand's 430 (the
/// bound test, `big_never_overflows_within_bounds`, holds it to that).
const WORDS: usize = 14;
/// Beyond these, a value is out of range (≥ 10^39 > `f32::MAX`) or rounds
/// to zero (< 10^-46 < 2^-150, half the smallest subnormal).
const MAX_MAGNITUDE: i32 = 38;
const MIN_MAGNITUDE: i32 = -46;

/// A decimal text cut to its first [`KEPT`] significant digits:
/// `value × 10^exponent`, plus `sticky` when non-zero digits were cut.
struct Cut {
    /// The kept digits as an integer.
    value: Big,
    /// The first 19 kept digits (all of them when fewer): the
    /// approximation's mantissa.
    lead: u64,
    kept: usize,
    exponent: i32,
    sticky: bool,
}

/// A decimal as the scanner in [`super::number`] found it: the digits
/// before the point and after it (sign and point left out), and the
/// written exponent.
#[derive(Clone, Copy, Debug)]
pub struct Parts<'t> {
    /// The digits before the point.
    pub int: &'t [u8],
    /// The digits after the point.
    pub fraction: &'t [u8],
    /// The exponent after `e`/`E` (0 without one).
    pub exponent: i32,
}

#[cfg(test)]
impl<'t> Parts<'t> {
    /// The parts of a text already known to be a decimal (sign, digits,
    /// optional fraction, optional exponent): [`parse_magnitude`]'s way in.
    fn of(t: &'t [u8]) -> Self {
        let t = match t.split_first() {
            Some((b'+' | b'-', rest)) => rest,
            _ => t,
        };
        let (int, rest) = split(t, digit_count(t));
        let (fraction, rest) = match rest.split_first() {
            Some((b'.', after)) => split(after, digit_count(after)),
            _ => (&[][..], rest),
        };
        Parts {
            int,
            fraction,
            exponent: written_exponent(rest),
        }
    }
}

/// The cut significant digits of a decimal. The digits go into `value`
/// eight at a time, each eight two word steps ([`eight`]) and one
/// multiply-add of the big integer: a hostile message may hold dozens of
/// 48-character numbers that all come here.
fn cut(
    Parts {
        int,
        fraction,
        exponent,
    }: Parts<'_>,
) -> Cut {
    // Leading zeros count for nothing before the point; after it (when
    // nothing came before) each moves the point one place.
    let (_, int) = split(int, zeros(int));
    let (skipped, fraction) = match int.is_empty() {
        true => split(fraction, zeros(fraction)),
        false => (&[][..], fraction),
    };
    let kept = (int.len() + fraction.len()).min(KEPT);
    let (int_kept, int_cut) = split(int, kept);
    let (fraction_kept, fraction_cut) = split(fraction, kept - int_kept.len());
    let mut value = Big::from_u64(0);
    // The first 19 digits as a `u64` too, from the same pieces (a second
    // pass over them cost the hostile worst case 2,900 instructions).
    let mut lead = Lead::default();
    for run in [int_kept, fraction_kept] {
        let mut pieces = run.chunks_exact(8);
        for piece in &mut pieces {
            let v = eight(piece);
            value.mul_add(100_000_000, v);
            lead.push(v, 8);
        }
        let rest = pieces.remainder();
        if !rest.is_empty() {
            let v = rest
                .iter()
                .fold(0u32, |v, &b| v * 10 + u32::from(b.wrapping_sub(b'0')));
            value.mul_add(pow10_u32(rest.len()), v);
            lead.push(v, rest.len());
        }
    }
    let sticky = int_cut.iter().chain(fraction_cut).any(|&b| b != b'0');
    // Cut digits before the point still scale the value; kept ones after
    // it divide it.
    let places = int_cut.len() as i32 - fraction_kept.len() as i32 - skipped.len() as i32;
    Cut {
        value,
        lead: lead.value,
        kept,
        exponent: exponent.saturating_add(places),
        sticky,
    }
}

/// The first 19 digits of a number as they go by in pieces.
#[derive(Default)]
struct Lead {
    value: u64,
    digits: usize,
}

impl Lead {
    /// A piece of `len` (at most 9) digits worth `v`: as many of them as
    /// still fit the 19.
    #[inline(always)]
    fn push(&mut self, v: u32, len: usize) {
        let take = len.min(19 - self.digits);
        if take > 0 {
            let head = v / pow10_u32(len - take);
            self.value = self.value * u64::from(pow10_u32(take)) + u64::from(head);
            self.digits += take;
        }
    }
}

/// The value of eight ASCII digits, first digit most significant: four
/// at a time in a word (after `- '0'` each byte is 0..9; times 10 plus
/// the next byte gives two-digit values 0..99 in bytes 0 and 2, which
/// never carry), then the two halves. About a third of the instructions
/// of a byte at a time.
#[inline(always)]
fn eight(piece: &[u8]) -> u32 {
    let four = |w: Option<&[u8; 4]>| {
        let v = u32::from_le_bytes(w.copied().unwrap_or(*b"0000")).wrapping_sub(0x3030_3030);
        let v = v.wrapping_mul(10).wrapping_add(v >> 8);
        (v & 0xff) * 100 + ((v >> 16) & 0xff)
    };
    let (hi, lo) = piece.split_at_checked(4).unwrap_or((piece, &[]));
    four(hi.first_chunk::<4>()) * 10_000 + four(lo.first_chunk::<4>())
}

/// 10^n for a run of at most nine digits (1 beyond: never asked).
#[inline(always)]
fn pow10_u32(n: usize) -> u32 {
    POW10_U32.get(n).copied().unwrap_or(1)
}

/// Powers of ten that fit a `u32`: the scale of a run of up to nine digits.
const POW10_U32: [u32; 10] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
];

/// `t` split after `n` bytes (all of it in the first part when shorter).
fn split(t: &[u8], n: usize) -> (&[u8], &[u8]) {
    t.split_at_checked(n).unwrap_or((t, &[]))
}

/// How many `0` digits `t` starts with.
fn zeros(t: &[u8]) -> usize {
    t.iter().take_while(|&&b| b == b'0').count()
}

/// How many ASCII digits `t` starts with.
#[cfg(test)]
fn digit_count(t: &[u8]) -> usize {
    t.iter().take_while(|b| b.is_ascii_digit()).count()
}

/// The exponent after a mantissa (`e`/`E`, sign, digits), 0 without one;
/// clamped: anything this large is out of range anyway.
#[cfg(test)]
fn written_exponent(rest: &[u8]) -> i32 {
    let Some((b'e' | b'E', r)) = rest.split_first() else {
        return 0;
    };
    let (negative, digits) = match r.split_first() {
        Some((b'-', d)) => (true, d),
        Some((b'+', d)) => (false, d),
        _ => (false, r),
    };
    let e = digits
        .iter()
        .take_while(|b| b.is_ascii_digit())
        .fold(0i32, |e, &b| (e * 10 + i32::from(b - b'0')).min(100_000));
    if negative {
        -e
    } else {
        e
    }
}

/// `f32` bits as `mantissa × 2^exponent` (finite, non-negative values;
/// the bits just past `f32::MAX` stand for 2^128).
fn decompose(bits: u32) -> (u64, i32) {
    let biased = (bits >> 23) as i32;
    let fraction = u64::from(bits & 0x7f_ffff);
    if biased == 0 {
        (fraction, -149)
    } else {
        (fraction | 1 << 23, biased - 150)
    }
}

/// The midpoint between two adjacent `f32` bit patterns, `m × 2^q`.
fn midpoint(low: u32, high: u32) -> (u64, i32) {
    let (ml, ql) = decompose(low);
    let (mh, qh) = decompose(high);
    let q = ql.min(qh);
    ((ml << (ql - q)) + (mh << (qh - q)), q - 1)
}

/// Compares the cut decimal `D × 10^e` (`sticky`: a little more) with
/// `m × 2^q`, exactly.
fn compare(d: &Big, c: &Cut, (m, q): (u64, i32)) -> Result<Ordering, NumberError> {
    // D × 5^e × 2^e against m × 2^q: the powers of five go to the side
    // where they are positive, the powers of two likewise.
    let mut right = Big::from_u64(m);
    let shift = c.exponent - q;
    // The digits are copied only when they are scaled: a robot's reals
    // have a fraction (a negative exponent), and their midpoint a smaller
    // power of two, so usually only the midpoint's side grows.
    let mut scaled;
    let left = match c.exponent >= 0 || shift > 0 {
        true => {
            scaled = d.clone();
            scaled.mul_pow5(c.exponent.max(0).unsigned_abs());
            scaled.shl(shift.max(0).unsigned_abs());
            &scaled
        }
        false => d,
    };
    if c.exponent < 0 {
        right.mul_pow5(c.exponent.unsigned_abs());
    }
    if shift < 0 {
        right.shl(shift.unsigned_abs());
    }
    if left.overflow || right.overflow {
        // Cannot happen within the magnitude bounds (tested); refuse rather
        // than guess.
        return Err(NumberError::OutOfRange);
    }
    Ok(match left.cmp(&right) {
        Ordering::Equal if c.sticky => Ordering::Greater,
        o => o,
    })
}

/// An `f64` close to `digits × 10^exponent` (a few `f64` ulps off), from
/// the first 19 digits and exact powers of ten.
fn approximate(c: &Cut) -> f64 {
    let n = c.kept.min(19);
    let mut v = u64_to_f64(c.lead);
    // Within the magnitude bounds, |e| < 190: at most nine steps.
    let mut e = c.exponent + (c.kept - n) as i32;
    while e != 0 {
        // `step <= 22`: always in the table (the fallback is dead).
        let step = e.unsigned_abs().min(22);
        let p = POW10_F64.get(step as usize).copied().unwrap_or(1.0);
        if e > 0 {
            v *= p;
            e -= step as i32;
        } else {
            v /= p;
            e += step as i32;
        }
    }
    v
}

/// `v as f64`, from its two halves: each half and the high one's scaling
/// are exact, so the one addition is the only rounding, as in `as`. The
/// MCU's FPU converts 32-bit integers only; `as` is a library call there.
#[inline(always)]
fn u64_to_f64(v: u64) -> f64 {
    f64::from((v >> 32) as u32) * 4_294_967_296.0 + f64::from(v as u32)
}

/// How far (in `f64` ulps) [`approximate`] may be off, with a wide margin:
/// ≤ 19 digits exact in a `u64`, one rounding to `f64`, at most nine
/// multiplications or divisions by exact powers of ten (≤ 0.5 ulp each),
/// and the digits past 19 (< 10^-18 relative).
const APPROXIMATION_ULPS: u64 = 64;

/// The common case in two steps: when the approximation is far from every
/// `f32` midpoint, its rounding is the exact value's; when it is near one,
/// a single exact comparison with that midpoint decides. `None` near the
/// top of the range or below the smallest subnormal, where the general
/// loop runs.
fn settle_near(d: &Big, c: &Cut, approx: f64) -> Result<Option<f32>, NumberError> {
    const NEAR_MAX: f64 = 3.0e38;
    if approx >= NEAR_MAX {
        return Ok(None);
    }
    let bits = approx.to_bits();
    // The f64 mantissa bits below f32 precision: 29 for a normal f32,
    // more for a subnormal one (its spacing stays 2^-149).
    let exponent = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let width = 29 + (-126 - exponent).max(0).unsigned_abs();
    if width > 52 {
        return Ok(None);
    }
    let below_f32 = (1u64 << width) - 1;
    let midpoint_bits = 1u64 << (width - 1);
    if (bits & below_f32).abs_diff(midpoint_bits) > APPROXIMATION_ULPS {
        return Ok(Some(approx as f32));
    }
    // Near the midpoint between `below` (the approximation cut to `f32`
    // precision, exact) and the next `f32`.
    let below = (f64::from_bits(bits & !below_f32) as f32).to_bits();
    let above = below + 1;
    let v = match compare(d, c, midpoint(below, above))? {
        Ordering::Greater => above,
        Ordering::Less => below,
        Ordering::Equal if below & 1 == 0 => below,
        Ordering::Equal => above,
    };
    Ok(Some(f32::from_bits(v)))
}

/// The correctly rounded magnitude of a decimal text (sign ignored; the
/// caller has checked it is a decimal).
#[cfg(test)]
pub fn parse_magnitude(t: &[u8]) -> Result<f32, NumberError> {
    parse_parts(Parts::of(t))
}

/// The correctly rounded magnitude of a decimal. Bounded work: one pass
/// over its digits, then at most a few hundred word operations.
pub fn parse_parts(parts: Parts<'_>) -> Result<f32, NumberError> {
    let c = cut(parts);
    if c.kept == 0 {
        return Ok(0.0);
    }
    // The value lies in [10^magnitude, 10^(magnitude + 1)).
    let magnitude = c.exponent.saturating_add(c.kept as i32 - 1);
    if magnitude > MAX_MAGNITUDE {
        return Err(NumberError::OutOfRange);
    }
    if magnitude < MIN_MAGNITUDE {
        return Ok(0.0);
    }
    let d = &c.value;
    const INFINITY: u32 = 0x7f80_0000;
    let approx = approximate(&c);
    if let Some(v) = settle_near(d, &c, approx)? {
        return Ok(v);
    }
    let mut bits = (approx as f32).to_bits().min(INFINITY - 1);
    // The approximation is at most one step off; a few rounds settle it.
    for _ in 0..4 {
        let up = compare(d, &c, midpoint(bits, bits + 1))?;
        if up == Ordering::Greater || (up == Ordering::Equal && bits & 1 == 1) {
            bits += 1;
            if bits >= INFINITY {
                return Err(NumberError::OutOfRange);
            }
            continue;
        }
        if bits > 0 {
            let down = compare(d, &c, midpoint(bits - 1, bits))?;
            if down == Ordering::Less || (down == Ordering::Equal && bits & 1 == 1) {
                bits -= 1;
                continue;
            }
        }
        break;
    }
    Ok(f32::from_bits(bits))
}

#[path = "exact_big.rs"]
mod big;
use big::Big;

#[cfg(test)]
#[path = "exact_tests.rs"]
mod tests;
