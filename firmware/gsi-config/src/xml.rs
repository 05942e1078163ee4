//! A small element tree built from `xmlparser` tokens, with the line and
//! column of every element, attribute and text, so validation can point at
//! the exact spot. Configuration files are small and read once at build time,
//! so this side may allocate; the firmware's message decoder does not use it.

use crate::diag::{Pos, Rule, Sink};
use xmlparser::{ElementEnd, Token, Tokenizer};

/// An attribute as written, with its value's entities decoded.
#[derive(Debug, Clone)]
pub struct Attr<'a> {
    /// The name as written, prefix included (`xml:lang`).
    pub name: &'a str,
    /// The value, with entities and character references decoded ([`unescape`]).
    pub value: String,
    /// Where the attribute name starts.
    pub pos: Pos,
}

/// A run of character data inside an element.
#[derive(Debug, Clone)]
pub struct Text {
    /// The characters, untrimmed, with entities and character references
    /// decoded ([`unescape`]).
    pub text: String,
    /// Where the first non-whitespace character is (just past the run when it
    /// is all whitespace).
    pub pos: Pos,
}

/// An element with its attributes, child elements and text, each in file
/// order. Comments, processing instructions and the declaration are dropped.
#[derive(Debug, Clone)]
pub struct Element<'a> {
    /// The tag name as written, prefix included.
    pub name: &'a str,
    /// Where the `<` of the start tag is.
    pub pos: Pos,
    /// The attributes, in the order written.
    pub attrs: Vec<Attr<'a>>,
    /// The child elements, in file order.
    pub children: Vec<Element<'a>>,
    /// The text runs (CDATA included), whitespace between children too; where
    /// they sit between `children` is not kept.
    pub texts: Vec<Text>,
}

impl<'a> Element<'a> {
    /// The first attribute called `name` (case-sensitive), if any.
    pub fn attr(&self, name: &str) -> Option<&Attr<'a>> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// All character data of the element, trimmed (for `<Name>X</Name>`).
    pub fn text(&self) -> String {
        let mut s = String::new();
        for t in &self.texts {
            s.push_str(&t.text);
        }
        s.trim().to_string()
    }

    /// Where the element's text starts, or the element itself when empty.
    pub fn text_pos(&self) -> Pos {
        self.texts
            .iter()
            .find(|t| !t.text.trim().is_empty())
            .map(|t| t.pos)
            .unwrap_or(self.pos)
    }

    /// The child elements called `name` (case-sensitive), in file order.
    pub fn children_named<'s>(&'s self, name: &'s str) -> impl Iterator<Item = &'s Element<'a>> {
        self.children.iter().filter(move |c| c.name == name)
    }
}

/// Maps byte offsets of a file to 1-based line/column.
pub struct LineIndex<'a> {
    text: &'a str,
    line_starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    /// Indexes the line starts of `text`, the whole file.
    pub fn new(text: &'a str) -> Self {
        let mut line_starts = vec![0];
        for (i, b) in text.bytes().enumerate() {
            if b == b'\n' {
                line_starts.push(i + 1);
            }
        }
        LineIndex { text, line_starts }
    }

    /// The 1-based line and character column of byte `offset` of the file.
    pub fn pos(&self, offset: usize) -> Pos {
        let line = match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        };
        let start = self.line_starts[line];
        let end = offset.min(self.text.len());
        let col = self.text.get(start..end).map_or(0, |s| s.chars().count());
        Pos {
            line: line as u32 + 1,
            col: col as u32 + 1,
        }
    }

    /// Byte offset of a (1-based row, 1-based char column) inside `sub`,
    /// which starts at byte `base` of the file.
    fn offset_of(&self, base: usize, row: u32, col: u32) -> usize {
        let sub = &self.text[base..];
        let mut offset = 0;
        for (i, line) in sub.split_inclusive('\n').enumerate() {
            if i + 1 == row as usize {
                let skip: usize = line
                    .chars()
                    .take(col.saturating_sub(1) as usize)
                    .map(char::len_utf8)
                    .sum();
                return base + offset + skip;
            }
            offset += line.len();
        }
        base + sub.len()
    }
}

/// Decodes the five predefined entities and character references. Unknown
/// entities are kept as written (configuration files never need them).
pub fn unescape(raw: &str) -> String {
    if !raw.contains('&') {
        return raw.to_string();
    }
    let mut out = String::with_capacity(raw.len());
    let mut rest = raw;
    while let Some(amp) = rest.find('&') {
        out.push_str(&rest[..amp]);
        let tail = &rest[amp..];
        let decoded = tail.find(';').and_then(|semi| {
            let name = &tail[1..semi];
            let c = match name {
                "amp" => Some('&'),
                "lt" => Some('<'),
                "gt" => Some('>'),
                "quot" => Some('"'),
                "apos" => Some('\''),
                _ => {
                    if let Some(hex) = name.strip_prefix("#x") {
                        u32::from_str_radix(hex, 16).ok().and_then(char::from_u32)
                    } else if let Some(dec) = name.strip_prefix('#') {
                        dec.parse().ok().and_then(char::from_u32)
                    } else {
                        None
                    }
                }
            };
            c.map(|c| (c, semi + 1))
        });
        match decoded {
            Some((c, len)) => {
                out.push(c);
                rest = &tail[len..];
            }
            None => {
                out.push('&');
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// Parses a whole file into its root element. Problems are reported to
/// `sink`; `None` means the file is not usable at all.
///
/// G6: the manual's example starts with a blank line before `<?xml …?>`,
/// which `xmlparser` rejects; leading whitespace is skipped (with a warning
/// when a declaration follows) and positions still refer to the real file.
pub fn parse<'a>(text: &'a str, sink: &mut Sink<'_>) -> Option<Element<'a>> {
    let index = LineIndex::new(text);
    let after_bom = text.strip_prefix('\u{feff}').map_or(0, |_| 3);
    let body = &text[after_bom..];
    let lead = body.len() - body.trim_start().len();
    let base = after_bom + lead;
    if lead > 0 && text[base..].starts_with("<?xml") {
        sink.warning(
            Rule::G6,
            index.pos(base),
            "whitespace before the XML declaration (as in the manual's example); accepted",
        );
    }

    let mut stack: Vec<Element<'a>> = Vec::new();
    let mut root: Option<Element<'a>> = None;
    for token in Tokenizer::from(&text[base..]) {
        let token = match token {
            Ok(t) => t,
            Err(e) => {
                let tp = e.pos();
                let off = index.offset_of(base, tp.row, tp.col);
                let msg = e.to_string();
                let msg = msg.rsplit_once(" at ").map_or(msg.as_str(), |(m, _)| m);
                sink.error(
                    Rule::Xml,
                    index.pos(off),
                    format!("not well-formed XML: {msg}"),
                );
                return None;
            }
        };
        match token {
            Token::ElementStart {
                prefix,
                local,
                span,
            } => {
                if root.is_some() {
                    sink.error(
                        Rule::Xml,
                        index.pos(base + span.start()),
                        "content after the root element",
                    );
                    return None;
                }
                let name = if prefix.is_empty() {
                    local.as_str()
                } else {
                    &text[base + prefix.start()..base + local.end()]
                };
                stack.push(Element {
                    name,
                    pos: index.pos(base + span.start()),
                    attrs: Vec::new(),
                    children: Vec::new(),
                    texts: Vec::new(),
                });
            }
            Token::Attribute {
                prefix,
                local,
                value,
                span,
            } => {
                if let Some(el) = stack.last_mut() {
                    let name = if prefix.is_empty() {
                        local.as_str()
                    } else {
                        &text[base + prefix.start()..base + local.end()]
                    };
                    el.attrs.push(Attr {
                        name,
                        value: unescape(value.as_str()),
                        pos: index.pos(base + span.start()),
                    });
                }
            }
            Token::ElementEnd { end, span } => match end {
                ElementEnd::Open => {}
                ElementEnd::Empty | ElementEnd::Close(..) => {
                    if let ElementEnd::Close(prefix, local) = end {
                        let name = if prefix.is_empty() {
                            local.as_str()
                        } else {
                            &text[base + prefix.start()..base + local.end()]
                        };
                        let open = stack.last().map(|e| e.name).unwrap_or("");
                        if name != open {
                            sink.error(
                                Rule::Xml,
                                index.pos(base + span.start()),
                                format!("end tag </{name}> does not match <{open}>"),
                            );
                            return None;
                        }
                    }
                    let Some(done) = stack.pop() else {
                        sink.error(
                            Rule::Xml,
                            index.pos(base + span.start()),
                            "unexpected end tag",
                        );
                        return None;
                    };
                    match stack.last_mut() {
                        Some(parent) => parent.children.push(done),
                        None => root = Some(done),
                    }
                }
            },
            Token::Text { text: t } | Token::Cdata { text: t, .. } => match stack.last_mut() {
                Some(el) => el.texts.push(Text {
                    text: unescape(t.as_str()),
                    pos: index.pos(base + t.start() + (t.len() - t.as_str().trim_start().len())),
                }),
                None => {
                    if !t.as_str().trim().is_empty() {
                        sink.error(
                            Rule::Xml,
                            index.pos(base + t.start()),
                            "text outside the root element",
                        );
                        return None;
                    }
                }
            },
            Token::DtdStart { span, .. } | Token::EmptyDtd { span, .. } => {
                sink.error(
                    Rule::Xml,
                    index.pos(base + span.start()),
                    "DOCTYPE is not allowed in GSI files (no entity expansion)",
                );
                return None;
            }
            Token::Declaration { .. }
            | Token::ProcessingInstruction { .. }
            | Token::Comment { .. }
            | Token::EntityDeclaration { .. }
            | Token::DtdEnd { .. } => {}
        }
    }
    if let Some(open) = stack.last() {
        sink.error(
            Rule::Xml,
            open.pos,
            format!("<{}> is never closed (file truncated?)", open.name),
        );
        return None;
    }
    if root.is_none() {
        sink.error(Rule::Xml, index.pos(base), "no root element");
    }
    root
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::Diagnostic;
    use std::path::Path;

    fn parse_ok(text: &str) -> (Option<Element<'_>>, Vec<Diagnostic>) {
        let mut out = Vec::new();
        let mut sink = Sink::new(Path::new("t.xml"), &mut out);
        let root = parse(text, &mut sink);
        (root, out)
    }

    #[test]
    fn positions_are_one_based_and_count_chars() {
        let idx = LineIndex::new("ab\n\u{e9}x<");
        assert_eq!(idx.pos(0), Pos { line: 1, col: 1 });
        assert_eq!(idx.pos(3), Pos { line: 2, col: 1 });
        assert_eq!(idx.pos(6), Pos { line: 2, col: 3 });
    }

    #[test]
    fn g6_leading_blank_line_is_a_warning_with_the_real_position() {
        let (root, diags) = parse_ok("\n<?xml version=\"1.0\"?>\n<A x=\"1\"/>");
        let root = root.expect("parses");
        assert_eq!(root.pos, Pos { line: 3, col: 1 });
        assert_eq!(root.attrs[0].pos, Pos { line: 3, col: 4 });
        assert_eq!(diags.len(), 1);
        assert_eq!(diags[0].rule, Rule::G6);
        assert_eq!(diags[0].pos, Pos { line: 2, col: 1 });
    }

    #[test]
    fn syntax_error_position_accounts_for_skipped_whitespace() {
        let (root, diags) = parse_ok("\n\n<A>\n  <B x=1/>\n</A>");
        assert!(root.is_none());
        assert_eq!(diags[0].rule, Rule::Xml);
        assert_eq!(diags[0].pos.line, 4);
    }

    #[test]
    fn mismatched_end_tag_is_an_error() {
        let (root, diags) = parse_ok("<A><B></C></A>");
        assert!(root.is_none());
        assert!(diags[0].message.contains("</C>"), "{}", diags[0].message);
        assert_eq!(diags[0].pos, Pos { line: 1, col: 7 });
    }

    #[test]
    fn doctype_is_rejected() {
        let (root, diags) = parse_ok("<!DOCTYPE A [<!ENTITY e \"x\">]><A/>");
        assert!(root.is_none());
        assert!(diags[0].message.contains("DOCTYPE"));
    }

    #[test]
    fn unescape_decodes_entities_and_references() {
        assert_eq!(unescape("a&amp;b&lt;&#65;&#x42;&bogus;"), "a&b<AB&bogus;");
    }
}
