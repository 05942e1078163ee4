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
//!
//! Three layers, each with its own tests: `events` turns tokens into the
//! message's structure and checks it (root, `Id`/`Ts`, depth, tags); the
//! `Binder` here maps those events to the generated record's slots and
//! counts what the layout does not know; `bind` turns a slot's text and
//! attributes into typed values. They are generic and inlined into one
//! loop, so the layering costs no dispatch (`cargo codec-bench`).

mod bind;
mod declaration;
pub(crate) mod error;
mod events;

pub use bind::parse_bool;
pub use error::{DecodeError, DecodeErrorKind, Decoded, Tally, EXTRA_ITEMS};

use super::hand_over::HandOver;
use super::number::blank;
use crate::schema::{Body, MessageCodec, MAX_FIELDS};
use bind::{collect, components, finish_slot, set_component, Collected, Target};
use error::{bump, err};
use events::{Attr, Header, Text, Visitor};

/// The datagram as text. Robot messages are ASCII; checking that a block
/// at a time is several times cheaper than full UTF-8 validation, which
/// only runs when a non-ASCII byte is present.
#[allow(unsafe_code)]
fn utf8(bytes: &[u8]) -> Result<&str, core::str::Utf8Error> {
    if all_ascii(bytes) {
        // SAFETY: every byte is ASCII, and ASCII is valid UTF-8.
        Ok(unsafe { core::str::from_utf8_unchecked(bytes) })
    } else {
        core::str::from_utf8(bytes)
    }
}

/// `bytes.is_ascii()`, without its byte-at-a-time tail: core checks
/// 64-byte blocks and then each remaining byte alone (up to 63 of them, a
/// few hundred instructions per datagram); the tail here is one more block
/// ending at the last byte, overlapping the ones before it.
fn all_ascii(bytes: &[u8]) -> bool {
    const BLOCK: usize = 64;
    match bytes.len().checked_sub(BLOCK) {
        // (Both ranges are in bounds; were one not, `false` would only
        // send the datagram through full UTF-8 validation.)
        Some(last) => {
            let blocks = bytes.len() - bytes.len() % BLOCK;
            bytes.get(..blocks).is_some_and(<[u8]>::is_ascii)
                && bytes.get(last..).is_some_and(<[u8]>::is_ascii)
        }
        None => bytes.is_ascii(),
    }
}

/// Decodes one robot datagram of message `M` into `data` (in place, M2:
/// fields absent from the message keep their values).
///
/// The message as controllers write it takes the path the build compiled
/// from the layout ([`MessageCodec::decode_compiled_into`], see
/// [`super::compiled`]); whatever that path does not expect goes to
/// [`decode_general`], which gives the same answer for what both take and
/// keeps every rule for the rest. The reals the compiled path already
/// read the slow way are handed over ([`HandOver`]), not parsed again.
#[inline]
pub fn decode<M: MessageCodec>(bytes: &[u8], data: &mut M::Data) -> Result<Decoded, DecodeError> {
    if bytes.len() > M::MAX_RECEIVE_LEN {
        return Err(err(DecodeErrorKind::TooLong, M::MAX_RECEIVE_LEN));
    }
    let mut hand_over = HandOver::new(bytes);
    match M::decode_compiled_into(bytes, data, &mut hand_over) {
        Some(decoded) => Ok(decoded),
        None => general::<M>(bytes, data, &mut hand_over),
    }
}

/// The general decoder, on `xmlparser`: every message [`decode`] takes,
/// whatever its shape, with every rule of PROTOCOL.md. The compiled path
/// is measured and fuzzed against it.
///
/// Two layers: `events::walk` checks the message's structure and tells
/// the `Binder` each event; the binder maps them to the generated record.
pub fn decode_general<M: MessageCodec>(
    bytes: &[u8],
    data: &mut M::Data,
) -> Result<Decoded, DecodeError> {
    general::<M>(bytes, data, &mut HandOver::new(bytes))
}

/// [`decode_general`] taking the reals in `hand_over` as read.
#[inline(never)]
fn general<M: MessageCodec>(
    bytes: &[u8],
    data: &mut M::Data,
    hand_over: &mut HandOver,
) -> Result<Decoded, DecodeError> {
    use DecodeErrorKind as K;
    if bytes.len() > M::MAX_RECEIVE_LEN {
        return Err(err(K::TooLong, M::MAX_RECEIVE_LEN));
    }
    let text = utf8(bytes).map_err(|e| err(K::NotUtf8, e.valid_up_to()))?;
    // Where the compiled path got to, if it read a record's fields (never a
    // value body's): the walk resumes there, in the state it would have.
    let start = match (Binder::<M>::VALUE_BODY, hand_over.header, hand_over.mark) {
        (false, Some((id, ts)), mark) if mark.at > 0 => Some((
            events::Start {
                at: mark.at,
                id,
                ts,
            },
            mark,
        )),
        _ => None,
    };
    let mut binder = Binder::<M>::new(data, hand_over);
    if let Some((_, mark)) = start {
        binder.seen = mark.seen;
        binder.tally = mark.tally;
    }
    let Header { id, ts } = events::walk(text, M::WIRE_NAME, &mut binder, start.map(|(s, _)| s))?;
    Ok(Decoded {
        id,
        ts,
        tally: binder.finish(),
    })
}

/// The binding layer's walk state: which field text and attributes go to,
/// which fields were seen, and what the layout does not know (counted).
struct Binder<'a, 'd, M: MessageCodec> {
    data: &'d mut M::Data,
    /// The reals the compiled path read before it handed over.
    hand_over: &'d mut HandOver,
    /// Where text and attributes go now.
    target: Target,
    /// One bit per field seen (duplicates are errors, M2).
    seen: u64,
    /// What the open slot has collected.
    c: Collected<'a>,
    /// How many attributes the open slot has (`None`: it takes text),
    /// found once when it opens rather than at each attribute.
    components: Option<usize>,
    tally: Tally,
    /// Items the layout does not account for, and how many are allowed.
    extras: Extras,
}

impl<'a, 'd, M: MessageCodec> Binder<'a, 'd, M> {
    /// A value body's slot is the root itself; a record's opens per child.
    const VALUE_BODY: bool = matches!(M::BODY, Body::Value);

    #[inline(always)]
    fn new(data: &'d mut M::Data, hand_over: &'d mut HandOver) -> Self {
        let components = match Self::root_target() {
            Target::Slot(i) => M::field_mut(data, i).as_ref().and_then(components),
            Target::None => None,
        };
        Binder {
            data,
            hand_over,
            components,
            target: Self::root_target(),
            seen: 0,
            c: Collected::new(),
            tally: Tally::default(),
            extras: Extras {
                count: 0,
                limit: M::FIELDS.len().saturating_add(EXTRA_ITEMS),
            },
        }
    }

    /// Where the root's own text and attributes go.
    #[inline(always)]
    fn root_target() -> Target {
        if Self::VALUE_BODY {
            Target::Slot(0)
        } else {
            Target::None
        }
    }

    /// The tally, with the record's fields the message did not carry (M2).
    #[inline(always)]
    fn finish(mut self) -> Tally {
        if !Self::VALUE_BODY {
            let n = M::FIELDS.len().min(MAX_FIELDS);
            let missing = n as u32 - (self.seen & mask(n)).count_ones();
            self.tally.missing_fields = self
                .tally
                .missing_fields
                .saturating_add(u16::try_from(missing).unwrap_or(u16::MAX));
        }
        self.tally
    }

    /// The open slot `i` is complete: check and store what it collected.
    #[inline(always)]
    fn finish_slot(&mut self, i: usize) -> Result<(), DecodeError> {
        match M::field_mut(self.data, i) {
            Some(field) => finish_slot(field, self.components, &mut self.c, &mut self.tally),
            None => Ok(()),
        }
    }
}

impl<'a, M: MessageCodec> Visitor<'a> for Binder<'a, '_, M> {
    #[inline(always)]
    fn child(&mut self, prefix: &'a str, name: &'a str, at: usize) -> Result<(), DecodeError> {
        self.target = match (Self::VALUE_BODY, M::field_index(name.as_bytes())) {
            (false, Some(i)) if prefix.is_empty() => {
                let bit = 1u64.checked_shl(i as u32).unwrap_or(0);
                if self.seen & bit != 0 {
                    return Err(err(DecodeErrorKind::Duplicate, at));
                }
                self.seen |= bit;
                self.c = Collected::new();
                self.components = M::field_mut(self.data, i).as_ref().and_then(components);
                Target::Slot(i)
            }
            _ => {
                bump(&mut self.tally.unknown_elements);
                self.extras.add(at)?;
                Target::None
            }
        };
        Ok(())
    }

    #[inline(always)]
    fn attr(&mut self, a: Attr<'a>) -> Result<(), DecodeError> {
        let Attr {
            on_root,
            prefix,
            name,
            value,
            at,
        } = a;
        // A record's values are in its children (M4), a value body's on
        // the root.
        if let (Target::Slot(i), true) = (self.target, on_root || !Self::VALUE_BODY) {
            let known = match M::field_mut(self.data, i) {
                Some(field) if prefix.is_empty() => {
                    // A value's attributes beyond its count (a repeated
                    // `X="…"` once all are set) are extras: each would be
                    // parsed again. Counted once: an unknown attribute is
                    // one extra below, wherever it stands.
                    let full = self.components.is_some_and(|n| self.c.assigned >= n);
                    let known = set_component(
                        field,
                        name.as_bytes(),
                        value,
                        at,
                        &mut self.tally,
                        self.hand_over,
                    )?;
                    if known && full {
                        self.extras.add(at)?;
                    } else if known {
                        self.c.assigned += 1;
                    }
                    known
                }
                _ => false,
            };
            if !known {
                bump(&mut self.tally.unknown_attributes);
                self.extras.add(at)?;
            }
        } else {
            if self.target != Target::None || on_root {
                bump(&mut self.tally.unknown_attributes);
            }
            // Inside a skipped element too: each costs tokenizing.
            self.extras.add(at)?;
        }
        Ok(())
    }

    #[inline(always)]
    fn text(&mut self, t: Text<'a>) -> Result<(), DecodeError> {
        let Text {
            on_root,
            text,
            at,
            cdata,
        } = t;
        match self.target {
            Target::Slot(i) if on_root == Self::VALUE_BODY => {
                collect(M::field_mut(self.data, i), &mut self.c, text, at, cdata)
            }
            _ => {
                if on_root && !blank(text.as_bytes()) {
                    bump(&mut self.tally.stray_text);
                    self.extras.add(at)?;
                }
                Ok(())
            }
        }
    }

    #[inline(always)]
    fn other(&mut self, at: usize) -> Result<(), DecodeError> {
        self.extras.add(at)
    }

    #[inline(always)]
    fn child_end(&mut self) -> Result<(), DecodeError> {
        if let (Target::Slot(i), false) = (self.target, Self::VALUE_BODY) {
            self.finish_slot(i)?;
        }
        // Back in the root of a value body: its own text continues (a
        // skipped child in between).
        self.target = Self::root_target();
        Ok(())
    }

    #[inline(always)]
    fn root_end(&mut self) -> Result<(), DecodeError> {
        match (self.target, Self::VALUE_BODY) {
            (Target::Slot(i), true) => self.finish_slot(i),
            _ => Ok(()),
        }
    }
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

/// The lowest `n` bits set (`seen` has a bit per field: [`MAX_FIELDS`] of
/// them fill a `u64`).
fn mask(n: usize) -> u64 {
    const _: () = assert!(MAX_FIELDS <= u64::BITS as usize);
    if n >= MAX_FIELDS {
        u64::MAX
    } else {
        (1u64 << n) - 1
    }
}

#[cfg(test)]
mod tests;
