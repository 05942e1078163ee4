//! Emission of the compiled decode path (`MessageCodec::decode_compiled`)
//! of each property the controller sends: the message as controllers
//! write it, one step per element or attribute, in Configuration.xml's
//! order, on the firmware's `codec::compiled::Scan`. It reads like the
//! message it expects, so a reviewer can hold it beside a captured
//! datagram; every byte it does not expect hands the datagram to the
//! general decoder.

use crate::emit::{bytes_lit, Emitter};
use crate::resolve::Idents;
use crate::sizes;
use gsi_config::{Device, SimpleType, TypeRef};

/// How the compiled path reads one value slot (a field, or a property's
/// own value).
enum Read {
    /// Element text (M3), read by the named function.
    Text(String),
    /// A frame's `X Y Z Rx Ry Rz` (M4).
    Frame,
    /// Joints' `J1..J6` (M4).
    Joints,
    /// An array, `X1..XN` (M4), read by the named `Scan` method (`reals`,
    /// `bools`, `times`, `strings`).
    Array(&'static str),
}

fn read(id: &Idents, ty: TypeRef, size: Option<u16>) -> Read {
    let text = |f: &str| format!("compiled::{f}");
    match (ty, size) {
        (TypeRef::Simple(SimpleType::Frame), _) => Read::Frame,
        (TypeRef::Simple(SimpleType::Joints), _) => Read::Joints,
        (TypeRef::Simple(SimpleType::Real), Some(_)) => Read::Array("reals"),
        (TypeRef::Simple(SimpleType::Bool), Some(_)) => Read::Array("bools"),
        (TypeRef::Simple(SimpleType::Time), Some(_)) => Read::Array("times"),
        (TypeRef::Simple(SimpleType::String), Some(_)) => Read::Array("strings"),
        (TypeRef::Simple(SimpleType::Bool), None) => Read::Text(text("boolean")),
        (TypeRef::Simple(SimpleType::Real), None) => Read::Text(text("real")),
        (TypeRef::Simple(SimpleType::Time), None) => Read::Text(text("time")),
        (TypeRef::Simple(SimpleType::String), None) => Read::Text(text("string")),
        (TypeRef::Enum(i), _) => Read::Text(format!("{}::from_wire", id.enums[i])),
        // Records are never fields or simple values (G3).
        (TypeRef::Record(_), _) => Read::Text(String::new()),
    }
}

/// The statement that reads a slot of attributes into `place` (a `&mut`
/// expression), ending at `close` for the IRC5's text form.
fn attributes(how: &Read, place: &str, close: &str) -> String {
    match how {
        Read::Frame => format!("s.frame({place}, {close})?;"),
        Read::Joints => format!("s.joints({place}, {close})?;"),
        Read::Array(f) => format!("s.{f}({place}, {close})?;"),
        Read::Text(_) => String::new(),
    }
}

/// Whether the compiled paths of `d` name the module `compiled` itself
/// (a value read by one of its functions), beside its `Scan`.
pub(crate) fn names_module(d: &Device, id: &Idents) -> bool {
    let uses = |ty: TypeRef, size: Option<u16>| match read(id, ty, size) {
        Read::Text(f) => f.starts_with("compiled::"),
        _ => false,
    };
    d.received().any(|p| match p.ty {
        TypeRef::Record(r) => d.records[r].fields.iter().any(|f| uses(f.ty, f.size)),
        ty => uses(ty, p.size),
    })
}

/// Emits `decode_compiled` for property `p` (inside its `impl MessageCodec`).
pub(crate) fn emit_decode_compiled(
    e: &mut Emitter,
    d: &Device,
    id: &Idents,
    p: &gsi_config::Property,
) {
    let w = p.wire();
    e.doc(format!(
        "The compiled decode path of `<{w}>` (`codec::compiled`): the message as controllers"
    ));
    e.doc("write it, each step named for what it matches; `None` at the first byte it does not");
    e.doc("expect, and the general decoder reads the datagram.");
    e.line("#[inline]");
    e.open("fn decode_compiled(bytes: &[u8], data: &mut Self::Data) -> Option<Decoded>");
    e.line(format!(
        "let (mut s, root) = Scan::root(bytes, {})?;",
        bytes_lit(&format!("<{w}"))
    ));
    let close = bytes_lit(&format!("</{w}>"));
    match p.ty {
        TypeRef::Record(r) => {
            e.line("s.body()?;");
            for (j, f) in d.records[r].fields.iter().enumerate() {
                let fw = f.wire();
                let place = format!("data.{}", id.fields[r][j]);
                let field_close = bytes_lit(&format!("</{fw}>"));
                let how = read(id, f.ty, f.size);
                match &how {
                    Read::Text(parse) => {
                        e.line(format!("// <{fw}>…</{fw}>"));
                        e.open(format!("if s.open({})", bytes_lit(&format!("<{fw}>"))));
                        assign(e, &place, &format!("s.text({field_close}, {parse})?;"));
                    }
                    _ => {
                        e.line(format!(
                            "// {}",
                            crate::types::wire_doc(fw, f.ty, f.size).trim_matches('`')
                        ));
                        e.open(format!("if s.open_attrs({})", bytes_lit(&format!("<{fw}"))));
                        e.line(attributes(&how, &format!("&mut {place}"), &field_close));
                    }
                }
                e.close(" else {");
                e.indent += 1;
                e.line("s.missing();");
                e.close("");
            }
            e.line(format!("s.end(root, {close})"));
        }
        ty => match read(id, ty, p.size) {
            Read::Text(parse) => {
                e.line("s.body()?;");
                assign(e, "*data", &format!("s.text({close}, {parse})?;"));
                e.line("s.finish(root)");
            }
            how => {
                debug_assert!(sizes::attribute_names(ty, p.size).is_some());
                e.line(attributes(&how, "data", &close));
                e.line("s.finish(root)");
            }
        },
    }
    e.close("");
}

/// `place = value;` laid out as rustfmt does: on one line when it fits in
/// 100 columns, else the value on the next line (one call, which fits).
fn assign(e: &mut Emitter, place: &str, value: &str) {
    let one = format!("{place} = {value}");
    if e.indent * 4 + one.len() <= 100 {
        e.line(one);
    } else {
        e.line(format!("{place} ="));
        e.indent += 1;
        e.line(value);
        e.indent -= 1;
    }
}
