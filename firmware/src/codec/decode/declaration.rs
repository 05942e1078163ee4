//! M1: the XML declaration, skipped unread by the general path (the
//! firmware README's statement of what is checked: nothing but that it
//! comes once, first).

use super::error::{err, DecodeError, DecodeErrorKind as K};
use crate::codec::number::is_xml_space_char;

/// M1 as the firmware README states it: the XML declaration's content is
/// not checked. `<?xml` followed by XML whitespace or `?`, at the start,
/// is skipped to the first `?>` (`<?xml?>`, `<?xml version=""?>` and
/// `<?xml version="1." encoding=""?>` are taken alike; xmlparser refused
/// the second, issue 42 #16); `body` is returned as it is when it does not
/// start with one, or the declaration never ends (the tokenizer then says
/// why). A second declaration right after the first is refused
/// (`Malformed` at it): a declaration comes once, first. Linear in the
/// declaration's length. `whole` is the datagram's length, for offsets.
pub(super) fn after_declaration(body: &str, whole: usize) -> Result<&str, DecodeError> {
    // A byte-order mark may come first (xmlparser skips one).
    let Some(rest) = declaration_end(body.strip_prefix('\u{feff}').unwrap_or(body)) else {
        return Ok(body);
    };
    let next = rest.trim_start_matches(is_xml_space_char);
    if declaration_end(next).is_some() {
        return Err(err(K::Malformed, whole - next.len()));
    }
    Ok(rest)
}

/// The text after the XML declaration `body` starts with, if it starts
/// with a whole one.
fn declaration_end(body: &str) -> Option<&str> {
    let b = body.as_bytes();
    let opens = b.starts_with(b"<?xml")
        && b.get(5)
            .is_some_and(|&c| c == b'?' || matches!(c, b' ' | b'\t' | b'\r' | b'\n'));
    if !opens {
        return None;
    }
    let tail = b.get(5..)?;
    let close = tail.windows(2).position(|w| w == b"?>")?;
    body.get(5 + close + 2..)
}
