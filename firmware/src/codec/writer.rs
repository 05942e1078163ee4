//! The byte sink every encoder writes into ([`Writer`]): a fixed buffer
//! that never panics and never allocates. Numbers are written into it by
//! [`super::format`], text by [`super::text`], whole replies by
//! [`super::encode()`].

/// A byte sink with a fixed capacity that never panics: a write that does
/// not fit sets `overflow` and is dropped. Buffers are sized by the
/// generated maxima, so in the firmware it never overflows; the flag makes
/// sure a wrong size is an error, not memory corruption.
///
/// Invariant: `len <= buf.len()`. `len` starts at 0, and only `reserve`,
/// `fill` and [`Writer::byte`] advance it, each after finding in `buf`
/// the bytes it counts. [`Writer::written`] is the one place that relies on it.
pub struct Writer<'a> {
    buf: &'a mut [u8],
    /// Bytes written; never more than `buf.len()` (see above).
    len: usize,
    overflow: bool,
}

impl<'a> Writer<'a> {
    /// An empty sink over `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Writer {
            buf,
            len: 0,
            overflow: false,
        }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing written yet.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// A write did not fit (and was dropped).
    pub fn overflowed(&self) -> bool {
        self.overflow
    }

    /// The bytes written so far.
    pub fn written(&self) -> &[u8] {
        // `len <= buf.len()` (the type's invariant): the empty fallback is
        // never taken; it only keeps a panic path out of the image.
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// The next `n` bytes of the buffer, counted as written, for the
    /// caller to fill; `None`, and the overflow flag set, when they do not
    /// fit.
    #[inline]
    pub(crate) fn reserve(&mut self, n: usize) -> Option<&mut [u8]> {
        let start = self.len;
        match self.buf.get_mut(start..start + n) {
            Some(dst) => {
                self.len = start + n;
                Some(dst)
            }
            None => {
                self.overflow = true;
                None
            }
        }
    }

    /// Appends `b`, or nothing if it does not fit whole.
    #[inline]
    pub fn bytes(&mut self, b: &[u8]) {
        if let Some(dst) = self.reserve(b.len()) {
            // Equal lengths by construction; zipped so no length-mismatch
            // panic path is left (cargo panic-check).
            for (d, s) in dst.iter_mut().zip(b) {
                *d = *s;
            }
        }
    }

    /// Appends the first `n` bytes of `word` (`n` ≤ 8), or nothing if they
    /// do not fit: a short piece built in registers (an attribute's
    /// `" X12="`) in one 8-byte store where the buffer has room for all
    /// eight, instead of a copy loop or a `memcpy` call for five bytes.
    /// The bytes after the `n` counted are scratch: beyond
    /// [`Writer::written`], and the next write starts over them.
    #[inline]
    pub fn word(&mut self, word: [u8; 8], n: usize) {
        if !self.fill(n, |dst: &mut [u8; 8]| *dst = word) {
            // Near the end of the buffer: byte by byte; `n` > 8 is a
            // miscount, refused like a write that does not fit.
            match word.get(..n) {
                Some(piece) => self.bytes(piece),
                None => self.overflow = true,
            }
        }
    }

    /// Lets `write` fill the next `N` bytes of the buffer and counts the
    /// first `n` (`n` ≤ `N`) as written; `false`, and nothing written,
    /// when `N` bytes are not left. For a writer that puts its bytes in
    /// any order at positions it masks into the `N` (no bounds checks),
    /// such as a number's digits from the last one backwards; the caller
    /// writes some other way when this returns `false` (only ever near
    /// the end of the buffer).
    #[inline]
    pub(crate) fn fill<const N: usize>(
        &mut self,
        n: usize,
        write: impl FnOnce(&mut [u8; N]),
    ) -> bool {
        let start = self.len;
        let room = self
            .buf
            .get_mut(start..start + N)
            .and_then(|d| <&mut [u8; N]>::try_from(d).ok());
        match room {
            Some(dst) if n <= N => {
                write(dst);
                self.len = start + n;
                true
            }
            _ => false,
        }
    }

    /// Appends one byte, or nothing if it does not fit.
    #[inline]
    pub fn byte(&mut self, b: u8) {
        match self.buf.get_mut(self.len) {
            Some(dst) => {
                *dst = b;
                self.len += 1;
            }
            None => self.overflow = true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_that_does_not_fit_is_dropped_whole_and_flagged() {
        let mut buf = [0u8; 4];
        let mut w = Writer::new(&mut buf);
        w.bytes(b"abc");
        assert!(!w.overflowed());
        w.bytes(b"de");
        assert!(w.overflowed());
        assert_eq!(w.written(), b"abc");
        w.byte(b'd');
        w.byte(b'e');
        assert_eq!(w.written(), b"abcd");
        assert!(w.reserve(1).is_none());
    }

    #[test]
    fn a_word_counts_only_its_first_n_bytes_and_fits_at_the_very_end() {
        let piece = *b" X7=\"---";
        // Room for the whole word: the first five bytes are written.
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf);
        w.word(piece, 5);
        w.byte(b'1');
        assert_eq!(w.written(), b" X7=\"1");
        // Room for exactly five (not the word's eight): written byte by
        // byte, all five, not flagged.
        let mut buf = [0u8; 5];
        let mut w = Writer::new(&mut buf);
        w.word(piece, 5);
        assert_eq!((w.written(), w.overflowed()), (&b" X7=\""[..], false));
        // Room for four: nothing written, flagged.
        let mut buf = [0u8; 4];
        let mut w = Writer::new(&mut buf);
        w.word(piece, 5);
        assert_eq!((w.written(), w.overflowed()), (&b""[..], true));
        // A miscounted piece (more than eight bytes) is refused, not cut.
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf);
        w.word(piece, 9);
        assert_eq!((w.written(), w.overflowed()), (&b""[..], true));
    }
}
