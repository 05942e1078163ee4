//! What the decoder reports: why a datagram was rejected (with its byte
//! offset) and, for an accepted one, what was tolerated on the way (M2).

use crate::value::Time;

/// Why a datagram was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeErrorKind {
    /// Longer than the message's compile-time `MAX_RECEIVE_LEN`.
    TooLong,
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
}

/// A rejected datagram: what and where (byte offset in the datagram).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DecodeError {
    pub kind: DecodeErrorKind,
    pub offset: usize,
}

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
    pub tally: Tally,
}

pub(super) fn err(kind: DecodeErrorKind, offset: usize) -> DecodeError {
    DecodeError { kind, offset }
}

pub(super) fn bump(counter: &mut u16) {
    *counter = counter.saturating_add(1);
}
