//! The compiled path's byte steps: whitespace (a long run read once,
//! [`Scan::gap`]), digits, literals. A third `impl` block of [`Scan`],
//! kept apart from the scanner's core (names, texts, the root) in
//! `compiled.rs` and the values of attributes in `compiled_attrs.rs`.

use super::{class, is_xml_space, same, Scan, INDENTATION, SPACE};

impl Scan<'_> {
    /// Skips XML whitespace; whether there was any. A compact message has
    /// none (one test), an indented one a few bytes a line; a run longer
    /// than indentation (a hostile datagram may be thousands of bytes of
    /// it) is read four bytes a turn, once: read again from its start (an
    /// attribute that was not next rewinds to before it), it is a jump
    /// ([`Scan::gap`]). So the work is linear in the datagram whatever
    /// the layout tries at each gap: at most [`INDENTATION`] bytes a try.
    #[inline(always)]
    pub(super) fn ws(&mut self) -> bool {
        let before = self.rest.len();
        while let [b, rest @ ..] = self.rest {
            if !is_xml_space(*b) {
                break;
            }
            self.rest = rest;
            if before - self.rest.len() == INDENTATION {
                self.padding(before);
                break;
            }
        }
        self.rest.len() != before
    }

    /// The rest of a long run of whitespace that started where `rest` was
    /// `start` bytes long: a jump when it was read before, else read and
    /// noted.
    #[cold]
    #[inline(never)]
    pub(super) fn padding(&mut self, start: usize) {
        let (from, to) = self.gap;
        if from == start {
            let skip = self.rest.len().saturating_sub(to);
            self.rest = self.rest.get(skip..).unwrap_or(&[]);
            return;
        }
        self.read_padding();
        self.gap = (start, self.rest.len());
    }

    /// Reads a run of whitespace to its end.
    pub(super) fn read_padding(&mut self) {
        while let Some((&[a, b, c, d], rest)) = self.rest.split_first_chunk::<4>() {
            if class(a) & class(b) & class(c) & class(d) & SPACE == 0 {
                break;
            }
            self.rest = rest;
        }
        while let [b, rest @ ..] = self.rest {
            if class(*b) & SPACE == 0 {
                break;
            }
            self.rest = rest;
        }
    }

    /// Skips bytes while `keep` holds.
    pub(super) fn skip(&mut self, keep: impl Fn(u8) -> bool) {
        while let [b, rest @ ..] = self.rest {
            if !keep(*b) {
                break;
            }
            self.rest = rest;
        }
    }

    /// Skips decimal digits; how many.
    pub(super) fn digits(&mut self) -> usize {
        let before = self.rest.len();
        self.skip(|b| b.is_ascii_digit());
        before - self.rest.len()
    }

    /// A decimal number of at most four digits (`X1`..`X1000`) and how
    /// many digits it had; more than four reads as `usize::MAX`.
    #[inline(always)]
    pub(super) fn number(&mut self) -> (usize, usize) {
        let mut n = 0usize;
        let mut digits = 0;
        while let [b @ b'0'..=b'9', rest @ ..] = self.rest {
            n = n.saturating_mul(10).saturating_add(usize::from(b - b'0'));
            digits += 1;
            self.rest = rest;
        }
        (if digits > 4 { usize::MAX } else { n }, digits)
    }

    /// Consumes the literal `lit` if the input starts with it.
    #[inline(always)]
    pub(super) fn lit<const N: usize>(&mut self, lit: &[u8; N]) -> bool {
        match self.rest.split_first_chunk::<N>() {
            Some((head, rest)) if same(head, lit) => {
                self.rest = rest;
                true
            }
            _ => false,
        }
    }

    /// [`Scan::lit`] of a slice (the out-of-line, spaced forms).
    pub(super) fn prefix(&mut self, lit: &[u8]) -> bool {
        match self.rest.strip_prefix(lit) {
            Some(rest) => {
                self.rest = rest;
                true
            }
            None => false,
        }
    }
}
