//! The compiled path's primitives on hand-made inputs. The generated
//! matchers themselves are tested per shape, and against the general
//! decoder, in `host-tests/tests/compiled.rs`.
use super::*;

fn scan(text: &str) -> Scan<'_> {
    Scan {
        rest: text.as_bytes(),
        tally: Tally::default(),
        gap: (usize::MAX, 0),
        hand_over: hand_over(text.as_bytes()),
        len: text.len(),
        seen: 0,
    }
}

/// A hand-over table for `bytes` that lives as long as the test.
fn hand_over(bytes: &[u8]) -> &'static mut HandOver {
    std::boxed::Box::leak(std::boxed::Box::new(HandOver::new(bytes)))
}

/// A long run of whitespace before attributes that are not there: every
/// try leaves it unread (nothing consumed), the run is noted once and
/// then jumped, and the element's end after it is found (issue 36: each
/// try used to read the whole run again).
#[test]
fn a_long_gap_is_read_once_and_every_try_after_it_sees_it() {
    let text = format!("{}\t\n{}/>", " ".repeat(3_000), " ".repeat(500));
    let mut s = scan(&text);
    for lit in [b" Y=\"", b" Z=\""] {
        assert!(!s.attr(lit));
        assert_eq!(s.rest.len(), text.len(), "nothing consumed");
    }
    assert_eq!(s.gap, (text.len(), 2), "the run noted: all but `/>`");
    assert!(!s.element(1), "X1 is not there either");
    assert_eq!(s.rest.len(), text.len());
    assert_eq!(s.values_end(1, 18, b"</AppData>"), Some(()));
    assert_eq!(rest(&s), "");
    // Two long runs: the second is read, not taken for the first.
    let two = format!("{0}X=\"1\"{0}/>", " ".repeat(20));
    let mut t = scan(&two);
    assert!(t.attr(b" X=\""));
    assert_eq!(t.real(), Some(1.0));
    assert_eq!(t.values_end(1, 18, b"</AppData>"), Some(()));
    assert_eq!(rest(&t), "");
}

fn rest<'a>(s: &Scan<'a>) -> &'a str {
    core::str::from_utf8(s.rest).unwrap()
}

#[test]
fn literals_compare_a_word_at_a_time_at_every_length() {
    let text = b"<RobData Id=\"1\">0123456789abcdef";
    for n in 0..text.len() {
        let lit: heapless::Vec<u8, 64> = heapless::Vec::from_slice(&text[..n]).unwrap();
        macro_rules! check {
            ($($len:literal)*) => {$(
                if n == $len {
                    let lit: &[u8; $len] = lit.as_slice().try_into().unwrap();
                    assert!(same(lit, lit));
                    for i in 0..$len {
                        let mut other = *lit;
                        other[i] ^= 0x20;
                        assert!(!same(lit, &other), "length {} byte {i}", $len);
                    }
                }
            )*};
        }
        check!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25);
    }
}

#[test]
fn m1_the_root_its_id_and_ts() {
    let (s, root) = Scan::root(
        b" \n<RobData Id=\"7\" Ts=\"1.5\">",
        b"<RobData",
        hand_over(b""),
    )
    .unwrap();
    assert_eq!((root.id, root.ts), (7, Some(Time::from_micros(1_500_000))));
    assert_eq!(rest(&s), ">");
    let (_, root) = Scan::root(b"<RobData\tId = \"7\"/>", b"<RobData", hand_over(b"")).unwrap();
    assert_eq!((root.id, root.ts), (7, None));
    for bad in [
        "<RobDataX Id=\"7\">",
        "<RobData Ts=\"1\" Id=\"7\">",
        "<RobData Id='7'>",
        "<RobData Id=\"7x\">",
        "<RobData Id=\"&#55;\">",
        "<RobData>",
        "<!--c--><RobData Id=\"7\">",
    ] {
        assert!(
            Scan::root(bad.as_bytes(), b"<RobData", hand_over(b"")).is_none(),
            "{bad}"
        );
    }
}

#[test]
fn m1_declarations_as_xmlparser_reads_them() {
    for good in [
        "<?xml version=\"1.0\"?>",
        "<?xml version=\"1.0\" ?>",
        "<?xml version=\"1.1\" encoding=\"UTF-8\"?>",
        "<?xml version=\"1.0\" encoding=\"ISO-8859_1.x\" standalone=\"no\"?>",
        "<?xml version=\"1.0\"\tstandalone=\"yes\"\n?>",
    ] {
        let text = format!("{good}\n<R Id=\"1\">");
        assert!(
            Scan::root(text.as_bytes(), b"<R", hand_over(b"")).is_some(),
            "{good}"
        );
    }
    for handed_over in [
        "<?xml version='1.0'?>",
        "<?xml  version=\"1.0\"?>",
        "<?xml version=\"1.\"?>",
        "<?xml version=\"2.0\"?>",
        "<?xml version=\"1.0\"encoding=\"UTF-8\"?>",
        "<?xml version=\"1.0\" encoding=\"8bit\"?>",
        "<?xml version=\"1.0\" standalone=\"maybe\"?>",
        "<?xml version=\"1.0\" standalone=\"yes\" encoding=\"UTF-8\"?>",
        "<?xml version=\"1.0\" foo=\"bar\"?>",
        "<?xml-stylesheet href=\"a\"?>",
        "<?xml version=\"1.0\"",
    ] {
        let text = format!("{handed_over}<R Id=\"1\">");
        assert!(
            Scan::root(text.as_bytes(), b"<R", hand_over(b"")).is_none(),
            "{handed_over}"
        );
    }
}

#[test]
fn m3_start_tags_and_text() {
    let mut s = scan(" \n<Ts_act>1.5</Ts_act><P_act X");
    assert!(!s.open(b"<RobMode>"), "another field");
    assert!(s.open(b"<Ts_act>"));
    assert_eq!(
        s.text(b"</Ts_act>", time),
        Some(Time::from_micros(1_500_000))
    );
    assert!(!s.open(b"<P_ac>"));
    assert!(!s.open_attrs(b"<P_ac"), "a name ends at a delimiter");
    assert!(s.open_attrs(b"<P_act"));
    assert_eq!(rest(&s), " X");
    let mut s = scan("<Ts_act\n>2</Ts_act\t>");
    assert!(s.open(b"<Ts_act>"));
    assert_eq!(s.text(b"</Ts_act>", real), Some(2.0));
    assert_eq!(rest(&s), "");
}

#[test]
fn text_with_markup_references_or_other_bytes_is_not_taken() {
    for bad in [
        "a&amp;b</N>",
        "a>b</N>",
        "a]]>b</N>",
        "a\u{1}b</N>",
        "\u{e9}</N>",
        "ab",
        "ab</M>",
        "ab<!--c--></N>",
    ] {
        let mut s = scan(bad);
        assert_eq!(s.text(b"</N>", string), None, "{bad:?}");
    }
    let mut s = scan("a\tb\r\nc'\"=/</N>");
    assert_eq!(s.text(b"</N>", string).as_deref(), Some("a\tb\r\nc'\"=/"));
}

#[test]
fn m4_attributes_compact_and_spaced() {
    let mut s = scan(" X=\"1\"\n\t Rx = \"2\" Y=\"3\"");
    assert!(s.attr(b" X=\""));
    assert_eq!(s.real(), Some(1.0));
    assert!(!s.attr(b" R=\""), "a name ends at a delimiter");
    assert!(s.attr(b" Rx=\""));
    assert_eq!(s.real(), Some(2.0));
    assert!(
        !s.attr(b" X=\""),
        "not the next attribute: nothing consumed"
    );
    assert!(s.attr(b" Y=\""));
    assert_eq!(s.value(), Some(&b"3"[..]));
    assert!(
        !scan("X=\"1\"").attr(b" X=\""),
        "whitespace must separate attributes"
    );
    assert!(
        !scan(" X='1'").attr(b" X=\""),
        "single quotes go to the general path"
    );
}

#[test]
fn m4_array_element_names_without_leading_zeros() {
    let mut s = scan(" X1=\"1\" X2 = \"2\"\n X10=\"10\"");
    assert!(s.element(1));
    assert_eq!(s.real(), Some(1.0));
    assert!(!s.element(1), "X2 is not X1");
    assert!(s.element(2));
    assert_eq!(s.real(), Some(2.0));
    assert!(!s.element(1), "X10 is not X1");
    assert!(s.element(10));
    for bad in [
        " X01=\"",
        " X0=\"",
        " X1a=\"",
        " x1=\"",
        " X=\"",
        " X1000000=\"",
    ] {
        assert!(!scan(bad).element(1) && !scan(bad).element(1000), "{bad}");
    }
    assert!(scan(" X1000=\"").element(1000));
}

#[test]
fn values_stop_at_their_quote_and_refuse_what_the_general_path_must_see() {
    assert_eq!(scan("a >b\"").value(), Some(&b"a >b"[..]));
    for bad in ["a<b\"", "a&b\"", "a\u{0}\"", "\u{e9}\"", "ab"] {
        assert_eq!(scan(bad).value(), None, "{bad:?}");
    }
}

#[test]
fn m5_reals_in_place_or_by_the_general_parser() {
    for (text, v) in [
        ("1620.000\"", 1620.0f32),
        ("-0.000497347\"", -0.000497347),
        ("1.21592e-06\"", 1.21592e-06),
        (" 5 \"", 5.0),
        ("12345678901234567890123\"", 1.2345679e22),
    ] {
        let mut s = scan(text);
        assert_eq!(s.real().map(f32::to_bits), Some(v.to_bits()), "{text}");
        assert_eq!(rest(&s), "");
    }
    for bad in ["1x\"", "1", "\"", "1e99\"", "--1\""] {
        assert_eq!(scan(bad).real(), None, "{bad}");
    }
}

#[test]
fn m2_m4_the_end_of_a_field_of_attributes_counts_what_was_left_out() {
    let ends = |text: &str, n: usize| {
        let mut s = scan(text);
        let r = s.values_end(n, 6, b"</P>");
        (r.is_some(), s.tally, rest(&s).len())
    };
    let t = |missing_values, shape_mismatches| Tally {
        missing_values,
        shape_mismatches,
        ..Tally::default()
    };
    assert_eq!(ends(" />", 6), (true, t(0, 0), 0));
    assert_eq!(ends("/>", 2), (true, t(4, 0), 0));
    assert_eq!(ends("/>", 0), (true, t(0, 1), 0));
    assert_eq!(ends(">0</P>", 0), (true, t(0, 1), 0));
    assert_eq!(ends("></P >", 0), (true, t(0, 1), 0));
    assert!(!ends(">0</P>", 1).0, "values and text: the general path's");
    assert!(!ends(" Q=\"1\"/>", 6).0);
}

#[test]
fn the_end_of_the_message_allows_only_whitespace_after_the_root() {
    let root = Root { id: 1, ts: None };
    assert!(scan("</R> \r\n\t").end(root, b"</R>").is_some());
    assert!(scan(" </R\n>").end(root, b"</R>").is_some());
    for bad in ["</R>x", "</R><!---->", "</R><R/>", "</S>", "</R"] {
        assert!(scan(bad).end(root, b"</R>").is_none(), "{bad}");
    }
}
