//! What the decoder reports: why a datagram was rejected (with its byte
//! offset) and, for an accepted one, what was tolerated on the way (M2).

use crate::value::Time;

/// Why a datagram was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeErrorKind {
    /// Longer than the message's compile-time `MAX_RECEIVE_LEN`.
    TooLong,
    /// Not valid UTF-8; the offset is where the valid prefix ends.
    NotUtf8,
    /// Any DOCTYPE/DTD: never processed, so no entity expansion, ever.
    Doctype,
    /// Not well-formed XML.
    Malformed,
    /// The root element is not the expected property (M1).
    WrongRoot,
    /// The root has no `Id` attribute (M1, M8).
    MissingId,
    /// `Id` is not an unsigned 32-bit decimal (S3).
    InvalidId,
    /// `Ts` is not a decimal number of seconds.
    InvalidTs,
    /// An element nested deeper than the layout (root → field).
    TooDeep,
    /// The document ends before its root element does.
    Truncated,
    /// Anything but whitespace, comments or processing instructions after
    /// the root element.
    TrailingGarbage,
    /// An end tag that does not close the open element.
    MismatchedTag,
    /// A `real` that is not a decimal number (M5).
    InvalidNumber,
    /// A decimal number beyond the type's range (`1e39` for `f32`).
    NumberOutOfRange,
    /// A `real` text longer than [`crate::codec::number::MAX_NUMBER_LEN`]
    /// characters: refused unread (M5 decision; bounded cost).
    NumberTooLong,
    /// A `time` that is not a decimal number of seconds, or beyond range.
    InvalidTime,
    /// A `bool` other than `true/false/1/0` in any case (M7).
    InvalidBool,
    /// An enum value that is no member's alias (G3).
    UnknownEnumMember,
    /// An entity or character reference that is not defined (M6).
    BadReference,
    /// A field, `Id` or `Ts` given twice in one message: no controller
    /// does that, and each repeat would cost a value's decoding again.
    Duplicate,
    /// More items the layout does not account for (unknown elements and
    /// attributes, attributes beyond a value's count, comments, processing
    /// instructions, stray text) than [`EXTRA_ITEMS`] allows: rejected as
    /// soon as the limit is passed, so the cost of any datagram stays that
    /// of a legitimate one.
    TooManyExtras,
}

/// How many items a message may hold beyond its layout's fields before it
/// is rejected ([`DecodeErrorKind::TooManyExtras`]), on top of one per
/// field: room for a controller configured with a few more fields or
/// attributes than the device, and for a comment or two.
pub const EXTRA_ITEMS: usize = 16;

impl DecodeErrorKind {
    /// Every kind, in declaration order (the statistics count each).
    pub const ALL: [DecodeErrorKind; 21] = [
        Self::TooLong,
        Self::NotUtf8,
        Self::Doctype,
        Self::Malformed,
        Self::WrongRoot,
        Self::MissingId,
        Self::InvalidId,
        Self::InvalidTs,
        Self::TooDeep,
        Self::Truncated,
        Self::TrailingGarbage,
        Self::MismatchedTag,
        Self::InvalidNumber,
        Self::NumberOutOfRange,
        Self::NumberTooLong,
        Self::InvalidTime,
        Self::InvalidBool,
        Self::UnknownEnumMember,
        Self::BadReference,
        Self::Duplicate,
        Self::TooManyExtras,
    ];

    /// Position in [`DecodeErrorKind::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// A short name for machines (metric labels, JSON keys):
    /// `too_long`, `not_utf8`, ….
    pub const fn name(self) -> &'static str {
        match self {
            Self::TooLong => "too_long",
            Self::NotUtf8 => "not_utf8",
            Self::Doctype => "doctype",
            Self::Malformed => "malformed",
            Self::WrongRoot => "wrong_root",
            Self::MissingId => "missing_id",
            Self::InvalidId => "invalid_id",
            Self::InvalidTs => "invalid_ts",
            Self::TooDeep => "too_deep",
            Self::Truncated => "truncated",
            Self::TrailingGarbage => "trailing_garbage",
            Self::MismatchedTag => "mismatched_tag",
            Self::InvalidNumber => "invalid_number",
            Self::NumberOutOfRange => "number_out_of_range",
            Self::NumberTooLong => "number_too_long",
            Self::InvalidTime => "invalid_time",
            Self::InvalidBool => "invalid_bool",
            Self::UnknownEnumMember => "unknown_enum_member",
            Self::BadReference => "bad_reference",
            Self::Duplicate => "duplicate",
            Self::TooManyExtras => "too_many_extras",
        }
    }

    /// What went wrong, for people, with the rule it breaks.
    pub const fn text(self) -> &'static str {
        match self {
            Self::TooLong => "message longer than the receive buffer",
            Self::NotUtf8 => "message is not valid UTF-8",
            Self::Doctype => "document type declaration refused (never processed)",
            Self::Malformed => "message is not well-formed XML (M1)",
            Self::WrongRoot => "root element is not the expected property (M1)",
            Self::MissingId => "root element has no Id attribute (M1, M8)",
            Self::InvalidId => "invalid Id: not an unsigned 32-bit decimal (S3)",
            Self::InvalidTs => "invalid Ts: not a decimal number of seconds (M1)",
            Self::TooDeep => "element nested deeper than root and field (M2)",
            Self::Truncated => "message ends before its root element does",
            Self::TrailingGarbage => "content after the root element (M1)",
            Self::MismatchedTag => "end tag does not close the open element",
            Self::InvalidNumber => "real is not a decimal number (M5)",
            Self::NumberOutOfRange => "number beyond the range of its type (M5)",
            Self::NumberTooLong => "number text too long to read (M5)",
            Self::InvalidTime => "time is not a decimal number of seconds in range (M5)",
            Self::InvalidBool => "bool is not true, false, 1 or 0 (M7)",
            Self::UnknownEnumMember => "enum value is no member's alias (G3)",
            Self::BadReference => "undefined entity or character reference (M6)",
            Self::Duplicate => "field, Id or Ts given twice",
            Self::TooManyExtras => "too many items outside the layout (M2)",
        }
    }
}

/// A rejected datagram: what and where (byte offset in the datagram).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DecodeError {
    /// What was wrong; counted per kind in the statistics.
    pub kind: DecodeErrorKind,
    /// Byte offset in the datagram where it was found (for `TooLong`, the
    /// limit that was passed).
    pub offset: usize,
}

impl core::fmt::Display for DecodeErrorKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.text())
    }
}

impl core::error::Error for DecodeErrorKind {}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} at byte {}", self.kind, self.offset)
    }
}

impl core::error::Error for DecodeError {}

/// What was tolerated in one message (M2 decisions), for the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// Child elements that are no field of the layout (skipped).
    pub unknown_elements: u16,
    /// Attributes the layout does not know (skipped).
    pub unknown_attributes: u16,
    /// Fields absent from the message (previous value kept).
    pub missing_fields: u16,
    /// Attributes absent from a frame, joints or array field (previous
    /// value kept).
    pub missing_values: u16,
    /// Fields in the wrong shape: text where attributes were expected or
    /// the other way round, or empty (previous value kept).
    pub shape_mismatches: u16,
    /// Strings cut at 80 bytes (M6).
    pub truncated_strings: u16,
    /// Non-whitespace text between the fields of a record (skipped).
    pub stray_text: u16,
}

/// A decoded message's header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decoded {
    /// The robot's message id, to echo in the reply (M8).
    pub id: u32,
    /// The robot's timestamp; `None` when the message had no `Ts`.
    pub ts: Option<Time>,
    /// What was skipped or kept from before on the way (M2).
    pub tally: Tally,
}

pub(super) fn err(kind: DecodeErrorKind, offset: usize) -> DecodeError {
    DecodeError { kind, offset }
}

pub(super) fn bump(counter: &mut u16) {
    *counter = counter.saturating_add(1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_kind_and_the_offset() {
        let e = err(DecodeErrorKind::InvalidBool, 42);
        assert_eq!(
            e.to_string(),
            "bool is not true, false, 1 or 0 (M7) at byte 42"
        );
        assert_eq!(
            DecodeErrorKind::WrongRoot.to_string(),
            "root element is not the expected property (M1)"
        );
    }
}
