//! Rust identifiers from GSI names. RAPID names are case-insensitive symbols
//! (G4); Rust wants `UpperCamel` types and `snake_case` fields, and some
//! RAPID-valid names are Rust keywords.

/// `FeedbackPose` → `feedback_pose`, `J_act` → `j_act`, `ABCValue` → `abc_value`.
pub fn snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            let prev = chars[i - 1];
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            if prev.is_ascii_lowercase()
                || prev.is_ascii_digit()
                || (prev.is_ascii_uppercase() && next_lower)
            {
                out.push('_');
            }
        }
        out.push(c.to_ascii_lowercase());
    }
    escape(out)
}

/// `robdata` → `Robdata`, `rob_data` → `RobData`, `RobotData` → `RobotData`.
pub fn camel(name: &str) -> String {
    let mut out = String::new();
    for part in name.split('_').filter(|p| !p.is_empty()) {
        let mut cs = part.chars();
        if let Some(first) = cs.next() {
            out.push(first.to_ascii_uppercase());
            out.extend(cs);
        }
    }
    if out.is_empty() {
        out.push('X');
    }
    escape(out)
}

const KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "dyn", "else", "enum", "extern", "false",
    "fn", "for", "gen", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub",
    "ref", "return", "static", "struct", "trait", "true", "type", "unsafe", "use", "where",
    "while", "abstract", "become", "box", "do", "final", "macro", "override", "priv", "try",
    "typeof", "unsized", "virtual", "yield",
];

/// Keywords become raw identifiers; the four that cannot be raw get a `_`.
fn escape(ident: String) -> String {
    if matches!(ident.as_str(), "self" | "Self" | "super" | "crate") {
        format!("{ident}_")
    } else if KEYWORDS.contains(&ident.as_str()) {
        format!("r#{ident}")
    } else {
        ident
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snake_case() {
        assert_eq!(snake("FeedbackPose"), "feedback_pose");
        assert_eq!(snake("J_act"), "j_act");
        assert_eq!(snake("ABCValue"), "abc_value");
        assert_eq!(snake("X1"), "x1");
        assert_eq!(snake("Feedback_Pose"), "feedback_pose");
        assert_eq!(snake("Type"), "r#type");
        assert_eq!(snake("Self"), "self_");
    }

    #[test]
    fn camel_case() {
        assert_eq!(camel("robdata"), "Robdata");
        assert_eq!(camel("rob_data"), "RobData");
        assert_eq!(camel("RobotData"), "RobotData");
        assert_eq!(camel("self"), "Self_");
    }
}
