//! Worst-case message sizes, computed from the layout so that every buffer
//! in the firmware is a compile-time constant that cannot be overrun.
//!
//! Two figures per message:
//! - **encoded**: what our encoder can write at most (compact, no
//!   whitespace, reals with the configured decimals, strings fully escaped);
//! - **receivable**: the longest text the robot may legitimately send for
//!   the same layout (XML declaration, indentation, numbers in any notation,
//!   character references), which sizes the receive buffer. A longer datagram
//!   is rejected before parsing.

use gsi_config::{Device, SimpleType, TypeRef};

/// Largest UDP payload over IPv4; no RRI message can be longer.
pub const MAX_DATAGRAM: usize = 65_507;

/// The longest `u32` in decimal (`4294967295`).
pub const ID_DIGITS: usize = 10;

/// The longest f32 integer part (`f32::MAX` has 39 digits), plus sign.
const REAL_INT: usize = 1 + 39;

/// Whole seconds of [`Time`] (i64 microseconds) have at most 13 digits.
const TIME_INT: usize = 1 + 13;

/// Longest string (G5, M6): 80 bytes in the firmware, so at most 80
/// characters.
use rri_vocabulary::MAX_STRING_LEN as MAX_STRING_CHARS;

pub use rri_vocabulary::Format;

fn fraction(decimals: u8) -> usize {
    if decimals == 0 {
        0
    } else {
        1 + decimals as usize
    }
}

/// One value as our encoder writes it, at most.
fn value_encoded(device: &Device, ty: TypeRef, f: Format) -> usize {
    match ty {
        TypeRef::Simple(SimpleType::Bool) => "FALSE".len(),
        TypeRef::Simple(SimpleType::Real) => REAL_INT + fraction(f.real_decimals),
        TypeRef::Simple(SimpleType::Time) => TIME_INT + fraction(f.time_decimals),
        // Every character may be escaped as `&quot;` (6 bytes); none is
        // longer than that in UTF-8 (4 bytes).
        TypeRef::Simple(SimpleType::String) => MAX_STRING_CHARS * 6,
        TypeRef::Simple(SimpleType::Frame | SimpleType::Joints) => 0,
        TypeRef::Enum(i) => device.enums[i]
            .members
            .iter()
            .map(|m| escaped_len(m.wire()))
            .max()
            .unwrap_or(0),
        TypeRef::Record(_) => 0,
    }
}

/// One value as a robot may write it, at most: any decimal notation of a
/// real or time within 48 characters, strings with character references
/// (`&#x1F600;` is 10 bytes for one character).
fn value_receivable(device: &Device, ty: TypeRef) -> usize {
    match ty {
        TypeRef::Simple(SimpleType::Bool) => "false".len(),
        TypeRef::Simple(SimpleType::Real | SimpleType::Time) => 48,
        TypeRef::Simple(SimpleType::String) => MAX_STRING_CHARS * 10,
        TypeRef::Enum(i) => device.enums[i]
            .members
            .iter()
            .map(|m| m.wire().len() * 6)
            .max()
            .unwrap_or(0),
        _ => 0,
    }
}

pub fn escaped_len(s: &str) -> usize {
    s.chars()
        .map(|c| match c {
            '&' => 5,
            '<' | '>' => 4,
            '"' | '\'' => 6,
            c => c.len_utf8(),
        })
        .sum()
}

/// Slack per element or attribute for whitespace a robot may add
/// (indentation, line breaks, spaces around `=`).
const SLACK_PER_ITEM: usize = 16;
/// Slack for an XML declaration and leading whitespace.
const SLACK_PROLOGUE: usize = 128;

pub use gsi_config::attribute_names;

/// Size of one value slot: either element text or a set of attributes.
/// `wrap_open`/`wrap_close` are the bytes around text values.
fn slot(
    device: &Device,
    name: &str,
    ty: TypeRef,
    size: Option<u16>,
    value: &dyn Fn(TypeRef) -> usize,
    slack: usize,
) -> usize {
    match attribute_names(ty, size) {
        Some(attrs) => {
            let scalar = match ty {
                TypeRef::Simple(SimpleType::Frame | SimpleType::Joints) => {
                    value(TypeRef::Simple(SimpleType::Real))
                }
                t => value(t),
            };
            // `<name` + ` A="v"`… + `/>`
            1 + name.len()
                + attrs
                    .iter()
                    .map(|a| 1 + a.len() + 2 + scalar + 1 + slack)
                    .sum::<usize>()
                + 2
                + slack
        }
        // `<name>v</name>`
        None => {
            let _ = device;
            2 + name.len() + value(ty) + 3 + name.len() + slack
        }
    }
}

/// `(encoded, receivable)` maximum lengths of a property's message.
pub fn message_sizes(device: &Device, prop: &gsi_config::Property, f: Format) -> (usize, usize) {
    let enc = |t: TypeRef| value_encoded(device, t, f);
    let rcv = |t: TypeRef| value_receivable(device, t);
    let root = prop.wire();
    // `<root Id="…" Ts="…"` … `</root>`
    let header = |ts: usize, slack: usize| {
        1 + root.len() + 5 + ID_DIGITS + 1 + 5 + ts + 1 + slack * 2 + 3 + root.len() + slack
    };
    let body = |value: &dyn Fn(TypeRef) -> usize, slack: usize| match prop.ty {
        TypeRef::Record(i) => {
            1 + device.records[i]
                .fields
                .iter()
                .map(|fl| slot(device, fl.wire(), fl.ty, fl.size, value, slack))
                .sum::<usize>()
        }
        // A property of a simple type carries its value on the root element
        // itself: text (`>v</root>`) or attributes; reuse the slot size.
        ty => slot(device, "", ty, prop.size, value, slack),
    };
    let encoded = header(TIME_INT + fraction(f.time_decimals), 0) + body(&enc, 0);
    let receivable = SLACK_PROLOGUE + header(48, SLACK_PER_ITEM) + body(&rcv, SLACK_PER_ITEM);
    (encoded, receivable)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_counts_entities() {
        assert_eq!(escaped_len("a&b<\"'>"), 1 + 5 + 1 + 4 + 6 + 6 + 4);
        assert_eq!(escaped_len("é"), 2);
    }

    #[test]
    fn f32_max_has_39_integer_digits() {
        assert_eq!(format!("{:.0}", f32::MAX).len(), 39);
        assert_eq!(format!("{:.0}", f32::MIN).len(), REAL_INT);
    }

    #[test]
    fn time_integer_part_fits() {
        assert_eq!((i64::MIN / 1_000_000).to_string().len(), TIME_INT);
    }
}
