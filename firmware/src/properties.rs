//! Several properties per direction (M11): a configuration may declare any
//! number of RAPID variables the controller sends (`SiSetCyclic`, each at
//! its own rate) and the device sends (`SiGetCyclic`). The build generates
//! one struct per direction holding every property's data
//! (`layout::RobotProperties`, `layout::DeviceProperties`); the traits here
//! are how the cycle engine sees them without knowing the configuration.
//!
//! A property is named by its index: its position among the properties of
//! its direction, in Configuration.xml order (the generated
//! `RobotProperty` / `DeviceProperty` enums give them names).

use crate::codec::{decode, BufferTooSmall, DecodeError, Decoded, Encoded};
use crate::schema::{FieldMut, FieldRef, Format, MessageCodec, PropertyInfo};
use crate::value::Time;

/// Most properties one direction may have. The engine keeps an Id tracker
/// per robot property and a schedule per periodic device property in
/// arrays of this size; the GSI compiler refuses a configuration with more
/// (G3 sets no limit; a device with more than a handful is unheard of).
pub use rri_vocabulary::MAX_PROPERTIES;

/// Every property the controller may send (G3: `WriteOnly`, `ReadWrite`
/// or no `Flag`), each with its last good value (M2).
pub trait RobotSet: Default {
    /// Root element names (M1), by property index.
    const WIRE_NAMES: &'static [&'static str];
    /// Each property with its fields, for the diagnostics.
    const INFO: &'static [PropertyInfo];
    /// The longest message of any of them: the receive buffer's size.
    const MAX_RECEIVE_LEN: usize;

    /// Decodes `bytes` into the property its root element names (M1),
    /// starting from that property's last good value (M2): `work` is the
    /// scratch copy decoded into, so a rejected message changes nothing in
    /// `self`; an accepted one is committed to `self`. Returns the
    /// property's index. A root that names no property is
    /// [`crate::codec::DecodeErrorKind::WrongRoot`].
    fn decode(&mut self, work: &mut Self, bytes: &[u8]) -> Result<(usize, Decoded), DecodeError>;

    /// Field `index` of property `property` (for a simple-typed property,
    /// index 0 is its value); `None` past the end.
    fn field(&self, property: usize, index: usize) -> Option<FieldRef<'_>>;
}

/// Every property the device may send (G3: `ReadOnly`, `ReadWrite` or no
/// `Flag`), with the data the application fills in.
pub trait DeviceSet: Default {
    /// Root element names (M1), by property index.
    const WIRE_NAMES: &'static [&'static str];
    /// Each property with its fields, for the diagnostics.
    const INFO: &'static [PropertyInfo];
    /// The longest message of any of them: the send buffer's size.
    const MAX_SEND_LEN: usize;

    /// Encodes property `property` with the given `Id` and `Ts` into `out`.
    /// An index that names no property writes nothing
    /// ([`BufferTooSmall`], counted by the engine as an encode failure).
    fn encode(
        &self,
        property: usize,
        id: u32,
        ts: Time,
        format: Format,
        out: &mut [u8],
    ) -> Result<Encoded, BufferTooSmall>;

    /// Field `index` of property `property`, to fill in; `None` past the
    /// end.
    fn field_mut(&mut self, property: usize, index: usize) -> Option<FieldMut<'_>>;
}

/// One property's share of [`RobotSet::decode`]: decode into `work`, a
/// copy of `last`, and on success swap it in, so `last` only ever holds a
/// whole good message.
pub fn decode_committed<M: MessageCodec>(
    last: &mut M::Data,
    work: &mut M::Data,
    bytes: &[u8],
) -> Result<Decoded, DecodeError>
where
    M::Data: Clone,
{
    work.clone_from(last);
    let decoded = decode::<M>(bytes, work)?;
    core::mem::swap(last, work);
    Ok(decoded)
}

/// The root element's name, for choosing the property to decode (M1):
/// skips leading whitespace, an XML declaration, comments and processing
/// instructions, then reads the name up to whitespace, `/` or `>`.
/// `None` when the prologue is not that simple; the caller then lets the
/// full decoder report what is wrong. Reads at most the whole input once,
/// with no state but an index.
pub fn root_name(bytes: &[u8]) -> Option<&[u8]> {
    let mut at = 0;
    loop {
        while bytes.get(at).is_some_and(|b| b.is_ascii_whitespace()) {
            at += 1;
        }
        let rest = bytes.get(at..)?;
        if rest.starts_with(b"<?") {
            at += find(rest, b"?>")? + 2;
        } else if rest.starts_with(b"<!--") {
            at += find(rest, b"-->")? + 3;
        } else if let Some(name) = rest.strip_prefix(b"<") {
            let end = name
                .iter()
                .position(|&b| b.is_ascii_whitespace() || b == b'/' || b == b'>')?;
            return name.get(..end).filter(|n| !n.is_empty());
        } else {
            return None;
        }
    }
}

/// Position of `needle` in `hay`.
fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m1_root_name_after_declaration_comments_and_whitespace() {
        assert_eq!(root_name(b"<RobData Id=\"1\"/>"), Some(&b"RobData"[..]));
        assert_eq!(
            root_name(b" \r\n<?xml version=\"1.0\"?><!-- c --> <Speed>1</Speed>"),
            Some(&b"Speed"[..])
        );
        assert_eq!(root_name(b"<Speed/>"), Some(&b"Speed"[..]));
        assert_eq!(root_name(b"<Speed>"), Some(&b"Speed"[..]));
    }

    #[test]
    fn unusual_prologues_are_left_to_the_decoder() {
        assert_eq!(root_name(b""), None);
        assert_eq!(root_name(b"<Speed"), None, "cut name");
        assert_eq!(root_name(b"<?xml"), None, "unclosed declaration");
        assert_eq!(root_name(b"<!-- open"), None);
        assert_eq!(root_name(b"<!DOCTYPE x><a/>"), Some(&b"!DOCTYPE"[..]));
        assert_eq!(root_name(b"text<a/>"), None);
        assert_eq!(root_name(b"< a/>"), None);
    }
}
