//! The compiled decode path (`codec::compiled`, generated per robot
//! property by the build) shape by shape: each shape it takes, with the
//! answer the general path gives for the same bytes (checked by
//! `differential::agree`), and each kind of byte that hands a datagram
//! over to the general path, with the general path's answer asserted.

use host_tests::differential::{agree, prior};
use host_tests::layouts::{anydevice as manual, every_type as et, several, udptest};
use host_tests::shared_rri;
use rri_firmware::codec::{DecodeErrorKind as K, Decoded, Tally};
use rri_firmware::schema::MessageCodec;
use rri_firmware::value::{Frame, Time};
use std::fmt::Debug;

/// `text` decoded from [`prior`]: the compiled path must take it, and
/// agree with the general path.
fn takes<M: MessageCodec>(text: &str) -> (Decoded, M::Data)
where
    M::Data: Default + Clone + Debug,
{
    let a = agree::<M>(text.as_bytes(), &prior::<M>());
    let d = a
        .compiled
        .unwrap_or_else(|| panic!("the compiled path handed over {text:?}"));
    (d, a.data)
}

/// `text` must go to the general path; its answer.
fn handed_over<M: MessageCodec>(text: &str) -> Result<Decoded, K>
where
    M::Data: Default + Clone + Debug,
{
    let a = agree::<M>(text.as_bytes(), &prior::<M>());
    assert!(a.compiled.is_none(), "the compiled path took {text:?}");
    a.general.map_err(|e| e.kind)
}

fn read(path: &str) -> String {
    std::fs::read_to_string(shared_rri().join(path)).expect("protocol material")
}

fn bench(name: &str) -> String {
    std::fs::read_to_string(host_tests::workspace().join("host-tests/bench").join(name))
        .expect("bench message")
}

const COMPACT: &str = r#"<RobData Id="7" Ts="1.5"><RobMode>ManRS</RobMode><Ts_act>1.2</Ts_act><P_act X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><J_act J1="1" J2="2" J3="3" J4="4" J5="5" J6="6"/><Ts_des>1.25</Ts_des><P_des X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><J_des J1="1" J2="2" J3="3" J4="4" J5="5" J6="6"/><AppData X1="1" X2="2" X3="3" X4="4" X5="5" X6="6" X7="7" X8="8" X9="9" X10="10" X11="11" X12="12" X13="13" X14="14" X15="15" X16="16" X17="17" X18="18"/></RobData>"#;

fn nothing_tolerated(d: &Decoded) {
    assert_eq!(d.tally, Tally::default());
}

// --- Shapes the compiled path takes ----------------------------------------

#[test]
fn m9_the_manuals_message_as_printed_compact_and_at_its_maximum() {
    let (d, data) = takes::<manual::RobDataMessage>(&read("examples/messages/RobData.xml"));
    assert_eq!((d.id, d.ts), (111, Some(Time::from_micros(1_202_000))));
    nothing_tolerated(&d);
    assert_eq!(
        data.feedback_pose.rz, 100.0,
        "an attribute after a line break"
    );
    assert_eq!(data.application_data[17], 1620.0);
    let (d, _) = takes::<manual::RobDataMessage>(&bench("RobData-compact.xml"));
    nothing_tolerated(&d);
    let (d, data) = takes::<manual::RobDataMessage>(&bench("RobData-max.xml"));
    assert_eq!(d.id, u32::MAX);
    assert_eq!(data.operation_mode, manual::OperationMode::ReducedSpeed);
    assert_eq!(data.planned_joints[5], -12_345.679);
    let (d, _) = takes::<manual::RobDataMessage>(COMPACT);
    nothing_tolerated(&d);
}

#[test]
fn the_real_irc5_capture_no_robmode_and_appdata_as_text() {
    // No whitespace, exponents, RobMode left out, `<AppData>0</AppData>`
    // where the layout has 20 reals: tolerated and counted as the general
    // path counts them (M2).
    let (d, data) = takes::<udptest::RsRobDataMessage>(&read("real-world/captured-RobData.xml"));
    assert_eq!(
        d.tally,
        Tally {
            missing_fields: 1,
            shape_mismatches: 1,
            ..Tally::default()
        }
    );
    assert_eq!(data.feedback_joints[3], 1.21592e-06);
    assert_eq!(data.application_data, [7.25; 20], "previous value kept");
}

#[test]
fn m1_a_declaration_and_whitespace_around_the_root() {
    for prologue in [
        "<?xml version=\"1.0\"?>",
        " \r\n\t<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n",
        "<?xml version=\"1.0\" encoding=\"utf-8\" standalone=\"yes\" ?>",
        "<?xml version=\"1.1\" standalone=\"no\"?>",
        "\n\n",
    ] {
        let (d, _) = takes::<manual::RobDataMessage>(&format!("{prologue}{COMPACT}\r\n \t"));
        assert_eq!(d.id, 7, "{prologue:?}");
    }
}

#[test]
fn xml_whitespace_wherever_xml_allows_it() {
    let spaced = COMPACT
        .replace(
            "<RobData Id=\"7\" Ts=\"1.5\">",
            "<RobData\n Id = \"7\"\tTs=\r\n\"1.5\" >",
        )
        .replace("</RobMode>", "</RobMode \n>")
        .replace("<Ts_act>", "<Ts_act\t>")
        .replace(" Y=", "\n    Y=")
        .replace("Rz=\"6\"/>", "Rz = \"6\" />")
        .replace(" X10=", "\r\n X10 =")
        .replace("</RobData>", "</RobData  >");
    let (d, data) = takes::<manual::RobDataMessage>(&spaced);
    nothing_tolerated(&d);
    assert_eq!(
        (data.feedback_pose.y, data.application_data[9]),
        (2.0, 10.0)
    );
    // Whitespace inside text values is the general path's to trim; the
    // compiled path hands the same text to the same parsers.
    let (_, data) = takes::<manual::RobDataMessage>(&COMPACT.replace(">1.2<", "> 1.2\n<"));
    assert_eq!(data.feedback_time, Time::from_micros(1_200_000));
}

#[test]
fn m2_fields_left_out_keep_their_value_and_are_counted() {
    let no_pose = COMPACT.replace(r#"<P_act X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/>"#, "");
    let (d, data) = takes::<manual::RobDataMessage>(&no_pose);
    assert_eq!(d.tally.missing_fields, 1);
    assert_eq!(
        data.feedback_pose,
        prior::<manual::RobDataMessage>().feedback_pose
    );
    let (d, data) = takes::<manual::RobDataMessage>(r#"<RobData Id="1"></RobData>"#);
    assert_eq!((d.tally.missing_fields, d.ts), (8, None));
    assert_eq!(
        format!("{data:?}"),
        format!("{:?}", prior::<manual::RobDataMessage>())
    );
}

#[test]
fn m4_attributes_left_out_keep_their_value_and_are_counted() {
    let text = COMPACT
        .replace(r#" Ry="5""#, "")
        .replace(r#" X5="5""#, "")
        .replace(r#" X18="18""#, "")
        .replace(r#" J1="1""#, "");
    let (d, data) = takes::<manual::RobDataMessage>(&text);
    // Ry and J1 of both poses and joints, X5 and X18.
    assert_eq!(d.tally.missing_values, 6);
    let before = prior::<manual::RobDataMessage>();
    assert_eq!(data.feedback_pose.ry, before.feedback_pose.ry);
    assert_eq!(data.feedback_joints[0], before.feedback_joints[0]);
    assert_eq!(data.application_data[4], 7.25);
    assert_eq!(data.application_data[5], 6.0);
}

#[test]
fn m4_wrong_shapes_of_a_field_of_attributes_are_counted() {
    for appdata in [
        "<AppData>0</AppData>",
        "<AppData></AppData>",
        "<AppData/>",
        "<AppData >  </AppData>",
    ] {
        let text = COMPACT.replace(
            &COMPACT[COMPACT.find("<AppData").unwrap()..COMPACT.find("</RobData>").unwrap()],
            appdata,
        );
        let (d, data) = takes::<manual::RobDataMessage>(&text);
        assert_eq!(d.tally.shape_mismatches, 1, "{appdata}");
        assert_eq!(data.application_data, [7.25; 18], "{appdata}");
    }
}

#[test]
fn m5_numbers_in_every_form_the_general_path_reads() {
    for (text, value) in [
        ("1.21592e-06", 1.21592e-06f32),
        ("-0.000497347", -0.000497347),
        ("+12", 12.0),
        (".5", 0.5),
        ("5.", 5.0),
        ("-0", -0.0),
        ("1E3", 1000.0),
        ("12345678901234567890123", 1.2345679e22),
        ("3.4028235e38", f32::MAX),
        ("1e-45", 1e-45),
        (" 7 ", 7.0),
    ] {
        let msg = COMPACT.replace(r#"X="1""#, &format!(r#"X="{text}""#));
        let (_, data) = takes::<manual::RobDataMessage>(&msg);
        assert_eq!(data.feedback_pose.x.to_bits(), value.to_bits(), "{text}");
    }
    let (_, data) = takes::<manual::RobDataMessage>(&COMPACT.replace(">1.2<", ">12e-1<"));
    assert_eq!(data.feedback_time, Time::from_micros(1_200_000));
}

#[test]
fn every_type_strings_bools_enums_and_arrays_of_each() {
    let text = r#"<RobData Id="3" Ts="0.004"><RobMode>Auto</RobMode><Ts_act>1</Ts_act><P_act X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><J_act J1="1" J2="2" J3="3" J4="4" J5="5" J6="6"/><Enabled>TRUE</Enabled><Gain>0.5</Gain><Note>welding seam 2, pass 1</Note><Phase>Approach</Phase><Target X="9" Y="8" Z="7" Rx="6" Ry="5" Rz="4"/><Fl X1="true" X2="0" X3="FALSE"/><Stamps X1="1.5" X2="2.25"/><Labels X1="a b" X2=""/><AppData X1="1" X2="2" X3="3" X4="4"/></RobData>"#;
    let (d, data) = takes::<et::RsRobDataMessage>(text);
    nothing_tolerated(&d);
    assert!(data.enabled);
    assert_eq!(data.note.as_str(), "welding seam 2, pass 1");
    assert_eq!(data.phase, et::Phase::Approach);
    assert_eq!(data.flags, [true, false, false]);
    assert_eq!(data.stamps[1], Time::from_micros(2_250_000));
    assert_eq!(
        (data.labels[0].as_str(), data.labels[1].as_str()),
        ("a b", "")
    );
    // An empty string is a value, not a missing one (as the general path).
    let (d, data) = takes::<et::RsRobDataMessage>(&text.replace("welding seam 2, pass 1", ""));
    nothing_tolerated(&d);
    assert_eq!(data.note.as_str(), "");
}

#[test]
fn m1_values_on_the_root_text_and_attributes() {
    let (d, data) = takes::<et::SpeedMessage>(r#"<Speed Id="9" Ts="2">-1.5e2</Speed>"#);
    assert_eq!((d.id, data), (9, -150.0));
    let (d, data) =
        takes::<several::ToolMessage>(r#"<Tool Id="9" X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/>"#);
    nothing_tolerated(&d);
    assert_eq!(
        data,
        Frame {
            x: 1.0,
            y: 2.0,
            z: 3.0,
            rx: 4.0,
            ry: 5.0,
            rz: 6.0
        }
    );
    let (d, _) = takes::<several::ToolMessage>(r#"<Tool Id="9" X="1"/>"#);
    assert_eq!(d.tally.missing_values, 5);
    let (d, _) = takes::<several::ToolMessage>(r#"<Tool Id="9">0</Tool>"#);
    assert_eq!(d.tally.shape_mismatches, 1);
}

// --- Bytes that hand a datagram over to the general path --------------------

#[test]
fn markup_the_compiled_path_does_not_read_goes_to_the_general_path() {
    let over = handed_over::<manual::RobDataMessage>;
    // A comment before the end tag (the bench's hand-over input): taken
    // by the general path and counted as an extra item, not an error.
    assert!(over(&COMPACT.replace("</RobData>", "<!-- c --></RobData>")).is_ok());
    assert!(over(&COMPACT.replace("<Ts_act>", "<?pi x?><Ts_act>")).is_ok());
    assert!(over(&COMPACT.replace(">1.2<", "><![CDATA[1.2]]><")).is_ok());
    assert!(over(&format!("<!-- before -->{COMPACT}")).is_ok());
    assert!(over(&format!("{COMPACT}<!-- after -->")).is_ok());
    assert_eq!(
        over(&format!("<!DOCTYPE RobData>{COMPACT}")),
        Err(K::Doctype)
    );
}

/// Issue 36, finding 2: the reals the compiled path read the slow way
/// before it handed a datagram over are handed over with it
/// (`codec::HandOver`) and not parsed again; `agree` holds `decode`, which
/// does that, to the general path alone, value for value (records are
/// compared bit for bit through their `Debug` text). Each real here is
/// one the plain path does not take: an exponent, whitespace, a long
/// mantissa, a halfway case, each in another attribute, with values the
/// compiled path did not keep (plain ones) between them.
#[test]
fn m5_reals_read_before_a_late_hand_over_are_the_general_paths() {
    let halfway = format!("1.000000059604644775390625{}1", "0".repeat(21));
    let slow = [
        "1.5e0",
        " 2 ",
        "-0.0000000000000000000000000000000000011754943",
        &halfway,
        "3.4028235e38",
        "7",
    ];
    let mut text = COMPACT.to_string();
    for (i, v) in slow.iter().enumerate() {
        text = text.replacen(
            &format!(r#" X{}="{}""#, i + 1, i + 1),
            &format!(r#" X{}="{v}""#, i + 1),
            1,
        );
    }
    let late = text.replace("</RobData>", "<!-- c --></RobData>");
    assert!(handed_over::<manual::RobDataMessage>(&late).is_ok());
    let a = agree::<manual::RobDataMessage>(late.as_bytes(), &prior::<manual::RobDataMessage>());
    let app = a.data.application_data;
    let want: Vec<f32> = slow.iter().map(|v| v.trim().parse().unwrap()).collect();
    assert_eq!(
        app[..6].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // Refused late: the same error as the general path's.
    let refused = text.replace("</RobData>", "</RobDatx>");
    assert!(handed_over::<manual::RobDataMessage>(&refused).is_err());
}

/// Issue 36, finding 2 (M1: one root, nothing after it; M2: the fields
/// seen and tolerated carry over): a datagram the compiled path hands over after
/// some of a record's fields is walked by the general path from the end
/// of the last field it read whole (`codec::HandOver`'s mark), not from
/// the start. `agree` holds `decode`, which resumes, to the general path
/// alone, which walks it all: the same answer, error kind and offset
/// included, and the same record. The cases: whatever follows the root
/// (the resumed walk's tokenizer reads a fragment, which takes text,
/// CDATA and tags there as tokens the whole document's refuses), and a
/// hand-over in every field.
#[test]
fn m1_m2_a_late_hand_over_resumes_where_the_compiled_path_stopped() {
    let over = handed_over::<manual::RobDataMessage>;
    for tail in [
        "x",
        "  x",
        "\n<!-- c -->\n",
        "<!-- c -->x",
        "<?pi x?>",
        "<?xml version=\"1.0\"?>",
        "<![CDATA[x]]>",
        "<RobData Id=\"2\"/>",
        "</RobData>",
        "</x>",
        "<!DOCTYPE x>",
        "&amp;",
        "<",
        " <a",
    ] {
        let text = format!("{COMPACT}{tail}");
        let general = over(&text);
        let blank_or_misc = tail.trim().is_empty()
            || tail.trim().starts_with("<!-- c -->") && tail.trim().len() == 10
            || tail.starts_with("<?pi");
        assert_eq!(general.is_ok(), blank_or_misc, "{tail:?}: {general:?}");
    }
    // Before the root's end tag, after whitespace the resumed walk skips
    // (the mark moves past it when a tag follows).
    for end in [
        "   </RobDatx>",
        "   x</RobData>",
        " \n<!-- c --></RobData>",
        "\t</RobData >x",
        "  </RobData",
        "  <",
        "  ",
    ] {
        let text = COMPACT.replace("</RobData>", end);
        agree::<manual::RobDataMessage>(text.as_bytes(), &prior::<manual::RobDataMessage>());
    }
    // A hand-over in each field: a comment inside it, a bad value, the
    // field cut short.
    for field in [
        "<RobMode>",
        "<Ts_act>",
        "<P_act",
        "<J_act",
        "<Ts_des>",
        "<P_des",
        "<J_des",
        "<AppData",
    ] {
        let at = COMPACT.find(field).expect("the field is in the message") + field.len();
        for inner in ["<!-- c -->", "&amp;", "\u{1}", " X=\"y\"", "/"] {
            let text = format!("{}{inner}{}", &COMPACT[..at], &COMPACT[at..]);
            agree::<manual::RobDataMessage>(text.as_bytes(), &prior::<manual::RobDataMessage>());
        }
        let cut = &COMPACT[..at + 3];
        assert!(over(cut).is_err(), "{cut:?}");
    }
}

#[test]
fn references_quotes_and_prefixes_go_to_the_general_path() {
    let over = handed_over::<manual::RobDataMessage>;
    assert!(
        over(&COMPACT.replace(r#"X="1""#, r#"X="&#49;""#)).is_err(),
        "M5: no references in numbers"
    );
    assert!(over(&COMPACT.replace(r#"X="1""#, "X='1'")).is_ok());
    assert_eq!(
        over(&COMPACT.replace("<RobMode>ManRS<", "<RobMode>Man&amp;RS<")),
        Err(K::UnknownEnumMember)
    );
    assert!(over(&COMPACT.replace("<Ts_act>1.2</Ts_act>", "<a:Ts_act>1.2</a:Ts_act>")).is_ok());
    assert!(over(&COMPACT.replace(r#" Y="2""#, r#" a:Y="2""#)).is_ok());
    let (d, _) = takes::<et::RsRobDataMessage>(r#"<RobData Id="1"><Note>a</Note></RobData>"#);
    assert_eq!(d.tally.missing_fields, 12);
    let note =
        handed_over::<et::RsRobDataMessage>(r#"<RobData Id="1"><Note>a &lt; b</Note></RobData>"#);
    assert!(note.is_ok());
}

#[test]
fn elements_and_attributes_out_of_the_layout_go_to_the_general_path() {
    let over = handed_over::<manual::RobDataMessage>;
    // Unknown element and attribute (M2: counted), fields and attributes
    // out of order (M2/M4: taken), repeated (Duplicate / extras).
    let t = over(&COMPACT.replace("<Ts_act>", "<Extra/><Ts_act>")).expect("M2");
    assert_eq!(t.tally.unknown_elements, 1);
    let t = over(&COMPACT.replace(r#" Y="2""#, r#" Y="2" W="0""#)).expect("M2");
    assert_eq!(t.tally.unknown_attributes, 2, "in P_act and P_des");
    assert!(over(&COMPACT.replace(r#" X="1" Y="2""#, r#" Y="2" X="1""#)).is_ok());
    let swapped = COMPACT.replace(
        "<RobMode>ManRS</RobMode><Ts_act>1.2</Ts_act>",
        "<Ts_act>1.2</Ts_act><RobMode>ManRS</RobMode>",
    );
    assert!(over(&swapped).is_ok());
    assert_eq!(
        over(&COMPACT.replace("</RobData>", "<Ts_act>1</Ts_act></RobData>")),
        Err(K::Duplicate)
    );
    assert_eq!(
        over(&COMPACT.replace(r#" Ts="1.5""#, r#" Ts="1.5" Ts="2""#)),
        Err(K::Duplicate)
    );
    assert!(over(&COMPACT.replace(r#" X2="2""#, r#" X2="2" X2="3""#)).is_ok());
    assert!(
        over(&COMPACT.replace(r#" X2="2""#, r#" X02="2""#)).is_ok(),
        "X02 is no element name"
    );
    assert!(
        over(&COMPACT.replace("<Ts_act>1.2</Ts_act>", "<Ts_act/>")).is_ok(),
        "M2: no value"
    );
    assert_eq!(
        over(r#"<RobData Id="1"/>"#).map(|d| d.tally.missing_fields),
        Ok(8)
    );
}

#[test]
fn bytes_outside_what_controllers_write_go_to_the_general_path() {
    let over = handed_over::<manual::RobDataMessage>;
    // Non-ASCII, control characters, a byte-order mark.
    assert_eq!(
        over(&COMPACT.replace("<Ts_act>", "<Ts_act>\u{a0}")),
        Err(K::InvalidTime)
    );
    assert_eq!(
        over(&COMPACT.replace("<Ts_act>", "<Ts_act>\u{1}")),
        Err(K::Malformed)
    );
    assert!(
        over(&format!("\u{feff}{COMPACT}")).is_ok(),
        "xmlparser skips a BOM"
    );
    // Text after the root, a second root, a cut message.
    assert_eq!(over(&format!("{COMPACT}x")), Err(K::TrailingGarbage));
    assert_eq!(
        over(&format!("{COMPACT}{COMPACT}")),
        Err(K::TrailingGarbage)
    );
    assert_eq!(over(&COMPACT[..COMPACT.len() - 1]), Err(K::Truncated));
    // A declaration the compiled path does not read.
    assert!(over(&format!("<?xml version='1.0'?>{COMPACT}")).is_ok());
    assert!(over(&format!("<?xml version = \"1.0\"?>{COMPACT}")).is_ok());
    // Its content is not checked (issue 42 #16; the firmware README).
    assert!(over(&format!("<?xml version=\"1.0\"encoding=\"x\"?>{COMPACT}")).is_ok());
    assert!(over(&format!("\u{feff}<?xml version=\"\"?>{COMPACT}")).is_ok());
    // Once, first.
    assert_eq!(
        over(&format!("<?xml version=\"\"?> <?xml?>{COMPACT}")),
        Err(K::Malformed)
    );
    // Wrong root, bad Id, values the parsers refuse.
    assert_eq!(
        over(&COMPACT.replace("RobData", "RobDatum")),
        Err(K::WrongRoot)
    );
    assert_eq!(
        over(&COMPACT.replace(r#"Id="7""#, r#"Id="-7""#)),
        Err(K::InvalidId)
    );
    assert_eq!(
        over(&COMPACT.replace(r#"X="1""#, r#"X="1x""#)),
        Err(K::InvalidNumber)
    );
    assert_eq!(
        over(&COMPACT.replace(r#"X="1""#, r#"X="1e39""#)),
        Err(K::NumberOutOfRange)
    );
    assert_eq!(
        over(&COMPACT.replace(">ManRS<", ">Manual<")),
        Err(K::UnknownEnumMember)
    );
    // A `>` in text: legal XML, but the compiled path never checks `]]>`.
    let note =
        handed_over::<et::RsRobDataMessage>(r#"<RobData Id="1"><Note>a > b</Note></RobData>"#);
    assert!(note.is_ok());
}
