//! The event layer of the decoder: `xmlparser`'s tokens become the events
//! of one RRI message, each with its byte offset in the datagram, and every
//! structural rule is checked here (M1: one root of the expected name with
//! `Id` and optional `Ts`; at most two levels, M2–M4; tags that match; no
//! DOCTYPE; nothing but comments and whitespace after the root). What the
//! events mean for the generated record is the binding walk's business
//! ([`super::decode`]); this layer knows only the root's name.
//!
//! Constant work per token, no recursion: one pass over the tokens, and
//! the visitor is told at most one event per token.

use super::error::{err, DecodeError, DecodeErrorKind as K};
use crate::codec::number::{blank, is_xml_space_char, parse_time, parse_u32};
use crate::value::Time;
use xmlparser::{ElementEnd, Token, Tokenizer};

/// What the binding walk does with each structural event of a message.
/// `at` is a byte offset in the datagram, for the error it may raise there;
/// any error ends the walk. Called in the message's order, monomorphised
/// and inlined into [`walk`], so the layering costs no dispatch.
pub(super) trait Visitor<'a> {
    /// A child element of the root opens (`<P_act`, `at` its `<`): a
    /// record's field (M2), or an unknown element.
    fn child(&mut self, prefix: &'a str, name: &'a str, at: usize) -> Result<(), DecodeError>;
    /// An attribute of the root other than `Id` and `Ts`, or of the open
    /// child (M4).
    fn attr(&mut self, a: Attr<'a>) -> Result<(), DecodeError>;
    /// Character data directly in the root or in the open child (M3).
    fn text(&mut self, t: Text<'a>) -> Result<(), DecodeError>;
    /// A comment or processing instruction (`at` its `<`): an item no
    /// layout accounts for, which still cost tokenizing.
    fn other(&mut self, at: usize) -> Result<(), DecodeError>;
    /// The open child ends (`/>` or `</P_act>`).
    fn child_end(&mut self) -> Result<(), DecodeError>;
    /// The root ends: the message is complete.
    fn root_end(&mut self) -> Result<(), DecodeError>;
}

/// One attribute as the walk tells it ([`Visitor::attr`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Attr<'a> {
    /// On the root (`true`), or on the open child.
    pub on_root: bool,
    pub prefix: &'a str,
    pub name: &'a str,
    /// Still with its character references.
    pub value: &'a str,
    /// The value's byte offset in the datagram.
    pub at: usize,
}

/// Character data as the walk tells it ([`Visitor::text`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Text<'a> {
    /// Directly in the root (`true`), or in the open child.
    pub on_root: bool,
    pub text: &'a str,
    /// Its byte offset in the datagram.
    pub at: usize,
    /// CDATA, taken literally; other text still has its character
    /// references.
    pub cdata: bool,
}

/// The root's attributes the engine needs (M1, M8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Header {
    /// `Id`: the message's sequence number, echoed in the reply (M8).
    pub id: u32,
    /// `Ts`: the controller's time stamp, when present.
    pub ts: Option<Time>,
}

/// Where a walk starts inside the root, between two of its children: a
/// byte offset in the datagram at which the compiled path had checked
/// everything before (`codec::HandOver`), and the root's `Id` and `Ts` it
/// read there.
#[derive(Clone, Copy, Debug)]
pub(super) struct Start {
    pub at: usize,
    pub id: u32,
    pub ts: Option<Time>,
}

/// Walks the datagram `text`, whose root must be named `root`, telling
/// `v` each structural event; returns the root's `Id` and `Ts` once the
/// root has ended and nothing but comments and whitespace follow.
///
/// From `from` when given: the tokens before it are not read again, and
/// the walk is where it would be there (in the root, its header read).
/// `xmlparser` then tokenizes a fragment, which after the root's end
/// gives text, CDATA and tags as tokens instead of refusing them: each is
/// refused here as the whole document's walk refuses it (trailing
/// garbage, at the end of the last token), and whitespace is skipped as
/// it would be.
#[inline(always)]
pub(super) fn walk<'a, V: Visitor<'a>>(
    text: &'a str,
    root: &str,
    v: &mut V,
    from: Option<Start>,
) -> Result<Header, DecodeError> {
    // M1: whitespace may precede the declaration; xmlparser does not allow
    // it, so skip it and keep offsets relative to the datagram. A resumed
    // walk reads from its start: `xmlparser` counts lines and columns from
    // the first byte of the text it is given for every error, so giving
    // it the whole datagram would scan it all again (38,600 x86
    // instructions for a refused 3.5 KB message).
    let trimmed = text.trim_start_matches(is_xml_space_char);
    let lead = text.len() - trimmed.len();
    let resumed = from.and_then(|s| Some((s, text.get(s.at..)?)));
    let body = match resumed {
        Some((_, rest)) => rest,
        None => super::declaration::after_declaration(trimmed, text.len())?,
    };
    let base = text.len() - body.len();
    // 0 outside the root, 1 in the root, 2 in a child.
    let mut depth: u8 = 0;
    let mut done = false;
    // Inside the root's start tag (its attributes are still coming).
    let mut in_root_tag = false;
    // Prefix and name of the open child, for its end tag.
    let mut child: (&str, &str) = ("", "");
    let mut id: Option<u32> = None;
    let mut ts: Option<Time> = None;
    // Offset just after the last complete token: where an error is
    // reported when the tokenizer fails.
    let mut last_end = base;
    let tokens = match resumed {
        Some((start, _)) => {
            (depth, id, ts) = (1, Some(start.id), start.ts);
            Tokenizer::from_fragment(body, 0..body.len())
        }
        None => Tokenizer::from(body),
    };

    for token in tokens {
        let token = token.map_err(|e| token_error(&e, done, text, lead, last_end))?;
        if done {
            // After the root (a fragment's tokens only: the whole
            // document's tokenizer refuses these itself).
            match token {
                Token::Text { text: t } if blank(t.as_bytes()) => continue,
                Token::ProcessingInstruction { .. } | Token::Comment { .. } => {}
                _ => return Err(err(K::TrailingGarbage, last_end)),
            }
        }
        match token {
            Token::Declaration { span, .. } => last_end = base + span.end(),
            Token::ProcessingInstruction { span, .. } | Token::Comment { span, .. } => {
                v.other(base + span.start())?;
                last_end = base + span.end();
            }
            Token::DtdStart { span, .. }
            | Token::EmptyDtd { span, .. }
            | Token::EntityDeclaration { span, .. }
            | Token::DtdEnd { span } => return Err(err(K::Doctype, base + span.start())),
            Token::ElementStart {
                prefix,
                local,
                span,
            } => {
                let at = base + span.start();
                if span.end() >= body.len() {
                    // `<RobD` at the end: the name itself was cut.
                    return Err(err(K::Truncated, at));
                }
                let (prefix, name) = (prefix.as_str(), local.as_str());
                match depth {
                    0 => {
                        if !prefix.is_empty() || name != root {
                            return Err(err(K::WrongRoot, at));
                        }
                        in_root_tag = true;
                    }
                    1 => {
                        child = (prefix, name);
                        v.child(prefix, name, at)?;
                    }
                    _ => return Err(err(K::TooDeep, at)),
                }
                depth += 1;
                last_end = base + span.end();
            }
            Token::Attribute {
                prefix,
                local,
                value,
                span,
            } => {
                let at = base + value.start();
                let (prefix, name) = (prefix.as_str(), local.as_str());
                let on_root = depth == 1;
                if on_root && prefix.is_empty() && name == "Id" {
                    if id.is_some() {
                        return Err(err(K::Duplicate, at));
                    }
                    id = Some(parse_u32(value.as_bytes()).map_err(|_| err(K::InvalidId, at))?);
                } else if on_root && prefix.is_empty() && name == "Ts" {
                    if ts.is_some() {
                        return Err(err(K::Duplicate, at));
                    }
                    ts = Some(parse_time(value.as_bytes()).map_err(|_| err(K::InvalidTs, at))?);
                } else {
                    v.attr(Attr {
                        on_root,
                        prefix,
                        name,
                        value: value.as_str(),
                        at,
                    })?;
                }
                last_end = base + span.end();
            }
            Token::ElementEnd { end, span } => {
                let at = base + span.start();
                if in_root_tag {
                    // M1: `Id` is on the root's start tag or nowhere.
                    if id.is_none() {
                        return Err(err(K::MissingId, at));
                    }
                    in_root_tag = false;
                }
                let closing = match end {
                    ElementEnd::Open => false,
                    ElementEnd::Empty => true,
                    ElementEnd::Close(prefix, local) => {
                        let open = if depth == 1 { ("", root) } else { child };
                        if (prefix.as_str(), local.as_str()) != open {
                            return Err(err(K::MismatchedTag, at));
                        }
                        true
                    }
                };
                if closing {
                    if depth == 2 {
                        v.child_end()?;
                        depth = 1;
                    } else {
                        v.root_end()?;
                        depth = 0;
                        done = true;
                    }
                }
                last_end = base + span.end();
            }
            Token::Text { text: t } | Token::Cdata { text: t, .. } => {
                let cdata = matches!(token, Token::Cdata { .. });
                if depth > 0 {
                    v.text(Text {
                        on_root: depth == 1,
                        text: t.as_str(),
                        at: base + t.start(),
                        cdata,
                    })?;
                }
                last_end = base + t.end();
            }
        }
    }
    if !done {
        return Err(err(K::Truncated, text.len()));
    }
    let id = id.ok_or(err(K::MissingId, base))?;
    Ok(Header { id, ts })
}

/// The error of a token the tokenizer refused: trailing garbage after the
/// root (`done`), a message cut short, or malformed XML. `last_end` is the
/// datagram offset after the last good token, `lead` the length of the
/// whitespace the datagram starts with (a resumed walk's tokens start
/// later, but the rule is the whole datagram's).
#[cold]
fn token_error(
    e: &xmlparser::Error,
    done: bool,
    text: &str,
    lead: usize,
    last_end: usize,
) -> DecodeError {
    let kind = if done {
        K::TrailingGarbage
    } else if ends_early(e) || unfinished_tail(text, last_end, last_end == lead) {
        // The tokenizer stopped because the input did.
        K::Truncated
    } else {
        K::Malformed
    };
    err(kind, last_end)
}

/// Whether the input after the last complete token is only the start of
/// one (`<`, `</Ts_`, `<P_act X="1" `): no `>` outside quotes, so more bytes
/// could have completed it. Error path only: linear in the tail.
fn unfinished_tail(text: &str, from: usize, first: bool) -> bool {
    let Some(tail) = text.as_bytes().get(from..) else {
        return false;
    };
    if first && !tail.contains(&b'<') {
        // Text without any markup (`hello robot`) is no cut message.
        return false;
    }
    let mut quote: Option<u8> = None;
    for &b in tail {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if q == b => quote = None,
            (None, b'>') => return false,
            _ => {}
        }
    }
    true
}

/// Whether the tokenizer failed because the input stopped mid-token.
fn ends_early(e: &xmlparser::Error) -> bool {
    use xmlparser::{Error as E, StreamError};
    match e {
        E::InvalidDeclaration(s, _)
        | E::InvalidComment(s, _)
        | E::InvalidPI(s, _)
        | E::InvalidDoctype(s, _)
        | E::InvalidEntity(s, _)
        | E::InvalidElement(s, _)
        | E::InvalidAttribute(s, _)
        | E::InvalidCdata(s, _)
        | E::InvalidCharData(s, _) => matches!(s, StreamError::UnexpectedEndOfStream),
        E::UnknownToken(_) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    /// The events of a walk, as the test visitor records them.
    #[derive(Debug, PartialEq)]
    enum Event<'a> {
        Child(&'a str, &'a str, usize),
        Attr(bool, &'a str, &'a str, &'a str, usize),
        Text(bool, &'a str, usize, bool),
        Other(usize),
        ChildEnd,
        RootEnd,
    }

    #[derive(Default)]
    struct Record<'a>(Vec<Event<'a>>);

    impl<'a> Visitor<'a> for Record<'a> {
        fn child(&mut self, prefix: &'a str, name: &'a str, at: usize) -> Result<(), DecodeError> {
            self.0.push(Event::Child(prefix, name, at));
            Ok(())
        }
        fn attr(&mut self, a: Attr<'a>) -> Result<(), DecodeError> {
            self.0
                .push(Event::Attr(a.on_root, a.prefix, a.name, a.value, a.at));
            Ok(())
        }
        fn text(&mut self, t: Text<'a>) -> Result<(), DecodeError> {
            self.0.push(Event::Text(t.on_root, t.text, t.at, t.cdata));
            Ok(())
        }
        fn other(&mut self, at: usize) -> Result<(), DecodeError> {
            self.0.push(Event::Other(at));
            Ok(())
        }
        fn child_end(&mut self) -> Result<(), DecodeError> {
            self.0.push(Event::ChildEnd);
            Ok(())
        }
        fn root_end(&mut self) -> Result<(), DecodeError> {
            self.0.push(Event::RootEnd);
            Ok(())
        }
    }

    /// Every event of `text` (root `R`) and how the walk ended.
    fn events(text: &str) -> (Vec<Event<'_>>, Result<Header, DecodeError>) {
        let mut v = Record::default();
        let header = walk(text, "R", &mut v, None);
        (v.0, header)
    }

    fn kind(text: &str) -> (K, usize) {
        let e = events(text).1.expect_err(text);
        (e.kind, e.offset)
    }

    #[test]
    fn m1_m4_a_message_as_events_with_offsets() {
        let text =
            r#" <?xml version="1.0"?><R Id="7" Ts="1.5" U="u"><A>1</A><B X="2"/><!--c--></R>"#;
        let (ev, header) = events(text);
        assert_eq!(
            header,
            Ok(Header {
                id: 7,
                ts: Some(Time::from_micros(1_500_000))
            })
        );
        let at = |s: &str| text.find(s).unwrap();
        assert_eq!(
            ev,
            [
                Event::Attr(true, "", "U", "u", at("u\"")),
                Event::Child("", "A", at("<A>")),
                Event::Text(false, "1", at("1<"), false),
                Event::ChildEnd,
                Event::Child("", "B", at("<B")),
                Event::Attr(false, "", "X", "2", at("2\"")),
                Event::ChildEnd,
                Event::Other(at("<!--")),
                Event::RootEnd,
            ]
        );
    }

    #[test]
    fn m1_a_value_body_and_cdata_are_root_text() {
        let (ev, header) = events("<R Id=\"1\"><![CDATA[a<b]]></R>");
        assert_eq!(header.map(|h| h.id), Ok(1));
        assert_eq!(ev, [Event::Text(true, "a<b", 19, true), Event::RootEnd]);
        let (ev, _) = events("<R Id=\"1\"/>");
        assert_eq!(ev, [Event::RootEnd]);
    }

    #[test]
    fn m1_structural_rules_are_checked_here() {
        assert_eq!(kind("<S Id=\"1\"/>"), (K::WrongRoot, 0));
        assert_eq!(kind("<p:R Id=\"1\"/>"), (K::WrongRoot, 0));
        assert_eq!(kind("<R Ts=\"1\"/>"), (K::MissingId, 9));
        assert_eq!(kind("<R Id=\"1\" Id=\"2\"/>").0, K::Duplicate);
        assert_eq!(kind("<R Id=\"x\"/>"), (K::InvalidId, 7));
        assert_eq!(kind("<R Id=\"1\" Ts=\"now\"/>").0, K::InvalidTs);
        assert_eq!(kind("<R Id=\"1\"><A><B/></A></R>").0, K::TooDeep);
        assert_eq!(kind("<R Id=\"1\"><A></B></R>").0, K::MismatchedTag);
        assert_eq!(kind("<R Id=\"1\"></S>").0, K::MismatchedTag);
        assert_eq!(kind("<!DOCTYPE R><R Id=\"1\"/>").0, K::Doctype);
        assert_eq!(kind("<R Id=\"1\"/><R Id=\"2\"/>").0, K::TrailingGarbage);
        assert_eq!(kind("<R Id=\"1\"><A>1</A>").0, K::Truncated);
        assert_eq!(kind("<R Id=\"1\"><A X=\"1").0, K::Truncated);
        assert_eq!(kind("hello robot").0, K::Malformed);
        // An Id on a child is just an attribute of the child.
        let (ev, header) = events("<R Id=\"1\"><A Id=\"2\"/></R>");
        assert_eq!(header.map(|h| h.id), Ok(1));
        assert_eq!(ev[1], Event::Attr(false, "", "Id", "2", 17));
    }

    #[test]
    fn an_error_of_the_visitor_ends_the_walk() {
        struct Refuse;
        impl<'a> Visitor<'a> for Refuse {
            fn child(&mut self, _: &'a str, _: &'a str, at: usize) -> Result<(), DecodeError> {
                Err(err(K::Duplicate, at))
            }
            fn attr(&mut self, _: Attr<'a>) -> Result<(), DecodeError> {
                Ok(())
            }
            fn text(&mut self, _: Text<'a>) -> Result<(), DecodeError> {
                Ok(())
            }
            fn other(&mut self, _: usize) -> Result<(), DecodeError> {
                Ok(())
            }
            fn child_end(&mut self) -> Result<(), DecodeError> {
                panic!("the walk went on after an error")
            }
            fn root_end(&mut self) -> Result<(), DecodeError> {
                panic!("the walk went on after an error")
            }
        }
        let e = walk("<R Id=\"1\"><A/></R>", "R", &mut Refuse, None).unwrap_err();
        assert_eq!((e.kind, e.offset), (K::Duplicate, 10));
    }

    #[test]
    fn trailing_comments_and_whitespace_are_allowed() {
        let (ev, header) = events("<R Id=\"1\"/> <!--x--> \n");
        assert_eq!(header.map(|h| h.id), Ok(1));
        assert_eq!(ev.last(), Some(&Event::Other(12)));
    }
}
