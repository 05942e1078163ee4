//! Emission of the layout's constants: network, channel, supervision and
//! number settings, and the totals (buffer
//! sizes, the engine configuration) every buffer of the firmware is sized by.

use crate::emit::{str_lit, Emitter};
use crate::resolve::Idents;
use crate::sets;
use crate::Options;
use gsi_config::{Device, Property, TypeRef};
use rri_vocabulary::{parse_ipv4, Format};

pub(crate) fn emit_settings(e: &mut Emitter, d: &Device, f: Format, opts: &Options) {
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
    match parse_ipv4(&d.network.address) {
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
        "pub const CHANNEL_PROTOCOL: Protocol = Protocol::{};",
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

pub(crate) fn emit_totals(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    sizes: &[(usize, usize)],
    opts: &Options,
) {
    let received: Vec<usize> = (0..d.properties.len())
        .filter(|&i| d.properties[i].direction.robot_sends())
        .collect();
    let sent: Vec<usize> = (0..d.properties.len())
        .filter(|&i| d.properties[i].direction.device_sends())
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
    for (i, p) in d.properties.iter().enumerate() {
        // A property with `Flag="None"` travels neither way.
        if p.direction.robot_sends() || p.direction.device_sends() {
            emit_property_info(e, d, i, p);
        }
    }
    let info = |idx: &[usize]| -> Vec<String> { idx.iter().map(|i| format!("INFO_{i}")).collect() };
    e.doc("The properties the controller sends, with their fields, as the diagnostics");
    e.doc("describe them.");
    e.array(
        &format!(
            "pub const RECEIVED_INFO: [PropertyInfo; {}] = ",
            received.len()
        ),
        &info(&received),
    );
    e.doc("The properties the device sends, with their fields, as the diagnostics describe");
    e.doc("them.");
    e.array(
        &format!("pub const SENT_INFO: [PropertyInfo; {}] = ", sent.len()),
        &info(&sent),
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

/// A type as Configuration.xml names it: a record's or an enum's name, or
/// the G5 spelling, with `[N]` for an array.
fn type_text(d: &Device, ty: TypeRef, size: Option<u16>) -> String {
    let base = match ty {
        TypeRef::Simple(s) => s.as_str().to_string(),
        TypeRef::Enum(i) => d.enums[i].name.clone(),
        TypeRef::Record(i) => d.records[i].name.clone(),
    };
    match size {
        Some(n) => format!("{base}[{n}]"),
        None => base,
    }
}

/// `const INFO_<i>: PropertyInfo = …;` for property `i`, `p`.
fn emit_property_info(e: &mut Emitter, d: &Device, i: usize, p: &Property) {
    e.doc(format!("`{}` as the diagnostics describe it.", p.name));
    e.open(format!("const INFO_{i}: PropertyInfo = PropertyInfo"));
    e.line(format!("name: {},", str_lit(&p.name)));
    e.line(format!("wire: {},", str_lit(p.wire())));
    e.line(format!("ty: {},", str_lit(&type_text(d, p.ty, p.size))));
    let fields: Vec<String> = match p.ty {
        TypeRef::Record(r) => d.records[r]
            .fields
            .iter()
            .map(|f| {
                format!(
                    "({}, {})",
                    str_lit(f.wire()),
                    str_lit(&type_text(d, f.ty, f.size))
                )
            })
            .collect(),
        _ => Vec::new(),
    };
    // `fields: &[…],` as rustfmt lays out an array (see `Emitter::array`).
    let literal = format!("[{}]", fields.join(", "));
    if literal.len() <= 60 && e.indent * 4 + "fields: &".len() + literal.len() < 99 {
        e.line(format!("fields: &{literal},"));
    } else {
        e.line("fields: &[");
        for f in &fields {
            e.line(format!("    {f},"));
        }
        e.line("],");
    }
    e.close(";");
}
