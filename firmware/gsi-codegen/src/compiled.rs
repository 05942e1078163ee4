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
use gsi_config::{Device, Diagnostic, Rule, SimpleType, TypeRef};

/// How the compiled path reads one value slot (a field, or a property's
/// own value).
enum Read {
    /// Element text (M3), read by [`Parse`].
    Text(Parse),
    /// Attributes (M4).
    Attrs(Attrs),
}

/// A slot read from attributes (M4).
enum Attrs {
    /// A frame's `X Y Z Rx Ry Rz`.
    Frame,
    /// Joints' `J1..J6`.
    Joints,
    /// An array, `X1..XN`, read by the named `Scan` method (`reals`,
    /// `bools`, `times`, `strings`).
    Array(&'static str),
}

/// What parses an element's text: a function of the firmware's
/// `codec::compiled`, or an enum's generated `from_wire`. A path is only
/// written out when the code is emitted ([`Parse::path`]).
enum Parse {
    /// `compiled::<name>`.
    Compiled(&'static str),
    /// `<the enum's Rust name>::from_wire`, by index into `Device::enums`.
    Enum(usize),
}

impl Parse {
    fn path(&self, id: &Idents) -> String {
        match self {
            Parse::Compiled(f) => format!("compiled::{f}"),
            Parse::Enum(i) => format!("{}::from_wire", id.enums[*i]),
        }
    }
}

/// How a slot of type `ty` (an array of `size` when `Some`) is read;
/// `None` for a record, which is never a field or a simple value (records
/// do not nest, G3): [`refuse_nested_records`] makes that a build error
/// before anything is emitted.
fn read(ty: TypeRef, size: Option<u16>) -> Option<Read> {
    Some(match (ty, size) {
        (TypeRef::Simple(SimpleType::Frame), _) => Read::Attrs(Attrs::Frame),
        (TypeRef::Simple(SimpleType::Joints), _) => Read::Attrs(Attrs::Joints),
        (TypeRef::Simple(SimpleType::Real), Some(_)) => Read::Attrs(Attrs::Array("reals")),
        (TypeRef::Simple(SimpleType::Bool), Some(_)) => Read::Attrs(Attrs::Array("bools")),
        (TypeRef::Simple(SimpleType::Time), Some(_)) => Read::Attrs(Attrs::Array("times")),
        (TypeRef::Simple(SimpleType::String), Some(_)) => Read::Attrs(Attrs::Array("strings")),
        (TypeRef::Simple(SimpleType::Bool), None) => Read::Text(Parse::Compiled("boolean")),
        (TypeRef::Simple(SimpleType::Real), None) => Read::Text(Parse::Compiled("real")),
        (TypeRef::Simple(SimpleType::Time), None) => Read::Text(Parse::Compiled("time")),
        (TypeRef::Simple(SimpleType::String), None) => Read::Text(Parse::Compiled("string")),
        (TypeRef::Enum(i), _) => Read::Text(Parse::Enum(i)),
        (TypeRef::Record(_), _) => return None,
    })
}

/// A field whose type is a record: gsi-config refuses one (G3), and a
/// model built otherwise must not reach emission. One diagnostic per such
/// field, at its `<Field>` tag.
pub(crate) fn refuse_nested_records(d: &Device) -> Vec<Diagnostic> {
    d.records
        .iter()
        .flat_map(|r| r.fields.iter().map(move |f| (r, f)))
        .filter(|(_, f)| matches!(f.ty, TypeRef::Record(_)))
        .map(|(r, f)| {
            crate::resolve::diag(
                d,
                f.pos,
                Rule::G3,
                format!(
                    "field `{}` of record `{}` is itself a record: records do not nest, so no message can carry it",
                    f.name, r.name
                ),
            )
        })
        .collect()
}

/// The statement that reads a slot of attributes into `place` (a `&mut`
/// expression), ending at `close` for the IRC5's text form.
fn attributes(how: &Attrs, place: &str, close: &str) -> String {
    match how {
        Attrs::Frame => format!("s.frame({place}, {close})?;"),
        Attrs::Joints => format!("s.joints({place}, {close})?;"),
        Attrs::Array(f) => format!("s.{f}({place}, {close})?;"),
    }
}

/// Whether the compiled paths of `d` name the module `compiled` itself
/// (a value read by one of its functions), beside its `Scan`.
pub(crate) fn names_module(d: &Device) -> bool {
    let uses = |ty: TypeRef, size: Option<u16>| {
        matches!(read(ty, size), Some(Read::Text(Parse::Compiled(_))))
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
    // The signature as rustfmt breaks it (over 100 columns on one line).
    e.line("fn decode_compiled_into(");
    for param in [
        "bytes: &[u8],",
        "data: &mut Self::Data,",
        "hand_over: &mut HandOver,",
    ] {
        e.line(format!("    {param}"));
    }
    e.open(") -> Option<Decoded>");
    e.line(format!(
        "let (mut s, root) = Scan::root(bytes, {}, hand_over)?;",
        bytes_lit(&format!("<{w}"))
    ));
    let close = bytes_lit(&format!("</{w}>"));
    match p.ty {
        TypeRef::Record(r) => {
            e.line("s.fields()?;");
            for (j, f) in d.records[r].fields.iter().enumerate() {
                let fw = f.wire();
                let place = format!("data.{}", id.fields[r][j]);
                let field_close = bytes_lit(&format!("</{fw}>"));
                let Some(how) = read(f.ty, f.size) else {
                    // `generate` refused it first (`refuse_nested_records`).
                    e.line("compile_error!(\"a record-typed field (G3)\");");
                    continue;
                };
                match &how {
                    Read::Text(parse) => {
                        let parse = parse.path(id);
                        e.line(format!("// <{fw}>…</{fw}>"));
                        e.open(format!("if s.open({})", bytes_lit(&format!("<{fw}>"))));
                        assign(e, &place, &format!("s.text({field_close}, {parse})?;"));
                    }
                    Read::Attrs(attrs) => {
                        e.line(format!(
                            "// {}",
                            crate::types::wire_doc(fw, f.ty, f.size).trim_matches('`')
                        ));
                        e.open(format!("if s.open_attrs({})", bytes_lit(&format!("<{fw}"))));
                        e.line(attributes(attrs, &format!("&mut {place}"), &field_close));
                    }
                }
                e.line(format!("s.field_end({j});"));
                e.close(" else {");
                e.indent += 1;
                e.line("s.missing();");
                e.close("");
            }
            e.line(format!("s.end(root, {close})"));
        }
        ty => match read(ty, p.size) {
            None => e.line("compile_error!(\"a record-typed value (G3)\");"),
            Some(Read::Text(parse)) => {
                e.line("s.body()?;");
                let parse = parse.path(id);
                assign(e, "*data", &format!("s.text({close}, {parse})?;"));
                e.line("s.finish(root)");
            }
            Some(Read::Attrs(attrs)) => {
                debug_assert!(sizes::attribute_names(ty, p.size).is_some());
                e.line(attributes(&attrs, "data", &close));
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The manual's example, as the build loads it.
    fn manual() -> Device {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../gsi/GSI");
        gsi_config::load(&dir, None)
            .expect("the manual's example loads")
            .device
    }

    /// A record-typed field (a model gsi-config would refuse, built
    /// otherwise) is a build error at its `<Field>` tag, not generated
    /// code that reads it with nothing (`s.text(close, )`).
    #[test]
    fn a_record_typed_field_is_a_build_error_naming_its_position() {
        let mut d = manual();
        let (r, f) = d
            .records
            .iter()
            .enumerate()
            .find_map(|(r, rec)| (!rec.fields.is_empty()).then_some((r, 0)))
            .expect("the example has a record with fields");
        d.records[r].fields[f].ty = TypeRef::Record(r);
        let pos = d.records[r].fields[f].pos;
        let errors = crate::generate(&d, &crate::Options::default())
            .expect_err("a record-typed field must not generate");
        let e = errors
            .iter()
            .find(|e| e.message.contains("is itself a record"))
            .expect("the nested record is named");
        assert_eq!((e.rule, e.pos), (Rule::G3, pos));
        assert!(pos.line > 0, "a real position: {pos:?}");
        assert!(
            e.file.ends_with("Configuration.xml"),
            "{}",
            e.file.display()
        );
        // The manual's example as it is still generates.
        assert!(crate::generate(&manual(), &crate::Options::default()).is_ok());
    }

    #[test]
    fn text_is_parsed_by_a_typed_path() {
        let id_free = |ty, size| match read(ty, size) {
            Some(Read::Text(Parse::Compiled(f))) => Some(f),
            _ => None,
        };
        assert_eq!(
            id_free(TypeRef::Simple(SimpleType::Real), None),
            Some("real")
        );
        assert_eq!(id_free(TypeRef::Simple(SimpleType::Real), Some(3)), None);
        assert!(matches!(
            read(TypeRef::Enum(2), None),
            Some(Read::Text(Parse::Enum(2)))
        ));
        assert!(read(TypeRef::Record(0), None).is_none());
    }
}
