//! The validated device model: what a GSI folder says, with every name
//! resolved and every rule of G1–G6 already checked. Both the firmware's build
//! script and the host tools (robot simulator) work from this.

use crate::diag::{Diagnostic, Pos};

/// The controller's physical Ethernet port (Description.xml `Network/@Port`).
/// Informational for the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhysicalPort {
    Lan,
    Service,
    Axc1,
    Axc2,
    Axc3,
    Axc4,
}

impl PhysicalPort {
    pub const ALL: [PhysicalPort; 6] = [
        PhysicalPort::Lan,
        PhysicalPort::Service,
        PhysicalPort::Axc1,
        PhysicalPort::Axc2,
        PhysicalPort::Axc3,
        PhysicalPort::Axc4,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            PhysicalPort::Lan => "Lan",
            PhysicalPort::Service => "Service",
            PhysicalPort::Axc1 => "Axc1",
            PhysicalPort::Axc2 => "Axc2",
            PhysicalPort::Axc3 => "Axc3",
            PhysicalPort::Axc4 => "Axc4",
        }
    }
}

/// Transport of the cyclic channel. `HpUdp` is plain UDP on the wire; only
/// the controller's side is different.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Protocol {
    Udp,
    Tcp,
    HpUdp,
}

impl Protocol {
    pub const ALL: [Protocol; 3] = [Protocol::Udp, Protocol::Tcp, Protocol::HpUdp];

    pub fn as_str(self) -> &'static str {
        match self {
            Protocol::Udp => "Udp",
            Protocol::Tcp => "Tcp",
            Protocol::HpUdp => "HpUdp",
        }
    }

    /// True for both UDP flavours.
    pub fn is_udp(self) -> bool {
        matches!(self, Protocol::Udp | Protocol::HpUdp)
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Network {
    /// IP address or host name of the device, as written.
    pub address: String,
    pub port: PhysicalPort,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    pub protocol: Protocol,
    /// UDP/TCP port the device listens on.
    pub port: u16,
}

/// `Settings` of Description.xml: the controller's supervision (S1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Supervision {
    pub timeout_ms: u32,
    pub max_lost: u32,
    pub dry_run: bool,
}

/// `Link="Intern"`: the controller fills the value itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Link {
    #[default]
    Rapid,
    Intern,
}

/// The simple types of G5.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SimpleType {
    Bool,
    /// `real` or `num`: single precision.
    Real,
    /// Seconds; exact fixed point in the firmware.
    Time,
    /// At most 80 characters.
    String,
    /// `frame` or `pose`: X Y Z Rx Ry Rz.
    Frame,
    /// `joints` or `joint`: J1..J6.
    Joints,
}

impl SimpleType {
    /// G5: type names are case-insensitive and have aliases.
    pub fn from_name(name: &str) -> Option<SimpleType> {
        Some(match name.to_ascii_lowercase().as_str() {
            "bool" => SimpleType::Bool,
            "real" | "num" => SimpleType::Real,
            "time" => SimpleType::Time,
            "string" => SimpleType::String,
            "frame" | "pose" => SimpleType::Frame,
            "joints" | "joint" => SimpleType::Joints,
            _ => return None,
        })
    }

    pub fn as_str(self) -> &'static str {
        match self {
            SimpleType::Bool => "bool",
            SimpleType::Real => "real",
            SimpleType::Time => "time",
            SimpleType::String => "string",
            SimpleType::Frame => "frame",
            SimpleType::Joints => "joints",
        }
    }

    /// Attribute names of a multi-value type (M4), `None` for single values.
    pub fn components(self) -> Option<&'static [&'static str]> {
        match self {
            SimpleType::Frame => Some(&["X", "Y", "Z", "Rx", "Ry", "Rz"]),
            SimpleType::Joints => Some(&["J1", "J2", "J3", "J4", "J5", "J6"]),
            _ => None,
        }
    }

    /// Whether `Size` may make an array of this type: single values only,
    /// because an array travels as attributes `X1..XN` (M4).
    pub fn can_be_array(self) -> bool {
        self.components().is_none()
    }
}

/// The attribute names of a multi-value slot (M4): `X1..XN` for an array
/// of `size`, `X Y Z Rx Ry Rz` for a frame, `J1..J6` for joints; `None`
/// for a value that travels as element text (M3).
pub fn attribute_names(ty: TypeRef, size: Option<u16>) -> Option<Vec<String>> {
    if let Some(n) = size {
        return Some((1..=n).map(|i| format!("X{i}")).collect());
    }
    match ty {
        TypeRef::Simple(s) => s
            .components()
            .map(|c| c.iter().map(|s| s.to_string()).collect()),
        _ => None,
    }
}

/// A resolved type reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TypeRef {
    Simple(SimpleType),
    /// Index into [`Device::enums`].
    Enum(usize),
    /// Index into [`Device::records`].
    Record(usize),
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Member {
    pub name: String,
    pub alias: Option<String>,
    pub pos: Pos,
}

impl Member {
    /// What travels in messages (G3: the alias, else the name).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Enum {
    pub name: String,
    pub link: Link,
    pub members: Vec<Member>,
    pub pos: Pos,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub ty: TypeRef,
    /// `Some(n)`: an array of n values.
    pub size: Option<u16>,
    pub link: Link,
    pub alias: Option<String>,
    pub pos: Pos,
}

impl Field {
    /// Element name in messages (M2: alias, else name).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    pub name: String,
    pub alias: Option<String>,
    pub fields: Vec<Field>,
    pub pos: Pos,
}

impl Record {
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

/// G3 `Flag`, seen from RAPID.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Flag {
    /// Neither direction.
    None,
    /// RAPID reads it: the device sends it.
    ReadOnly,
    /// RAPID writes it: the controller sends it to the device.
    WriteOnly,
    /// Both directions (also when omitted).
    #[default]
    ReadWrite,
}

impl Flag {
    pub fn as_str(self) -> &'static str {
        match self {
            Flag::None => "None",
            Flag::ReadOnly => "ReadOnly",
            Flag::WriteOnly => "WriteOnly",
            Flag::ReadWrite => "ReadWrite",
        }
    }

    /// The controller sends this property to the device.
    pub fn robot_sends(self) -> bool {
        matches!(self, Flag::WriteOnly | Flag::ReadWrite)
    }

    /// The device sends this property to the controller.
    pub fn device_sends(self) -> bool {
        matches!(self, Flag::ReadOnly | Flag::ReadWrite)
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Property {
    pub name: String,
    pub ty: TypeRef,
    pub size: Option<u16>,
    pub flag: Flag,
    pub link: Link,
    pub alias: Option<String>,
    pub pos: Pos,
}

impl Property {
    /// Root element name of its messages (M1: alias, else name).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }

    /// Whether a user's `name` means this property: its `Name` or its
    /// `Alias`, in any case (RAPID names are case-insensitive, G4). Build
    /// settings (`RRI_REPLY`, `RRI_PERIODIC`) and the simulator's `--send`
    /// / `--reply` all name properties this way.
    pub fn is_named(&self, name: &str) -> bool {
        let name = name.trim();
        self.name.eq_ignore_ascii_case(name) || self.wire().eq_ignore_ascii_case(name)
    }
}

/// One fully validated device.
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    pub name: String,
    /// Description.xml `Type` and `Class`: free text, not validated.
    pub device_type: String,
    pub class: String,
    pub network: Network,
    pub channel: Channel,
    pub supervision: Supervision,
    pub enums: Vec<Enum>,
    pub records: Vec<Record>,
    pub properties: Vec<Property>,
    /// Path of Configuration.xml, for diagnostics found later (code
    /// generation checks message sizes against the transport).
    pub configuration_file: std::path::PathBuf,
}

impl Device {
    /// Properties the controller sends to the device.
    pub fn received(&self) -> impl Iterator<Item = &Property> {
        self.properties.iter().filter(|p| p.flag.robot_sends())
    }

    /// Properties the device sends to the controller.
    pub fn sent(&self) -> impl Iterator<Item = &Property> {
        self.properties.iter().filter(|p| p.flag.device_sends())
    }

    /// The type's name as written in the configuration.
    pub fn type_name(&self, ty: TypeRef) -> &str {
        match ty {
            TypeRef::Simple(s) => s.as_str(),
            TypeRef::Enum(i) => &self.enums[i].name,
            TypeRef::Record(i) => &self.records[i].name,
        }
    }
}

/// What a successful load gives: the device, the files that were read (for
/// `rerun-if-changed`) and the warnings (G6 quirks and the like).
#[derive(Clone, Debug)]
pub struct Loaded {
    pub device: Device,
    pub files: Vec<std::path::PathBuf>,
    pub warnings: Vec<Diagnostic>,
}
