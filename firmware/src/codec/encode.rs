//! Device → robot: typed data into a reply datagram, straight into the
//! caller's buffer (M1–M8).
//!
//! The fixed parts are byte strings precomputed by the build script
//! (tags) or here (attribute names with their quotes, array names built
//! in registers); values are written by the fixed-decimal
//! writers of [`super::format`], never by `core::fmt`. Output is compact (no
//! whitespace). With a buffer of the message's generated
//! `MAX_ENCODED_LEN`, encoding cannot run out of space; a smaller buffer is
//! an error, never an overrun.

use super::format::digit_pair;
use super::text::write_escaped;
use super::writer::Writer;
use crate::schema::{Body, FieldRef, Format, MessageCodec};
use crate::value::{RriString, Time};
use rri_vocabulary::{FALSE, TRUE};

/// What encoding reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoded {
    /// Bytes written at the start of the buffer.
    pub len: usize,
    /// Non-finite reals written as zero (M5), for the statistics.
    pub non_finite: u16,
}

/// The buffer is smaller than the message (it must be `MAX_ENCODED_LEN`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall;

impl core::fmt::Display for BufferTooSmall {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("reply buffer smaller than the message's MAX_ENCODED_LEN")
    }
}

impl core::error::Error for BufferTooSmall {}

/// An attribute's opener with, in front of it, the quote that closes the
/// attribute before it (`" Rx="`): one word store for both. A field's
/// first attribute is written without that quote ([`Out::opener`]) and
/// its last one is closed after the loop.
type Opener = ([u8; 8], usize);

/// [`Opener`] of `text` (at most 8 bytes, the quote included; a longer
/// one fails the build).
#[allow(clippy::indexing_slicing)] // evaluated at compile time
const fn opener(text: &[u8]) -> Opener {
    assert!(text.len() <= 8, "an attribute opener is one 8-byte word");
    let mut word = [0u8; 8];
    let mut i = 0;
    while i < text.len() && i < 8 {
        word[i] = text[i];
        i += 1;
    }
    (word, i)
}

const FRAME_ATTRS: [Opener; 6] = [
    opener(b"\" X=\""),
    opener(b"\" Y=\""),
    opener(b"\" Z=\""),
    opener(b"\" Rx=\""),
    opener(b"\" Ry=\""),
    opener(b"\" Rz=\""),
];
const JOINT_ATTRS: [Opener; 6] = [
    opener(b"\" J1=\""),
    opener(b"\" J2=\""),
    opener(b"\" J3=\""),
    opener(b"\" J4=\""),
    opener(b"\" J5=\""),
    opener(b"\" J6=\""),
];

struct Out<'w, 'b> {
    w: &'w mut Writer<'b>,
    format: Format,
    non_finite: u16,
}

impl Out<'_, '_> {
    fn real(&mut self, v: f32) {
        if !self.w.real(v, self.format.real_decimals) {
            self.non_finite = self.non_finite.saturating_add(1);
        }
    }

    fn bool(&mut self, v: bool) {
        self.w.bytes(if v { TRUE } else { FALSE });
    }

    fn time(&mut self, t: Time) {
        self.w.time(t, self.format.time_decimals);
    }

    fn string(&mut self, s: &RriString) {
        write_escaped(self.w, s.as_str());
    }

    /// Attribute `i` of a field: its [`Opener`], without the leading
    /// quote when it is the first (`i == 0`).
    #[inline]
    fn opener(&mut self, (word, len): Opener, i: usize) {
        let first = u32::from(i == 0);
        let word = u64::from_le_bytes(word) >> (8 * first);
        self.w.word(word.to_le_bytes(), len - first as usize);
    }

    /// The [`Opener`] of array element `i` (0-based, M4), `" X<i+1>="`:
    /// up to `X99` one word built in registers, beyond that digit by digit
    /// (out of line: arrays that long are rare).
    #[inline]
    fn array_attr(&mut self, i: usize) {
        let n = i + 1;
        if n < 10 {
            let d = b'0' + n as u8;
            self.opener(([b'"', b' ', b'X', d, b'=', b'"', 0, 0], 6), i);
        } else if n < 100 {
            let [hi, lo] = digit_pair(n as u64);
            self.opener(([b'"', b' ', b'X', hi, lo, b'=', b'"', 0], 7), i);
        } else {
            self.long_array_attr(n);
        }
    }

    #[cold]
    #[inline(never)]
    fn long_array_attr(&mut self, n: usize) {
        self.w.bytes(b"\" X");
        self.w.u64(n as u64);
        self.w.bytes(b"=\"");
    }

    /// The attributes of a multi-value field (M4); `false` for text values.
    fn attributes(&mut self, value: &FieldRef<'_>) -> bool {
        let start = self.w.len();
        match value {
            FieldRef::Frame(f) => {
                let values = [f.x, f.y, f.z, f.rx, f.ry, f.rz];
                for (i, (name, v)) in FRAME_ATTRS.iter().zip(values).enumerate() {
                    self.opener(*name, i);
                    self.real(v);
                }
            }
            FieldRef::Joints(j) => {
                for (i, (name, v)) in JOINT_ATTRS.iter().zip(j.iter()).enumerate() {
                    self.opener(*name, i);
                    self.real(*v);
                }
            }
            FieldRef::Reals(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.real(*v);
                }
            }
            FieldRef::Bools(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.bool(*v);
                }
            }
            FieldRef::Times(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.time(*v);
                }
            }
            FieldRef::Strs(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.string(v);
                }
            }
            _ => return false,
        }
        // The last attribute's closing quote (an array of none, which G3
        // does not allow, has no attribute to close).
        if self.w.len() > start {
            self.w.byte(b'"');
        }
        true
    }

    /// A text value (M3).
    fn text(&mut self, value: &FieldRef<'_>) {
        match value {
            FieldRef::Bool(v) => self.bool(*v),
            FieldRef::Real(v) => self.real(*v),
            FieldRef::Time(v) => self.time(*v),
            FieldRef::Str(s) => self.string(s),
            FieldRef::Enum(wire) => write_escaped(self.w, wire),
            _ => {}
        }
    }
}

/// Encodes message `M` carrying `data`, answering robot message `id` (M8)
/// with the device's timestamp `ts`, into `buf`.
pub fn encode<M: MessageCodec>(
    data: &M::Data,
    id: u32,
    ts: Time,
    format: Format,
    buf: &mut [u8],
) -> Result<Encoded, BufferTooSmall> {
    let mut w = Writer::new(buf);
    let mut out = Out {
        w: &mut w,
        format,
        non_finite: 0,
    };
    out.w.bytes(M::OPEN);
    out.w.u64(u64::from(id));
    out.w.bytes(b"\" Ts=\"");
    out.time(ts);
    out.w.byte(b'"');
    match M::BODY {
        Body::Value => match M::field(data, 0) {
            Some(value) => {
                if out.attributes(&value) {
                    out.w.bytes(b"/>");
                } else {
                    out.w.byte(b'>');
                    out.text(&value);
                    out.w.bytes(M::CLOSE);
                }
            }
            None => out.w.bytes(b"/>"),
        },
        Body::Record => {
            out.w.byte(b'>');
            for (i, wire) in M::FIELDS.iter().enumerate() {
                let Some(value) = M::field(data, i) else {
                    continue;
                };
                out.w.bytes(wire.open);
                if !out.attributes(&value) {
                    out.text(&value);
                }
                out.w.bytes(wire.close);
            }
            out.w.bytes(M::CLOSE);
        }
    }
    let non_finite = out.non_finite;
    if w.overflowed() {
        return Err(BufferTooSmall);
    }
    Ok(Encoded {
        len: w.len(),
        non_finite,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::format;

    /// M4: element `i` of an array is `X<i+1>`, for every length G3
    /// allows (1 to 1000), whether the buffer has room to spare (one word
    /// store) or ends right after the name (byte by byte); every element
    /// but the first closes the one before it.
    #[test]
    fn m4_array_attribute_names_count_from_x1() {
        for i in 0..1000 {
            let close = if i == 0 { "" } else { "\"" };
            let want = format!("{close} X{}=\"", i + 1);
            for room in [64, want.len()] {
                let mut buf = [0u8; 64];
                let mut w = Writer::new(&mut buf[..room]);
                let mut out = Out {
                    w: &mut w,
                    format: Format::new(3, 3),
                    non_finite: 0,
                };
                out.array_attr(i);
                assert!(!w.overflowed(), "{want} in {room} bytes");
                assert_eq!(w.written(), want.as_bytes(), "room {room}");
            }
        }
    }

    fn attributes(value: FieldRef<'_>) -> (bool, std::string::String) {
        let mut buf = [0u8; 256];
        let mut w = Writer::new(&mut buf);
        let mut out = Out {
            w: &mut w,
            format: Format::new(1, 3),
            non_finite: 0,
        };
        let multi = out.attributes(&value);
        assert!(!w.overflowed());
        (
            multi,
            std::string::String::from_utf8(w.written().to_vec()).unwrap(),
        )
    }

    /// M4: each value is quoted once, whatever shares a word store.
    #[test]
    fn m4_attributes_are_each_quoted() {
        let p = crate::value::Frame {
            x: 1.0,
            y: 2.0,
            z: 3.0,
            rx: 4.0,
            ry: 5.0,
            rz: -6.0,
        };
        assert_eq!(
            attributes(FieldRef::Frame(&p)).1,
            r#" X="1.0" Y="2.0" Z="3.0" Rx="4.0" Ry="5.0" Rz="-6.0""#
        );
        let j = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0];
        assert_eq!(
            attributes(FieldRef::Joints(&j)).1,
            r#" J1="0.5" J2="1.0" J3="1.5" J4="2.0" J5="2.5" J6="3.0""#
        );
        let flags = [true, false];
        assert_eq!(
            attributes(FieldRef::Bools(&flags)).1,
            r#" X1="TRUE" X2="FALSE""#
        );
        assert_eq!(attributes(FieldRef::Reals(&[7.0])).1, r#" X1="7.0""#);
        // No elements (G3 allows none, a hand-written record could): no
        // stray quote.
        assert_eq!(attributes(FieldRef::Reals(&[])), (true, "".into()));
        assert_eq!(attributes(FieldRef::Real(1.0)), (false, "".into()));
    }

    #[test]
    fn buffer_too_small_says_what_the_buffer_must_hold() {
        assert_eq!(
            BufferTooSmall.to_string(),
            "reply buffer smaller than the message's MAX_ENCODED_LEN"
        );
    }
}
