//! # gsi-codegen: fixed RRI message layouts from a GSI device model
//!
//! Turns a validated [`gsi_config::Device`] into Rust source for the `no_std`
//! firmware: constants for the network, channel and supervision settings, an
//! enum per `Enum` (with its wire aliases), a struct per `Record`, and per
//! property a message type with its wire name and compile-time maximum
//! lengths, so every buffer in the firmware is sized by a constant.
//!
//! The output is meant to be read: it is formatted as rustfmt would, every
//! item is documented with what the configuration said, and a golden test in
//! `host-tests` shows reviewers every change to it.

mod emit;
pub mod names;
mod sets;
pub mod sizes;

pub use sets::{device_property, periodic, MAX_PROPERTIES};

use emit::{str_lit, Emitter};
use gsi_config::{Device, Diagnostic, Flag, Link, Pos, Rule, Severity, SimpleType, TypeRef};
use std::collections::HashMap;

/// Build-time choices that are not in the GSI files.
#[derive(Clone, Debug)]
pub struct Options {
    /// Path of the firmware crate as seen from the generated code: `crate`
    /// inside the firmware, `::rri_firmware` elsewhere.
    pub crate_path: String,
    /// Decimals of reals in sent messages (M5), 0..=6.
    pub real_decimals: u8,
    /// Decimals of times in sent messages (M5: 1 ms → 3), 0..=6.
    pub time_decimals: u8,
    /// `RRI_CONTROLLER`: the pinned controller's IPv4 address and,
    /// optionally, the port periodic sends go to.
    pub controller: Option<([u8; 4], Option<u16>)>,
    /// `RRI_SEND_PERIOD_MS`: periodic sends of the reply property for
    /// one-way streams, a multiple of 4 ms; 0 = off.
    pub send_period_ms: u32,
    /// `RRI_REPLY`: the reply property, as its position among the
    /// properties the device sends ([`device_property`]); default 0, the
    /// first.
    pub reply: usize,
    /// `RRI_PERIODIC`: (position among the properties the device sends,
    /// period in ms) of the properties sent on their own schedules
    /// ([`periodic`]).
    pub periodic: Vec<(usize, u32)>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            crate_path: "crate".into(),
            real_decimals: 3,
            time_decimals: 3,
            controller: None,
            send_period_ms: 0,
            reply: 0,
            periodic: Vec::new(),
        }
    }
}

/// Most decimals the fixed-point encoder writes (time is held in µs).
pub const MAX_DECIMALS: u8 = 6;

/// The Rust names of everything generated, resolved once.
struct Idents {
    enums: Vec<String>,
    variants: Vec<Vec<String>>,
    records: Vec<String>,
    fields: Vec<Vec<String>>,
    messages: Vec<String>,
}

fn diag(device: &Device, pos: Pos, rule: Rule, message: String) -> Diagnostic {
    Diagnostic {
        severity: Severity::Error,
        rule,
        file: device.configuration_file.clone(),
        pos,
        message,
    }
}

/// Resolves Rust names and reports collisions the GSI rules cannot see
/// (two RAPID names that become the same Rust identifier).
fn idents(device: &Device, errors: &mut Vec<Diagnostic>) -> Idents {
    let mut types: HashMap<String, (String, Pos)> = HashMap::new();
    let mut claim = |ident: String, what: String, pos: Pos, errors: &mut Vec<Diagnostic>| {
        if let Some((other, _)) = types.get(&ident) {
            errors.push(diag(
                device,
                pos,
                Rule::G4,
                format!("{what} and {other} both become the Rust type `{ident}`; rename one"),
            ));
        } else {
            types.insert(ident.clone(), (what, pos));
        }
        ident
    };
    // The per-direction sets (M11) take these names.
    let first = device.properties.first().map_or(Pos::default(), |p| p.pos);
    for (name, what) in [
        (
            "RobotProperty",
            "the generated enum of the robot's properties",
        ),
        (
            "RobotProperties",
            "the generated struct of the robot's properties",
        ),
        (
            "DeviceProperty",
            "the generated enum of the device's properties",
        ),
        (
            "DeviceProperties",
            "the generated struct of the device's properties",
        ),
    ] {
        claim(name.to_string(), what.to_string(), first, errors);
    }
    let enums = device
        .enums
        .iter()
        .map(|e| {
            claim(
                names::camel(&e.name),
                format!("enum \"{}\"", e.name),
                e.pos,
                errors,
            )
        })
        .collect();
    let records = device
        .records
        .iter()
        .map(|r| {
            claim(
                names::camel(&r.name),
                format!("record \"{}\"", r.name),
                r.pos,
                errors,
            )
        })
        .collect();
    let messages = device
        .properties
        .iter()
        .map(|p| {
            claim(
                format!("{}Message", names::camel(&p.name).trim_start_matches("r#")),
                format!("property \"{}\"", p.name),
                p.pos,
                errors,
            )
        })
        .collect();
    let unique = |list: Vec<(String, &str, Pos)>, kind: &str, errors: &mut Vec<Diagnostic>| {
        let mut seen: HashMap<String, &str> = HashMap::new();
        list.into_iter()
            .map(|(ident, name, pos)| {
                if let Some(other) = seen.get(&ident) {
                    errors.push(diag(
                        device,
                        pos,
                        Rule::G4,
                        format!("{kind} \"{other}\" and \"{name}\" both become `{ident}` in Rust; rename one"),
                    ));
                }
                seen.insert(ident.clone(), name);
                ident
            })
            .collect::<Vec<_>>()
    };
    let variants = device
        .enums
        .iter()
        .map(|e| {
            let list = e
                .members
                .iter()
                .map(|m| (names::camel(&m.name), m.name.as_str(), m.pos))
                .collect();
            unique(list, "members", errors)
        })
        .collect();
    let fields = device
        .records
        .iter()
        .map(|r| {
            let list = r
                .fields
                .iter()
                .map(|f| (names::snake(&f.name), f.name.as_str(), f.pos))
                .collect();
            unique(list, "fields", errors)
        })
        .collect();
    Idents {
        enums,
        variants,
        records,
        fields,
        messages,
    }
}

/// The Rust type of a value of `ty`, as an array when `size` is given.
fn rust_type(id: &Idents, ty: TypeRef, size: Option<u16>) -> String {
    let base = match ty {
        TypeRef::Simple(SimpleType::Bool) => "bool".to_string(),
        TypeRef::Simple(SimpleType::Real) => "f32".to_string(),
        TypeRef::Simple(SimpleType::Time) => "Time".to_string(),
        TypeRef::Simple(SimpleType::String) => "RriString".to_string(),
        TypeRef::Simple(SimpleType::Frame) => "Frame".to_string(),
        TypeRef::Simple(SimpleType::Joints) => "Joints".to_string(),
        TypeRef::Enum(i) => id.enums[i].clone(),
        TypeRef::Record(i) => id.records[i].clone(),
    };
    match size {
        Some(n) => format!("[{base}; {n}]"),
        None => base,
    }
}

/// A `const` expression for the default value of `ty`.
fn default_expr(id: &Idents, ty: TypeRef, size: Option<u16>) -> String {
    let base = match ty {
        TypeRef::Simple(SimpleType::Bool) => "false".to_string(),
        TypeRef::Simple(SimpleType::Real) => "0.0".to_string(),
        TypeRef::Simple(SimpleType::Time) => "Time::ZERO".to_string(),
        TypeRef::Simple(SimpleType::String) => "RriString::new()".to_string(),
        TypeRef::Simple(SimpleType::Frame) => "Frame::ZERO".to_string(),
        TypeRef::Simple(SimpleType::Joints) => "[0.0; 6]".to_string(),
        TypeRef::Enum(i) => format!("{}::{}", id.enums[i], id.variants[i][0]),
        TypeRef::Record(i) => format!("{}::DEFAULT", id.records[i]),
    };
    match (size, ty) {
        (Some(n), TypeRef::Simple(SimpleType::String)) => format!("[const {{ {base} }}; {n}]"),
        (Some(n), _) => format!("[{base}; {n}]"),
        (None, _) => base,
    }
}

/// How a value travels, for doc comments.
fn wire_doc(device: &Device, wire: &str, ty: TypeRef, size: Option<u16>) -> String {
    match sizes::attribute_names(ty, size) {
        Some(attrs) if attrs.len() > 3 => format!(
            "`<{wire} {}=\"…\" … {}=\"…\"/>`",
            attrs[0],
            attrs[attrs.len() - 1]
        ),
        Some(attrs) => format!(
            "`<{wire} {}/>`",
            attrs
                .iter()
                .map(|a| format!("{a}=\"…\""))
                .collect::<Vec<_>>()
                .join(" ")
        ),
        None => {
            let _ = device;
            format!("`<{wire}>…</{wire}>`")
        }
    }
}

fn type_doc(device: &Device, ty: TypeRef, size: Option<u16>, link: Link) -> String {
    let mut s = format!("`{}`", device.type_name(ty));
    if let Some(n) = size {
        s.push_str(&format!(" × {n}"));
    }
    if link == Link::Intern {
        s.push_str(", `Link=\"Intern\"` (filled by the controller)");
    }
    s
}

/// Parses dotted-quad IPv4 text.
fn ipv4(address: &str) -> Option<[u8; 4]> {
    let parts: Vec<u8> = address
        .split('.')
        .map(|p| p.parse::<u8>())
        .collect::<Result<_, _>>()
        .ok()?;
    parts.try_into().ok()
}

/// Generates the layout source for `device`. Errors (name collisions in
/// Rust, messages larger than a datagram) name Configuration.xml positions.
pub fn generate(device: &Device, opts: &Options) -> Result<String, Vec<Diagnostic>> {
    let mut errors = Vec::new();
    let id = idents(device, &mut errors);
    let format = sizes::Format {
        real_decimals: opts.real_decimals.min(MAX_DECIMALS),
        time_decimals: opts.time_decimals.min(MAX_DECIMALS),
    };
    let mut message_sizes = Vec::new();
    for p in &device.properties {
        let (enc, rcv) = sizes::message_sizes(device, p, format);
        if enc > sizes::MAX_DATAGRAM {
            errors.push(diag(
                device,
                p.pos,
                Rule::G3,
                format!(
                    "message <{}> can be {enc} bytes long, more than one UDP datagram ({} bytes); use fewer or smaller fields",
                    p.wire(),
                    sizes::MAX_DATAGRAM
                ),
            ));
        }
        message_sizes.push((enc, rcv.min(sizes::MAX_DATAGRAM)));
    }
    for (dir, list) in [
        (
            "the controller sends",
            device.received().collect::<Vec<_>>(),
        ),
        ("the device sends", device.sent().collect()),
    ] {
        if let Some(p) = list.get(MAX_PROPERTIES) {
            errors.push(diag(
                device,
                p.pos,
                Rule::G3,
                format!(
                    "more than {MAX_PROPERTIES} properties {dir}: the firmware serves at most {MAX_PROPERTIES} per direction"
                ),
            ));
        }
    }
    let sent_count = device.sent().count();
    let bad_index = |i: usize| sent_count > 0 && i >= sent_count;
    if bad_index(opts.reply) || opts.periodic.iter().any(|&(i, _)| bad_index(i)) {
        errors.push(diag(
            device,
            Pos::default(),
            Rule::G3,
            format!(
                "RRI_REPLY / RRI_PERIODIC name a property beyond the {sent_count} the device sends"
            ),
        ));
    }
    if !errors.is_empty() {
        return Err(errors);
    }

    let k = &opts.crate_path;
    let mut e = Emitter::default();
    e.line(format!(
        "// @generated by gsi-codegen from the GSI configuration of device \"{}\".",
        device.name
    ));
    e.line("// Do not edit: change Description.xml / Configuration.xml and rebuild.");
    e.blank();
    let mut schema = vec!["Body", "ChannelProtocol", "ControllerPort", "Direction"];
    schema.extend([
        "FieldMut",
        "FieldRef",
        "FieldWire",
        "Format",
        "Message",
        "MessageCodec",
    ]);
    if !device.records.is_empty() {
        schema.push("Record");
    }
    if !device.enums.is_empty() {
        schema.push("WireEnum");
    }
    let has_rx = device.received().next().is_some();
    let has_tx = device.sent().next().is_some();
    let mut codec = Vec::new();
    if has_tx {
        codec.extend(["encode", "BufferTooSmall"]);
    }
    if has_rx {
        codec.extend(["DecodeError", "Decoded"]);
    }
    if has_tx {
        codec.push("Encoded");
    }
    e.use_list(&format!("{k}::codec"), &codec);
    e.use_list(
        &format!("{k}::engine"),
        &["Config as EngineConfig", "Periodic", "Pinned"],
    );
    let mut sets = Vec::new();
    if has_rx {
        sets.push("decode_committed");
        if device.received().nth(1).is_some() {
            sets.push("root_name");
        }
    }
    if has_tx {
        sets.push("DeviceSet");
    }
    if has_rx {
        sets.push("RobotSet");
    }
    e.use_list(&format!("{k}::properties"), &sets);
    e.use_list(&format!("{k}::schema"), &schema);
    let used = |t: SimpleType| {
        let fields = device
            .records
            .iter()
            .flat_map(|r| r.fields.iter().map(|f| f.ty));
        fields
            .chain(device.properties.iter().map(|p| p.ty))
            .any(|ty| ty == TypeRef::Simple(t))
    };
    let values: Vec<&str> = [
        (SimpleType::Frame, "Frame"),
        (SimpleType::Joints, "Joints"),
        (SimpleType::String, "RriString"),
        (SimpleType::Time, "Time"),
    ]
    .into_iter()
    .filter(|(t, _)| used(*t) || (*t == SimpleType::Time && has_tx))
    .map(|(_, name)| name)
    .collect();
    e.use_list(&format!("{k}::value"), &values);
    e.blank();
    emit_settings(&mut e, device, format, opts);
    for (i, en) in device.enums.iter().enumerate() {
        e.blank();
        emit_enum(&mut e, &id, i, en);
    }
    for (i, r) in device.records.iter().enumerate() {
        e.blank();
        emit_record(&mut e, device, &id, i, r);
    }
    for (i, p) in device.properties.iter().enumerate() {
        e.blank();
        emit_message(&mut e, device, &id, i, p, message_sizes[i]);
    }
    e.blank();
    emit_array_attrs(&mut e, device);
    e.blank();
    emit_totals(&mut e, device, &id, &message_sizes, opts);
    Ok(e.finish())
}

fn emit_settings(e: &mut Emitter, d: &Device, f: sizes::Format, opts: &Options) {
    e.doc("Device name (Description.xml `<Name>`, Settings.xml client).");
    e.line(format!(
        "pub const DEVICE_NAME: &str = {};",
        str_lit(&d.name)
    ));
    e.doc("Device type (Description.xml `<Type>`, free text).");
    e.line(format!(
        "pub const DEVICE_TYPE: &str = {};",
        str_lit(&d.device_type)
    ));
    e.doc("Device class (Description.xml `<Class>`, free text).");
    e.line(format!(
        "pub const DEVICE_CLASS: &str = {};",
        str_lit(&d.class)
    ));
    e.doc("The device's own IP address or host name (`<Network Address>`).");
    e.line(format!(
        "pub const NETWORK_ADDRESS: &str = {};",
        str_lit(&d.network.address)
    ));
    e.doc("[`NETWORK_ADDRESS`] as IPv4 octets, `None` when it is a host name.");
    match ipv4(&d.network.address) {
        Some([a, b, c, dd]) => e.line(format!(
            "pub const NETWORK_IPV4: Option<[u8; 4]> = Some([{a}, {b}, {c}, {dd}]);"
        )),
        None => e.line("pub const NETWORK_IPV4: Option<[u8; 4]> = None;"),
    }
    e.doc("The controller's physical port the device is cabled to (`<Network Port>`).");
    e.line(format!(
        "pub const CONTROLLER_PORT: ControllerPort = ControllerPort::{};",
        d.network.port.as_str()
    ));
    e.doc("Transport of the cyclic channel (`<Channel Protocol>`).");
    e.line(format!(
        "pub const CHANNEL_PROTOCOL: ChannelProtocol = ChannelProtocol::{};",
        d.channel.protocol.as_str()
    ));
    e.doc("Port the device listens on (`<Channel Port>`).");
    e.line(format!("pub const CHANNEL_PORT: u16 = {};", d.channel.port));
    e.doc("S1: the controller's answer timeout in milliseconds (`<TimeOut>`).");
    e.line(format!(
        "pub const TIMEOUT_MS: u32 = {};",
        d.supervision.timeout_ms
    ));
    e.doc("S1: most unanswered messages in a row the controller tolerates (`<MaxLost>`).");
    e.line(format!(
        "pub const MAX_LOST: u32 = {};",
        d.supervision.max_lost
    ));
    e.doc("S1: `true` = one-way streams, TimeOut and MaxLost are not supervised (`<DryRun>`).");
    e.line(format!(
        "pub const DRY_RUN: bool = {};",
        d.supervision.dry_run
    ));
    e.doc("M5: decimals of reals in sent messages (`RRI_REAL_DECIMALS`).");
    e.line(format!(
        "pub const REAL_DECIMALS: u8 = {};",
        f.real_decimals
    ));
    e.doc("M5: decimals of times in sent messages (`RRI_TIME_DECIMALS`).");
    e.line(format!(
        "pub const TIME_DECIMALS: u8 = {};",
        f.time_decimals
    ));
    e.doc("M5: how sent messages write numbers ([`REAL_DECIMALS`], [`TIME_DECIMALS`]).");
    e.open("pub const FORMAT: Format = Format");
    e.line("real_decimals: REAL_DECIMALS,");
    e.line("time_decimals: TIME_DECIMALS,");
    e.close(";");
    e.doc("`RRI_CONTROLLER`: the only controller answered, when pinned.");
    match opts.controller {
        None => e.line("pub const CONTROLLER: Option<Pinned> = None;"),
        Some(([a, b, c, dd], port)) => {
            let port = match port {
                Some(p) => format!("Some({p})"),
                None => "None".to_string(),
            };
            e.open("pub const CONTROLLER: Option<Pinned> = Some(Pinned");
            e.line(format!("ip: [{a}, {b}, {c}, {dd}],"));
            e.line(format!("port: {port},"));
            e.close(");");
        }
    }
    e.doc("`RRI_SEND_PERIOD_MS`: periodic sends for one-way streams (0 = off).");
    e.line(format!(
        "pub const SEND_PERIOD_MS: u32 = {};",
        opts.send_period_ms
    ));
    e.doc("The cycle engine's settings for this device.");
    e.open("pub const ENGINE_CONFIG: EngineConfig = EngineConfig");
    e.line("timeout_ms: TIMEOUT_MS,");
    e.line("max_lost: MAX_LOST,");
    e.line("dry_run: DRY_RUN,");
    e.line("controller: CONTROLLER,");
    if d.sent().next().is_some() {
        e.line("reply: REPLY.index(),");
    } else {
        e.line("reply: 0,");
    }
    e.line("send_period_ms: SEND_PERIOD_MS,");
    e.line("periodic: &PERIODIC,");
    e.line("format: FORMAT,");
    e.close(";");
}

fn emit_enum(e: &mut Emitter, id: &Idents, i: usize, en: &gsi_config::Enum) {
    let name = &id.enums[i];
    let link = if en.link == Link::Intern {
        " (`Link=\"Intern\"`: the controller fills it)"
    } else {
        ""
    };
    e.doc(format!("Enum `{}`{link}.", en.name));
    e.doc("");
    e.doc("Each member travels as its alias, or its name when it has none (G3).");
    e.line("#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]");
    e.open(format!("pub enum {name}"));
    for (j, m) in en.members.iter().enumerate() {
        e.doc(format!("`{}`, travels as `{}`.", m.name, m.wire()));
        if j == 0 {
            e.line("#[default]");
        }
        e.line(format!("{},", id.variants[i][j]));
    }
    e.close("");
    e.blank();
    e.open(format!("impl {name}"));
    e.doc("Every member, in declaration order.");
    let members: Vec<String> = id.variants[i]
        .iter()
        .map(|v| format!("Self::{v}"))
        .collect();
    e.array(
        &format!("pub const MEMBERS: [Self; {}] = ", members.len()),
        &members,
    );
    e.blank();
    e.doc("The text that travels in messages.");
    e.open("pub const fn wire(self) -> &'static str");
    e.open("match self");
    for (j, m) in en.members.iter().enumerate() {
        e.line(format!(
            "Self::{} => {},",
            id.variants[i][j],
            str_lit(m.wire())
        ));
    }
    e.close("");
    e.close("");
    e.blank();
    e.doc("The member whose wire text is exactly `text`.");
    e.open("pub fn from_wire(text: &[u8]) -> Option<Self>");
    e.open("match text");
    for (j, m) in en.members.iter().enumerate() {
        e.line(format!(
            "{} => Some(Self::{}),",
            emit::bytes_lit(m.wire()),
            id.variants[i][j]
        ));
    }
    e.line("_ => None,");
    e.close("");
    e.close("");
    e.close("");
    e.blank();
    e.open(format!("impl WireEnum for {name}"));
    e.open("fn wire_text(&self) -> &'static str");
    e.line("self.wire()");
    e.close("");
    e.blank();
    e.open("fn set_from_wire(&mut self, text: &[u8]) -> bool");
    e.open("match Self::from_wire(text)");
    e.open("Some(member) =>");
    e.line("*self = member;");
    e.line("true");
    e.close("");
    e.line("None => false,");
    e.close("");
    e.close("");
    e.close("");
}

fn emit_record(e: &mut Emitter, d: &Device, id: &Idents, i: usize, r: &gsi_config::Record) {
    let name = &id.records[i];
    match &r.alias {
        Some(a) => e.doc(format!("Record `{}` (alias `{a}`).", r.name)),
        None => e.doc(format!("Record `{}`.", r.name)),
    }
    let copy = r
        .fields
        .iter()
        .all(|f| f.ty != TypeRef::Simple(SimpleType::String));
    e.line(if copy {
        "#[derive(Clone, Copy, Debug, PartialEq)]"
    } else {
        "#[derive(Clone, Debug, PartialEq)]"
    });
    e.open(format!("pub struct {name}"));
    for (j, f) in r.fields.iter().enumerate() {
        e.doc(format!(
            "`{}`: {}; travels as {}.",
            f.name,
            type_doc(d, f.ty, f.size, f.link),
            wire_doc(d, f.wire(), f.ty, f.size)
        ));
        e.line(format!(
            "pub {}: {},",
            id.fields[i][j],
            rust_type(id, f.ty, f.size)
        ));
    }
    e.close("");
    e.blank();
    let defaults: Vec<(String, String)> = r
        .fields
        .iter()
        .enumerate()
        .map(|(j, f)| (id.fields[i][j].clone(), default_expr(id, f.ty, f.size)))
        .collect();
    emit_defaults(e, name, "Every field", &defaults);
    e.blank();
    e.open(format!("impl Record for {name}"));
    let items: Vec<Vec<String>> = r
        .fields
        .iter()
        .map(|f| {
            let w = f.wire();
            let (open, close) = if sizes::attribute_names(f.ty, f.size).is_some() {
                (format!("<{w}"), "/>".to_string())
            } else {
                (format!("<{w}>"), format!("</{w}>"))
            };
            vec![
                emit::bytes_lit(w),
                emit::bytes_lit(&open),
                emit::bytes_lit(&close),
            ]
        })
        .collect();
    e.call_array(
        "const FIELDS: &'static [FieldWire] = &",
        "FieldWire::new",
        &items,
    );
    e.blank();
    e.open("fn field_index(name: &[u8]) -> Option<usize>");
    e.open("match name");
    for (j, f) in r.fields.iter().enumerate() {
        e.line(format!("{} => Some({j}),", emit::bytes_lit(f.wire())));
    }
    e.line("_ => None,");
    e.close("");
    e.close("");
    e.blank();
    e.open("fn field(&self, index: usize) -> Option<FieldRef<'_>>");
    e.open("Some(match index");
    for (j, f) in r.fields.iter().enumerate() {
        let v = format!("self.{}", id.fields[i][j]);
        e.line(format!("{j} => {},", field_ref(f.ty, f.size, &v)));
    }
    e.line("_ => return None,");
    e.close(")");
    e.close("");
    e.blank();
    e.open("fn field_mut(&mut self, index: usize) -> Option<FieldMut<'_>>");
    e.open("Some(match index");
    for (j, f) in r.fields.iter().enumerate() {
        let v = format!("&mut self.{}", id.fields[i][j]);
        e.line(format!("{j} => {},", field_mut(f.ty, f.size, &v)));
    }
    e.line("_ => return None,");
    e.close(")");
    e.close("");
    e.close("");
}

/// `impl {name} { pub const DEFAULT }` from (field, default expression)
/// pairs, and `Default` returning it (a `const` so the firmware's statics
/// start from it without running code).
fn emit_defaults(e: &mut Emitter, name: &str, what: &str, fields: &[(String, String)]) {
    e.open(format!("impl {name}"));
    e.doc(format!(
        "{what} zero, false, empty or the first enum member."
    ));
    e.open("pub const DEFAULT: Self = Self");
    for (field, value) in fields {
        e.line(format!("{field}: {value},"));
    }
    e.close(";");
    e.close("");
    e.blank();
    e.open(format!("impl Default for {name}"));
    e.open("fn default() -> Self");
    e.line("Self::DEFAULT");
    e.close("");
    e.close("");
}

/// The `FieldRef` constructor for a value; `v` is a place expression.
fn field_ref(ty: TypeRef, size: Option<u16>, v: &str) -> String {
    let variant = variant(ty, size);
    match (ty, size) {
        (_, Some(_)) => format!("FieldRef::{variant}(&{v})"),
        (TypeRef::Enum(_), None) => format!("FieldRef::Enum({v}.wire())"),
        (TypeRef::Simple(SimpleType::Bool | SimpleType::Real | SimpleType::Time), None) => {
            format!("FieldRef::{variant}({v})")
        }
        _ => format!("FieldRef::{variant}(&{v})"),
    }
}

/// The `FieldMut` constructor for a value; `v` is a `&mut` expression.
fn field_mut(ty: TypeRef, size: Option<u16>, v: &str) -> String {
    format!("FieldMut::{}({v})", variant(ty, size))
}

fn variant(ty: TypeRef, size: Option<u16>) -> &'static str {
    match (ty, size) {
        (TypeRef::Simple(SimpleType::Bool), None) => "Bool",
        (TypeRef::Simple(SimpleType::Real), None) => "Real",
        (TypeRef::Simple(SimpleType::Time), None) => "Time",
        (TypeRef::Simple(SimpleType::String), None) => "Str",
        (TypeRef::Simple(SimpleType::Frame), _) => "Frame",
        (TypeRef::Simple(SimpleType::Joints), _) => "Joints",
        (TypeRef::Simple(SimpleType::Bool), Some(_)) => "Bools",
        (TypeRef::Simple(SimpleType::Real), Some(_)) => "Reals",
        (TypeRef::Simple(SimpleType::Time), Some(_)) => "Times",
        (TypeRef::Simple(SimpleType::String), Some(_)) => "Strs",
        (TypeRef::Enum(_), _) => "Enum",
        // Records are never fields or simple values (G3).
        (TypeRef::Record(_), _) => "Record",
    }
}

fn direction(flag: Flag) -> &'static str {
    match flag {
        Flag::None => "None",
        Flag::ReadOnly => "DeviceToRobot",
        Flag::WriteOnly => "RobotToDevice",
        Flag::ReadWrite => "Both",
    }
}

fn emit_message(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    i: usize,
    p: &gsi_config::Property,
    (enc, rcv): (usize, usize),
) {
    let name = &id.messages[i];
    let travel = match p.flag {
        Flag::None => "travels in neither direction",
        Flag::ReadOnly => "the device sends it to the controller",
        Flag::WriteOnly => "the controller sends it to the device",
        Flag::ReadWrite => "it travels in both directions",
    };
    e.doc(format!(
        "Property `{}` of type {} (`Flag=\"{}\"`): {travel}.",
        p.name,
        type_doc(d, p.ty, p.size, p.link),
        p.flag.as_str()
    ));
    if p.flag != Flag::None {
        e.doc("");
        e.doc(format!(
            "On the wire: `<{} Id=\"…\" Ts=\"…\">…</{}>` (M1).",
            p.wire(),
            p.wire()
        ));
    }
    e.line("#[derive(Clone, Copy, Debug, PartialEq, Eq)]");
    e.line(format!("pub struct {name};"));
    e.blank();
    e.open(format!("impl Message for {name}"));
    e.line(format!("type Data = {};", rust_type(id, p.ty, p.size)));
    e.line(format!("const NAME: &'static str = {};", str_lit(&p.name)));
    e.line(format!(
        "const WIRE_NAME: &'static str = {};",
        str_lit(p.wire())
    ));
    e.line(format!(
        "const DIRECTION: Direction = Direction::{};",
        direction(p.flag)
    ));
    e.line(format!("const MAX_ENCODED_LEN: usize = {enc};"));
    e.line(format!("const MAX_RECEIVE_LEN: usize = {rcv};"));
    e.close("");
    e.blank();
    let w = p.wire();
    e.open(format!("impl MessageCodec for {name}"));
    let value_body = !matches!(p.ty, TypeRef::Record(_));
    e.line(if value_body {
        "const BODY: Body = Body::Value;"
    } else {
        "const BODY: Body = Body::Record;"
    });
    e.line(format!(
        "const OPEN: &'static [u8] = {};",
        emit::bytes_lit(&format!("<{w} Id=\""))
    ));
    e.line(format!(
        "const CLOSE: &'static [u8] = {};",
        emit::bytes_lit(&format!("</{w}>"))
    ));
    e.line("const ARRAY_ATTRS: &'static [&'static [u8]] = &ARRAY_ATTRS;");
    match p.ty {
        TypeRef::Record(r) => {
            let rec = &id.records[r];
            e.line(format!(
                "const FIELDS: &'static [FieldWire] = <{rec} as Record>::FIELDS;"
            ));
            e.blank();
            e.open("fn field_index(name: &[u8]) -> Option<usize>");
            e.line(format!("{rec}::field_index(name)"));
            e.close("");
            e.blank();
            e.open("fn field(data: &Self::Data, index: usize) -> Option<FieldRef<'_>>");
            e.line("data.field(index)");
            e.close("");
            e.blank();
            e.open("fn field_mut(data: &mut Self::Data, index: usize) -> Option<FieldMut<'_>>");
            e.line("data.field_mut(index)");
            e.close("");
        }
        ty => {
            e.line("const FIELDS: &'static [FieldWire] = &[FieldWire::new(b\"\", b\"\", b\"\")];");
            e.blank();
            e.open("fn field_index(_name: &[u8]) -> Option<usize>");
            e.line("None");
            e.close("");
            e.blank();
            e.open("fn field(data: &Self::Data, index: usize) -> Option<FieldRef<'_>>");
            let value = field_ref(ty, p.size, "*data").replace("&*data", "data");
            e.line(format!("(index == 0).then_some({value})"));
            e.close("");
            e.blank();
            e.open("fn field_mut(data: &mut Self::Data, index: usize) -> Option<FieldMut<'_>>");
            let value = field_mut(ty, p.size, "data");
            e.line(format!("(index == 0).then_some({value})"));
            e.close("");
        }
    }
    e.close("");
}

/// The ` X<i>="` attribute openers of arrays (M4) up to the longest array
/// of the layout, so the encoder copies them instead of formatting indices.
fn emit_array_attrs(e: &mut Emitter, d: &Device) {
    let sizes = d
        .records
        .iter()
        .flat_map(|r| r.fields.iter().map(|f| f.size));
    let longest = sizes
        .chain(d.properties.iter().map(|p| p.size))
        .flatten()
        .max()
        .unwrap_or(0);
    e.doc("Attribute openers of array elements, ` X1=\"` … (M4), precomputed up to the");
    e.doc("longest array of this layout.");
    e.line("#[rustfmt::skip]");
    if longest == 0 {
        e.line("pub const ARRAY_ATTRS: [&[u8]; 0] = [];");
        return;
    }
    e.line(format!("pub const ARRAY_ATTRS: [&[u8]; {longest}] = ["));
    for i in 1..=longest {
        e.line(format!("    {},", emit::bytes_lit(&format!(" X{i}=\""))));
    }
    e.line("];");
}

fn emit_totals(e: &mut Emitter, d: &Device, id: &Idents, sizes: &[(usize, usize)], opts: &Options) {
    let received: Vec<usize> = (0..d.properties.len())
        .filter(|&i| d.properties[i].flag.robot_sends())
        .collect();
    let sent: Vec<usize> = (0..d.properties.len())
        .filter(|&i| d.properties[i].flag.device_sends())
        .collect();
    let list = |idx: &[usize]| -> Vec<String> {
        idx.iter()
            .map(|&i| str_lit(d.properties[i].wire()))
            .collect()
    };
    e.doc("Root element names of the messages the controller sends to the device.");
    e.array(
        &format!("pub const RECEIVED: [&str; {}] = ", received.len()),
        &list(&received),
    );
    e.doc("Root element names of the messages the device sends to the controller.");
    e.array(
        &format!("pub const SENT: [&str; {}] = ", sent.len()),
        &list(&sent),
    );
    let max_of = |idx: &[usize], pick: fn(&(usize, usize)) -> usize| {
        idx.iter().map(|&i| pick(&sizes[i])).max().unwrap_or(0)
    };
    if let Some(&rx) = received.first() {
        e.doc("The first property the controller sends (the codec bench's message).");
        e.line(format!("pub type RobotMessage = {};", id.messages[rx]));
    }
    if let Some(&tx) = sent.get(opts.reply) {
        e.doc("The message every robot message is answered with (`RRI_REPLY`).");
        e.line(format!("pub type ReplyMessage = {};", id.messages[tx]));
    }
    if !received.is_empty() && !sent.is_empty() {
        e.doc("The cycle engine for this device.");
        e.line(format!(
            "pub type DeviceEngine = {}::engine::Engine<RobotProperties, DeviceProperties>;",
            opts.crate_path
        ));
    }
    e.doc("Size of the receive buffer: the longest message the controller may send.");
    e.doc("A longer datagram is rejected before it is parsed.");
    e.line(format!(
        "pub const MAX_RECEIVE_LEN: usize = {};",
        max_of(&received, |s| s.1)
    ));
    e.doc("Size of the send buffer: the longest message the device can encode.");
    e.line(format!(
        "pub const MAX_SEND_LEN: usize = {};",
        max_of(&sent, |s| s.0)
    ));
    sets::emit_sets(e, d, id, &received, &sent, opts.reply, &opts.periodic);
}
