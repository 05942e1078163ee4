//! Name resolution: the Rust identifier of every enum, variant, record,
//! field and message, chosen once, and the collisions the GSI rules cannot
//! see (two RAPID names that become one Rust identifier, G4).

use crate::names;
use gsi_config::{Device, Diagnostic, Pos, Rule, Severity};
use std::collections::HashMap;

/// The Rust names of everything generated, resolved once.
pub(crate) struct Idents {
    /// Per `Enum`: its type name.
    pub enums: Vec<String>,
    /// Per `Enum`: its variants' names.
    pub variants: Vec<Vec<String>>,
    /// Per `Record`: its struct name.
    pub records: Vec<String>,
    /// Per `Record`: its fields' names.
    pub fields: Vec<Vec<String>>,
    /// Per property: its message type name.
    pub messages: Vec<String>,
}

pub(crate) fn diag(device: &Device, pos: Pos, rule: Rule, message: String) -> Diagnostic {
    Diagnostic {
        severity: Severity::Error,
        rule,
        file: device.configuration_file.clone(),
        pos,
        message,
    }
}

/// Resolves Rust names and reports collisions the GSI rules cannot see
/// (two RAPID names that become the same Rust identifier).
pub(crate) fn idents(device: &Device, errors: &mut Vec<Diagnostic>) -> Idents {
    let mut types: HashMap<String, (String, Pos)> = HashMap::new();
    let mut claim = |ident: String, what: String, pos: Pos, errors: &mut Vec<Diagnostic>| {
        if let Some((other, _)) = types.get(&ident) {
            errors.push(diag(
                device,
                pos,
                Rule::G4,
                format!("{what} and {other} both become the Rust type `{ident}`; rename one"),
            ));
        } else {
            types.insert(ident.clone(), (what, pos));
        }
        ident
    };
    // The per-direction sets (M11) take these names.
    let first = device.properties.first().map_or(Pos::default(), |p| p.pos);
    for (name, what) in [
        (
            "RobotProperty",
            "the generated enum of the robot's properties",
        ),
        (
            "RobotProperties",
            "the generated struct of the robot's properties",
        ),
        (
            "DeviceProperty",
            "the generated enum of the device's properties",
        ),
        (
            "DeviceProperties",
            "the generated struct of the device's properties",
        ),
    ] {
        claim(name.to_string(), what.to_string(), first, errors);
    }
    let enums = device
        .enums
        .iter()
        .map(|e| {
            claim(
                names::camel(&e.name),
                format!("enum \"{}\"", e.name),
                e.pos,
                errors,
            )
        })
        .collect();
    let records = device
        .records
        .iter()
        .map(|r| {
            claim(
                names::camel(&r.name),
                format!("record \"{}\"", r.name),
                r.pos,
                errors,
            )
        })
        .collect();
    let messages = device
        .properties
        .iter()
        .map(|p| {
            claim(
                format!("{}Message", names::camel(&p.name).trim_start_matches("r#")),
                format!("property \"{}\"", p.name),
                p.pos,
                errors,
            )
        })
        .collect();
    let unique = |list: Vec<(String, &str, Pos)>, kind: &str, errors: &mut Vec<Diagnostic>| {
        let mut seen: HashMap<String, &str> = HashMap::new();
        list.into_iter()
            .map(|(ident, name, pos)| {
                if let Some(other) = seen.get(&ident) {
                    errors.push(diag(
                        device,
                        pos,
                        Rule::G4,
                        format!("{kind} \"{other}\" and \"{name}\" both become `{ident}` in Rust; rename one"),
                    ));
                }
                seen.insert(ident.clone(), name);
                ident
            })
            .collect::<Vec<_>>()
    };
    let variants = device
        .enums
        .iter()
        .map(|e| {
            let list = e
                .members
                .iter()
                .map(|m| (names::camel(&m.name), m.name.as_str(), m.pos))
                .collect();
            unique(list, "members", errors)
        })
        .collect();
    let fields = device
        .records
        .iter()
        .map(|r| {
            let list = r
                .fields
                .iter()
                .map(|f| (names::snake(&f.name), f.name.as_str(), f.pos))
                .collect();
            unique(list, "fields", errors)
        })
        .collect();
    Idents {
        enums,
        variants,
        records,
        fields,
        messages,
    }
}
