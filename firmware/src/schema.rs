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
