//! `--show FIELD,…`: the reply's values as the controller receives them,
//! so an integrator checks their sensor's data without a packet capture:
//! printed live (throttled), as CSV columns (`--show-csv`) and plotted over
//! time (`--show-plot`).
//!
//! A FIELD names a slot of the reply property as Configuration.xml does:
//! a field by its `Name` or `Alias` (any case, G4), optionally after the
//! property's name (`SensData.AppData.X1`), and a component of a
//! multi-value field (M4: `X1..XN` of an array, `X Y Z Rx Ry Rz` of a
//! frame, `J1..J6` of joints); a multi-value field without a component
//! shows every component. The reply is parsed a second time only when
//! `--show` is given: without it the run's hot path is unchanged.

use crate::record::Cycle;
pub use crate::shown::{Cell, Shown};
use crate::wire::{self, Element};
use gsi_config::{attribute_names, Device, Property, SimpleType, TypeRef};
use std::io::{self, Write};
use std::path::Path;

/// How a slot's text becomes a [`Cell`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Num,
    Bool,
    Text,
}

/// One shown column: where in the reply its value is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Column {
    /// `Field` or `Field.Component`, with the wire spellings (M2, M4):
    /// the CSV header and the plot's caption.
    pub label: String,
    /// The field's element (M2); `None`: the root (a simple-typed
    /// property, M1).
    element: Option<String>,
    /// The attribute of a multi-value slot (M4); `None`: the text (M3).
    attribute: Option<String>,
    kind: Kind,
    /// Plotted (a number or a bool).
    pub numeric: bool,
}

/// The resolved `--show` list for one reply property.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Show {
    /// The columns, in the order asked for.
    pub columns: Vec<Column>,
}

/// A slot of the layout: its label, element, type and size.
struct Slot {
    label: String,
    element: Option<String>,
    ty: TypeRef,
    size: Option<u16>,
    /// Names it answers to (the field's Name and Alias).
    names: Vec<String>,
}

fn slots(device: &Device, prop: &Property) -> Vec<Slot> {
    match prop.ty {
        TypeRef::Record(r) => device.records[r]
            .fields
            .iter()
            .map(|f| Slot {
                label: f.wire().to_string(),
                element: Some(f.wire().to_string()),
                ty: f.ty,
                size: f.size,
                names: vec![f.name.clone(), f.wire().to_string()],
            })
            .collect(),
        ty => vec![Slot {
            label: prop.wire().to_string(),
            element: None,
            ty,
            size: prop.size,
            names: vec![prop.name.clone(), prop.wire().to_string()],
        }],
    }
}

fn kind(ty: TypeRef) -> Kind {
    match ty {
        TypeRef::Simple(SimpleType::Bool) => Kind::Bool,
        TypeRef::Simple(SimpleType::String) | TypeRef::Enum(_) => Kind::Text,
        _ => Kind::Num,
    }
}

fn column(slot: &Slot, attribute: Option<String>) -> Column {
    let k = kind(slot.ty);
    Column {
        label: match &attribute {
            Some(a) => format!("{}.{a}", slot.label),
            None => slot.label.clone(),
        },
        element: slot.element.clone(),
        attribute,
        kind: k,
        numeric: k != Kind::Text,
    }
}

/// Every name `--show` accepts for `prop`, one per slot component.
pub fn available(device: &Device, prop: &Property) -> Vec<String> {
    let mut out = Vec::new();
    for s in slots(device, prop) {
        match attribute_names(s.ty, s.size) {
            Some(names) => out.extend(names.iter().map(|n| format!("{}.{n}", s.label))),
            None => out.push(s.label),
        }
    }
    out
}

impl Show {
    /// Resolves `names` against the reply property `prop`, or says which
    /// name is unknown and lists the ones there are.
    pub fn resolve(device: &Device, prop: &Property, names: &[String]) -> Result<Show, String> {
        let all = slots(device, prop);
        let mut columns = Vec::new();
        for name in names.iter().map(|n| n.trim()).filter(|n| !n.is_empty()) {
            let unknown = || {
                format!(
                    "--show {name}: no such field in the reply <{}> of device {}; available: {}",
                    prop.wire(),
                    device.name,
                    available(device, prop).join(", ")
                )
            };
            let mut parts: Vec<&str> = name.split('.').map(str::trim).collect();
            let named = |part: &str, s: &Slot| s.names.iter().any(|n| n.eq_ignore_ascii_case(part));
            // The property's own name in front is the layout's full path
            // (unless a field has that name too).
            if parts.len() > 1 && prop.is_named(parts[0]) && !all.iter().any(|s| named(parts[0], s))
            {
                parts.remove(0);
            }
            let slot = all
                .iter()
                .find(|s| named(parts[0], s))
                .ok_or_else(unknown)?;
            let components = attribute_names(slot.ty, slot.size);
            match (parts.as_slice(), components) {
                ([_], None) => columns.push(column(slot, None)),
                ([_], Some(comps)) => {
                    columns.extend(comps.into_iter().map(|c| column(slot, Some(c))))
                }
                ([_, c], Some(comps)) => {
                    let c = comps
                        .into_iter()
                        .find(|n| n.eq_ignore_ascii_case(c))
                        .ok_or_else(unknown)?;
                    columns.push(column(slot, Some(c)));
                }
                _ => return Err(unknown()),
            }
        }
        if columns.is_empty() {
            return Err(format!(
                "--show: name at least one field; available: {}",
                available(device, prop).join(", ")
            ));
        }
        Ok(Show { columns })
    }

    /// The shown values of one reply datagram (already checked against
    /// the layout), with the reply's `Ts`; `None` if it is no XML.
    pub fn extract(&self, bytes: &[u8]) -> Option<(Option<f64>, Vec<Cell>)> {
        let text = std::str::from_utf8(bytes).ok()?;
        let root = wire::tree(text).ok()?;
        let ts = attr(&root, "Ts").and_then(|t| t.trim().parse().ok());
        let cells = self.columns.iter().map(|c| value(&root, c)).collect();
        Some((ts, cells))
    }

    /// The CSV header's field columns.
    pub fn labels(&self) -> Vec<&str> {
        self.columns.iter().map(|c| c.label.as_str()).collect()
    }
}

fn attr<'e>(e: &'e Element, name: &str) -> Option<&'e str> {
    e.attrs
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.as_str())
}

fn value(root: &Element, c: &Column) -> Cell {
    let el = match &c.element {
        Some(name) => match root.children.iter().find(|e| &e.name == name) {
            Some(e) => e,
            None => return Cell::Missing,
        },
        None => root,
    };
    let raw = match &c.attribute {
        Some(a) => match attr(el, a) {
            Some(v) => v,
            None => return Cell::Missing,
        },
        None => el.text.as_str(),
    };
    let t = raw.trim();
    match c.kind {
        Kind::Num => t.parse().map(Cell::Num).unwrap_or(Cell::Missing),
        Kind::Bool => rri_vocabulary::parse_bool(t.as_bytes())
            .map(Cell::Bool)
            .unwrap_or(Cell::Missing),
        Kind::Text => Cell::Text(unescape(raw)),
    }
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn csv_field(v: &Cell) -> String {
    let s = v.to_string();
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s
    }
}

/// `--show-csv`: one row per answered message that carried shown values:
/// the robot message's Id, the reply's arrival (s since the run started),
/// the reply's `Ts`, then one column per shown value.
pub fn write_csv(path: &Path, show: &Show, cycles: &[Cycle]) -> io::Result<()> {
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "id,reply_s,reply_ts,{}", show.labels().join(","))?;
    for c in cycles {
        let (Some(shown), Some(at)) = (&c.shown, c.reply_us) else {
            continue;
        };
        let ts = shown.ts.map(|t| t.to_string()).unwrap_or_default();
        let values: Vec<String> = shown.values.iter().map(csv_field).collect();
        writeln!(
            f,
            "{},{:.6},{ts},{}",
            c.id,
            at as f64 / 1e6,
            values.join(",")
        )?;
    }
    f.flush()
}

/// One live line: `Id 1234  AppData.X1=0.5  EStr=OK`.
pub fn line(show: &Show, id: u32, cells: &[Cell]) -> String {
    let mut s = format!("reply to Id {id}:");
    for (c, v) in show.columns.iter().zip(cells) {
        s.push_str(&format!("  {}={v}", c.label));
    }
    s
}

#[cfg(test)]
mod tests;
