//! RRI `time` texts (M5) as exact microseconds, on the decimal scanner
//! of [`super`] (`split_decimal`): apart from `f32` reals because no float
//! is involved at all.

use super::{split_decimal, trim, NumberError, MAX_NUMBER_LEN};
use crate::value::Time;

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
    let d = split_decimal(t).ok_or(NumberError::Syntax)?;
    let (mantissa, exponent, first_dropped) = d.kept();
    // micros = mantissa × 10^(exponent + 6)
    let shift = exponent + 6;
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
    let micros = if shift >= 0 && first_dropped.is_some_and(|v| v >= 5) {
        micros.checked_add(1).ok_or(NumberError::OutOfRange)?
    } else {
        micros
    };
    // The magnitude of the least time, 2^63 µs, fits only negated.
    let micros = if d.negative {
        0i64.checked_sub_unsigned(micros)
    } else {
        i64::try_from(micros).ok()
    };
    Ok(Time::from_micros(micros.ok_or(NumberError::OutOfRange)?))
}
