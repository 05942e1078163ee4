//! Where the diagnostics are written ([`Out`]): a stream of bytes longer
//! than any buffer the device spends on it.
//!
//! A page is about 10 KB and the device has no heap, so it is never held
//! whole. The service renders a response once into [`Count`] to learn its
//! length (for `Content-Length`), then once per window of the stream into
//! [`Window`], which keeps only the bytes from `skip` on that fit its
//! buffer: every pass renders from the same copy of the status, so the
//! windows join into one consistent response. The cost is a few passes of
//! cheap integer formatting at the background's priority; the memory is
//! one window.
//!
//! Every string that came from a file (the GSI folder) or from the network
//! (a bad robot message) goes through the escaping writers here (`json`,
//! `json_bytes` for bytes that may not be UTF-8, `label`); nothing else
//! writes them.

/// A sink for a response: it never fails and never allocates; what does
/// not fit is the sink's business (counted, skipped or cut).
pub trait Out {
    /// Appends `b`.
    fn bytes(&mut self, b: &[u8]);
}

/// The writers every form uses, on any sink. Inherent methods of `dyn
/// Out` rather than provided methods of the trait: one copy of each in
/// the image, whatever the sink (provided methods would be copied per sink
/// type and inlined into every caller: tens of KiB of flash for the same
/// code).
impl dyn Out + '_ {
    /// Appends `s` as it is (for text of our own: markup, names we chose).
    pub fn str(&mut self, s: &str) {
        self.bytes(s.as_bytes());
    }

    /// Appends `v` in decimal.
    #[inline(never)]
    pub fn u64(&mut self, v: u64) {
        let mut digits = [0u8; 20];
        let mut at = digits.len();
        let mut v = v;
        loop {
            at -= 1;
            if let Some(d) = digits.get_mut(at) {
                *d = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || at == 0 {
                break;
            }
        }
        self.bytes(digits.get(at..).unwrap_or(&[]));
    }

    /// Appends `v` in decimal.
    pub fn u32(&mut self, v: u32) {
        self.u64(v.into());
    }

    /// Appends `us` microseconds as seconds with six decimals (`5` →
    /// `0.000005`), without float formatting: the whole seconds, then the
    /// remainder plus 10^6 with its leading `1` turned into the point.
    #[inline(never)]
    pub fn seconds(&mut self, us: u64) {
        self.u64(us / 1_000_000);
        let mut w = [0u8; 7];
        let mut frac = us % 1_000_000 + 1_000_000;
        for d in w.iter_mut().rev() {
            *d = b'0' + (frac % 10) as u8;
            frac /= 10;
        }
        w[0] = b'.';
        self.bytes(&w);
    }

    /// Appends an IPv4 address, `a.b.c.d`.
    #[inline(never)]
    pub fn ipv4(&mut self, ip: [u8; 4]) {
        for (i, octet) in ip.into_iter().enumerate() {
            if i > 0 {
                self.str(".");
            }
            self.u64(octet.into());
        }
    }

    /// Appends a MAC address, `02:00:52:52:49:01`.
    #[inline(never)]
    pub fn mac(&mut self, mac: [u8; 6]) {
        for (i, byte) in mac.into_iter().enumerate() {
            if i > 0 {
                self.str(":");
            }
            self.bytes(&hex(byte));
        }
    }

    /// Appends text inside a JSON string: `"` and `\` escaped, control
    /// characters as `\u00NN`; UTF-8 as it is.
    #[inline(never)]
    pub fn json(&mut self, text: &str) {
        escape(self, text.as_bytes(), json_escape);
    }

    /// Appends bytes that may be anything inside a JSON string: as
    /// `json`, and every byte from 0x80 as `\u00NN` (the byte's
    /// Latin-1 character), so the string is valid JSON whatever arrived
    /// and each byte can be read back.
    #[inline(never)]
    pub fn json_bytes(&mut self, bytes: &[u8]) {
        escape(self, bytes, |b| match b {
            0x80.. => Some(Piece::Unicode(b)),
            _ => json_escape(b),
        });
    }

    /// Appends a Prometheus label value (text exposition format 0.0.4):
    /// `\`, `"` and line feed escaped.
    #[inline(never)]
    pub fn label(&mut self, text: &str) {
        escape(self, text.as_bytes(), |b| match b {
            b'\\' => Some(Piece::Text("\\\\")),
            b'"' => Some(Piece::Text("\\\"")),
            b'\n' => Some(Piece::Text("\\n")),
            _ => None,
        });
    }
}

/// What an escaping writer puts in place of one byte.
enum Piece {
    Text(&'static str),
    /// `\u00NN`.
    Unicode(u8),
}

fn json_escape(b: u8) -> Option<Piece> {
    match b {
        b'"' => Some(Piece::Text("\\\"")),
        b'\\' => Some(Piece::Text("\\\\")),
        b'\n' => Some(Piece::Text("\\n")),
        b'\r' => Some(Piece::Text("\\r")),
        b'\t' => Some(Piece::Text("\\t")),
        0..=0x1f | 0x7f => Some(Piece::Unicode(b)),
        _ => None,
    }
}

fn hex(b: u8) -> [u8; 2] {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let digit = |n: u8| DIGITS.get(usize::from(n)).copied().unwrap_or(b'0');
    [digit(b >> 4), digit(b & 0x0f)]
}

/// Writes `bytes` with the runs that need no escaping in one piece each.
#[inline(never)]
fn escape(out: &mut dyn Out, bytes: &[u8], rule: fn(u8) -> Option<Piece>) {
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        let Some(piece) = rule(b) else { continue };
        out.bytes(bytes.get(start..i).unwrap_or(&[]));
        match piece {
            Piece::Text(t) => out.str(t),
            Piece::Unicode(b) => {
                out.str("\\u00");
                out.bytes(&hex(b));
            }
        }
        start = i + 1;
    }
    out.bytes(bytes.get(start..).unwrap_or(&[]));
}

/// Counts the bytes of a response without keeping any.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Count {
    /// Bytes written so far.
    pub len: usize,
}

impl Out for Count {
    fn bytes(&mut self, b: &[u8]) {
        self.len = self.len.saturating_add(b.len());
    }
}

/// Keeps the bytes of the stream from position `skip` on, as many as its
/// buffer holds; the rest is counted and dropped.
pub struct Window<'a> {
    skip: usize,
    /// Position in the whole stream.
    pos: usize,
    buf: &'a mut [u8],
    /// Bytes of `buf` filled (invariant: `len <= buf.len()`).
    len: usize,
}

impl<'a> Window<'a> {
    /// A window over `buf` starting at byte `skip` of the stream.
    pub fn new(buf: &'a mut [u8], skip: usize) -> Self {
        Window {
            skip,
            pos: 0,
            buf,
            len: 0,
        }
    }

    /// The bytes kept.
    pub fn kept(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// The whole stream's length as far as it was written.
    pub fn total(&self) -> usize {
        self.pos
    }
}

impl Out for Window<'_> {
    fn bytes(&mut self, b: &[u8]) {
        let end = self.pos.saturating_add(b.len());
        // The part of `b` at or after `skip + len` (what the buffer wants
        // next), as far as the buffer has room.
        let want = self.skip.saturating_add(self.len);
        if end > want && self.len < self.buf.len() {
            let from = want.saturating_sub(self.pos);
            let piece = b.get(from..).unwrap_or(&[]);
            let room = self.buf.get_mut(self.len..).unwrap_or(&mut []);
            let n = piece.len().min(room.len());
            for (d, s) in room.iter_mut().zip(piece).take(n) {
                *d = *s;
            }
            self.len += n;
        }
        self.pos = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Everything, for the tests.
    #[derive(Default)]
    struct All(Vec<u8>);

    impl Out for All {
        fn bytes(&mut self, b: &[u8]) {
            self.0.extend_from_slice(b);
        }
    }

    fn text(f: impl Fn(&mut dyn Out)) -> String {
        let mut a = All::default();
        f(&mut a);
        String::from_utf8(a.0).unwrap()
    }

    #[test]
    fn numbers_in_decimal_and_fixed_point() {
        assert_eq!(text(|o| o.u64(0)), "0");
        assert_eq!(text(|o| o.u64(u64::MAX)), "18446744073709551615");
        assert_eq!(text(|o| o.seconds(1_234_000)), "1.234000");
        assert_eq!(text(|o| o.seconds(5)), "0.000005");
        assert_eq!(text(|o| o.seconds(0)), "0.000000");
        assert_eq!(text(|o| o.seconds(u64::MAX)), "18446744073709.551615");
        assert_eq!(text(|o| o.ipv4([10, 49, 65, 74])), "10.49.65.74");
        assert_eq!(
            text(|o| o.mac([2, 0, 0x52, 0x52, 0x49, 0xab])),
            "02:00:52:52:49:ab"
        );
    }

    #[test]
    fn json_strings_stay_valid_whatever_the_bytes() {
        assert_eq!(
            text(|o| o.json("a\"b\\c\nd\u{1}")),
            "a\\\"b\\\\c\\nd\\u0001"
        );
        assert_eq!(text(|o| o.json_bytes(b"\xc3\x28<")), "\\u00c3(<");
        assert_eq!(text(|o| o.json("ü")), "ü");
    }

    #[test]
    fn prometheus_label_values_escape_backslash_quote_and_newline() {
        assert_eq!(text(|o| o.label("a\\b\"c\nd")), "a\\\\b\\\"c\\nd");
    }

    #[test]
    fn windows_of_one_stream_join_into_the_whole() {
        let write = |o: &mut dyn Out| {
            o.str("HTTP/1.1 200 OK\r\n");
            for i in 0..50u64 {
                o.u64(i * 7919);
                o.json("<&>\"");
            }
        };
        let mut whole = All::default();
        write(&mut whole);
        let mut count = Count::default();
        write(&mut count);
        assert_eq!(count.len, whole.0.len());
        for size in [1, 3, 7, 64, 1000] {
            let mut joined = Vec::new();
            let mut buf = vec![0u8; size];
            while joined.len() < count.len {
                let mut w = Window::new(&mut buf, joined.len());
                write(&mut w);
                assert_eq!(w.total(), count.len);
                assert!(!w.kept().is_empty());
                joined.extend_from_slice(w.kept());
            }
            assert_eq!(joined, whole.0, "window of {size}");
        }
    }
}
