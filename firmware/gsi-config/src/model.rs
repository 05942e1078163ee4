//! The validated device model: what a GSI folder says, with every name
//! resolved and every rule of G1–G6 already checked. Both the firmware's build
//! script and the host tools (robot simulator) work from this.

use crate::diag::{Diagnostic, Pos};

/// The closed word lists of G2 and G3, shared with the firmware.
pub use rri_vocabulary::{ControllerPort, Direction, Protocol};
/// Description.xml `<Network Address Port?>` (G2).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Network {
    /// IP address or host name of the device, as written.
    pub address: String,
    /// `Port`: the controller's physical port, `Lan` when omitted.
    pub port: ControllerPort,
}

/// Description.xml `<Network><Channel Type="Cyclic" Protocol Port>` (G2):
/// the device's one cyclic channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    /// `Protocol`: `Udp`, `Tcp` or `HpUdp`.
    pub protocol: Protocol,
    /// UDP/TCP port the device listens on.
    pub port: u16,
}

/// `Settings` of Description.xml: the controller's supervision (S1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Supervision {
    /// `<TimeOut>`: ms, positive, a multiple of 4 (G2). The controller's
    /// deadline for an answer (S1); the device's silence limit (S2, M10, S4).
    pub timeout_ms: u32,
    /// `<MaxLost>`: most messages in a row that may go unanswered before the
    /// controller raises a communication error (S1); the device mirrors it
    /// on Id gaps (S2, S3).
    pub max_lost: u32,
    /// `<DryRun>`: `true` = neither TimeOut nor MaxLost is supervised
    /// (one-way streams, S1).
    pub dry_run: bool,
}

/// `Link="Intern"`: the controller fills the value itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Link {
    /// No `Link` attribute: RAPID linkage, the RAPID program supplies the value.
    #[default]
    Rapid,
    /// `Link="Intern"`: the controller supplies the value from its own data
    /// (operation mode, motion data).
    Intern,
}

/// The simple types of G5.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SimpleType {
    /// `bool`: element text, sent as `TRUE`/`FALSE` (M7).
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

    /// The canonical G5 spelling, lower case (`real`, not `num`).
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
    /// One of the G5 simple types.
    Simple(SimpleType),
    /// Index into [`Device::enums`].
    Enum(usize),
    /// Index into [`Device::records`].
    Record(usize),
}

/// Configuration.xml `<Member Name Alias?>`: one value of an [`Enum`] (G3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Member {
    /// `Name`: the member on the RAPID side (G4), unique in its enum,
    /// case-insensitively.
    pub name: String,
    /// `Alias`: the member on the device side, the text that travels (G3,
    /// M3); 1..80 bytes, no leading or trailing spaces.
    pub alias: Option<String>,
    /// Where the `<Member>` start tag is.
    pub pos: Pos,
}

impl Member {
    /// What travels in messages (G3: the alias, else the name).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

/// Configuration.xml `<Enums><Enum Name Link?>`: an enumerated type (G3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Enum {
    /// `Name` (G4); one case-insensitive namespace with the records and the
    /// simple types (G5).
    pub name: String,
    /// `Link`: `Intern` when the controller fills the members (G3).
    pub link: Link,
    /// The `<Member>` children, in file order; at least one, names and wire
    /// names unique.
    pub members: Vec<Member>,
    /// Where the `<Enum>` start tag is.
    pub pos: Pos,
}

/// Configuration.xml `<Field Name Type Size? Link? Alias?>`: one field of a
/// [`Record`] (G3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// `Name` (G4), unique in its record, case-insensitively.
    pub name: String,
    /// `Type` (G5): a simple type or an enum, never a record (records do
    /// not nest, G3).
    pub ty: TypeRef,
    /// `Some(n)`: an array of n values.
    pub size: Option<u16>,
    /// `Link`: `Intern` when the controller fills the field (G3).
    pub link: Link,
    /// `Alias`: the field's element name in messages (M2); an XML name.
    pub alias: Option<String>,
    /// Where the `<Field>` start tag is.
    pub pos: Pos,
}

impl Field {
    /// Element name in messages (M2: alias, else name).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

/// Configuration.xml `<Records><Record Name Alias?>`: a complex type, a
/// RAPID `RECORD` (G3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    /// `Name` (G4); one case-insensitive namespace with the enums and the
    /// simple types (G5).
    pub name: String,
    /// `Alias`: informational, since the property names a message's root
    /// element (M1); an XML name.
    pub alias: Option<String>,
    /// The `<Field>` children, in file order, which is also their order in
    /// messages (M2); names and wire names unique.
    pub fields: Vec<Field>,
    /// Where the `<Record>` start tag is.
    pub pos: Pos,
}

impl Record {
    /// The alias, else the name. Unlike [`Field::wire`] and
    /// [`Property::wire`] it names no element in messages (M1).
    pub fn wire(&self) -> &str {
        self.alias.as_deref().unwrap_or(&self.name)
    }
}

/// Configuration.xml `<Properties><Property Name Type Size? Flag? Link?
/// Alias?>`: a variable RAPID can pass to `SiSetCyclic`/`SiGetCyclic` (G3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Property {
    /// `Name` (G4), unique case-insensitively.
    pub name: String,
    /// `Type` (G5): a record travels as child elements (M2), a simple type
    /// or an enum on the root element itself (M1).
    pub ty: TypeRef,
    /// `Size`: `Some(n)` for an array of n values, attributes `X1..XN` (M4).
    pub size: Option<u16>,
    /// `Flag` (G3), `ReadWrite` when omitted: which side sends the
    /// property.
    pub direction: Direction,
    /// `Link`: `Intern` when the controller fills the property (G3).
    pub link: Link,
    /// `Alias`: the root element's name in messages (M1); an XML name.
    pub alias: Option<String>,
    /// Where the `<Property>` start tag is.
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
    /// Description.xml `<Name>`, equal to the Settings.xml client name (G1,
    /// G2); a RAPID name (G4).
    pub name: String,
    /// Description.xml `Type` and `Class`: free text, not validated.
    pub device_type: String,
    /// Description.xml `<Class>`: free text, not validated.
    pub class: String,
    /// Description.xml `<Network>`: where the device is (G2).
    pub network: Network,
    /// Description.xml `<Channel>`: the transport and the port the device
    /// listens on (G2).
    pub channel: Channel,
    /// Description.xml `<Settings>`: TimeOut, MaxLost, DryRun (S1).
    pub supervision: Supervision,
    /// Configuration.xml `<Enums>`, in file order; [`TypeRef::Enum`]
    /// indexes it.
    pub enums: Vec<Enum>,
    /// Configuration.xml `<Records>`, in file order; [`TypeRef::Record`]
    /// indexes it.
    pub records: Vec<Record>,
    /// Configuration.xml `<Properties>`, in file order; names and wire names
    /// unique (G3).
    pub properties: Vec<Property>,
    /// Path of Configuration.xml, for diagnostics found later (code
    /// generation checks message sizes against the transport).
    pub configuration_file: std::path::PathBuf,
}

impl Device {
    /// Properties the controller sends to the device.
    pub fn received(&self) -> impl Iterator<Item = &Property> {
        self.properties.iter().filter(|p| p.direction.robot_sends())
    }

    /// Properties the device sends to the controller.
    pub fn sent(&self) -> impl Iterator<Item = &Property> {
        self.properties
            .iter()
            .filter(|p| p.direction.device_sends())
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
    /// The validated device.
    pub device: Device,
    /// The paths of Settings.xml, Description.xml and Configuration.xml, for
    /// `rerun-if-changed`.
    pub files: Vec<std::path::PathBuf>,
    /// Every diagnostic of the load (none is an error), in the order the
    /// files were read.
    pub warnings: Vec<Diagnostic>,
}
