//! G3/G5: Configuration.xml, the enums, records and properties that define
//! the message layouts.

use crate::diag::{Pos, Rule, Sink};
use crate::model::{Enum, Field, Flag, Link, Member, Property, Record, SimpleType, TypeRef};
use crate::names::{check_rapid_name, is_xml_name, keyword, MAX_STRING_LEN};
use crate::xml::Element;

/// Largest `Size` of an array. RAPID allows more, but every element costs
/// bytes in a datagram that must fit one UDP payload; 1000 reals already
/// need about 45 kB.
pub const MAX_ARRAY_SIZE: u16 = 1000;

/// Most fields in one record: the decoder tracks which fields a message
/// carried in one 64-bit mask.
pub const MAX_FIELDS: usize = 64;

#[derive(Debug, Default)]
pub struct Configuration {
    pub enums: Vec<Enum>,
    pub records: Vec<Record>,
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
fn stray_text(el: &Element<'_>, sink: &mut Sink<'_>) {
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

fn expect(el: &Element<'_>, wanted: &str, parent: &str, sink: &mut Sink<'_>) -> bool {
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
fn name_pos(el: &Element<'_>) -> Pos {
    el.attr("Name").map_or(el.pos, |a| a.pos)
}

fn required_name(el: &Element<'_>, what: &str, sink: &mut Sink<'_>) -> Option<String> {
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
fn declare(cfg: &Configuration, name: &str, pos: Pos, sink: &mut Sink<'_>) -> bool {
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

fn read_link(el: &Element<'_>, sink: &mut Sink<'_>) -> Link {
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
fn read_alias(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<String> {
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

fn read_enum(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<Enum> {
    stray_text(el, sink);
    let name = required_name(el, "enum name", sink);
    let link = read_link(el, sink);
    let mut members: Vec<Member> = Vec::new();
    for m in &el.children {
        if !expect(m, "Member", "Enum", sink) {
            continue;
        }
        let Some(mname) = required_name(m, "member name", sink) else {
            continue;
        };
        let alias = match m.attr("Alias") {
            None => None,
            Some(a) => {
                // The alias travels as a string value (M6: 80 bytes).
                let n = a.value.len();
                if a.value.is_empty() || a.value.trim() != a.value || n > MAX_STRING_LEN {
                    sink.error(
                        Rule::G3,
                        a.pos,
                        format!("member Alias \"{}\" must be 1..{MAX_STRING_LEN} bytes without leading or trailing spaces", a.value),
                    );
                    continue;
                }
                Some(a.value.clone())
            }
        };
        let member = Member {
            name: mname,
            alias,
            pos: m.pos,
        };
        if let Some(prev) = members
            .iter()
            .find(|p| p.name.eq_ignore_ascii_case(&member.name))
        {
            sink.error(
                Rule::G3,
                m.pos,
                format!(
                    "member \"{}\" is declared twice (first at line {})",
                    member.name, prev.pos.line
                ),
            );
            continue;
        }
        if let Some(prev) = members.iter().find(|p| p.wire() == member.wire()) {
            sink.error(
                Rule::G3,
                m.pos,
                format!(
                    "members \"{}\" and \"{}\" would both travel as \"{}\"",
                    prev.name,
                    member.name,
                    member.wire()
                ),
            );
            continue;
        }
        members.push(member);
    }
    let name = name?;
    if members.is_empty() {
        sink.error(Rule::G3, el.pos, format!("enum \"{name}\" has no <Member>"));
        return None;
    }
    Some(Enum {
        name,
        link,
        members,
        pos: el.pos,
    })
}

/// Resolves a `Type` attribute (G5): a simple type, or an enum or record of
/// this file, all case-insensitive.
fn resolve_type(el: &Element<'_>, cfg: &Configuration, sink: &mut Sink<'_>) -> Option<TypeRef> {
    let Some(a) = el.attr("Type") else {
        sink.error(Rule::G3, el.pos, format!("<{}> without Type", el.name));
        return None;
    };
    let name = a.value.trim();
    if let Some(s) = SimpleType::from_name(name) {
        return Some(TypeRef::Simple(s));
    }
    if let Some(i) = cfg
        .enums
        .iter()
        .position(|e| e.name.eq_ignore_ascii_case(name))
    {
        return Some(TypeRef::Enum(i));
    }
    if let Some(i) = cfg
        .records
        .iter()
        .position(|r| r.name.eq_ignore_ascii_case(name))
    {
        return Some(TypeRef::Record(i));
    }
    sink.error(
        Rule::G5,
        a.pos,
        format!("unknown type \"{name}\" (bool, real/num, time, string, frame/pose, joints/joint, or an Enum or Record of this file)"),
    );
    None
}

/// `Size`: only single-value simple types may be arrays.
fn read_size(
    el: &Element<'_>,
    ty: Option<TypeRef>,
    sink: &mut Sink<'_>,
) -> Result<Option<u16>, ()> {
    let Some(a) = el.attr("Size") else {
        return Ok(None);
    };
    let n = match a.value.trim().parse::<u16>() {
        Ok(n) if (1..=MAX_ARRAY_SIZE).contains(&n) => n,
        _ => {
            sink.error(
                Rule::G3,
                a.pos,
                format!(
                    "Size \"{}\" must be an integer 1..{MAX_ARRAY_SIZE}",
                    a.value
                ),
            );
            return Err(());
        }
    };
    match ty {
        Some(TypeRef::Simple(s)) if s.can_be_array() => Ok(Some(n)),
        Some(TypeRef::Simple(s)) => {
            sink.error(
                Rule::G3,
                a.pos,
                format!(
                    "Size on a {} : only bool, real, time and string can be arrays",
                    s.as_str()
                ),
            );
            Err(())
        }
        Some(TypeRef::Enum(_) | TypeRef::Record(_)) => {
            sink.error(
                Rule::G3,
                a.pos,
                "Size on an enum or record type: only basic types can be arrays",
            );
            Err(())
        }
        None => Err(()),
    }
}

fn read_fields(rec: &Element<'_>, cfg: &Configuration, sink: &mut Sink<'_>) -> Vec<Field> {
    let mut fields: Vec<Field> = Vec::new();
    for el in &rec.children {
        if !expect(el, "Field", "Record", sink) {
            continue;
        }
        let name = required_name(el, "field name", sink);
        let ty = resolve_type(el, cfg, sink);
        if let Some(TypeRef::Record(i)) = ty {
            let t = el.attr("Type").map_or(el.pos, |a| a.pos);
            sink.error(
                Rule::G3,
                t,
                format!(
                    "field of record type \"{}\": records cannot be nested",
                    cfg.records[i].name
                ),
            );
            continue;
        }
        let size = read_size(el, ty, sink);
        let link = read_link(el, sink);
        let alias = read_alias(el, sink);
        let (Some(name), Some(ty), Ok(size)) = (name, ty, size) else {
            continue;
        };
        let field = Field {
            name,
            ty,
            size,
            link,
            alias,
            pos: el.pos,
        };
        if let Some(prev) = fields
            .iter()
            .find(|f| f.name.eq_ignore_ascii_case(&field.name))
        {
            sink.error(
                Rule::G3,
                el.pos,
                format!(
                    "field \"{}\" is declared twice in this record (first at line {})",
                    field.name, prev.pos.line
                ),
            );
            continue;
        }
        if let Some(prev) = fields.iter().find(|f| f.wire() == field.wire()) {
            sink.error(
                Rule::G3,
                el.pos,
                format!(
                    "fields \"{}\" and \"{}\" would both travel as <{}>",
                    prev.name,
                    field.name,
                    field.wire()
                ),
            );
            continue;
        }
        fields.push(field);
    }
    fields
}

fn read_property(el: &Element<'_>, cfg: &Configuration, sink: &mut Sink<'_>) -> Option<Property> {
    let name = required_name(el, "property name", sink);
    let ty = resolve_type(el, cfg, sink);
    let size = read_size(el, ty, sink);
    let link = read_link(el, sink);
    let flag = match el.attr("Flag") {
        None => Some(Flag::ReadWrite),
        Some(a) => {
            let table = [
                ("None", Flag::None),
                ("ReadOnly", Flag::ReadOnly),
                ("WriteOnly", Flag::WriteOnly),
                ("ReadWrite", Flag::ReadWrite),
            ];
            let f = keyword(&a.value, &table);
            if f.is_none() {
                sink.error(
                    Rule::G3,
                    a.pos,
                    format!(
                        "Flag \"{}\" is not one of None, ReadOnly, WriteOnly, ReadWrite",
                        a.value
                    ),
                );
            }
            f
        }
    };
    let alias = read_alias(el, sink);
    Some(Property {
        name: name?,
        ty: ty?,
        size: size.ok()?,
        flag: flag?,
        link,
        alias,
        pos: el.pos,
    })
}
