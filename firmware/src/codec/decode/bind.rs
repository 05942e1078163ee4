//! The binding layer: text and attributes collected for one value slot
//! become the generated record's typed fields (reals, times, bools,
//! strings, frames, joints, arrays, enums), each conversion a counted,
//! typed error on bad input.

use super::error::{bump, err, DecodeError, DecodeErrorKind, Tally};
use crate::codec::hand_over::HandOver;
use crate::codec::number::{is_xml_space_char, parse_f32, parse_time, trim, NumberError};
use crate::codec::text::append_decoded;
use crate::schema::FieldMut;
use crate::value::{Frame, RriString, Time};

/// Where text and attributes currently go.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Target {
    /// Nothing: outside any value, or inside a skipped element.
    None,
    /// The value slot at this index of `M::FIELDS`.
    Slot(usize),
}

/// Text collected for the open value slot.
pub(super) struct Collected<'a> {
    /// First non-whitespace piece and its offset.
    piece: Option<(&'a str, usize)>,
    /// More than one non-whitespace piece (text split by comments/CDATA).
    fragmented: bool,
    /// The piece was CDATA: literal, no references to decode.
    piece_cdata: bool,
    /// Any character data at all (for strings, whitespace counts).
    any: bool,
    /// Attributes assigned (frame, joints, arrays).
    pub(super) assigned: usize,
    /// A string being decoded (strings may arrive in several pieces).
    string: RriString,
    string_truncated: bool,
}

impl<'a> Collected<'a> {
    pub(super) const fn new() -> Self {
        Collected {
            piece: None,
            fragmented: false,
            piece_cdata: false,
            any: false,
            assigned: 0,
            string: RriString::new(),
            string_truncated: false,
        }
    }
}

/// The value a frame's attribute `X Y Z Rx Ry Rz` sets (M4).
fn frame_slot<'f>(f: &'f mut Frame, name: &[u8]) -> Option<&'f mut f32> {
    Some(match name {
        b"X" => &mut f.x,
        b"Y" => &mut f.y,
        b"Z" => &mut f.z,
        b"Rx" => &mut f.rx,
        b"Ry" => &mut f.ry,
        b"Rz" => &mut f.rz,
        _ => return None,
    })
}

/// `J1`..`J6` → 0..5 (M4).
pub(super) fn joint_component(name: &[u8]) -> Option<usize> {
    match name {
        [b'J', d @ b'1'..=b'6'] => Some(usize::from(d - b'1')),
        _ => None,
    }
}

/// `X1`..`XN` → 0..N-1 (M4); no leading zeros, at most 4 digits (N ≤
/// 1000, G3). One and two digits (arrays up to 99, every one a robot has
/// sent us) are matched directly.
pub(super) fn array_component(name: &[u8], len: usize) -> Option<usize> {
    let n = match name {
        [b'X', d @ b'1'..=b'9'] => usize::from(d - b'0'),
        [b'X', t @ b'1'..=b'9', u @ b'0'..=b'9'] => {
            usize::from(t - b'0') * 10 + usize::from(u - b'0')
        }
        [b'X', b'1'..=b'9', rest @ ..] if rest.len() <= 3 => {
            let mut n = 0usize;
            for &b in name.get(1..)? {
                let d = b.wrapping_sub(b'0');
                if d > 9 {
                    return None;
                }
                n = n * 10 + usize::from(d);
            }
            n
        }
        _ => return None,
    };
    (1..=len).contains(&n).then(|| n - 1)
}

/// M7: `true/false/1/0` in any case, surrounded by XML whitespace or not
/// (the words themselves are `rri_vocabulary`'s).
pub fn parse_bool(text: &[u8]) -> Option<bool> {
    rri_vocabulary::parse_bool(trim(text))
}

pub(super) fn real(text: &str, at: usize) -> Result<f32, DecodeError> {
    parse_f32(text.as_bytes()).map_err(|e| match e {
        NumberError::Syntax => err(DecodeErrorKind::InvalidNumber, at),
        NumberError::OutOfRange => err(DecodeErrorKind::NumberOutOfRange, at),
        NumberError::TooLong => err(DecodeErrorKind::NumberTooLong, at),
    })
}

pub(super) fn time(text: &str, at: usize) -> Result<Time, DecodeError> {
    parse_time(text.as_bytes()).map_err(|_| err(DecodeErrorKind::InvalidTime, at))
}

pub(super) fn boolean(text: &str, at: usize) -> Result<bool, DecodeError> {
    parse_bool(text.as_bytes()).ok_or(err(DecodeErrorKind::InvalidBool, at))
}

/// Decodes a string value (text or attribute) into `out`; returns whether
/// it was cut at 80 bytes.
pub(super) fn string(out: &mut RriString, raw: &str, at: usize) -> Result<bool, DecodeError> {
    out.clear();
    append_decoded(out, raw).map_err(|b| err(DecodeErrorKind::BadReference, at + b.at))
}

/// Assigns one attribute of a multi-value slot. `Ok(false)`: the slot has
/// no such attribute (an unknown attribute).
#[inline(always)]
pub(super) fn set_component(
    field: FieldMut<'_>,
    name: &[u8],
    value: &str,
    at: usize,
    tally: &mut Tally,
    hand_over: &mut HandOver,
) -> Result<bool, DecodeError> {
    // A real the compiled path read before it handed over is taken as it
    // read it (the same bytes: the same value), not parsed again.
    let mut read_real = || match hand_over.take(value.as_bytes()) {
        Some(v) => Ok(v),
        None => real(value, at),
    };
    match field {
        FieldMut::Frame(f) => match frame_slot(f, name) {
            Some(slot) => *slot = read_real()?,
            None => return Ok(false),
        },
        FieldMut::Joints(j) => match joint_component(name).and_then(|i| j.get_mut(i)) {
            Some(slot) => *slot = read_real()?,
            None => return Ok(false),
        },
        FieldMut::Reals(a) => return set_element(a, name, read_real),
        FieldMut::Bools(a) => return set_element(a, name, || boolean(value, at)),
        FieldMut::Times(a) => return set_element(a, name, || time(value, at)),
        FieldMut::Strs(a) => {
            return set_element(a, name, || {
                let mut s = RriString::new();
                if string(&mut s, value, at)? {
                    bump(&mut tally.truncated_strings);
                }
                Ok(s)
            })
        }
        _ => return Ok(false),
    }
    Ok(true)
}

/// Sets array element `X<i>` (M4) to what `parse` makes of the value;
/// `Ok(false)` when the array has no such element. Inlined: a call per
/// element of a robot's `AppData` costs more than the binding itself.
#[inline(always)]
pub(super) fn set_element<T>(
    array: &mut [T],
    name: &[u8],
    parse: impl FnOnce() -> Result<T, DecodeError>,
) -> Result<bool, DecodeError> {
    let len = array.len();
    match array_component(name, len).and_then(|i| array.get_mut(i)) {
        Some(slot) => {
            *slot = parse()?;
            Ok(true)
        }
        None => Ok(false),
    }
}

/// Number of attributes a multi-value slot has, `None` for text values.
pub(super) fn components(field: &FieldMut<'_>) -> Option<usize> {
    match field {
        FieldMut::Frame(_) | FieldMut::Joints(_) => Some(6),
        FieldMut::Bools(a) => Some(a.len()),
        FieldMut::Reals(a) => Some(a.len()),
        FieldMut::Times(a) => Some(a.len()),
        FieldMut::Strs(a) => Some(a.len()),
        _ => None,
    }
}

/// Completes a value slot at its end tag; `components` is
/// [`components`] of `field`, found when the slot opened.
pub(super) fn finish_slot(
    field: FieldMut<'_>,
    components: Option<usize>,
    c: &mut Collected<'_>,
    tally: &mut Tally,
) -> Result<(), DecodeError> {
    if let Some(n) = components {
        if c.piece.is_some() {
            // Text where attributes were expected: the real IRC5's
            // `<AppData>0</AppData>`.
            bump(&mut tally.shape_mismatches);
        } else if c.assigned == 0 {
            bump(&mut tally.shape_mismatches);
        } else if c.assigned < n {
            tally.missing_values = tally
                .missing_values
                .saturating_add(u16::try_from(n - c.assigned).unwrap_or(u16::MAX));
        }
        return Ok(());
    }
    if let FieldMut::Str(s) = field {
        if c.string_truncated {
            bump(&mut tally.truncated_strings);
        }
        *s = core::mem::take(&mut c.string);
        return Ok(());
    }
    let Some((text, at)) = c.piece else {
        // `<Ts_act/>` or `<Ts_act> </Ts_act>`: no value.
        bump(&mut tally.shape_mismatches);
        return Ok(());
    };
    if c.fragmented {
        return Err(err(
            match field {
                FieldMut::Real(_) => DecodeErrorKind::InvalidNumber,
                FieldMut::Time(_) => DecodeErrorKind::InvalidTime,
                FieldMut::Bool(_) => DecodeErrorKind::InvalidBool,
                _ => DecodeErrorKind::UnknownEnumMember,
            },
            at,
        ));
    }
    match field {
        FieldMut::Real(v) => *v = real(text, at)?,
        FieldMut::Time(v) => *v = time(text, at)?,
        FieldMut::Bool(v) => *v = boolean(text, at)?,
        FieldMut::Enum(e) => {
            // An alias may hold `&` or `<` (escaped on the wire; CDATA is
            // literal, so `<![CDATA[Man&#x52;S]]>` is no `ManRS`).
            let mut decoded = RriString::new();
            let wire = if !c.piece_cdata && text.contains('&') {
                append_decoded(&mut decoded, text)
                    .map_err(|b| err(DecodeErrorKind::BadReference, at + b.at))?;
                decoded.as_bytes()
            } else {
                text.as_bytes()
            };
            let known = e.set_from_wire(trim(wire));
            if !known {
                return Err(err(DecodeErrorKind::UnknownEnumMember, at));
            }
        }
        _ => {}
    }
    Ok(())
}

/// Adds a piece of character data to the open slot.
pub(super) fn collect<'a>(
    field: Option<FieldMut<'_>>,
    c: &mut Collected<'a>,
    raw: &'a str,
    at: usize,
    cdata: bool,
) -> Result<(), DecodeError> {
    c.any = true;
    if let Some(FieldMut::Str(_)) = field {
        let cut = if cdata {
            // CDATA is literal: no references to decode.
            let room = crate::value::MAX_STRING_LEN - c.string.len();
            let mut end = raw.len().min(room);
            while !raw.is_char_boundary(end) {
                end -= 1;
            }
            let _ = c.string.push_str(raw.get(..end).unwrap_or(""));
            end < raw.len()
        } else {
            append_decoded(&mut c.string, raw)
                .map_err(|b| err(DecodeErrorKind::BadReference, at + b.at))?
        };
        c.string_truncated |= cut;
        return Ok(());
    }
    // Each end trimmed once; the lead is where the value starts.
    let from_start = raw.trim_start_matches(is_xml_space_char);
    let t = from_start.trim_end_matches(is_xml_space_char);
    if !t.is_empty() {
        if c.piece.is_some() {
            c.fragmented = true;
        } else {
            c.piece = Some((t, at + raw.len() - from_start.len()));
            c.piece_cdata = cdata;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m4_array_attribute_names_are_x1_to_xn_without_leading_zeros() {
        let at = |s: &str, len| array_component(s.as_bytes(), len);
        assert_eq!(at("X1", 18), Some(0));
        assert_eq!(at("X9", 18), Some(8));
        assert_eq!(at("X10", 18), Some(9));
        assert_eq!(at("X18", 18), Some(17));
        assert_eq!(at("X19", 18), None, "beyond the array");
        assert_eq!(at("X100", 1000), Some(99));
        assert_eq!(at("X1000", 1000), Some(999));
        for bad in [
            "X", "X0", "X01", "X010", "X10000", "Y1", "x1", "X1a", "X-1", "XX",
        ] {
            assert_eq!(at(bad, 1000), None, "{bad}");
        }
    }
}
