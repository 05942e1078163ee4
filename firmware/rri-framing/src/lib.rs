//! M10: framing RRI messages on a TCP stream, shared by the sensor
//! firmware (`rri_firmware::tcp`) and the host robot simulator. The manual
//! defines no framing; our decision: messages are back-to-back XML
//! documents, and a message ends with the end tag of its root element (or
//! a root that closes itself). The framer takes arbitrary chunks (one byte
//! at a time, or many messages at once), tracks just enough XML (tags,
//! quotes, comments, processing instructions, CDATA) to know where the root
//! ends, and hands out each complete message. Constant work per byte, no
//! heap, no panic.
//!
//! A crate of its own, with no build script: a tool that frames messages
//! (the simulator) must not be rebuilt when the firmware's configuration
//! (`RRI_GSI_DIR`) changes.
#![no_std]
// No unsafe code, and no panic outside the tests: the workspace lints
// (Cargo.toml).

/// A message longer than the receive buffer: close the connection (M10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FramingError;

impl core::fmt::Display for FramingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("message longer than the receive buffer (M10)")
    }
}

impl core::error::Error for FramingError {}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Character data (or whitespace between messages).
    Text,
    /// Just after `<`.
    Open,
    /// In a start tag; `slash` = the last byte was `/`.
    StartTag { slash: bool },
    /// In an end tag.
    EndTag,
    /// In a quoted attribute value of a start tag.
    Quoted { quote: u8 },
    /// In `<?…?>`; `question` = the last byte was `?`.
    Pi { question: bool },
    /// Just after `<!`.
    Bang,
    /// After `<!-`.
    BangDash,
    /// In `<!--…-->`; the number of `-` just seen.
    Comment { dashes: u8 },
    /// In `<![…]]>`; the number of `]` just seen.
    Cdata { brackets: u8 },
    /// In another `<!…>` declaration (a DOCTYPE: the decoder rejects it).
    Decl,
}

/// Splits a TCP byte stream into messages, in a buffer of `N` bytes (the
/// generated `MAX_RECEIVE_LEN`).
pub struct Framer<const N: usize> {
    buf: [u8; N],
    len: usize,
    mode: Mode,
    depth: u16,
    /// The buffer holds a complete message handed out by [`Framer::feed`].
    complete: bool,
}

impl<const N: usize> Default for Framer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Framer<N> {
    pub const fn new() -> Self {
        Framer {
            buf: [0; N],
            len: 0,
            mode: Mode::Text,
            depth: 0,
            complete: false,
        }
    }

    /// Forget a partial message (a new connection).
    pub fn reset(&mut self) {
        self.len = 0;
        self.mode = Mode::Text;
        self.depth = 0;
        self.complete = false;
    }

    /// Bytes of an unfinished message held.
    pub fn pending(&self) -> usize {
        if self.complete {
            0
        } else {
            self.len
        }
    }

    /// Feeds `chunk` until one message completes: returns how many bytes
    /// were used and the message, if one completed (valid until the next
    /// call). For transports that must answer each message before reading
    /// on (an async socket). After a [`FramingError`] the framer is reset
    /// and the caller closes the connection.
    pub fn feed(&mut self, chunk: &[u8]) -> Result<(usize, Option<&[u8]>), FramingError> {
        if self.complete {
            self.reset();
        }
        for (i, &b) in chunk.iter().enumerate() {
            // Whitespace between messages is not kept.
            if self.len == 0 && self.mode == Mode::Text && b.is_ascii_whitespace() {
                continue;
            }
            match self.buf.get_mut(self.len) {
                Some(slot) => *slot = b,
                None => {
                    self.reset();
                    return Err(FramingError);
                }
            }
            self.len += 1;
            if self.step(b) {
                self.complete = true;
                return Ok((i + 1, self.buf.get(..self.len)));
            }
        }
        Ok((chunk.len(), None))
    }

    /// Feeds `chunk`; calls `message` with every message it completes, in
    /// order. After a [`FramingError`] the framer is reset and the caller
    /// closes the connection.
    pub fn push(
        &mut self,
        chunk: &[u8],
        mut message: impl FnMut(&[u8]),
    ) -> Result<(), FramingError> {
        let mut rest = chunk;
        while !rest.is_empty() {
            let (used, done) = self.feed(rest)?;
            if let Some(m) = done {
                message(m);
            }
            rest = rest.get(used..).unwrap_or(&[]);
        }
        Ok(())
    }

    /// Advances the scanner by one byte; `true` when the root just ended.
    fn step(&mut self, b: u8) -> bool {
        let (mode, done) = match (self.mode, b) {
            (Mode::Text, b'<') => (Mode::Open, false),
            (Mode::Text, _) => (Mode::Text, false),
            (Mode::Open, b'/') => (Mode::EndTag, false),
            (Mode::Open, b'?') => (Mode::Pi { question: false }, false),
            (Mode::Open, b'!') => (Mode::Bang, false),
            (Mode::Open, _) => (Mode::StartTag { slash: false }, false),
            (Mode::StartTag { .. }, b'"' | b'\'') => (Mode::Quoted { quote: b }, false),
            (Mode::StartTag { slash: true }, b'>') => (Mode::Text, self.depth == 0),
            (Mode::StartTag { slash: false }, b'>') => {
                self.depth = self.depth.saturating_add(1);
                (Mode::Text, false)
            }
            (Mode::StartTag { .. }, _) => (Mode::StartTag { slash: b == b'/' }, false),
            (Mode::Quoted { quote }, _) if b == quote => (Mode::StartTag { slash: false }, false),
            (Mode::Quoted { quote }, _) => (Mode::Quoted { quote }, false),
            (Mode::EndTag, b'>') => {
                self.depth = self.depth.saturating_sub(1);
                (Mode::Text, self.depth == 0)
            }
            (Mode::EndTag, _) => (Mode::EndTag, false),
            (Mode::Pi { question: true }, b'>') => (Mode::Text, false),
            (Mode::Pi { .. }, _) => (
                Mode::Pi {
                    question: b == b'?',
                },
                false,
            ),
            (Mode::Bang, b'-') => (Mode::BangDash, false),
            (Mode::Bang, b'[') => (Mode::Cdata { brackets: 0 }, false),
            (Mode::Bang, b'>') => (Mode::Text, false),
            (Mode::Bang, _) => (Mode::Decl, false),
            (Mode::BangDash, b'-') => (Mode::Comment { dashes: 0 }, false),
            (Mode::BangDash, _) => (Mode::Decl, false),
            (Mode::Comment { dashes }, b'>') if dashes >= 2 => (Mode::Text, false),
            (Mode::Comment { dashes }, b'-') => (
                Mode::Comment {
                    dashes: dashes.saturating_add(1),
                },
                false,
            ),
            (Mode::Comment { .. }, _) => (Mode::Comment { dashes: 0 }, false),
            (Mode::Cdata { brackets }, b'>') if brackets >= 2 => (Mode::Text, false),
            (Mode::Cdata { brackets }, b']') => (
                Mode::Cdata {
                    brackets: brackets.saturating_add(1),
                },
                false,
            ),
            (Mode::Cdata { .. }, _) => (Mode::Cdata { brackets: 0 }, false),
            (Mode::Decl, b'>') => (Mode::Text, false),
            (Mode::Decl, _) => (Mode::Decl, false),
        };
        self.mode = mode;
        done
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::FramingError;
    use std::string::ToString;

    #[test]
    fn framing_error_names_its_rule() {
        assert_eq!(
            FramingError.to_string(),
            "message longer than the receive buffer (M10)"
        );
    }
}
