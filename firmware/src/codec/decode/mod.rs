//! Robot → device: a datagram into the caller's typed data, in place, on
//! top of `xmlparser`'s zero-allocation tokenizer (M1–M7).
//!
//! Tolerant where real controllers differ from the manual, strict where
//! safety needs it:
//! - unknown elements and attributes are skipped and counted (M2);
//! - a missing field keeps its previous value and is counted (M2);
//! - a field in the wrong shape (`<AppData>0</AppData>` where attributes
//!   were expected) keeps its previous value and is counted;
//! - everything else that is wrong is a [`DecodeError`] with the byte
//!   offset: not UTF-8, DOCTYPE, wrong root, bad `Id`, too long, too deep,
//!   truncated, trailing garbage, bad values.
//!
//! Work is bounded by the datagram length: every token consumes input, the
//! datagram is at most the generated `MAX_RECEIVE_LEN`, and no step loops
//! on anything else. No recursion, no heap, no panic.
//!
//! On an error the data may be partly updated (fields before the error);
//! decode into a copy of the last good data when that matters.

use super::number::{parse_f32, parse_time, parse_u32, trim, NumberError};
use super::text::append_decoded;
use crate::schema::{Body, FieldMut, MessageCodec};
use crate::value::{RriString, Time};
use xmlparser::{ElementEnd, Token, Tokenizer};

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
    /// A `real` text longer than [`super::number::MAX_NUMBER_LEN`]
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

fn err(kind: DecodeErrorKind, offset: usize) -> DecodeError {
    DecodeError { kind, offset }
}

fn bump(counter: &mut u16) {
    *counter = counter.saturating_add(1);
}

/// Where text and attributes currently go.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    /// Nothing: outside any value, or inside a skipped element.
    None,
    /// The value slot at this index of `M::FIELDS`.
    Slot(usize),
}

/// Text collected for the open value slot.
struct Collected<'a> {
    /// First non-whitespace piece and its offset.
    piece: Option<(&'a str, usize)>,
    /// More than one non-whitespace piece (text split by comments/CDATA).
    fragmented: bool,
    /// Any character data at all (for strings, whitespace counts).
    any: bool,
    /// Attributes assigned (frame, joints, arrays).
    assigned: usize,
    /// A string being decoded (strings may arrive in several pieces).
    string: RriString,
    string_truncated: bool,
}

impl<'a> Collected<'a> {
    const fn new() -> Self {
        Collected {
            piece: None,
            fragmented: false,
            any: false,
            assigned: 0,
            string: RriString::new(),
            string_truncated: false,
        }
    }
}

/// The component index of a frame attribute (M4).
fn frame_component(name: &[u8]) -> Option<usize> {
    match name {
        b"X" => Some(0),
        b"Y" => Some(1),
        b"Z" => Some(2),
        b"Rx" => Some(3),
        b"Ry" => Some(4),
        b"Rz" => Some(5),
        _ => None,
    }
}

/// `J1`..`J6` → 0..5 (M4).
fn joint_component(name: &[u8]) -> Option<usize> {
    match name {
        [b'J', d @ b'1'..=b'6'] => Some(usize::from(d - b'1')),
        _ => None,
    }
}

/// `X1`..`XN` → 0..N-1 (M4); no leading zeros, at most 4 digits (N ≤
/// 1000, G3).
fn array_component(name: &[u8], len: usize) -> Option<usize> {
    let digits = name.strip_prefix(b"X")?;
    if digits.first() == Some(&b'0') || digits.is_empty() || digits.len() > 4 {
        return None;
    }
    let mut n = 0usize;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        n = n * 10 + usize::from(d);
    }
    (1..=len).contains(&n).then(|| n - 1)
}

/// The datagram as text. Robot messages are ASCII; checking that a word at
/// a time is several times cheaper than full UTF-8 validation, which only
/// runs when a non-ASCII byte is present.
#[allow(unsafe_code)]
fn utf8(bytes: &[u8]) -> Result<&str, core::str::Utf8Error> {
    if bytes.is_ascii() {
        // SAFETY: every byte is ASCII, and ASCII is valid UTF-8.
        Ok(unsafe { core::str::from_utf8_unchecked(bytes) })
    } else {
        core::str::from_utf8(bytes)
    }
}

/// M7: `true/false/1/0` in any case, surrounded by whitespace or not.
pub fn parse_bool(text: &[u8]) -> Option<bool> {
    let t = trim(text);
    if t.eq_ignore_ascii_case(b"true") || t == b"1" {
        Some(true)
    } else if t.eq_ignore_ascii_case(b"false") || t == b"0" {
        Some(false)
    } else {
        None
    }
}

fn real(text: &str, at: usize) -> Result<f32, DecodeError> {
    parse_f32(text.as_bytes()).map_err(|e| match e {
        NumberError::Syntax => err(DecodeErrorKind::InvalidNumber, at),
        NumberError::OutOfRange => err(DecodeErrorKind::NumberOutOfRange, at),
        NumberError::TooLong => err(DecodeErrorKind::NumberTooLong, at),
    })
}

fn time(text: &str, at: usize) -> Result<Time, DecodeError> {
    parse_time(text.as_bytes()).map_err(|_| err(DecodeErrorKind::InvalidTime, at))
}

fn boolean(text: &str, at: usize) -> Result<bool, DecodeError> {
    parse_bool(text.as_bytes()).ok_or(err(DecodeErrorKind::InvalidBool, at))
}

/// Decodes a string value (text or attribute) into `out`; returns whether
/// it was cut at 80 bytes.
fn string(out: &mut RriString, raw: &str, at: usize) -> Result<bool, DecodeError> {
    out.clear();
    append_decoded(out, raw).map_err(|b| err(DecodeErrorKind::BadReference, at + b.at))
}

/// Assigns one attribute of a multi-value slot. `Ok(false)`: the slot has
/// no such attribute (an unknown attribute).
fn set_component(
    field: FieldMut<'_>,
    name: &[u8],
    value: &str,
    at: usize,
    tally: &mut Tally,
) -> Result<bool, DecodeError> {
    match field {
        FieldMut::Frame(f) => {
            let Some(i) = frame_component(name) else {
                return Ok(false);
            };
            let v = real(value, at)?;
            match i {
                0 => f.x = v,
                1 => f.y = v,
                2 => f.z = v,
                3 => f.rx = v,
                4 => f.ry = v,
                _ => f.rz = v,
            }
        }
        FieldMut::Joints(j) => match joint_component(name).and_then(|i| j.get_mut(i)) {
            Some(slot) => *slot = real(value, at)?,
            None => return Ok(false),
        },
        FieldMut::Reals(a) => return set_element(a, name, || real(value, at)),
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
/// `Ok(false)` when the array has no such element.
fn set_element<T>(
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
fn components(field: &FieldMut<'_>) -> Option<usize> {
    match field {
        FieldMut::Frame(_) | FieldMut::Joints(_) => Some(6),
        FieldMut::Bools(a) => Some(a.len()),
        FieldMut::Reals(a) => Some(a.len()),
        FieldMut::Times(a) => Some(a.len()),
        FieldMut::Strs(a) => Some(a.len()),
        _ => None,
    }
}

/// Completes a value slot at its end tag.
fn finish_slot(
    field: FieldMut<'_>,
    c: &mut Collected<'_>,
    tally: &mut Tally,
) -> Result<(), DecodeError> {
    if let Some(n) = components(&field) {
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
            // An alias may hold `&` or `<` (escaped on the wire).
            let mut decoded = RriString::new();
            let wire = if text.contains('&') {
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
fn collect<'a>(
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
    let t = raw.trim_matches(|ch| matches!(ch, ' ' | '\t' | '\r' | '\n'));
    if !t.is_empty() {
        if c.piece.is_some() {
            c.fragmented = true;
        } else {
            let lead = raw.len() - raw.trim_start_matches([' ', '\t', '\r', '\n']).len();
            c.piece = Some((t, at + lead));
        }
    }
    Ok(())
}

/// Decodes one robot datagram of message `M` into `data` (in place, M2:
/// fields absent from the message keep their values).
pub fn decode<M: MessageCodec>(bytes: &[u8], data: &mut M::Data) -> Result<Decoded, DecodeError> {
    use DecodeErrorKind as K;
    if bytes.len() > M::MAX_RECEIVE_LEN {
        return Err(err(K::TooLong, M::MAX_RECEIVE_LEN));
    }
    let text = utf8(bytes).map_err(|e| err(K::NotUtf8, e.valid_up_to()))?;
    // M1: whitespace may precede the declaration; xmlparser does not allow
    // it, so skip it and keep offsets relative to the datagram.
    let body = text.trim_start_matches([' ', '\t', '\r', '\n']);
    let base = text.len() - body.len();

    let value_body = M::BODY == Body::Value;
    let mut depth: u8 = 0;
    let mut done = false;
    let mut in_start_tag = false;
    let mut id: Option<u32> = None;
    let mut ts: Option<Time> = None;
    let mut target = Target::None;
    // Prefix and name of the open child element (depth 2), for the
    // end-tag check.
    let mut child: (&str, &str) = ("", "");
    let mut seen: u64 = 0;
    let mut c = Collected::new();
    let mut tally = Tally::default();
    let mut last_end = base;
    // Items the layout does not account for, and how many are allowed.
    let mut extras = Extras {
        count: 0,
        limit: M::FIELDS.len().saturating_add(EXTRA_ITEMS),
    };

    if value_body {
        target = Target::Slot(0);
    }

    for token in Tokenizer::from(body) {
        let token = token.map_err(|e| {
            let kind = if done {
                K::TrailingGarbage
            } else if ends_early(&e) || unfinished_tail(body, last_end - base) {
                // The tokenizer stopped because the input did.
                K::Truncated
            } else {
                K::Malformed
            };
            err(kind, last_end)
        })?;
        match token {
            Token::Declaration { span, .. } => last_end = base + span.end(),
            Token::ProcessingInstruction { span, .. } | Token::Comment { span, .. } => {
                extras.add(base + span.start())?;
                last_end = base + span.end();
            }
            Token::DtdStart { span, .. }
            | Token::EmptyDtd { span, .. }
            | Token::EntityDeclaration { span, .. }
            | Token::DtdEnd { span } => return Err(err(K::Doctype, base + span.start())),
            Token::ElementStart {
                prefix,
                local,
                span,
            } => {
                let at = base + span.start();
                if done {
                    return Err(err(K::TrailingGarbage, at));
                }
                if span.end() >= body.len() {
                    // `<RobD` at the end: the name itself was cut.
                    return Err(err(K::Truncated, at));
                }
                let name = local.as_str();
                match depth {
                    0 => {
                        if !prefix.is_empty() || name != M::WIRE_NAME {
                            return Err(err(K::WrongRoot, at));
                        }
                    }
                    1 => {
                        child = (prefix.as_str(), name);
                        target = match (value_body, M::field_index(name.as_bytes())) {
                            (false, Some(i)) if prefix.is_empty() => {
                                let bit = 1u64.checked_shl(i as u32).unwrap_or(0);
                                if seen & bit != 0 {
                                    return Err(err(K::Duplicate, at));
                                }
                                seen |= bit;
                                c = Collected::new();
                                Target::Slot(i)
                            }
                            _ => {
                                bump(&mut tally.unknown_elements);
                                extras.add(at)?;
                                Target::None
                            }
                        };
                    }
                    _ => return Err(err(K::TooDeep, at)),
                }
                depth += 1;
                in_start_tag = true;
                last_end = base + span.end();
            }
            Token::Attribute {
                prefix,
                local,
                value,
                span,
            } => {
                let at = base + value.start();
                let name = local.as_str().as_bytes();
                if depth == 1 && prefix.is_empty() && name == b"Id" {
                    if id.is_some() {
                        return Err(err(K::Duplicate, at));
                    }
                    id = Some(parse_u32(value.as_bytes()).map_err(|_| err(K::InvalidId, at))?);
                } else if depth == 1 && prefix.is_empty() && name == b"Ts" {
                    if ts.is_some() {
                        return Err(err(K::Duplicate, at));
                    }
                    ts = Some(parse_time(value.as_bytes()).map_err(|_| err(K::InvalidTs, at))?);
                } else if let (Target::Slot(i), true) = (target, depth == 1 || !value_body) {
                    let known = match M::field_mut(data, i) {
                        Some(field) if prefix.is_empty() => {
                            // A value's attributes beyond its count (a
                            // repeated `X="…"`) are extras: each would be
                            // parsed again.
                            if components(&field).is_some_and(|n| c.assigned >= n) {
                                extras.add(at)?;
                            }
                            let known = set_component(field, name, value.as_str(), at, &mut tally)?;
                            if known {
                                c.assigned += 1;
                            }
                            known
                        }
                        _ => false,
                    };
                    if !known {
                        bump(&mut tally.unknown_attributes);
                        extras.add(at)?;
                    }
                } else {
                    if target != Target::None || depth == 1 {
                        bump(&mut tally.unknown_attributes);
                    }
                    // Inside a skipped element too: each costs tokenizing.
                    extras.add(at)?;
                }
                last_end = base + span.end();
            }
            Token::ElementEnd { end, span } => {
                let at = base + span.start();
                if in_start_tag && depth == 1 && id.is_none() {
                    return Err(err(K::MissingId, at));
                }
                in_start_tag = false;
                let closing = match end {
                    ElementEnd::Open => false,
                    ElementEnd::Empty => true,
                    ElementEnd::Close(prefix, local) => {
                        let open = if depth == 1 {
                            ("", M::WIRE_NAME)
                        } else {
                            child
                        };
                        if (prefix.as_str(), local.as_str()) != open {
                            return Err(err(K::MismatchedTag, at));
                        }
                        true
                    }
                };
                if closing {
                    let slot_ends = (depth == 2 && !value_body) || (depth == 1 && value_body);
                    if slot_ends {
                        if let Target::Slot(i) = target {
                            if let Some(field) = M::field_mut(data, i) {
                                finish_slot(field, &mut c, &mut tally)?;
                            }
                        }
                    }
                    if depth == 2 {
                        target = if value_body {
                            Target::Slot(0)
                        } else {
                            Target::None
                        };
                        // Back in the root of a value body: its own text
                        // continues (a skipped child in between).
                    }
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        done = true;
                    }
                }
                last_end = base + span.end();
            }
            Token::Text { text: t } | Token::Cdata { text: t, .. } => {
                let cdata = matches!(token, Token::Cdata { .. });
                let at = base + t.start();
                let in_slot = (depth == 2 && !value_body) || (depth == 1 && value_body);
                match target {
                    Target::Slot(i) if in_slot => {
                        collect(M::field_mut(data, i), &mut c, t.as_str(), at, cdata)?;
                    }
                    _ => {
                        if depth == 1 && !trim(t.as_bytes()).is_empty() {
                            bump(&mut tally.stray_text);
                            extras.add(at)?;
                        }
                    }
                }
                last_end = base + t.end();
            }
        }
    }
    if !done {
        return Err(err(K::Truncated, bytes.len()));
    }
    let id = id.ok_or(err(K::MissingId, base))?;
    if !value_body {
        let n = M::FIELDS.len().min(64);
        let missing = n as u32 - (seen & mask(n)).count_ones();
        tally.missing_fields = tally
            .missing_fields
            .saturating_add(u16::try_from(missing).unwrap_or(u16::MAX));
    }
    Ok(Decoded { id, ts, tally })
}

/// The count of items a message holds beyond its layout (see
/// [`EXTRA_ITEMS`]).
struct Extras {
    count: usize,
    limit: usize,
}

impl Extras {
    /// One more at byte `at`; an error once there are more than allowed.
    fn add(&mut self, at: usize) -> Result<(), DecodeError> {
        self.count += 1;
        if self.count > self.limit {
            Err(err(DecodeErrorKind::TooManyExtras, at))
        } else {
            Ok(())
        }
    }
}

/// Whether the input after the last complete token is only the start of
/// one (`<`, `</Ts_`, `<P_act X="1" `): no `>` outside quotes, so more bytes
/// could have completed it. Error path only: linear in the tail.
fn unfinished_tail(text: &str, from: usize) -> bool {
    let tail = text.as_bytes().get(from..).unwrap_or(&[]);
    if from == 0 && !tail.contains(&b'<') {
        // Text without any markup (`hello robot`) is no cut message.
        return false;
    }
    let mut quote: Option<u8> = None;
    for &b in tail {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if q == b => quote = None,
            (None, b'>') => return false,
            _ => {}
        }
    }
    true
}

/// Whether the tokenizer failed because the input stopped mid-token.
fn ends_early(e: &xmlparser::Error) -> bool {
    use xmlparser::{Error as E, StreamError};
    match e {
        E::InvalidDeclaration(s, _)
        | E::InvalidComment(s, _)
        | E::InvalidPI(s, _)
        | E::InvalidDoctype(s, _)
        | E::InvalidEntity(s, _)
        | E::InvalidElement(s, _)
        | E::InvalidAttribute(s, _)
        | E::InvalidCdata(s, _)
        | E::InvalidCharData(s, _) => matches!(s, StreamError::UnexpectedEndOfStream),
        E::UnknownToken(_) => false,
    }
}

/// The lowest `n` bits set.
fn mask(n: usize) -> u64 {
    if n >= 64 {
        u64::MAX
    } else {
        (1u64 << n) - 1
    }
}
