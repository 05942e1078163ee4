//! G1: Settings.xml, the list of CDP clients (one per device).

use crate::diag::{Pos, Rule, Sink};
use crate::names::{check_rapid_name, keyword};
use crate::xml::Element;

/// One `Client` entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Client {
    /// `Name`: the device name and the name of its sub-folder (G1), a RAPID
    /// name (G4).
    pub name: String,
    /// Where the `Name` attribute is.
    pub pos: Pos,
}

/// The CDP clients of Settings.xml, in file order, plus where the list is
/// (for errors about choosing a device).
#[derive(Clone, Debug, Default)]
pub struct Settings {
    /// `<Clients><Client>` entries with a valid name, unique case-insensitively.
    pub clients: Vec<Client>,
    /// Where `<Clients>` is (the root element when there is none).
    pub pos: Pos,
}

/// Reads and checks Settings.xml (G1): the `<Client Convention="CDP" Name>`
/// entries of `<Clients>`; `<Servers>` is ignored, other elements with a
/// warning.
pub fn read(root: &Element<'_>, sink: &mut Sink<'_>) -> Settings {
    let mut settings = Settings {
        clients: Vec::new(),
        pos: root.pos,
    };
    if root.name != "Settings" {
        sink.error(
            Rule::G1,
            root.pos,
            format!("root element is <{}>, expected <Settings>", root.name),
        );
        return settings;
    }
    for child in &root.children {
        match child.name {
            "Clients" => {
                settings.pos = child.pos;
                for client in &child.children {
                    if client.name != "Client" {
                        sink.warning(
                            Rule::G1,
                            client.pos,
                            format!("<{}> in <Clients> ignored (expected <Client>)", client.name),
                        );
                        continue;
                    }
                    read_client(client, sink, &mut settings.clients);
                }
            }
            "Servers" => {}
            other => sink.warning(
                Rule::G1,
                child.pos,
                format!("<{other}> in <Settings> ignored (expected <Clients> or <Servers>)"),
            ),
        }
    }
    settings
}

fn read_client(el: &Element<'_>, sink: &mut Sink<'_>, clients: &mut Vec<Client>) {
    match el.attr("Convention") {
        None => sink.error(
            Rule::G1,
            el.pos,
            "<Client> without Convention (expected \"CDP\")",
        ),
        Some(a) if keyword(&a.value, &[("CDP", ())]).is_none() => sink.error(
            Rule::G1,
            a.pos,
            format!("Convention \"{}\" is not supported (only \"CDP\")", a.value),
        ),
        Some(_) => {}
    }
    let Some(name) = el.attr("Name") else {
        sink.error(Rule::G1, el.pos, "<Client> without Name");
        return;
    };
    if !check_rapid_name(sink, "client name", &name.value, name.pos) {
        return;
    }
    if let Some(first) = clients
        .iter()
        .find(|c| c.name.eq_ignore_ascii_case(&name.value))
    {
        sink.error(
            Rule::G1,
            name.pos,
            format!(
                "client \"{}\" is listed twice (first at line {})",
                name.value, first.pos.line
            ),
        );
        return;
    }
    clients.push(Client {
        name: name.value.clone(),
        pos: name.pos,
    });
}

/// Picks the device to build: the one named, or the only client there is.
pub fn choose<'s>(
    settings: &'s Settings,
    wanted: Option<&str>,
    sink: &mut Sink<'_>,
) -> Option<&'s Client> {
    let list = || {
        settings
            .clients
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    match wanted {
        Some(name) => {
            let found = settings.clients.iter().find(|c| c.name == name);
            if found.is_none() {
                let known = if settings.clients.is_empty() {
                    "none".to_string()
                } else {
                    list()
                };
                sink.error(
                    Rule::G1,
                    settings.pos,
                    format!(
                        "device \"{name}\" is not a CDP client of Settings.xml (clients: {known})"
                    ),
                );
            }
            found
        }
        None => match settings.clients.len() {
            0 => {
                sink.error(Rule::G1, settings.pos, "Settings.xml lists no CDP client");
                None
            }
            1 => settings.clients.first(),
            n => {
                sink.error(
                    Rule::G1,
                    settings.pos,
                    format!(
                        "Settings.xml lists {n} CDP clients ({}); choose one (RRI_DEVICE=<name> for the firmware build, --device <name> for the robot simulator)",
                        list()
                    ),
                );
                None
            }
        },
    }
}
