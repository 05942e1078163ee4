//! Device → robot: typed data into a reply datagram, straight into the
//! caller's buffer (M1–M8).
//!
//! The fixed parts (tags, attribute names, quotes) are byte strings
//! precomputed by the build script; values are written by the fixed-decimal
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

const FRAME_ATTRS: [&[u8]; 6] = [
    b" X=\"", b" Y=\"", b" Z=\"", b" Rx=\"", b" Ry=\"", b" Rz=\"",
];
const JOINT_ATTRS: [&[u8]; 6] = [
    b" J1=\"", b" J2=\"", b" J3=\"", b" J4=\"", b" J5=\"", b" J6=\"",
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

    /// ` X<i+1>="` for array element `i` (0-based, M4): up to `X99` one
    /// 8-byte word built in registers ([`Writer::word`]), beyond that
    /// digit by digit (out of line: arrays that long are rare).
    #[inline]
    fn array_attr(&mut self, i: usize) {
        let n = i + 1;
        if n < 10 {
            let d = b'0' + n as u8;
            self.w.word([b' ', b'X', d, b'=', b'"', 0, 0, 0], 5);
        } else if n < 100 {
            let [hi, lo] = digit_pair(n as u64);
            self.w.word([b' ', b'X', hi, lo, b'=', b'"', 0, 0], 6);
        } else {
            self.long_array_attr(n);
        }
    }

    #[cold]
    #[inline(never)]
    fn long_array_attr(&mut self, n: usize) {
        self.w.bytes(b" X");
        self.w.u64(n as u64);
        self.w.bytes(b"=\"");
    }

    /// The attributes of a multi-value field (M4); `false` for text values.
    fn attributes(&mut self, value: &FieldRef<'_>) -> bool {
        match value {
            FieldRef::Frame(f) => {
                for (name, v) in FRAME_ATTRS.iter().zip([f.x, f.y, f.z, f.rx, f.ry, f.rz]) {
                    self.w.bytes(name);
                    self.real(v);
                    self.w.byte(b'"');
                }
            }
            FieldRef::Joints(j) => {
                for (name, v) in JOINT_ATTRS.iter().zip(j.iter()) {
                    self.w.bytes(name);
                    self.real(*v);
                    self.w.byte(b'"');
                }
            }
            FieldRef::Reals(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.real(*v);
                    self.w.byte(b'"');
                }
            }
            FieldRef::Bools(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.bool(*v);
                    self.w.byte(b'"');
                }
            }
            FieldRef::Times(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.time(*v);
                    self.w.byte(b'"');
                }
            }
            FieldRef::Strs(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.array_attr(i);
                    self.string(v);
                    self.w.byte(b'"');
                }
            }
            _ => return false,
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
    /// store) or ends right after the name (byte by byte).
    #[test]
    fn m4_array_attribute_names_count_from_x1() {
        for i in 0..1000 {
            let want = format!(" X{}=\"", i + 1);
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

    #[test]
    fn buffer_too_small_says_what_the_buffer_must_hold() {
        assert_eq!(
            BufferTooSmall.to_string(),
            "reply buffer smaller than the message's MAX_ENCODED_LEN"
        );
    }
}
