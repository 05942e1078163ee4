//! Emission of the layout's types: an enum per `Enum`, a struct per
//! `Record` with its `Record` impl, and per property a message type with
//! its `MessageCodec`.

use crate::compiled::emit_decode_compiled;
use crate::emit::{self, str_lit, Emitter};
use crate::resolve::Idents;
use crate::sizes;
use crate::types::{default_expr, field_mut, field_ref, rust_type, type_doc, wire_doc, Value};
use gsi_config::{Device, Direction, Link, SimpleType, TypeRef};

pub(crate) fn emit_enum(e: &mut Emitter, id: &Idents, i: usize, en: &gsi_config::Enum) {
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

pub(crate) fn emit_record(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    i: usize,
    r: &gsi_config::Record,
) {
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
            wire_doc(f.wire(), f.ty, f.size)
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
        e.line(format!(
            "{j} => {},",
            field_ref(f.ty, f.size, Value::Place(&v))
        ));
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
pub(crate) fn emit_defaults(e: &mut Emitter, name: &str, what: &str, fields: &[(String, String)]) {
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

pub(crate) fn emit_message(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    i: usize,
    p: &gsi_config::Property,
    (enc, rcv): (usize, usize),
) {
    let name = &id.messages[i];
    let travel = match p.direction {
        Direction::None => "travels in neither direction",
        Direction::DeviceToRobot => "the device sends it to the controller",
        Direction::RobotToDevice => "the controller sends it to the device",
        Direction::Both => "it travels in both directions",
    };
    e.doc(format!(
        "Property `{}` of type {} (`Flag=\"{}\"`): {travel}.",
        p.name,
        type_doc(d, p.ty, p.size, p.link),
        p.direction.flag()
    ));
    if p.direction != Direction::None {
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
    // The variant's own name (Debug of a unit variant): the generated code
    // names the same `rri_vocabulary::Direction`, so a mismatch cannot build.
    e.line(format!(
        "const DIRECTION: Direction = Direction::{:?};",
        p.direction
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
            let value = field_ref(ty, p.size, Value::Ref("data"));
            e.line(format!("(index == 0).then_some({value})"));
            e.close("");
            e.blank();
            e.open("fn field_mut(data: &mut Self::Data, index: usize) -> Option<FieldMut<'_>>");
            let value = field_mut(ty, p.size, "data");
            e.line(format!("(index == 0).then_some({value})"));
            e.close("");
        }
    }
    if p.direction.robot_sends() {
        e.blank();
        emit_decode_compiled(e, d, id, p);
    }
    e.close("");
}
