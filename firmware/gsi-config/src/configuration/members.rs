//! The members of Configuration.xml: enums with their values, record
//! fields with their types and sizes, and properties (G3/G5).

use super::{expect, read_alias, read_link, required_name, stray_text};
use super::{Configuration, MAX_ARRAY_SIZE};
use crate::diag::{Rule, Sink};
use crate::model::{Direction, Enum, Field, Member, Property, SimpleType, TypeRef};
use crate::names::MAX_STRING_LEN;
use crate::xml::Element;

pub(super) fn read_enum(el: &Element<'_>, sink: &mut Sink<'_>) -> Option<Enum> {
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
pub(super) fn resolve_type(
    el: &Element<'_>,
    cfg: &Configuration,
    sink: &mut Sink<'_>,
) -> Option<TypeRef> {
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
pub(super) fn read_size(
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

pub(super) fn read_fields(
    rec: &Element<'_>,
    cfg: &Configuration,
    sink: &mut Sink<'_>,
) -> Vec<Field> {
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

pub(super) fn read_property(
    el: &Element<'_>,
    cfg: &Configuration,
    sink: &mut Sink<'_>,
) -> Option<Property> {
    let name = required_name(el, "property name", sink);
    let ty = resolve_type(el, cfg, sink);
    let size = read_size(el, ty, sink);
    let link = read_link(el, sink);
    let direction = match el.attr("Flag") {
        None => Some(Direction::default()),
        Some(a) => {
            let f = Direction::from_flag(&a.value);
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
        direction: direction?,
        link,
        alias,
        pos: el.pos,
    })
}
