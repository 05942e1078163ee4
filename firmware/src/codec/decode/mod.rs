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

mod bind;
mod error;

pub use bind::parse_bool;
pub use error::{DecodeError, DecodeErrorKind, Decoded, Tally, EXTRA_ITEMS};

use super::number::{parse_time, parse_u32, trim};
use crate::schema::{Body, MessageCodec};
use crate::value::Time;
use bind::{collect, components, finish_slot, set_component, Collected, Target};
use error::{bump, err};
use xmlparser::{ElementEnd, Token, Tokenizer};

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
