//! The long texts' side of the number scanner: a mantissa of more than
//! [`super::SAFE_DIGITS`] digits (a robot writes at most 9 significant ones; a
//! hostile message dozens of 48-character reals). Apart from the robot's
//! plain path in `number.rs`.

use super::{sign, Mantissa};

/// [`mantissa`] without the value (`value` is 0): the digits counted four
/// at a time ([`digit_count`]).
#[inline(always)]
pub(super) fn counted(t: &[u8]) -> Mantissa<'_> {
    let (negative, digits) = sign(t);
    let whole = digit_count(digits);
    let rest = digits.get(whole..).unwrap_or(&[]);
    let (fraction, rest) = match rest {
        [b'.', after @ ..] => {
            let n = digit_count(after);
            (n, after.get(n..).unwrap_or(&[]))
        }
        _ => (0, rest),
    };
    Mantissa {
        negative,
        digits,
        whole,
        fraction,
        value: 0,
        rest,
    }
}

/// How many ASCII digits `s` starts with, four bytes a step: a word whose
/// every byte has the high nibble 3 and, with 6 added, still has it, is
/// four of `0`..`9` (6 added to `0x30`..`0x39` carries into no other
/// byte; a byte that carries fails the first test). Only for long texts:
/// on a robot's short reals a failed word test costs more than it saves.
#[inline(always)]
pub(crate) fn digit_count(s: &[u8]) -> usize {
    let mut rest = s;
    while let Some((w, tail)) = rest.split_first_chunk::<4>() {
        let v = u32::from_le_bytes(*w);
        let high = v & 0xf0f0_f0f0;
        let low = (v.wrapping_add(0x0606_0606) & 0xf0f0_f0f0) >> 4;
        if high | low != 0x3333_3333 {
            break;
        }
        rest = tail;
    }
    while let [b'0'..=b'9', tail @ ..] = rest {
        rest = tail;
    }
    s.len() - rest.len()
}

/// The mantissa of more than [`super::SAFE_DIGITS`] digits: `whole` digits at
/// the start of `digits`, then a point and `fraction` digits (the text
/// after the sign, already scanned). Returns the first 19 significant
/// digits, the power of ten that goes with them and the first dropped
/// digit. Rare (a robot writes at most 9 significant digits), so kept out
/// of the common path.
#[cold]
#[inline(never)]
pub(super) fn long_mantissa(
    digits: &[u8],
    whole: usize,
    fraction: usize,
) -> (u64, i32, Option<u8>) {
    const FULL: u64 = 1_000_000_000_000_000_000;
    let (mut m, mut exponent, mut first_dropped) = (0u64, 0i32, None);
    // The digits, and the point between them at `whole` (if any).
    for (i, &b) in digits.iter().enumerate().take(whole + 1 + fraction) {
        if i == whole {
            continue;
        }
        let after_point = i > whole;
        let v = b.wrapping_sub(b'0');
        if m < FULL {
            m = m * 10 + u64::from(v);
            exponent -= i32::from(after_point);
        } else {
            // Past 19 significant digits: only the first one matters for
            // rounding.
            if first_dropped.is_none() {
                first_dropped = Some(v);
            }
            exponent += i32::from(!after_point);
        }
    }
    (m, exponent, first_dropped)
}
