//! G2: Description.xml, the device's name, network, channel and supervision.

use crate::diag::{Rule, Sink};
use crate::model::{Channel, ControllerPort, Network, Protocol, Supervision};
use crate::names::{check_rapid_name, keyword, parse_bool};
use crate::xml::Element;

/// What Description.xml says, each part `None` when it was missing or wrong
/// (an error has then been reported).
#[derive(Debug, Default)]
pub struct Description {
    /// `<Name>`: must be the CDP client's name in Settings.xml (G2).
    pub name: Option<String>,
    /// `<Type>`: free text, informational.
    pub device_type: String,
    /// `<Class>`: free text, informational.
    pub class: String,
    /// `<Network Address Port?>`.
    pub network: Option<Network>,
    /// `<Network><Channel Type="Cyclic" Protocol Port>`.
    pub channel: Option<Channel>,
    /// `<Settings>`: `TimeOut`, `MaxLost`, `DryRun` (S1).
    pub supervision: Option<Supervision>,
}

/// Reads and checks Description.xml against the client name it must carry.
pub fn read(root: &Element<'_>, client: &str, sink: &mut Sink<'_>) -> Description {
    let mut d = Description::default();
    if root.name != "Description" {
        sink.error(
            Rule::G2,
            root.pos,
            format!("root element is <{}>, expected <Description>", root.name),
        );
        return d;
    }
    let mut seen: Vec<&str> = Vec::new();
    for child in &root.children {
        if seen.contains(&child.name) {
            sink.error(
                Rule::G2,
                child.pos,
                format!("<{}> appears twice in <Description>", child.name),
            );
            continue;
        }
        seen.push(child.name);
        match child.name {
            "Name" => d.name = read_name(child, client, sink),
            "Convention" => {
                let text = child.text();
                if keyword(&text, &[("CDP", ())]).is_none() {
                    sink.error(
                        Rule::G2,
                        child.text_pos(),
                        format!("Convention \"{text}\" is not supported (only \"CDP\")"),
                    );
                }
            }
            "Type" => d.device_type = child.text(),
            "Class" => d.class = child.text(),
            "Network" => {
                let (network, channel) = read_network(child, sink);
                d.network = network;
                d.channel = channel;
            }
            "Settings" => d.supervision = read_supervision(child, sink),
            other => sink.warning(
                Rule::G2,
                child.pos,
                format!("<{other}> in <Description> is not part of the manual's format; ignored"),
            ),
        }
    }
    for (required, what) in [
        ("Name", "the device name"),
        ("Convention", "\"CDP\""),
        ("Network", "address and channel"),
        ("Settings", "TimeOut, MaxLost and DryRun"),
    ] {
        if !seen.contains(&required) {
            sink.error(
                Rule::G2,
                root.pos,
                format!("<Description> has no <{required}> ({what})"),
            );
        }
    }
    d
}

fn read_name(el: &Element<'_>, client: &str, sink: &mut Sink<'_>) -> Option<String> {
    let name = el.text();
    let pos = el.text_pos();
    if !check_rapid_name(sink, "device name", &name, pos) {
        return None;
    }
    if name != client {
        sink.error(
            Rule::G2,
            pos,
            format!("device name \"{name}\" does not match the Settings.xml client \"{client}\""),
        );
        return None;
    }
    Some(name)
}

fn read_network(el: &Element<'_>, sink: &mut Sink<'_>) -> (Option<Network>, Option<Channel>) {
    let address = match el.attr("Address") {
        None => {
            sink.error(Rule::G2, el.pos, "<Network> without Address");
            None
        }
        Some(a) if a.value.trim().is_empty() || a.value.trim().contains(char::is_whitespace) => {
            sink.error(
                Rule::G2,
                a.pos,
                format!("Address \"{}\" is not an IP address or host name", a.value),
            );
            None
        }
        Some(a) => Some(a.value.trim().to_string()),
    };
    let port = match el.attr("Port") {
        None => Some(ControllerPort::Lan),
        Some(a) => {
            let found = ControllerPort::from_gsi(&a.value);
            if found.is_none() {
                sink.error(
                    Rule::G2,
                    a.pos,
                    format!(
                        "Port \"{}\" is not a controller port (Lan, Service, Axc1..Axc4)",
                        a.value
                    ),
                );
            }
            found
        }
    };
    let network = match (address, port) {
        (Some(address), Some(port)) => Some(Network { address, port }),
        _ => None,
    };

    let mut channels = el.children_named("Channel");
    let channel = match channels.next() {
        None => {
            sink.error(Rule::G2, el.pos, "<Network> has no <Channel>");
            None
        }
        Some(ch) => read_channel(ch, sink),
    };
    for extra in channels {
        sink.error(
            Rule::G2,
            extra.pos,
            "only one cyclic <Channel> per device is supported",
        );
    }
    (network, channel)
}

fn read_channel(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<Channel> {
    match el.attr("Type") {
        None => sink.error(
            Rule::G2,
            el.pos,
            "<Channel> without Type (expected \"Cyclic\")",
        ),
        Some(a) if keyword(&a.value, &[("Cyclic", ())]).is_none() => sink.error(
            Rule::G2,
            a.pos,
            format!(
                "channel Type \"{}\" is not supported (only \"Cyclic\")",
                a.value
            ),
        ),
        Some(_) => {}
    }
    let protocol = match el.attr("Protocol") {
        None => {
            sink.error(
                Rule::G2,
                el.pos,
                "<Channel> without Protocol (Udp, Tcp or HpUdp)",
            );
            None
        }
        Some(a) => {
            let found = Protocol::from_gsi(&a.value);
            if found.is_none() {
                sink.error(
                    Rule::G2,
                    a.pos,
                    format!("Protocol \"{}\" is not Udp, Tcp or HpUdp", a.value),
                );
            }
            found
        }
    };
    let port = match el.attr("Port") {
        None => {
            sink.error(Rule::G2, el.pos, "<Channel> without Port");
            None
        }
        Some(a) => match a.value.trim().parse::<u16>() {
            Ok(p) if p > 0 => Some(p),
            _ => {
                sink.error(
                    Rule::G2,
                    a.pos,
                    format!("channel Port \"{}\" is not a port number 1..65535", a.value),
                );
                None
            }
        },
    };
    Some(Channel {
        protocol: protocol?,
        port: port?,
    })
}

fn read_supervision(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<Supervision> {
    let mut timeout = None;
    let mut max_lost = None;
    let mut dry_run = None;
    for child in &el.children {
        let text = child.text();
        let pos = child.text_pos();
        match child.name {
            "TimeOut" => match text.parse::<u32>() {
                Ok(ms) if ms > 0 && ms % 4 == 0 => timeout = Some(ms),
                _ => sink.error(
                    Rule::G2,
                    pos,
                    format!("TimeOut \"{text}\" must be a positive number of milliseconds, a multiple of 4"),
                ),
            },
            "MaxLost" => match text.parse::<u32>() {
                Ok(n) => max_lost = Some(n),
                Err(_) => sink.error(
                    Rule::G2,
                    pos,
                    format!("MaxLost \"{text}\" is not a non-negative integer"),
                ),
            },
            "DryRun" => match parse_bool(&text) {
                Some(b) => dry_run = Some(b),
                None => sink.error(
                    Rule::G2,
                    pos,
                    format!("DryRun \"{text}\" is not a bool (true or false)"),
                ),
            },
            other => sink.warning(
                Rule::G2,
                child.pos,
                format!("<{other}> in <Settings> is not part of the manual's format; ignored"),
            ),
        }
    }
    let names = ["TimeOut", "MaxLost", "DryRun"];
    for name in names {
        if el.children_named(name).next().is_none() {
            sink.error(Rule::G2, el.pos, format!("<Settings> has no <{name}>"));
        }
    }
    Some(Supervision {
        timeout_ms: timeout?,
        max_lost: max_lost?,
        dry_run: dry_run?,
    })
}
