//! A value's text as the generated matchers read it (M5–M7): through the
//! general path's own parsers, so the two paths cannot read a value
//! apart.

use crate::codec::decode::parse_bool;
use crate::codec::number::{parse_f32, parse_time};
use crate::value::{RriString, Time, MAX_STRING_LEN};

/// A `real` in text or an attribute value (M5), as the general path reads it.
#[inline(always)]
pub fn real(text: &[u8]) -> Option<f32> {
    parse_f32(text).ok()
}

/// A `time` (M5), as the general path reads it.
#[inline(always)]
pub fn time(text: &[u8]) -> Option<Time> {
    parse_time(text).ok()
}

/// A `bool` (M7), as the general path reads it.
#[inline(always)]
pub fn boolean(text: &[u8]) -> Option<bool> {
    parse_bool(text)
}

/// A `string` (M6) of at most 80 bytes; a longer one (cut and counted by
/// the general path) is not taken here. The bytes are ASCII: the scans
/// take no other.
pub fn string(text: &[u8]) -> Option<RriString> {
    if text.len() > MAX_STRING_LEN {
        return None;
    }
    let mut s = RriString::new();
    s.push_str(core::str::from_utf8(text).ok()?).ok()?;
    Some(s)
}
