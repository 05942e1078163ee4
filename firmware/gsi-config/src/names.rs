//! G4 names and the other lexical checks shared by the three files.

use crate::diag::{Pos, Rule, Sink};

/// Longest RAPID symbol (G4) and longest RAPID string (G5, M6; also the
/// longest enum alias we accept, since an alias travels as a string value).
pub use rri_vocabulary::{MAX_NAME_LEN, MAX_STRING_LEN};

/// G4: ASCII letter first, then ASCII letters, digits and `_`, at most 16.
/// Reports the first problem found and returns whether the name is valid.
pub fn check_rapid_name(sink: &mut Sink<'_>, what: &str, name: &str, pos: Pos) -> bool {
    let n = name.chars().count();
    if name.is_empty() {
        sink.error(Rule::G4, pos, format!("{what} is empty"));
        return false;
    }
    if n > MAX_NAME_LEN {
        sink.error(
            Rule::G4,
            pos,
            format!("{what} \"{name}\" has {n} characters (max {MAX_NAME_LEN})"),
        );
        return false;
    }
    let first = name.chars().next().unwrap_or(' ');
    if !first.is_ascii_alphabetic() {
        sink.error(
            Rule::G4,
            pos,
            format!("{what} \"{name}\" must start with an ASCII letter"),
        );
        return false;
    }
    if let Some(bad) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        sink.error(
            Rule::G4,
            pos,
            format!("{what} \"{name}\" contains '{bad}' (only ASCII letters, digits and '_')"),
        );
        return false;
    }
    true
}

/// Whether `s` can be an XML element or attribute name in a message. The
/// firmware compares names byte-wise, so only ASCII names are accepted.
pub fn is_xml_name(s: &str) -> bool {
    let mut chars = s.chars();
    match chars.next() {
        Some(c) if c.is_ascii_alphabetic() || c == '_' => {}
        _ => return false,
    }
    chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
        && !s.to_ascii_lowercase().starts_with("xml")
}

/// The value `table` gives the keyword `value` ([`rri_vocabulary::is_keyword`]:
/// any case, around whitespace).
pub fn keyword<T: Copy>(value: &str, table: &[(&str, T)]) -> Option<T> {
    table
        .iter()
        .find(|(k, _)| rri_vocabulary::is_keyword(value, k))
        .map(|(_, v)| *v)
}

/// Booleans in GSI files: the words of messages (M7), around whitespace.
pub fn parse_bool(value: &str) -> Option<bool> {
    rri_vocabulary::parse_bool(value.trim().as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn check(name: &str) -> Option<String> {
        let mut out = Vec::new();
        let mut sink = Sink::new(Path::new("x"), &mut out);
        check_rapid_name(&mut sink, "name", name, Pos::default());
        out.pop().map(|d| d.message)
    }

    #[test]
    fn g4_accepts_rapid_symbols() {
        assert_eq!(check("RobData"), None);
        assert_eq!(check("a_1"), None);
        assert_eq!(check("ABCDEFGHIJKLMNOP"), None);
    }

    #[test]
    fn g4_rejects_long_leading_digit_and_odd_characters() {
        assert_eq!(
            check("ABCDEFGHIJKLMNOPQ").as_deref(),
            Some("name \"ABCDEFGHIJKLMNOPQ\" has 17 characters (max 16)")
        );
        assert!(check("1abc").unwrap().contains("must start"));
        assert!(check("_abc").unwrap().contains("must start"));
        assert!(check("a-b").unwrap().contains("'-'"));
        assert!(check("").unwrap().contains("empty"));
    }

    #[test]
    fn xml_names() {
        assert!(is_xml_name("Ts_act"));
        assert!(is_xml_name("P-des.2"));
        assert!(!is_xml_name("2x"));
        assert!(!is_xml_name("a b"));
        assert!(!is_xml_name("xmlThing"));
        assert!(!is_xml_name(""));
    }

    #[test]
    fn bools() {
        assert_eq!(parse_bool(" TRUE "), Some(true));
        assert_eq!(parse_bool("0"), Some(false));
        assert_eq!(parse_bool("yes"), None);
    }
}
