//! G3/G5: Configuration.xml, the enums, records and properties that define
//! the message layouts.

use crate::diag::{Pos, Rule, Sink};
use crate::model::{Enum, Link, Property, Record, SimpleType};
use crate::names::{check_rapid_name, is_xml_name, keyword};
use crate::xml::Element;
use members::{read_enum, read_fields, read_property};

mod members;

/// Largest `Size` of an array. RAPID allows more, but every element costs
/// bytes in a datagram that must fit one UDP payload; 1000 reals already
/// need about 45 kB.
pub const MAX_ARRAY_SIZE: u16 = 1000;

/// Most fields in one record: the decoder tracks which fields a message
/// carried in one 64-bit mask.
pub use rri_vocabulary::MAX_FIELDS;

/// What Configuration.xml declares (G3), in file order. An entry that could
/// not be read is left out; an error has then been reported.
#[derive(Debug, Default)]
pub struct Configuration {
    /// `<Enums><Enum>`; [`crate::TypeRef::Enum`] indexes this list.
    pub enums: Vec<Enum>,
    /// `<Records><Record>`; [`crate::TypeRef::Record`] indexes this list.
    pub records: Vec<Record>,
    /// `<Properties><Property>`, names and wire names unique.
    pub properties: Vec<Property>,
}

/// Reads and checks Configuration.xml. Keeps going after errors so every
/// problem of the file is reported in one build.
pub fn read(root: &Element<'_>, sink: &mut Sink<'_>) -> Configuration {
    let mut cfg = Configuration::default();
    if root.name != "Configuration" {
        sink.error(
            Rule::G3,
            root.pos,
            format!("root element is <{}>, expected <Configuration>", root.name),
        );
        return cfg;
    }
    stray_text(root, sink);
    let mut sections: Vec<&str> = Vec::new();
    for section in &root.children {
        if sections.contains(&section.name) {
            sink.error(
                Rule::G3,
                section.pos,
                format!("<{}> appears twice in <Configuration>", section.name),
            );
            continue;
        }
        sections.push(section.name);
        match section.name {
            "Enums" | "Records" | "Properties" => stray_text(section, sink),
            other => sink.error(
                Rule::G3,
                section.pos,
                format!("unknown element <{other}> in <Configuration> (expected <Enums>, <Records> or <Properties>)"),
            ),
        }
    }
    let section = |name: &str| root.children.iter().find(|c| c.name == name);

    // Pass 1: declare types, so fields and properties can name any of them.
    let mut enum_els = Vec::new();
    if let Some(enums) = section("Enums") {
        for el in &enums.children {
            if expect(el, "Enum", "Enums", sink) {
                if let Some(e) = read_enum(el, sink) {
                    if declare(&cfg, &e.name, name_pos(el), sink) {
                        cfg.enums.push(e);
                    }
                }
                enum_els.push(el);
            }
        }
    }
    let mut record_els = Vec::new();
    if let Some(records) = section("Records") {
        for el in &records.children {
            if !expect(el, "Record", "Records", sink) {
                continue;
            }
            stray_text(el, sink);
            let Some(name) = required_name(el, "record name", sink) else {
                continue;
            };
            let alias = read_alias(el, sink);
            if declare(&cfg, &name, name_pos(el), sink) {
                cfg.records.push(Record {
                    name,
                    alias,
                    fields: Vec::new(),
                    pos: el.pos,
                });
                record_els.push((cfg.records.len() - 1, el));
            }
        }
    }

    // Pass 2: fields and properties, now that every type name is known.
    for (index, el) in record_els {
        let fields = read_fields(el, &cfg, sink);
        if fields.len() > MAX_FIELDS {
            sink.error(
                Rule::G3,
                el.pos,
                format!(
                    "record \"{}\" has {} fields; the firmware supports at most {MAX_FIELDS}",
                    cfg.records[index].name,
                    fields.len()
                ),
            );
        }
        if fields.is_empty() {
            sink.error(
                Rule::G3,
                el.pos,
                format!("record \"{}\" has no <Field>", cfg.records[index].name),
            );
        }
        cfg.records[index].fields = fields;
    }
    match section("Properties") {
        None => sink.error(
            Rule::G3,
            root.pos,
            "<Configuration> has no <Properties>: nothing can be exchanged",
        ),
        Some(props) => {
            let mut properties: Vec<Property> = Vec::new();
            for el in &props.children {
                if !expect(el, "Property", "Properties", sink) {
                    continue;
                }
                let Some(p) = read_property(el, &cfg, sink) else {
                    continue;
                };
                if let Some(prev) = properties
                    .iter()
                    .find(|q| q.name.eq_ignore_ascii_case(&p.name))
                {
                    sink.error(
                        Rule::G3,
                        p.pos,
                        format!(
                            "property \"{}\" is declared twice (first at line {})",
                            p.name, prev.pos.line
                        ),
                    );
                    continue;
                }
                if let Some(prev) = properties.iter().find(|q| q.wire() == p.wire()) {
                    sink.error(
                        Rule::G3,
                        p.pos,
                        format!(
                            "properties \"{}\" and \"{}\" would both travel as <{}>",
                            prev.name,
                            p.name,
                            p.wire()
                        ),
                    );
                    continue;
                }
                properties.push(p);
            }
            if properties.is_empty() && props.children.is_empty() {
                sink.error(Rule::G3, props.pos, "<Properties> has no <Property>");
            }
            cfg.properties = properties;
        }
    }
    cfg
}

/// G6: the manual's example has a stray `Alias="RobMode" />` line inside
/// `<Record>`; text in a container element is ignored with a warning.
pub(super) fn stray_text(el: &Element<'_>, sink: &mut Sink<'_>) {
    for t in &el.texts {
        let text = t.text.trim();
        if !text.is_empty() {
            sink.warning(
                Rule::G6,
                t.pos,
                format!("stray text `{text}` inside <{}> ignored", el.name),
            );
        }
    }
}

pub(super) fn expect(el: &Element<'_>, wanted: &str, parent: &str, sink: &mut Sink<'_>) -> bool {
    if el.name == wanted {
        return true;
    }
    sink.error(
        Rule::G3,
        el.pos,
        format!(
            "unknown element <{}> in <{parent}> (expected <{wanted}>)",
            el.name
        ),
    );
    false
}

/// Where the `Name` attribute is (the element when it has none).
pub(super) fn name_pos(el: &Element<'_>) -> Pos {
    el.attr("Name").map_or(el.pos, |a| a.pos)
}

pub(super) fn required_name(el: &Element<'_>, what: &str, sink: &mut Sink<'_>) -> Option<String> {
    match el.attr("Name") {
        None => {
            sink.error(Rule::G3, el.pos, format!("<{}> without Name", el.name));
            None
        }
        Some(a) => check_rapid_name(sink, what, &a.value, a.pos).then(|| a.value.clone()),
    }
}

/// Enum and record names share one namespace with each other and with the
/// simple types (G5), case-insensitively as in RAPID.
pub(super) fn declare(cfg: &Configuration, name: &str, pos: Pos, sink: &mut Sink<'_>) -> bool {
    if SimpleType::from_name(name).is_some() {
        sink.error(
            Rule::G5,
            pos,
            format!("type \"{name}\" has the name of a simple type"),
        );
        return false;
    }
    let prev = cfg
        .enums
        .iter()
        .map(|e| (&e.name, e.pos))
        .chain(cfg.records.iter().map(|r| (&r.name, r.pos)))
        .find(|(n, _)| n.eq_ignore_ascii_case(name));
    if let Some((_, p)) = prev {
        sink.error(
            Rule::G3,
            pos,
            format!(
                "type \"{name}\" is declared twice (first at line {})",
                p.line
            ),
        );
        return false;
    }
    true
}

pub(super) fn read_link(el: &Element<'_>, sink: &mut Sink<'_>) -> Link {
    match el.attr("Link") {
        None => Link::Rapid,
        Some(a) => keyword(&a.value, &[("Intern", Link::Intern)]).unwrap_or_else(|| {
            sink.error(
                Rule::G3,
                a.pos,
                format!("Link \"{}\" is not valid (only \"Intern\")", a.value),
            );
            Link::Rapid
        }),
    }
}

/// Record, field and property aliases become element names on the wire.
pub(super) fn read_alias(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<String> {
    let a = el.attr("Alias")?;
    if is_xml_name(&a.value) {
        Some(a.value.clone())
    } else {
        sink.error(
            Rule::G3,
            a.pos,
            format!(
                "Alias \"{}\" cannot be an XML element name (ASCII letter or '_' first, then letters, digits, '_', '-', '.')",
                a.value
            ),
        );
        None
    }
}
