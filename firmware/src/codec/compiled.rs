//! The compiled decode path: the robot message as controllers write it,
//! matched byte by byte by code the build script generates from the layout
//! (one function per robot property, `decode_compiled` in the generated
//! `layout`), on the primitives of this module.
//!
//! What it takes (M1–M7): whitespace and an optional XML declaration
//! before the root; the root's `Id` and optional `Ts`; a record's fields in
//! Configuration.xml's order, any of them left out (M2, counted); a
//! frame's `X Y Z Rx Ry Rz`, joints' `J1..J6` and an array's `X1..XN` in
//! that order, any left out (M4, counted); the real IRC5's
//! `<AppData>0</AppData>` where attributes were expected (counted as a
//! shape mismatch); XML whitespace wherever XML allows it; numbers in any
//! notation the general path reads (the same functions read them).
//!
//! What it refuses, at the first byte it does not expect, by returning
//! `None`: everything else — comments, processing instructions, CDATA,
//! references (`&`), single quotes, namespace prefixes, unknown or
//! repeated elements and attributes, fields out of order, non-ASCII or
//! control bytes, anything after the root but whitespace. The datagram
//! then goes to the general decoder (`decode::decode_general`, on
//! `xmlparser`), which keeps every rule of PROTOCOL.md and reports the
//! error, if any.
//!
//! The contract, checked by the differential fuzz target and the tests:
//! when this path returns `Some`, the general path accepts the same bytes
//! with the same header, the same record and the same tally. It may write
//! into the record before it gives up; the general path then writes every
//! value again (each value the compiled path set came from an element or
//! attribute the general path binds the same way), and `decode` is called
//! on a scratch copy anyway (`properties::decode_committed`).
//!
//! No heap, no recursion, no panic; every loop consumes input, so the work
//! is linear in the datagram. A datagram handed over is read once in all:
//! the general path resumes at the end of the last field this path read
//! whole, and takes the reals it read the slow way as read
//! ([`super::HandOver`]).

use super::decode::{Decoded, Tally};
use super::hand_over::{HandOver, Mark};
use super::number::{
    digit_count, is_xml_space, parse_f32_general, parse_time, parse_u32, plain_prefix,
    MAX_NUMBER_LEN,
};
use crate::value::Time;

/// A byte the compiled path takes inside element text: printable ASCII
/// but `<` (the end of the text), `&` (a reference) and `>` (so a text
/// cannot hold `]]>`, which XML forbids), or XML whitespace.
const TEXT: u8 = 1;
/// A byte it takes inside a `"`-quoted attribute value: printable ASCII
/// but `"` (the end of the value), `<` (forbidden there) and `&`, or XML
/// whitespace.
const VALUE: u8 = 2;

/// XML whitespace (space, tab, CR, LF).
const SPACE: u8 = 4;

/// [`TEXT`], [`VALUE`] and [`SPACE`] of every byte: one load a byte in
/// the scans.
static CLASS: [u8; 256] = classes();

#[allow(clippy::indexing_slicing)] // evaluated at compile time
const fn classes() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        let c = b as u8;
        let printable = c >= 0x20 && c < 0x7f;
        if (printable || is_xml_space(c)) && c != b'&' && c != b'<' {
            t[b] = if c == b'"' {
                TEXT
            } else if c == b'>' {
                VALUE
            } else {
                TEXT | VALUE
            };
            if is_xml_space(c) {
                t[b] |= SPACE;
            }
        }
        b += 1;
    }
    t
}

/// The class of `b` ([`TEXT`], [`VALUE`]).
#[inline(always)]
fn class(b: u8) -> u8 {
    // 256 entries: every `u8` is in bounds.
    CLASS.get(usize::from(b)).copied().unwrap_or(0)
}

/// [`Scan::real`]'s window for the plain notation: 21 bytes and the one
/// after them.
const PLAIN_WINDOW: usize = 22;

/// The longest real attribute value the compiled path reads: a number of
/// `MAX_NUMBER_LEN` characters and some whitespace around it. Longer ones
/// go to the general path (which refuses the number, or trims the
/// whitespace), so no value costs the compiled path more than this.
const NUMBER_VALUE_LEN: usize = MAX_NUMBER_LEN + 16;

/// Whitespace [`Scan::ws`] reads a byte at a time before it takes the run
/// for padding: a line break and indentation.
const INDENTATION: usize = 12;

/// A machine word: literals are compared a word at a time.
type Word = usize;
const WORD: usize = core::mem::size_of::<Word>();

/// The word of `a` at `at` (little-endian); `at + WORD <= N` at every call.
#[inline(always)]
fn word<const N: usize>(a: &[u8; N], at: usize) -> Word {
    match a
        .get(at..at + WORD)
        .and_then(|w| <[u8; WORD]>::try_from(w).ok())
    {
        Some(w) => Word::from_le_bytes(w),
        None => 0,
    }
}

/// `a == b` a word at a time, the last word overlapping the one before it
/// (both arrays are the same constant length, so this unrolls into a few
/// loads compared with immediates).
#[inline(always)]
fn same<const N: usize>(a: &[u8; N], b: &[u8; N]) -> bool {
    if N < WORD {
        return a == b;
    }
    let mut diff = 0;
    let mut at = 0;
    while at + WORD <= N {
        diff |= word(a, at) ^ word(b, at);
        at += WORD;
    }
    if at < N {
        diff |= word(a, N - WORD) ^ word(b, N - WORD);
    }
    diff == 0
}

/// The root's `Id` and `Ts` (M1, M8).
#[derive(Clone, Copy, Debug)]
pub struct Root {
    id: u32,
    ts: Option<Time>,
}

/// A cursor over the datagram: what is left of it, and what was tolerated
/// so far (M2).
pub struct Scan<'a> {
    rest: &'a [u8],
    tally: Tally,
    /// The last long run of whitespace read ([`Scan::ws`]): where it
    /// starts and ends, as lengths of `rest`. An attribute that is not
    /// next rewinds to before its whitespace, and the next one expected
    /// reads the same run again: this makes that a jump, so each run is
    /// read once however many attributes are tried after it.
    gap: (usize, usize),
    /// The reals read the slow way, and where the general path may resume,
    /// for it should this one hand the datagram over ([`HandOver`]).
    hand_over: &'a mut HandOver,
    /// The datagram's length: offsets for the marks.
    len: usize,
    /// The record's fields read whole so far, one bit each. Also in the
    /// mark, on purpose: kept here, the bits stay in a register; or-ing
    /// into the mark's own cost the realistic compute median 245
    /// Thumb-2 instructions (and folding the root's `Id`/`Ts` into the
    /// mark, 45 more), measured with `cargo qemu-bench`.
    seen: u64,
}

impl<'a> Scan<'a> {
    /// The prologue and the root's start tag up to its own attributes:
    /// XML whitespace, an optional XML declaration, whitespace, `open`
    /// (`<RobData`), then `Id="…"` and optionally `Ts="…"` (M1). The reals
    /// read the slow way are kept in `hand_over`.
    #[inline(always)]
    pub fn root<const N: usize>(
        bytes: &'a [u8],
        open: &[u8; N],
        hand_over: &'a mut HandOver,
    ) -> Option<(Self, Root)> {
        let mut s = Scan {
            rest: bytes,
            tally: Tally::default(),
            gap: (usize::MAX, 0),
            hand_over,
            len: bytes.len(),
            seen: 0,
        };
        s.ws();
        if s.rest.first() == Some(&b'<') && s.rest.get(1) == Some(&b'?') {
            s.declaration()?;
            s.ws();
        }
        if !s.lit(open) || !s.attr(b" Id=\"") {
            return None;
        }
        let id = parse_u32(s.value()?).ok()?;
        let ts = match s.attr(b" Ts=\"") {
            true => Some(parse_time(s.value()?).ok()?),
            false => None,
        };
        s.hand_over.header = Some((id, ts));
        Some((s, Root { id, ts }))
    }

    /// `<?xml version="1.N" [encoding="…"] [standalone="yes|no"]?>`, as
    /// `xmlparser` reads a declaration (double quotes, no whitespace
    /// around `=`: what else XML allows goes to the general path). Out of
    /// line: a controller sends none.
    #[cold]
    #[inline(never)]
    fn declaration(&mut self) -> Option<()> {
        if !self.lit(b"<?xml version=\"1.") || self.digits() == 0 || !self.lit(b"\"") {
            return None;
        }
        let mut spaced = self.ws();
        if spaced && self.lit(b"encoding=\"") {
            // EncName: [A-Za-z] ([A-Za-z0-9._] | '-')*
            if !self.rest.first().is_some_and(u8::is_ascii_alphabetic) {
                return None;
            }
            self.skip(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'));
            if !self.lit(b"\"") {
                return None;
            }
            spaced = self.ws();
        }
        if spaced && self.lit(b"standalone=\"") {
            if !(self.lit(b"yes\"") || self.lit(b"no\"")) {
                return None;
            }
            self.ws();
        }
        self.lit(b"?>").then_some(())
    }

    /// The end of the root's start tag: `>` (a record's fields follow).
    #[inline(always)]
    pub fn body(&mut self) -> Option<()> {
        self.ws();
        self.lit(b">").then_some(())
    }

    /// [`Scan::body`] of a record: its fields follow, and the general path
    /// may resume here ([`Scan::field_end`]).
    #[inline(always)]
    pub fn fields(&mut self) -> Option<()> {
        self.body()?;
        self.mark(0);
        Some(())
    }

    /// Field `j` of the record was read whole, up to its end: the general
    /// path, should this one hand the datagram over after it, resumes here
    /// with the fields seen and what was tolerated so far.
    #[inline(always)]
    pub fn field_end(&mut self, j: usize) {
        self.mark(1u64.checked_shl(j as u32).unwrap_or(0));
    }

    #[inline(always)]
    fn mark(&mut self, field: u64) {
        self.seen |= field;
        self.hand_over.mark = Mark {
            at: self.len - self.rest.len(),
            seen: self.seen,
            tally: Tally {
                missing_fields: 0,
                ..self.tally
            },
        };
    }

    /// Whitespace, then the start tag of a text field, `<Ts_act>` (M3):
    /// `true` past it, or `false` with nothing consumed (the field is not
    /// next: left out, M2, or the message is not one this path takes).
    #[inline(always)]
    pub fn open<const N: usize>(&mut self, tag: &[u8; N]) -> bool {
        self.ws();
        self.lit(tag) || self.open_spaced(tag)
    }

    /// [`Scan::open`] of `<Ts_act >`: whitespace before the `>`.
    #[cold]
    #[inline(never)]
    fn open_spaced(&mut self, tag: &[u8]) -> bool {
        let name = tag.get(..tag.len().saturating_sub(1)).unwrap_or(&[]);
        let save = self.rest;
        if self.prefix(name) && self.ws() && self.lit(b">") {
            return true;
        }
        self.rest = save;
        false
    }

    /// Whitespace, then the start of a field of attributes, `<P_act` (M4),
    /// followed by whitespace, `/` or `>`: `true` past the name, or
    /// `false` with nothing consumed.
    #[inline(always)]
    pub fn open_attrs<const N: usize>(&mut self, tag: &[u8; N]) -> bool {
        self.ws();
        let save = self.rest;
        if self.lit(tag) {
            if let Some(&b) = self.rest.first() {
                if is_xml_space(b) || b == b'/' || b == b'>' {
                    return true;
                }
            }
        }
        self.rest = save;
        false
    }

    /// A field left out of the message (M2: its previous value is kept).
    #[inline(always)]
    pub fn missing(&mut self) {
        bump(&mut self.tally.missing_fields);
    }

    /// The element text after a start tag, read by `parse`, then the end
    /// tag `close` (`</Ts_act>`, whitespace allowed before its `>`).
    #[inline(always)]
    pub fn text<const C: usize, T>(
        &mut self,
        close: &[u8; C],
        parse: impl FnOnce(&'a [u8]) -> Option<T>,
    ) -> Option<T> {
        let len = self
            .rest
            .iter()
            .position(|&b| class(b) & TEXT == 0)
            .unwrap_or(self.rest.len());
        let (text, rest) = self.rest.split_at_checked(len)?;
        self.rest = rest;
        let value = parse(text)?;
        self.close(close).then_some(value)
    }

    /// An end tag, `</Ts_act>` or `</Ts_act >`.
    #[inline(always)]
    fn close<const C: usize>(&mut self, close: &[u8; C]) -> bool {
        self.lit(close) || self.close_spaced(close)
    }

    #[cold]
    #[inline(never)]
    fn close_spaced(&mut self, close: &[u8]) -> bool {
        let name = close.get(..close.len().saturating_sub(1)).unwrap_or(&[]);
        self.prefix(name) && self.ws() && self.lit(b">")
    }

    /// An attribute, ` X="` (`lit`: one space, the name, `="`), with any
    /// XML whitespace before the name and around `=`: `true` with the
    /// value next, or `false` with nothing consumed.
    #[inline(always)]
    pub fn attr<const N: usize>(&mut self, lit: &[u8; N]) -> bool {
        self.lit(lit) || self.attr_spaced(lit)
    }

    #[inline(never)]
    fn attr_spaced(&mut self, lit: &[u8]) -> bool {
        // ` X="` without its first and last two bytes: the name.
        let name = lit.get(1..lit.len().saturating_sub(2)).unwrap_or(&[]);
        let save = self.rest;
        if self.ws() && self.prefix(name) && self.equals() {
            return true;
        }
        self.rest = save;
        false
    }

    /// `=` and the opening quote, whitespace around the `=`.
    #[inline(always)]
    fn equals(&mut self) -> bool {
        self.ws();
        if !self.lit(b"=") {
            return false;
        }
        self.ws();
        self.lit(b"\"")
    }

    /// An attribute's value up to its closing quote, which is consumed.
    #[inline(always)]
    pub fn value(&mut self) -> Option<&'a [u8]> {
        let len = self.rest.iter().position(|&b| class(b) & VALUE == 0)?;
        let (value, rest) = self.rest.split_at_checked(len)?;
        let (&quote, rest) = rest.split_first()?;
        self.rest = rest;
        (quote == b'"').then_some(value)
    }

    /// A real attribute value (M5) and its closing quote: the robot's
    /// plain notation read in place, anything else by `parse_f32` over the
    /// value, as the general path reads it.
    #[inline(always)]
    pub fn real(&mut self) -> Option<f32> {
        // A plain number takes at most 21 bytes (19 digits, a sign, a
        // point): in a window of 22, one that ends before the window's
        // end ends where it would in the whole datagram, and a longer run
        // of digits costs no more than the window.
        let window = self.rest.get(..PLAIN_WINDOW).unwrap_or(self.rest);
        if let Some((v, n)) = plain_prefix(window) {
            if let Some((&b'"', rest)) = self.rest.get(n..).and_then(<[u8]>::split_first) {
                self.rest = rest;
                return Some(v);
            }
        }
        self.real_other()
    }

    /// [`Scan::real`] of any other text: a value of at most
    /// [`NUMBER_VALUE_LEN`] bytes read by `parse_f32`; a longer one (a
    /// number the general path refuses, or whitespace it trims) is left to
    /// the general path unread.
    #[inline(never)]
    fn real_other(&mut self) -> Option<f32> {
        let head = self.rest.get(..NUMBER_VALUE_LEN + 1).unwrap_or(self.rest);
        let len = value_len(head)?;
        let (value, rest) = self.rest.split_at_checked(len)?;
        let (&b'"', rest) = rest.split_first()? else {
            return None;
        };
        // Not the plain notation (`Scan::real` tried it): straight to the
        // whole scanner, which gives what `parse_f32` gives for any text.
        let v = parse_f32_general(value).ok()?;
        self.hand_over.keep(value, v);
        self.rest = rest;
        Some(v)
    }

    /// The end of the message: the root's end tag `close` (after a
    /// record's fields or a value's text), then nothing but whitespace.
    #[inline(always)]
    pub fn end<const C: usize>(mut self, root: Root, close: &[u8; C]) -> Option<Decoded> {
        self.ws();
        if self.hand_over.mark.at > 0 && self.rest.first() == Some(&b'<') {
            // Whitespace up to a tag is one blank text the general path
            // would skip: it may resume after it (a hostile message pads
            // here with kilobytes of it).
            self.hand_over.mark.at = self.len - self.rest.len();
        }
        if !self.close(close) {
            return None;
        }
        self.finish(root)
    }

    /// The end of a message whose root already ended (`/>` of a value of
    /// attributes, or the end tag read with its text): nothing but
    /// whitespace after it.
    #[inline(always)]
    pub fn finish(mut self, root: Root) -> Option<Decoded> {
        self.ws();
        self.rest.is_empty().then_some(Decoded {
            id: root.id,
            ts: root.ts,
            tally: self.tally,
        })
    }
}

/// Where the attribute value at the start of `head` ends (the first byte
/// not of [`VALUE`]), or `None` when `head` ends first: its runs of digits
/// four bytes a step ([`digit_count`]), any other byte by its class. A
/// long real is mostly digits: this is a third of the byte-at-a-time scan.
#[inline(always)]
fn value_len(head: &[u8]) -> Option<usize> {
    let mut rest = head;
    loop {
        rest = rest.get(digit_count(rest)..).unwrap_or(&[]);
        match rest {
            [b, tail @ ..] if class(*b) & VALUE != 0 => rest = tail,
            [_, ..] => return Some(head.len() - rest.len()),
            [] => return None,
        }
    }
}

fn bump(counter: &mut u16) {
    *counter = counter.saturating_add(1);
}

#[path = "compiled_attrs.rs"]
mod attrs;
#[path = "compiled_bytes.rs"]
mod bytes;
#[path = "compiled_values.rs"]
mod values;
pub use values::{boolean, real, string, time};

#[cfg(test)]
#[path = "compiled_tests.rs"]
mod tests;
