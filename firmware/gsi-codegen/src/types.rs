//! Type mapping: how a GSI type becomes a Rust type, a default value, a
//! `FieldRef`/`FieldMut` constructor and a line of documentation.

use crate::resolve::Idents;
use crate::sizes;
use gsi_config::{Device, Link, SimpleType, TypeRef};

/// The Rust type of a value of `ty`, as an array when `size` is given.
pub(crate) fn rust_type(id: &Idents, ty: TypeRef, size: Option<u16>) -> String {
    let base = match ty {
        TypeRef::Simple(SimpleType::Bool) => "bool".to_string(),
        TypeRef::Simple(SimpleType::Real) => "f32".to_string(),
        TypeRef::Simple(SimpleType::Time) => "Time".to_string(),
        TypeRef::Simple(SimpleType::String) => "RriString".to_string(),
        TypeRef::Simple(SimpleType::Frame) => "Frame".to_string(),
        TypeRef::Simple(SimpleType::Joints) => "Joints".to_string(),
        TypeRef::Enum(i) => id.enums[i].clone(),
        TypeRef::Record(i) => id.records[i].clone(),
    };
    match size {
        Some(n) => format!("[{base}; {n}]"),
        None => base,
    }
}

/// A `const` expression for the default value of `ty`.
pub(crate) fn default_expr(id: &Idents, ty: TypeRef, size: Option<u16>) -> String {
    let base = match ty {
        TypeRef::Simple(SimpleType::Bool) => "false".to_string(),
        TypeRef::Simple(SimpleType::Real) => "0.0".to_string(),
        TypeRef::Simple(SimpleType::Time) => "Time::ZERO".to_string(),
        TypeRef::Simple(SimpleType::String) => "RriString::new()".to_string(),
        TypeRef::Simple(SimpleType::Frame) => "Frame::ZERO".to_string(),
        TypeRef::Simple(SimpleType::Joints) => "[0.0; 6]".to_string(),
        TypeRef::Enum(i) => format!("{}::{}", id.enums[i], id.variants[i][0]),
        TypeRef::Record(i) => format!("{}::DEFAULT", id.records[i]),
    };
    match (size, ty) {
        (Some(n), TypeRef::Simple(SimpleType::String)) => format!("[const {{ {base} }}; {n}]"),
        (Some(n), _) => format!("[{base}; {n}]"),
        (None, _) => base,
    }
}

/// How a value travels, for doc comments.
pub(crate) fn wire_doc(wire: &str, ty: TypeRef, size: Option<u16>) -> String {
    match sizes::attribute_names(ty, size) {
        Some(attrs) if attrs.len() > 3 => format!(
            "`<{wire} {}=\"…\" … {}=\"…\"/>`",
            attrs[0],
            attrs[attrs.len() - 1]
        ),
        Some(attrs) => format!(
            "`<{wire} {}/>`",
            attrs
                .iter()
                .map(|a| format!("{a}=\"…\""))
                .collect::<Vec<_>>()
                .join(" ")
        ),
        None => format!("`<{wire}>…</{wire}>`"),
    }
}

pub(crate) fn type_doc(device: &Device, ty: TypeRef, size: Option<u16>, link: Link) -> String {
    let mut s = format!("`{}`", device.type_name(ty));
    if let Some(n) = size {
        s.push_str(&format!(" × {n}"));
    }
    if link == Link::Intern {
        s.push_str(", `Link=\"Intern\"` (filled by the controller)");
    }
    s
}

/// How generated code reaches a value.
#[derive(Clone, Copy)]
pub(crate) enum Value<'a> {
    /// A place expression (`data.x`).
    Place(&'a str),
    /// A reference to the value (`data` of a whole-message property).
    Ref(&'a str),
}

/// The `FieldRef` constructor for a value.
pub(crate) fn field_ref(ty: TypeRef, size: Option<u16>, v: Value<'_>) -> String {
    if let (TypeRef::Enum(_), None) = (ty, size) {
        // Method calls dereference by themselves.
        let (Value::Place(v) | Value::Ref(v)) = v;
        return format!("FieldRef::Enum({v}.wire())");
    }
    // Single bools, reals and times travel by value, the rest by reference.
    let by_value = size.is_none()
        && matches!(
            ty,
            TypeRef::Simple(SimpleType::Bool | SimpleType::Real | SimpleType::Time)
        );
    let arg = match (v, by_value) {
        (Value::Place(v), true) | (Value::Ref(v), false) => v.to_string(),
        (Value::Place(v), false) => format!("&{v}"),
        (Value::Ref(v), true) => format!("*{v}"),
    };
    format!("FieldRef::{}({arg})", variant(ty, size))
}

/// The `FieldMut` constructor for a value; `v` is a `&mut` expression.
pub(crate) fn field_mut(ty: TypeRef, size: Option<u16>, v: &str) -> String {
    format!("FieldMut::{}({v})", variant(ty, size))
}

pub(crate) fn variant(ty: TypeRef, size: Option<u16>) -> &'static str {
    match (ty, size) {
        (TypeRef::Simple(SimpleType::Bool), None) => "Bool",
        (TypeRef::Simple(SimpleType::Real), None) => "Real",
        (TypeRef::Simple(SimpleType::Time), None) => "Time",
        (TypeRef::Simple(SimpleType::String), None) => "Str",
        (TypeRef::Simple(SimpleType::Frame), _) => "Frame",
        (TypeRef::Simple(SimpleType::Joints), _) => "Joints",
        (TypeRef::Simple(SimpleType::Bool), Some(_)) => "Bools",
        (TypeRef::Simple(SimpleType::Real), Some(_)) => "Reals",
        (TypeRef::Simple(SimpleType::Time), Some(_)) => "Times",
        (TypeRef::Simple(SimpleType::String), Some(_)) => "Strs",
        (TypeRef::Enum(_), _) => "Enum",
        // Records are never fields or simple values (G3).
        (TypeRef::Record(_), _) => "Record",
    }
}
