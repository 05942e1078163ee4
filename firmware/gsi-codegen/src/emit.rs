//! A tiny writer for readable, rustfmt-clean generated code.

use std::fmt::Write;

#[derive(Default)]
pub struct Emitter {
    out: String,
    pub(crate) indent: usize,
}

impl Emitter {
    /// One line at the current indentation (empty lines stay empty).
    pub fn line(&mut self, text: impl AsRef<str>) {
        let text = text.as_ref();
        if !text.is_empty() {
            for _ in 0..self.indent {
                self.out.push_str("    ");
            }
            self.out.push_str(text);
        }
        self.out.push('\n');
    }

    /// `///` doc lines, one per line of `text`.
    pub fn doc(&mut self, text: impl AsRef<str>) {
        let text = text.as_ref();
        if text.is_empty() {
            self.line("///");
        }
        for l in text.lines() {
            if l.is_empty() {
                self.line("///");
            } else {
                self.line(format!("/// {l}"));
            }
        }
    }

    /// Opens a block: `head {`.
    pub fn open(&mut self, head: impl AsRef<str>) {
        self.line(format!("{} {{", head.as_ref()));
        self.indent += 1;
    }

    /// Closes a block with `}` plus a suffix (`,` or `;` or nothing).
    pub fn close(&mut self, suffix: &str) {
        self.indent = self.indent.saturating_sub(1);
        self.line(format!("}}{suffix}"));
    }

    /// `head[a, b, c];` on one line when rustfmt would keep it there (the
    /// literal within 60 columns, the line within 100), else one item a line.
    pub fn array(&mut self, head: &str, items: &[String]) {
        let literal = format!("[{}]", items.join(", "));
        if literal.len() <= 60 && self.indent * 4 + head.len() + literal.len() < 100 {
            self.line(format!("{head}{literal};"));
        } else {
            self.line(format!("{head}["));
            for item in items {
                self.line(format!("    {item},"));
            }
            self.line("];");
        }
    }

    /// `use path::{a, b, …};` filled to 100 columns the way rustfmt does.
    pub fn use_list(&mut self, path: &str, items: &[&str]) {
        match items {
            [] => {}
            [one] => self.line(format!("use {path}::{one};")),
            many => {
                let one_line = format!("use {path}::{{{}}};", many.join(", "));
                if one_line.len() <= 100 {
                    self.line(one_line);
                    return;
                }
                self.line(format!("use {path}::{{"));
                let mut line = String::new();
                for item in many {
                    let piece = format!("{item},");
                    if !line.is_empty() && 4 + line.len() + 1 + piece.len() > 100 {
                        self.line(format!("    {line}"));
                        line.clear();
                    }
                    if !line.is_empty() {
                        line.push(' ');
                    }
                    line.push_str(&piece);
                }
                self.line(format!("    {line}"));
                self.line("};");
            }
        }
    }

    /// `prefix f(a, b, c)suffix` on one line when rustfmt keeps it there,
    /// else one argument a line.
    pub fn call(&mut self, prefix: &str, f: &str, args: &[String], suffix: &str) {
        let joined = args.join(", ");
        let one = format!("{prefix}{f}({joined}){suffix}");
        if joined.len() <= 60 && self.indent * 4 + one.len() <= 100 {
            self.line(one);
        } else {
            self.line(format!("{prefix}{f}("));
            for a in args {
                self.line(format!("{prefix}    {a},"));
            }
            self.line(format!("{prefix}){suffix}"));
        }
    }

    /// `head[f(..), f(..)];`: an array of calls, one line when short
    /// (rustfmt keeps a literal of up to 60 columns together), else one
    /// call a line, each laid out by [`Emitter::call`].
    pub fn call_array(&mut self, head: &str, f: &str, calls: &[Vec<String>]) {
        let items: Vec<String> = calls
            .iter()
            .map(|args| format!("{f}({})", args.join(", ")))
            .collect();
        let literal = format!("[{}]", items.join(", "));
        if literal.len() <= 60 && self.indent * 4 + head.len() + literal.len() < 100 {
            self.line(format!("{head}{literal};"));
            return;
        }
        self.line(format!("{head}["));
        for args in calls {
            self.call("    ", f, args, ",");
        }
        self.line("];");
    }

    pub fn blank(&mut self) {
        if !self.out.ends_with("\n\n") && !self.out.ends_with("{\n") && !self.out.is_empty() {
            self.out.push('\n');
        }
    }

    pub fn finish(mut self) -> String {
        while self.out.ends_with("\n\n") {
            self.out.pop();
        }
        self.out
    }
}

/// A Rust string literal for `s`.
pub fn str_lit(s: &str) -> String {
    format!("{s:?}")
}

/// A Rust byte-string literal for an ASCII/UTF-8 string.
pub fn bytes_lit(s: &str) -> String {
    let mut out = String::from("b\"");
    for b in s.bytes() {
        match b {
            b'"' => out.push_str("\\\""),
            b'\\' => out.push_str("\\\\"),
            0x20..=0x7e => out.push(b as char),
            _ => {
                let _ = write!(out, "\\x{b:02x}");
            }
        }
    }
    out.push('"');
    out
}
