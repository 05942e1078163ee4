//! Every property of each direction as one struct (M11): the engine's view
//! of a configuration with several properties the controller sends
//! (decoded by root element) and several the device sends (the reply
//! property and periodic ones), plus the build settings that choose them
//! (`RRI_REPLY`, `RRI_PERIODIC`).

use super::emit::{self, Emitter};
use crate::resolve::Idents;
use crate::types::{default_expr, rust_type};
use gsi_config::Device;

/// Most properties per direction: the firmware sizes its per-property
/// arrays with the same constant.
pub use rri_vocabulary::MAX_PROPERTIES;

/// The position among the properties the device sends of the one a build
/// setting names; the error lists the choices.
pub fn device_property(device: &Device, setting: &str, name: &str) -> Result<usize, String> {
    let name = name.trim();
    if let Some(i) = device.sent().position(|p| p.is_named(name)) {
        return Ok(i);
    }
    let choices: Vec<&str> = device.sent().map(|p| p.name.as_str()).collect();
    let why = match device.properties.iter().find(|p| p.is_named(name)) {
        Some(p) => format!(
            "property \"{}\" is Flag=\"{}\": the device never sends it",
            p.name,
            p.direction.flag()
        ),
        None => format!("no property \"{name}\" in the configuration"),
    };
    Err(format!(
        "{setting}={name}: {why}; choose one the device sends: {}",
        if choices.is_empty() {
            "(none)".to_string()
        } else {
            choices.join(", ")
        }
    ))
}

/// `RRI_PERIODIC=Name=MS[,Name=MS…]`: (device property index, period).
/// `reply` is the reply property's index (its period is
/// `RRI_SEND_PERIOD_MS`).
pub fn periodic(device: &Device, text: &str, reply: usize) -> Result<Vec<(usize, u32)>, String> {
    let mut out: Vec<(usize, u32)> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((name, ms)) = item.split_once('=') else {
            return Err(format!(
                "RRI_PERIODIC: `{item}` is not Name=MS (e.g. RRI_PERIODIC=Offsets=32)"
            ));
        };
        let index = device_property(device, "RRI_PERIODIC", name)?;
        let ms = match ms.trim().parse::<u32>() {
            Ok(ms) if ms > 0 && ms % 4 == 0 => ms,
            _ => {
                return Err(format!(
                    "RRI_PERIODIC: {}={}: the period must be a positive multiple of 4 ms",
                    name.trim(),
                    ms.trim()
                ))
            }
        };
        if index == reply {
            return Err(format!(
                "RRI_PERIODIC: {} is the reply property; its unprompted sends are RRI_SEND_PERIOD_MS",
                name.trim()
            ));
        }
        if out.iter().any(|&(i, _)| i == index) {
            return Err(format!("RRI_PERIODIC: {} is listed twice", name.trim()));
        }
        out.push((index, ms));
    }
    Ok(out)
}

/// The struct field holding property `i`.
fn field_name(d: &Device, i: usize) -> String {
    super::names::snake(&d.properties[i].name)
}

/// Emits `RobotProperty` / `DeviceProperty`, `RobotProperties` /
/// `DeviceProperties` and their `RobotSet` / `DeviceSet` impls, `REPLY`
/// and `PERIODIC`. `received` and `sent` are property indices.
pub(crate) fn emit_sets(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    received: &[usize],
    sent: &[usize],
    reply: usize,
    periodic: &[(usize, u32)],
) {
    let directions: [(&[usize], &str, &str, &str, &str); 2] = [
        (
            received,
            "RobotProperty",
            "the controller sends",
            "RobotProperties",
            "The last good value of every property the controller sends (M2, M11).",
        ),
        (
            sent,
            "DeviceProperty",
            "the device sends",
            "DeviceProperties",
            "Every property the device sends, as the application last filled it in.",
        ),
    ];
    for (robot, (props, which, who, set, doc)) in [true, false].into_iter().zip(directions) {
        if props.is_empty() {
            continue;
        }
        e.blank();
        emit_which(e, d, which, who, props);
        e.blank();
        emit_struct(e, d, id, set, doc, props);
        e.blank();
        if robot {
            emit_robot_set(e, d, id, props);
        } else {
            emit_device_set(e, d, id, props);
        }
    }
    e.blank();
    let variant = |pos: usize| super::names::camel(&d.properties[sent[pos]].name);
    if let Some(&r) = sent.get(reply) {
        e.doc(format!(
            "`RRI_REPLY`: the property every robot message is answered with (`<{}>`).",
            d.properties[r].wire()
        ));
        e.line(format!(
            "pub const REPLY: DeviceProperty = DeviceProperty::{};",
            variant(reply)
        ));
    }
    e.doc("`RRI_PERIODIC`: device properties sent on their own schedules (ms).");
    let head = format!("pub const PERIODIC: [Periodic; {}] = ", periodic.len());
    let entry = |e: &mut Emitter, p: usize, ms: u32| {
        e.line(format!("property: DeviceProperty::{}.index(),", variant(p)));
        e.line(format!("period_ms: {ms},"));
    };
    match periodic {
        [] => e.line(format!("{head}[];")),
        [(p, ms)] => {
            e.open(format!("{head}[Periodic"));
            entry(e, *p, *ms);
            e.close("];");
        }
        many => {
            e.line(format!("{head}["));
            e.indent += 1;
            for &(p, ms) in many {
                e.open("Periodic");
                entry(e, p, ms);
                e.close(",");
            }
            e.indent -= 1;
            e.line("];");
        }
    }
}

/// The enum naming the properties of one direction.
fn emit_which(e: &mut Emitter, d: &Device, name: &str, who: &str, props: &[usize]) {
    e.doc(format!(
        "The properties {who}, in Configuration order; `index()` is how the cycle"
    ));
    e.doc("engine names them (`CycleInfo::arrived`, `CycleInfo::sending`).");
    e.line("#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]");
    e.open(format!("pub enum {name}"));
    for &i in props {
        let p = &d.properties[i];
        e.doc(format!("`{}`, travels as `<{}>`.", p.name, p.wire()));
        e.line(format!("{},", super::names::camel(&p.name)));
    }
    e.close("");
    e.blank();
    e.open(format!("impl {name}"));
    e.doc("Every one, in Configuration order.");
    let all: Vec<String> = props
        .iter()
        .map(|&i| format!("Self::{}", super::names::camel(&d.properties[i].name)))
        .collect();
    e.array(&format!("pub const ALL: [Self; {}] = ", all.len()), &all);
    e.blank();
    e.doc("Its position in [`Self::ALL`].");
    e.open("pub const fn index(self) -> usize");
    e.line("self as usize");
    e.close("");
    e.blank();
    e.doc("The property at `index`.");
    e.open("pub fn from_index(index: usize) -> Option<Self>");
    e.line("Self::ALL.get(index).copied()");
    e.close("");
    e.close("");
}

fn emit_struct(e: &mut Emitter, d: &Device, id: &Idents, name: &str, doc: &str, props: &[usize]) {
    e.doc(doc);
    e.line("#[derive(Clone, Debug, PartialEq)]");
    e.open(format!("pub struct {name}"));
    for &i in props {
        let p = &d.properties[i];
        e.doc(format!("`{}` (`<{}>`).", p.name, p.wire()));
        e.line(format!(
            "pub {}: {},",
            field_name(d, i),
            rust_type(id, p.ty, p.size)
        ));
    }
    e.close("");
    e.blank();
    let defaults: Vec<(String, String)> = props
        .iter()
        .map(|&i| {
            let p = &d.properties[i];
            (field_name(d, i), default_expr(id, p.ty, p.size))
        })
        .collect();
    crate::items::emit_defaults(e, name, "Every value", &defaults);
}

fn emit_robot_set(e: &mut Emitter, d: &Device, id: &Idents, props: &[usize]) {
    e.open("impl RobotSet for RobotProperties");
    e.line("const WIRE_NAMES: &'static [&'static str] = &RECEIVED;");
    e.line("const INFO: &'static [PropertyInfo] = &RECEIVED_INFO;");
    e.line("const MAX_RECEIVE_LEN: usize = MAX_RECEIVE_LEN;");
    e.blank();
    e.open("fn decode(&mut self, work: &mut Self, bytes: &[u8]) -> Result<(usize, Decoded), DecodeError>");
    // Each property decodes into its scratch copy and commits (M2).
    let decode_one = |e: &mut Emitter, pos: usize| {
        let i = props[pos];
        let f = field_name(d, i);
        e.line(format!(
            "let (last, scratch) = (&mut self.{f}, &mut work.{f});"
        ));
        e.line(format!(
            "let decoded = decode_committed::<{}>(last, scratch, bytes)?;",
            id.messages[i]
        ));
        e.line(format!("Ok(({pos}, decoded))"));
    };
    if props.len() == 1 {
        decode_one(e, 0);
    } else {
        e.line("// M1: the root element names the property; any other root is");
        e.line("// reported by the first one's decoder (WrongRoot, with its offset).");
        e.open("match root_name(bytes)");
        for pos in (1..props.len()).chain([0]) {
            let wire = d.properties[props[pos]].wire();
            if pos == 0 {
                e.open("_ =>");
            } else {
                e.open(format!("Some({}) =>", emit::bytes_lit(wire)));
            }
            decode_one(e, pos);
            e.close("");
        }
        e.close("");
    }
    e.close("");
    e.blank();
    e.open("fn field(&self, property: usize, index: usize) -> Option<FieldRef<'_>>");
    emit_dispatch(e, d, id, props, "_ => None,", |message, field| {
        format!("{message}::field(&self.{field}, index)")
    });
    e.close("");
    e.close("");
}

/// `match property { 0 => …, 1 => …, <fallback> }`: one arm per property,
/// built by `arm` from its message type and struct field.
fn emit_dispatch(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    props: &[usize],
    fallback: &str,
    arm: impl Fn(&str, &str) -> String,
) {
    e.open("match property");
    for (pos, &i) in props.iter().enumerate() {
        e.line(format!(
            "{pos} => {},",
            arm(&id.messages[i], &field_name(d, i))
        ));
    }
    e.line(fallback);
    e.close("");
}

fn emit_device_set(e: &mut Emitter, d: &Device, id: &Idents, props: &[usize]) {
    e.open("impl DeviceSet for DeviceProperties");
    e.line("const WIRE_NAMES: &'static [&'static str] = &SENT;");
    e.line("const INFO: &'static [PropertyInfo] = &SENT_INFO;");
    e.line("const MAX_SEND_LEN: usize = MAX_SEND_LEN;");
    e.blank();
    e.line("fn encode(");
    for arg in [
        "&self,",
        "property: usize,",
        "id: u32,",
        "ts: Time,",
        "format: Format,",
        "out: &mut [u8],",
    ] {
        e.line(format!("    {arg}"));
    }
    e.open(") -> Result<Encoded, BufferTooSmall>");
    emit_dispatch(
        e,
        d,
        id,
        props,
        "_ => Err(BufferTooSmall),",
        |message, field| format!("encode::<{message}>(&self.{field}, id, ts, format, out)"),
    );
    e.close("");
    e.blank();
    e.open("fn field_mut(&mut self, property: usize, index: usize) -> Option<FieldMut<'_>>");
    emit_dispatch(e, d, id, props, "_ => None,", |message, field| {
        format!("{message}::field_mut(&mut self.{field}, index)")
    });
    e.close("");
    e.close("");
}
