//! The binding layer on a hand-written layout: a record `<T>` with a
//! real `A` and a frame `P`.
use super::*;
use crate::schema::{Direction, FieldMut, FieldRef, FieldWire, Message};
use crate::value::Frame;

#[derive(Default)]
struct Data {
    a: f32,
    p: Frame,
}

struct T;

impl Message for T {
    type Data = Data;
    const NAME: &'static str = "T";
    const WIRE_NAME: &'static str = "T";
    const DIRECTION: Direction = Direction::RobotToDevice;
    const MAX_ENCODED_LEN: usize = 0;
    const MAX_RECEIVE_LEN: usize = 512;
}

impl MessageCodec for T {
    const BODY: Body = Body::Record;
    const OPEN: &'static [u8] = b"";
    const CLOSE: &'static [u8] = b"";
    const FIELDS: &'static [FieldWire] = &[
        FieldWire::new(b"A", b"", b""),
        FieldWire::new(b"P", b"", b""),
    ];
    fn field_index(name: &[u8]) -> Option<usize> {
        match name {
            b"A" => Some(0),
            b"P" => Some(1),
            _ => None,
        }
    }
    fn field(data: &Data, index: usize) -> Option<FieldRef<'_>> {
        match index {
            0 => Some(FieldRef::Real(data.a)),
            1 => Some(FieldRef::Frame(&data.p)),
            _ => None,
        }
    }
    fn field_mut(data: &mut Data, index: usize) -> Option<FieldMut<'_>> {
        match index {
            0 => Some(FieldMut::Real(&mut data.a)),
            1 => Some(FieldMut::Frame(&mut data.p)),
            _ => None,
        }
    }
}

fn run(text: &str) -> (Data, Result<Decoded, DecodeError>) {
    let mut data = Data::default();
    let r = decode::<T>(text.as_bytes(), &mut data);
    (data, r)
}

/// The general path takes a real the compiled path kept for exactly
/// its bytes (a planted value shows it was taken, not parsed), and
/// parses every other one.
#[test]
fn m5_a_real_handed_over_is_taken_not_parsed_again() {
    let text = r#"<T Id="3"><P X="1e0" Y="2e0"/></T>"#;
    let bytes = text.as_bytes();
    let x = text.find("1e0").unwrap();
    let mut hand_over = HandOver::new(bytes);
    hand_over.keep(&bytes[x..x + 3], 42.0);
    let mut data = Data::default();
    general::<T>(bytes, &mut data, &mut hand_over).unwrap();
    assert_eq!((data.p.x, data.p.y), (42.0, 2.0));
}

#[test]
fn m2_m4_fields_bind_by_name_in_any_order() {
    let (d, r) = run(r#"<T Id="3"><P X="1" Rz="-2"/><A>2.5</A></T>"#);
    let r = r.unwrap();
    assert_eq!((r.id, d.a, d.p.x, d.p.rz), (3, 2.5, 1.0, -2.0));
    // Y, Z, Rx, Ry were not sent: kept, and counted.
    let missing = Tally {
        missing_values: 4,
        ..Tally::default()
    };
    assert_eq!(r.tally, missing);
}

#[test]
fn m2_unknown_items_are_counted_and_missing_fields_kept() {
    let (d, r) = run(r#"<T Id="1" Mode="x">hi<Q>1</Q><A B="1">4</A></T>"#);
    let t = r.unwrap().tally;
    assert_eq!(d.a, 4.0);
    assert_eq!(
        (
            t.unknown_elements,
            t.unknown_attributes,
            t.stray_text,
            t.missing_fields
        ),
        (1, 2, 1, 1)
    );
}

#[test]
fn m2_a_field_twice_is_an_error_at_its_second_start() {
    let text = r#"<T Id="1"><A>1</A><A>2</A></T>"#;
    let e = run(text).1.unwrap_err();
    assert_eq!((e.kind, e.offset), (DecodeErrorKind::Duplicate, 18));
}

/// An unknown attribute is one extra wherever it stands in a value's
/// attributes: before its components or after them (it used to count
/// twice after them: exactness list of issue 36).
#[test]
fn an_unknown_attribute_costs_the_same_before_and_after_a_values_components() {
    let frame = r#"X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6""#;
    // Two fields + EXTRA_ITEMS extras are allowed.
    let unknown: String = (1..=2 + EXTRA_ITEMS)
        .map(|i| format!(r#" U{i}="0""#))
        .collect();
    let after = format!(r#"<T Id="1"><P {frame}{unknown}/></T>"#);
    let before = format!(r#"<T Id="1"><P{unknown} {frame}/></T>"#);
    for text in [&after, &before] {
        let (d, r) = run(text);
        let t = r.unwrap_or_else(|e| panic!("{text}: {e:?}")).tally;
        assert_eq!(
            (t.unknown_attributes, d.p.rz),
            (2 + EXTRA_ITEMS as u16, 6.0)
        );
    }
    let one_more = |text: &str| text.replace("U1=", "U0=\"0\" U1=");
    for text in [one_more(&after), one_more(&before)] {
        assert_eq!(
            run(&text).1.unwrap_err().kind,
            DecodeErrorKind::TooManyExtras,
            "{text}"
        );
    }
}

#[test]
fn extras_beyond_the_layout_are_refused() {
    // Two fields + EXTRA_ITEMS extras are allowed; one more is not.
    let comments = "<!---->".repeat(2 + EXTRA_ITEMS);
    assert!(run(&format!(r#"<T Id="1">{comments}</T>"#)).1.is_ok());
    let e = run(&format!(r#"<T Id="1">{comments}<!----></T>"#))
        .1
        .unwrap_err();
    assert_eq!(e.kind, DecodeErrorKind::TooManyExtras);
}
