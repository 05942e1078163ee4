//! A replayed reply against the recorded one: the same fields, and each
//! value the same (numbers within a tolerance). A reply is read as a flat
//! list of values named as `--show` names them: `EStr`, `AppData.X1`, and
//! the root's attributes (`Id`, `Ts`).

use crate::wire;

/// How values are compared.
#[derive(Clone, Debug, Default)]
pub struct Rules {
    /// The tolerance for every number without one of its own.
    pub tolerance: f64,
    /// Per field (`AppData.X1`, or `AppData` for all of its values).
    pub per_field: Vec<(String, f64)>,
    /// Fields not compared (same naming); the root's `Ts`, the device's
    /// own clock, is never compared.
    pub ignore: Vec<String>,
    /// Only Ids, acceptance and timing: no field or value.
    pub ignore_values: bool,
}

impl Rules {
    fn ignored(&self, name: &str) -> bool {
        name == "Ts" || self.ignore.iter().any(|i| covers(i, name))
    }

    fn tolerance(&self, name: &str) -> f64 {
        // The most specific rule wins: a field's own, then its element's.
        self.per_field
            .iter()
            .filter(|(f, _)| covers(f, name))
            .max_by_key(|(f, _)| f.len())
            .map_or(self.tolerance, |(_, t)| *t)
    }
}

/// Whether rule name `rule` covers value `name` (`AppData` covers
/// `AppData.X1`).
fn covers(rule: &str, name: &str) -> bool {
    name == rule
        || name
            .strip_prefix(rule)
            .is_some_and(|rest| rest.starts_with('.'))
}

/// One way a replayed reply differs from the recorded one.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    /// The value's name, or `(fields)` for a different set of fields.
    pub field: String,
    pub recorded: String,
    pub replayed: String,
}

/// A reply as `name = value` pairs, in document order.
pub fn values(bytes: &[u8]) -> Result<Vec<(String, String)>, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not UTF-8".to_string())?;
    let root = wire::tree(text)?;
    let mut out: Vec<(String, String)> = root.attrs.clone();
    let text = root.text.trim();
    if !text.is_empty() {
        out.push((root.name.clone(), text.to_string()));
    }
    for child in &root.children {
        for (k, v) in &child.attrs {
            out.push((format!("{}.{k}", child.name), v.clone()));
        }
        let t = child.text.trim();
        if !t.is_empty() || child.attrs.is_empty() {
            out.push((child.name.clone(), t.to_string()));
        }
    }
    Ok(out)
}

/// What differs between the `recorded` and the `replayed` reply under
/// `rules` (nothing: the same).
pub fn compare(recorded: &[u8], replayed: &[u8], rules: &Rules) -> Vec<Difference> {
    if rules.ignore_values {
        return Vec::new();
    }
    let (r, p) = match (values(recorded), values(replayed)) {
        (Ok(r), Ok(p)) => (r, p),
        (Err(e), _) => {
            return vec![Difference {
                field: "(reply)".into(),
                recorded: format!("unreadable: {e}"),
                replayed: String::new(),
            }]
        }
        (_, Err(e)) => {
            return vec![Difference {
                field: "(reply)".into(),
                recorded: String::new(),
                replayed: format!("unreadable: {e}"),
            }]
        }
    };
    let names = |v: &[(String, String)]| -> Vec<String> {
        v.iter()
            .map(|(k, _)| k.clone())
            .filter(|k| !rules.ignored(k))
            .collect()
    };
    let (rn, pn) = (names(&r), names(&p));
    let mut out = Vec::new();
    let sorted = |mut v: Vec<String>| {
        v.sort();
        v
    };
    if sorted(rn.clone()) != sorted(pn.clone()) {
        let only = |a: &[String], b: &[String]| -> String {
            a.iter()
                .filter(|x| !b.contains(x))
                .cloned()
                .collect::<Vec<_>>()
                .join(" ")
        };
        out.push(Difference {
            field: "(fields)".into(),
            recorded: only(&rn, &pn),
            replayed: only(&pn, &rn),
        });
    }
    for (name, rv) in r.iter().filter(|(k, _)| !rules.ignored(k)) {
        let Some((_, pv)) = p.iter().find(|(k, _)| k == name) else {
            continue;
        };
        if !same(rv, pv, rules.tolerance(name)) {
            out.push(Difference {
                field: name.clone(),
                recorded: rv.clone(),
                replayed: pv.clone(),
            });
        }
    }
    out
}

/// Two values alike: as numbers within `tolerance` when both are numbers,
/// else as the same text.
fn same(a: &str, b: &str, tolerance: f64) -> bool {
    let (a, b) = (a.trim(), b.trim());
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) if x.is_finite() && y.is_finite() => (x - y).abs() <= tolerance,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: &[u8] =
        br#"<SensData Id="7" Ts="1.5"><EStr>ok</EStr><AppData X1="1.0" X2="2.5"/></SensData>"#;

    #[test]
    fn the_same_reply_differs_in_nothing_and_ts_is_the_devices_own() {
        let later =
            br#"<SensData Id="7" Ts="99"><EStr>ok</EStr><AppData X1="1" X2="2.50"/></SensData>"#;
        assert_eq!(compare(R, later, &Rules::default()), vec![]);
    }

    #[test]
    fn values_differ_beyond_their_tolerance_per_field_or_element() {
        let p =
            br#"<SensData Id="7" Ts="1.5"><EStr>ok</EStr><AppData X1="1.2" X2="2.9"/></SensData>"#;
        let d = compare(R, p, &Rules::default());
        assert_eq!(d.len(), 2);
        assert_eq!(
            (
                d[0].field.as_str(),
                d[0].recorded.as_str(),
                d[0].replayed.as_str()
            ),
            ("AppData.X1", "1.0", "1.2")
        );
        let rules = Rules {
            tolerance: 0.25,
            per_field: vec![("AppData.X2".into(), 0.5)],
            ..Rules::default()
        };
        assert_eq!(compare(R, p, &rules), vec![]);
        let rules = Rules {
            per_field: vec![("AppData".into(), 0.5)],
            ..Rules::default()
        };
        assert_eq!(compare(R, p, &rules), vec![]);
    }

    #[test]
    fn ignored_fields_and_ignore_values_compare_nothing_of_them() {
        let p =
            br#"<SensData Id="7" Ts="1.5"><EStr>live</EStr><AppData X1="5" X2="2.5"/></SensData>"#;
        let rules = Rules {
            ignore: vec!["EStr".into(), "AppData.X1".into()],
            ..Rules::default()
        };
        assert_eq!(compare(R, p, &rules), vec![]);
        let all = Rules {
            ignore_values: true,
            ..Rules::default()
        };
        assert_eq!(compare(R, b"<SensData/>", &all), vec![]);
    }

    #[test]
    fn a_missing_or_extra_field_is_named() {
        let p =
            br#"<SensData Id="7" Ts="1.5"><AppData X1="1.0" X2="2.5"/><Extra>1</Extra></SensData>"#;
        let d = compare(R, p, &Rules::default());
        assert_eq!(d[0].field, "(fields)");
        assert_eq!(
            (d[0].recorded.as_str(), d[0].replayed.as_str()),
            ("EStr", "Extra")
        );
    }
}
