//! The vocabulary of the generated layouts: the [`Message`] trait every
//! generated property implements and the field views the codec works
//! through, so the codec and the cycle engine can work on any
//! configuration. The protocol's words and limits (transports, directions,
//! number format) come from `rri-vocabulary`, which the GSI compiler shares.

pub use rri_vocabulary::{ControllerPort, Direction, Format, Protocol, MAX_FIELDS};

/// One property of Configuration.xml as a message type (M1): its data type,
/// names and the compile-time bounds of its encoded form.
pub trait Message {
    /// The record (or value) the message carries.
    type Data;
    /// The property's `Name`.
    const NAME: &'static str;
    /// The root element name on the wire (`Alias`, else `Name`).
    const WIRE_NAME: &'static str;
    /// Who sends it (G3 `Flag`): the engine decodes only what the
    /// controller sends and encodes only what the device sends.
    const DIRECTION: Direction;
    /// Most bytes our encoder can write for this message.
    const MAX_ENCODED_LEN: usize;
    /// Most bytes the controller may send for this message (whitespace,
    /// declaration and any number notation included); longer is rejected.
    const MAX_RECEIVE_LEN: usize;
}

use crate::value::{Frame, Joints, RriString, Time};

/// A generated enum, seen by the codec without knowing its type.
pub trait WireEnum {
    /// The text that travels in messages.
    fn wire_text(&self) -> &'static str;
    /// Sets the member whose wire text is exactly `text`; `false` (and no
    /// change) when there is none.
    fn set_from_wire(&mut self, text: &[u8]) -> bool;
}

/// Mutable access to one field's value, for the decoder: one variant per
/// G5 type, so the decoder parses text by type without knowing the record.
pub enum FieldMut<'a> {
    /// `bool`, element text (M3, M7).
    Bool(&'a mut bool),
    /// `real`/`num`, element text (M3, M5).
    Real(&'a mut f32),
    /// `time`, element text, exact to the microsecond (M3, M5).
    Time(&'a mut Time),
    /// `string`, element text, at most 80 bytes (M3, M6).
    Str(&'a mut RriString),
    /// A generated enum, element text matched against its members (M3).
    Enum(&'a mut dyn WireEnum),
    /// `frame`/`pose`: attributes `X Y Z Rx Ry Rz` (M4).
    Frame(&'a mut Frame),
    /// `joints`: attributes `J1..J6` (M4).
    Joints(&'a mut Joints),
    /// An array of `bool`: attributes `X1..XN` (M4).
    Bools(&'a mut [bool]),
    /// An array of `real`: attributes `X1..XN` (M4).
    Reals(&'a mut [f32]),
    /// An array of `time`: attributes `X1..XN` (M4).
    Times(&'a mut [Time]),
    /// An array of `string`: attributes `X1..XN` (M4).
    Strs(&'a mut [RriString]),
}

/// Read access to one field's value, for the encoder; the variants mirror
/// [`FieldMut`]'s.
pub enum FieldRef<'a> {
    /// `bool`, written `TRUE`/`FALSE` (M7).
    Bool(bool),
    /// `real`, written with the configured decimals (M5).
    Real(f32),
    /// `time`, written with the configured decimals (M5).
    Time(Time),
    /// `string`, XML-escaped on the way out (M6).
    Str(&'a RriString),
    /// A generated enum's wire text (its alias, else its name).
    Enum(&'static str),
    /// `frame`/`pose` (M4).
    Frame(&'a Frame),
    /// `joints` (M4).
    Joints(&'a Joints),
    /// An array of `bool` (M4).
    Bools(&'a [bool]),
    /// An array of `real` (M4).
    Reals(&'a [f32]),
    /// An array of `time` (M4).
    Times(&'a [Time]),
    /// An array of `string` (M4).
    Strs(&'a [RriString]),
}

/// The fixed bytes of one field on the wire, precomputed by the build
/// script: `<EStr>` … `</EStr>` for a text value (M3), `<P_act` … `/>` for
/// attributes (M4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldWire {
    /// Element name (alias, else name).
    pub name: &'static [u8],
    /// What the encoder writes before the value: `<EStr>` (M3) or
    /// `<P_act` (M4, the attributes follow).
    pub open: &'static [u8],
    /// What it writes after: `</EStr>` or `/>`.
    pub close: &'static [u8],
}

impl FieldWire {
    /// The generated tables are `const`, so this is a `const fn`.
    pub const fn new(name: &'static [u8], open: &'static [u8], close: &'static [u8]) -> Self {
        FieldWire { name, open, close }
    }
}

/// A generated record: its fields by index, in Configuration order.
pub trait Record {
    /// Wire pieces of every field, in order (at most [`MAX_FIELDS`]).
    const FIELDS: &'static [FieldWire];
    /// The index of the field whose element name is `name`.
    fn field_index(name: &[u8]) -> Option<usize>;
    /// The field at `index` for the encoder; `None` past the last.
    fn field(&self, index: usize) -> Option<FieldRef<'_>>;
    /// The field at `index` for the decoder; `None` past the last.
    fn field_mut(&mut self, index: usize) -> Option<FieldMut<'_>>;
}

/// How a message's body is laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Body {
    /// A record: one child element per field (M2).
    Record,
    /// A property of a simple type: the value is the root element's text,
    /// or its attributes for frame, joints and arrays (next to `Id`, `Ts`).
    Value,
}

/// The codec's view of a generated message type.
pub trait MessageCodec: Message {
    /// Whether the body is a record's child elements or the root's own
    /// value.
    const BODY: Body;
    /// `<Root Id="`: the fixed start of every encoded message.
    const OPEN: &'static [u8];
    /// `</Root>`.
    const CLOSE: &'static [u8];
    /// For [`Body::Record`], the record's fields; for [`Body::Value`], one
    /// entry whose `name` is empty.
    const FIELDS: &'static [FieldWire];
    /// [`Record::field_index`] of the message's record; always `None` for
    /// a [`Body::Value`], which has no child elements.
    fn field_index(name: &[u8]) -> Option<usize>;
    /// [`Record::field`] of `data`, or the value itself at index 0.
    fn field(data: &Self::Data, index: usize) -> Option<FieldRef<'_>>;
    /// [`Record::field_mut`] of `data`, or the value itself at index 0.
    fn field_mut(data: &mut Self::Data, index: usize) -> Option<FieldMut<'_>>;

    /// The compiled decode path of this message ([`crate::codec::compiled`],
    /// generated for every property the controller sends): `Some` with
    /// exactly what the general decoder would report for `bytes`, or
    /// `None` to leave them to it. `None` for every other message. The
    /// reals it read the slow way are kept in `hand_over` for the general
    /// decoder, which then does not parse them again.
    #[inline(always)]
    fn decode_compiled_into(
        bytes: &[u8],
        data: &mut Self::Data,
        hand_over: &mut crate::codec::HandOver,
    ) -> Option<crate::codec::Decoded> {
        let _ = (bytes, data, hand_over);
        None
    }

    /// [`MessageCodec::decode_compiled_into`] on its own (what the
    /// differential tests and the benches compare with the general path).
    #[inline(always)]
    fn decode_compiled(bytes: &[u8], data: &mut Self::Data) -> Option<crate::codec::Decoded> {
        Self::decode_compiled_into(bytes, data, &mut crate::codec::HandOver::new(bytes))
    }
}

/// One property as the diagnostics describe it (generated as
/// `layout::RECEIVED_INFO` and `layout::SENT_INFO`): its name, its type as
/// Configuration.xml gives it, and the fields of a record with theirs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PropertyInfo {
    /// `Name`.
    pub name: &'static str,
    /// The root element's name on the wire (`Alias`, else `Name`).
    pub wire: &'static str,
    /// Its type: a record's or enum's name, or a G5 type (`real[18]` for
    /// an array).
    pub ty: &'static str,
    /// A record's fields: element name and type, in Configuration order
    /// (empty for a simple type).
    pub fields: &'static [(&'static str, &'static str)],
}
