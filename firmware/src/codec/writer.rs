//! The byte sink every encoder writes into ([`Writer`]): a fixed buffer
//! that never panics and never allocates. Numbers are written into it by
//! [`super::format`], text by [`super::text`], whole replies by
//! [`super::encode()`].

/// A byte sink with a fixed capacity that never panics: a write that does
/// not fit sets `overflow` and is dropped. Buffers are sized by the
/// generated maxima, so in the firmware it never overflows; the flag makes
/// sure a wrong size is an error, not memory corruption.
///
/// Invariant: `len <= buf.len()`. `len` starts at 0, and only `reserve`
/// and [`Writer::byte`] advance it, each after finding in `buf` the bytes
/// it counts. [`Writer::written`] is the one place that relies on it.
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

    /// The next `n` bytes of the buffer, counted as written, for a writer
    /// that fills them in any order (digits from the last one backwards);
    /// `None`, and the overflow flag set, when they do not fit.
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
}
