//! The vocabulary of the generated layouts: transport settings, message
//! directions and the [`Message`] trait every generated property implements,
//! so the codec and the cycle engine can work on any configuration.

/// Transport of the cyclic channel (Description.xml `<Channel Protocol>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelProtocol {
    Udp,
    Tcp,
    /// The controller's high-priority UDP path: plain UDP on the wire.
    HpUdp,
}

impl ChannelProtocol {
    /// True for both UDP flavours (M10 framing applies only to TCP).
    pub const fn is_udp(self) -> bool {
        matches!(self, ChannelProtocol::Udp | ChannelProtocol::HpUdp)
    }
}

/// The controller's physical Ethernet port (informational for the device).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerPort {
    Lan,
    Service,
    Axc1,
    Axc2,
    Axc3,
    Axc4,
}

/// Which way a property travels (G3 `Flag`, seen from RAPID).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// `Flag="None"`.
    None,
    /// `Flag="WriteOnly"`: the controller sends it to the device.
    RobotToDevice,
    /// `Flag="ReadOnly"`: the device sends it to the controller.
    DeviceToRobot,
    /// `Flag="ReadWrite"` or omitted.
    Both,
}

impl Direction {
    /// The controller sends this property to the device.
    pub const fn robot_sends(self) -> bool {
        matches!(self, Direction::RobotToDevice | Direction::Both)
    }

    /// The device sends this property to the controller.
    pub const fn device_sends(self) -> bool {
        matches!(self, Direction::DeviceToRobot | Direction::Both)
    }
}

/// One property of Configuration.xml as a message type (M1): its data type,
/// names and the compile-time bounds of its encoded form.
pub trait Message {
    /// The record (or value) the message carries.
    type Data;
    /// The property's `Name`.
    const NAME: &'static str;
    /// The root element name on the wire (`Alias`, else `Name`).
    const WIRE_NAME: &'static str;
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

/// Mutable access to one field's value, for the decoder.
pub enum FieldMut<'a> {
    Bool(&'a mut bool),
    Real(&'a mut f32),
    Time(&'a mut Time),
    Str(&'a mut RriString),
    Enum(&'a mut dyn WireEnum),
    Frame(&'a mut Frame),
    Joints(&'a mut Joints),
    Bools(&'a mut [bool]),
    Reals(&'a mut [f32]),
    Times(&'a mut [Time]),
    Strs(&'a mut [RriString]),
}

/// Read access to one field's value, for the encoder.
pub enum FieldRef<'a> {
    Bool(bool),
    Real(f32),
    Time(Time),
    Str(&'a RriString),
    Enum(&'static str),
    Frame(&'a Frame),
    Joints(&'a Joints),
    Bools(&'a [bool]),
    Reals(&'a [f32]),
    Times(&'a [Time]),
    Strs(&'a [RriString]),
}

/// The fixed bytes of one field on the wire, precomputed by the build
/// script: `<EStr>` … `</EStr>` for a text value (M3), `<P_act` … `/>` for
/// attributes (M4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldWire {
    /// Element name (alias, else name).
    pub name: &'static [u8],
    pub open: &'static [u8],
    pub close: &'static [u8],
}

impl FieldWire {
    pub const fn new(name: &'static [u8], open: &'static [u8], close: &'static [u8]) -> Self {
        FieldWire { name, open, close }
    }
}

/// Most fields a record has (G3; gsi-config refuses more). The decoder's
/// duplicate check keeps one bit per field in a `u64`, and code that walks
/// a record by index stops here at the latest.
pub const MAX_FIELDS: usize = 64;

/// A generated record: its fields by index, in Configuration order.
pub trait Record {
    /// Wire pieces of every field, in order (at most [`MAX_FIELDS`]).
    const FIELDS: &'static [FieldWire];
    /// The index of the field whose element name is `name`.
    fn field_index(name: &[u8]) -> Option<usize>;
    fn field(&self, index: usize) -> Option<FieldRef<'_>>;
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
    const BODY: Body;
    /// `<Root Id="`: the fixed start of every encoded message.
    const OPEN: &'static [u8];
    /// `</Root>`.
    const CLOSE: &'static [u8];
    /// For [`Body::Record`], the record's fields; for [`Body::Value`], one
    /// entry whose `name` is empty.
    const FIELDS: &'static [FieldWire];
    /// ` X1="`, ` X2="`, …: attribute openers of array elements (M4),
    /// precomputed for the longest array of the layout.
    const ARRAY_ATTRS: &'static [&'static [u8]] = &[];
    fn field_index(name: &[u8]) -> Option<usize>;
    fn field(data: &Self::Data, index: usize) -> Option<FieldRef<'_>>;
    fn field_mut(data: &mut Self::Data, index: usize) -> Option<FieldMut<'_>>;
}

/// How numbers are written in sent messages (M5), from the build settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Format {
    pub real_decimals: u8,
    pub time_decimals: u8,
}
