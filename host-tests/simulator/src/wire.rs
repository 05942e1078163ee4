//! Messages built and checked from the GSI model at run time, so the
//! simulator can drive any RRI sensor, not only one built from this
//! repository. Independent of the firmware's codec on purpose: it is the
//! other side of the wire, and a second opinion in the tests.

use super::numbers::{g6, ts};
use gsi_config::{Device, Field, Property, SimpleType, TypeRef};
use rri_vocabulary::{parse_bool, FALSE, MAX_STRING_LEN, TRUE};
use std::fmt::Write;

/// One value to send.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Bool(bool),
    Real(f64),
    Time(f64),
    Str(String),
    /// Index of the enum member.
    Enum(usize),
    /// Frame (X Y Z Rx Ry Rz) or joints (J1..J6).
    Six([f64; 6]),
    Array(Vec<Value>),
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

fn scalar(device: &Device, ty: TypeRef, v: &Value) -> String {
    match v {
        Value::Bool(b) => String::from_utf8_lossy(if *b { TRUE } else { FALSE }).into(),
        Value::Real(x) => g6(*x),
        Value::Time(t) => ts(*t),
        Value::Str(s) => escape(s),
        Value::Enum(i) => match ty {
            TypeRef::Enum(e) => device.enums[e]
                .members
                .get(*i)
                .map(|m| escape(m.wire()))
                .unwrap_or_default(),
            _ => String::new(),
        },
        Value::Six(_) | Value::Array(_) => String::new(),
    }
}

use gsi_config::attribute_names as attributes;

/// One value slot: element text, or attributes (`"<name"` already written).
fn slot(out: &mut String, device: &Device, name: &str, ty: TypeRef, size: Option<u16>, v: &Value) {
    match (attributes(ty, size), v) {
        (Some(names), Value::Six(six)) => {
            let _ = write!(out, "<{name}");
            for (n, x) in names.iter().zip(six) {
                let _ = write!(out, " {n}=\"{}\"", g6(*x));
            }
            out.push_str("/>");
        }
        (Some(names), Value::Array(items)) => {
            let _ = write!(out, "<{name}");
            for (n, item) in names.iter().zip(items) {
                let _ = write!(out, " {n}=\"{}\"", scalar(device, ty, item));
            }
            out.push_str("/>");
        }
        _ => {
            let _ = write!(out, "<{name}>{}</{name}>", scalar(device, ty, v));
        }
    }
}

/// A robot message of `prop`: `<Root Id=".." Ts="..">` and every field,
/// values from `value(field)`. Compact, like the real controller.
pub fn robot_message(
    device: &Device,
    prop: &Property,
    id: u32,
    t: f64,
    mut value: impl FnMut(&Field) -> Value,
) -> String {
    let root = prop.wire();
    let mut out = format!("<{root} Id=\"{id}\" Ts=\"{}\">", ts(t));
    match prop.ty {
        TypeRef::Record(r) => {
            for f in &device.records[r].fields {
                let v = value(f);
                slot(&mut out, device, f.wire(), f.ty, f.size, &v);
            }
        }
        ty => {
            // A simple-typed property: the value on the root itself.
            let pseudo = Field {
                name: prop.name.clone(),
                ty,
                size: prop.size,
                link: prop.link,
                alias: None,
                pos: prop.pos,
            };
            let v = value(&pseudo);
            match attributes(ty, prop.size) {
                Some(_) => {
                    let mut attrs = String::new();
                    slot(&mut attrs, device, "", ty, prop.size, &v);
                    out = format!(
                        "<{root} Id=\"{id}\" Ts=\"{}\"{}",
                        ts(t),
                        attrs.trim_start_matches('<')
                    );
                    return out;
                }
                None => out.push_str(&scalar(device, ty, &v)),
            }
        }
    }
    let _ = write!(out, "</{root}>");
    out
}

/// What a reply said, once it passed every check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reply {
    pub id: u32,
    pub ts: f64,
}

/// One element of a reply: its name, attributes, text and children.
#[derive(Default)]
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) attrs: Vec<(String, String)>,
    pub(crate) text: String,
    pub(crate) children: Vec<Element>,
}

/// A small tree of the reply (std side: allocation is fine here).
pub(crate) fn tree(text: &str) -> Result<Element, String> {
    use xmlparser::{ElementEnd, Token, Tokenizer};
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    for token in Tokenizer::from(text.trim_start()) {
        match token.map_err(|e| format!("not well-formed XML: {e}"))? {
            Token::ElementStart { local, .. } => {
                if root.is_some() {
                    return Err("content after the root element".into());
                }
                if stack.len() >= 2 {
                    return Err(format!("<{}> nested deeper than a field", local.as_str()));
                }
                stack.push(Element {
                    name: local.as_str().into(),
                    ..Default::default()
                });
            }
            Token::Attribute { local, value, .. } => {
                if let Some(e) = stack.last_mut() {
                    e.attrs.push((local.as_str().into(), value.as_str().into()));
                }
            }
            Token::Text { text } => {
                if let Some(e) = stack.last_mut() {
                    e.text.push_str(text.as_str());
                }
            }
            Token::ElementEnd {
                end: ElementEnd::Open,
                ..
            } => {}
            Token::ElementEnd { .. } => {
                let done = stack.pop().ok_or("unbalanced end tag")?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(done),
                    None => root = Some(done),
                }
            }
            Token::DtdStart { .. } | Token::EmptyDtd { .. } => {
                return Err("DOCTYPE in a reply".into())
            }
            _ => {}
        }
    }
    root.ok_or_else(|| "truncated reply (no complete root element)".into())
}

fn check_scalar(device: &Device, ty: TypeRef, text: &str, what: &str) -> Result<(), String> {
    let t = text.trim();
    let ok = match ty {
        TypeRef::Simple(SimpleType::Real | SimpleType::Time) => {
            t.parse::<f64>().is_ok_and(f64::is_finite)
        }
        TypeRef::Simple(SimpleType::Bool) => parse_bool(t.as_bytes()).is_some(),
        // Escaped text: each of the 80 bytes may take a few more.
        TypeRef::Simple(SimpleType::String) => text.chars().count() <= MAX_STRING_LEN * 4,
        TypeRef::Enum(e) => {
            let decoded = t
                .replace("&amp;", "&")
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&quot;", "\"")
                .replace("&apos;", "'");
            device.enums[e].members.iter().any(|m| m.wire() == decoded)
        }
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{what}: `{text}` is not a valid {}",
            device.type_name(ty)
        ))
    }
}

fn check_attrs(
    device: &Device,
    ty: TypeRef,
    size: Option<u16>,
    attrs: &[(String, String)],
    what: &str,
) -> Result<(), String> {
    let names = attributes(ty, size).unwrap_or_default();
    let item = match ty {
        TypeRef::Simple(SimpleType::Frame | SimpleType::Joints) => {
            TypeRef::Simple(SimpleType::Real)
        }
        t => t,
    };
    for n in &names {
        let (_, v) = attrs
            .iter()
            .find(|(k, _)| k == n)
            .ok_or_else(|| format!("{what}: attribute {n} missing"))?;
        check_scalar(device, item, v, &format!("{what} {n}"))?;
    }
    Ok(())
}

/// The root element's name of a message, if it has one.
pub fn root_name(bytes: &[u8]) -> Option<String> {
    use xmlparser::{Token, Tokenizer};
    let text = std::str::from_utf8(bytes).ok()?;
    Tokenizer::from(text.trim_start()).find_map(|t| match t {
        Ok(Token::ElementStart { local, .. }) => Some(local.as_str().to_string()),
        _ => None,
    })
}

/// Checks a reply against `prop` of the layout: the root, `Id` and `Ts`,
/// and every field present, in its shape, with a valid value.
pub fn check_reply(device: &Device, prop: &Property, bytes: &[u8]) -> Result<Reply, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "reply is not UTF-8".to_string())?;
    let root = tree(text)?;
    if root.name != prop.wire() {
        return Err(format!("root <{}>, expected <{}>", root.name, prop.wire()));
    }
    let attr = |n: &str| {
        root.attrs
            .iter()
            .find(|(k, _)| k == n)
            .map(|(_, v)| v.as_str())
    };
    let id = attr("Id")
        .ok_or("no Id")?
        .trim()
        .parse::<u32>()
        .map_err(|_| "Id is not a u32".to_string())?;
    let ts = attr("Ts")
        .ok_or("no Ts")?
        .trim()
        .parse::<f64>()
        .map_err(|_| "Ts is not a number".to_string())?;
    match prop.ty {
        TypeRef::Record(r) => {
            let fields = &device.records[r].fields;
            for child in &root.children {
                if !fields.iter().any(|f| f.wire() == child.name) {
                    return Err(format!("unexpected element <{}>", child.name));
                }
            }
            for f in fields {
                let what = format!("<{}>", f.wire());
                let el = root
                    .children
                    .iter()
                    .find(|c| c.name == f.wire())
                    .ok_or_else(|| format!("field {what} missing"))?;
                match attributes(f.ty, f.size) {
                    Some(_) => check_attrs(device, f.ty, f.size, &el.attrs, &what)?,
                    None => check_scalar(device, f.ty, &el.text, &what)?,
                }
            }
        }
        ty => match attributes(ty, prop.size) {
            Some(_) => check_attrs(device, ty, prop.size, &root.attrs, "root")?,
            None => check_scalar(device, ty, &root.text, "root")?,
        },
    }
    Ok(Reply { id, ts })
}
