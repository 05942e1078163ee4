//! Strings on the wire (M6): escaped on the way out, entity- and
//! character-reference-decoded on the way in, cut at 80 bytes on a UTF-8
//! boundary.

use super::writer::Writer;
use crate::value::{RriString, MAX_STRING_LEN};

/// Writes `s` with `& < > " '` escaped (valid in element text and in
/// attribute values alike). Tab, line feed and carriage return become
/// character references, so they survive a receiver's whitespace
/// normalisation; other control characters cannot be written in XML 1.0 at
/// all and become `?`. No replacement is longer than 6 bytes, the bound the
/// build script sizes buffers with.
pub fn write_escaped(w: &mut Writer<'_>, s: &str) {
    // `rest` is what is left to write; its first `i` bytes need no escape.
    // Splitting at `i` is the loop's own bound, so every slice written
    // comes from a split, none from an index that could be off.
    let mut rest = s.as_bytes();
    let mut i = 0;
    while let Some((plain, [b, after @ ..])) = rest.split_at_checked(i) {
        let entity: &[u8] = match *b {
            b'&' => b"&amp;",
            b'<' => b"&lt;",
            b'>' => b"&gt;",
            b'"' => b"&quot;",
            b'\'' => b"&apos;",
            b'\t' => b"&#9;",
            b'\n' => b"&#10;",
            b'\r' => b"&#13;",
            0..=0x1f => b"?",
            _ => {
                i += 1;
                continue;
            }
        };
        w.bytes(plain);
        w.bytes(entity);
        rest = after;
        i = 0;
    }
    w.bytes(rest);
}

/// A reference that is not one of the five predefined entities or a valid
/// character reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadReference {
    /// Byte offset of the `&` within the text.
    pub at: usize,
}

impl core::fmt::Display for BadReference {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("undefined entity or character reference (M6)")
    }
}

impl core::error::Error for BadReference {}

/// Longest reference we look at: `&#x10FFFF;` / `&#1114111;` are 10 bytes.
const MAX_REFERENCE: usize = 10;

/// XML 1.0's `Char`: what a character reference may name (not NUL, not
/// the other C0 controls but tab, LF and CR, not U+FFFE/U+FFFF).
fn is_xml_char(c: char) -> bool {
    matches!(c, '\t' | '\n' | '\r' | '\u{20}'..='\u{D7FF}' | '\u{E000}'..='\u{FFFD}' | '\u{10000}'..)
}

fn reference(r: &[u8]) -> Option<char> {
    let c = reference_any(r)?;
    is_xml_char(c).then_some(c)
}

fn reference_any(r: &[u8]) -> Option<char> {
    match r {
        b"amp" => Some('&'),
        b"lt" => Some('<'),
        b"gt" => Some('>'),
        b"quot" => Some('"'),
        b"apos" => Some('\''),
        [b'#', b'x', hex @ ..] if !hex.is_empty() => {
            let mut v: u32 = 0;
            for &h in hex {
                v = v * 16 + (h as char).to_digit(16)?;
            }
            char::from_u32(v)
        }
        [b'#', dec @ ..] if !dec.is_empty() => {
            let mut v: u32 = 0;
            for &d in dec {
                v = v * 10 + (d as char).to_digit(10)?;
            }
            char::from_u32(v)
        }
        _ => None,
    }
}

/// Appends raw element text to `out`, decoding references. Returns whether
/// the text was cut at [`MAX_STRING_LEN`] bytes (M6); what does not fit is
/// dropped at a character boundary, never split.
pub fn append_decoded(out: &mut RriString, raw: &str) -> Result<bool, BadReference> {
    let mut truncated = false;
    let mut push = |out: &mut RriString, s: &str| {
        if truncated {
            return;
        }
        let room = MAX_STRING_LEN - out.len();
        if s.len() <= room {
            // Cannot fail: it fits.
            let _ = out.push_str(s);
        } else {
            // The longest head that fits and ends on a character boundary
            // (`get` is `None` inside a character). The empty head always
            // is one, so the loop ends by `cut == 0` at the latest.
            let mut cut = room;
            let head = loop {
                if let Some(head) = s.get(..cut) {
                    break head;
                }
                cut -= 1;
            };
            let _ = out.push_str(head);
            truncated = true;
        }
    };
    let mut rest = raw;
    // Where `rest` starts in `raw`, for the error's offset.
    let mut offset = 0;
    while let Some((before, after)) = rest.split_once('&') {
        push(out, before);
        let bad = BadReference {
            at: offset + before.len(),
        };
        // The first `;` ends the reference; it must come within the
        // `MAX_REFERENCE` bytes after the `&` (a search past them only
        // happens on the way to the error).
        let (name, tail) = after
            .split_once(';')
            .filter(|(name, _)| name.len() < MAX_REFERENCE)
            .ok_or(bad)?;
        let c = reference(name.as_bytes()).ok_or(bad)?;
        let mut utf8 = [0u8; 4];
        push(out, c.encode_utf8(&mut utf8));
        offset += before.len() + 1 + name.len() + 1;
        rest = tail;
    }
    push(out, rest);
    Ok(truncated)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn escaped(s: &str) -> heapless::Vec<u8, 256> {
        let mut buf = [0u8; 256];
        let mut w = Writer::new(&mut buf);
        write_escaped(&mut w, s);
        heapless::Vec::from_slice(w.written()).unwrap()
    }

    #[test]
    fn m6_escapes_control_characters() {
        assert_eq!(&escaped("a\tb\nc\rd\u{1}e")[..], b"a&#9;b&#10;c&#13;d?e");
    }

    #[test]
    fn m6_escapes_the_five_characters() {
        assert_eq!(
            &escaped("a&b<c>d\"e'f")[..],
            b"a&amp;b&lt;c&gt;d&quot;e&apos;f"
        );
        assert_eq!(&escaped("plain")[..], b"plain");
        assert_eq!(&escaped("")[..], b"");
    }

    #[test]
    fn m6_decodes_entities_and_character_references() {
        let mut s = RriString::new();
        assert_eq!(
            append_decoded(&mut s, "a&amp;b&lt;&#65;&#x42;&quot;&apos;&gt;"),
            Ok(false)
        );
        assert_eq!(s.as_str(), "a&b<AB\"'>");
    }

    #[test]
    fn m6_rejects_unknown_or_unterminated_references() {
        let mut s = RriString::new();
        assert_eq!(
            append_decoded(&mut s, "ab&nbsp;"),
            Err(BadReference { at: 2 })
        );
        assert_eq!(
            append_decoded(&mut s, "&amp;&#xD800;"),
            Err(BadReference { at: 5 })
        );
        assert_eq!(append_decoded(&mut s, "x&amp"), Err(BadReference { at: 1 }));
        assert_eq!(append_decoded(&mut s, "&#;"), Err(BadReference { at: 0 }));
    }

    #[test]
    fn a_bad_reference_displays_a_lowercase_message_citing_m6() {
        let e = BadReference { at: 3 };
        assert_eq!(
            e.to_string(),
            "undefined entity or character reference (M6)"
        );
        let e: &dyn core::error::Error = &e;
        assert!(e.source().is_none());
    }

    #[test]
    fn m6_long_strings_are_cut_at_80_bytes_on_a_char_boundary() {
        let mut s = RriString::new();
        let long = "é".repeat(50); // 100 bytes
        assert_eq!(append_decoded(&mut s, &long), Ok(true));
        assert_eq!(s.len(), 80);
        assert_eq!(s.chars().count(), 40);

        let mut s = RriString::new();
        let odd = ["x", &"é".repeat(45)].concat(); // 91 bytes, boundary at 79
        assert_eq!(append_decoded(&mut s, &odd), Ok(true));
        assert_eq!(s.len(), 79);

        let mut s = RriString::new();
        assert_eq!(append_decoded(&mut s, &"a".repeat(80)), Ok(false));
        assert_eq!(s.len(), 80);
    }
}
