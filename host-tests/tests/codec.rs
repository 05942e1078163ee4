//! The message codec against the manual's messages, the real IRC5 capture
//! and hand-made bad inputs (PROTOCOL.md M1–M8). Every rejection asserts its
//! kind and byte offset, every tolerance its counter.

// Tests set "previous values" on a default struct before decoding over it.
#![allow(clippy::field_reassign_with_default)]

use host_tests::layouts::{anydevice, every_type, udptest};
use host_tests::shared_rri;
use rri_firmware::codec::{decode, encode, DecodeErrorKind as K, Tally};
use rri_firmware::schema::{Message, MessageCodec};
use rri_firmware::value::{Frame, RriString, Time};

fn manual(name: &str) -> Vec<u8> {
    std::fs::read(shared_rri().join("examples/messages").join(name)).expect("manual message")
}

fn rob(
    text: &str,
) -> Result<(rri_firmware::codec::Decoded, anydevice::RobotData), rri_firmware::codec::DecodeError>
{
    let mut data = anydevice::RobotData::default();
    decode::<anydevice::RobDataMessage>(text.as_bytes(), &mut data).map(|d| (d, data))
}

fn kind_at(text: &str) -> (K, usize) {
    let e = rob(text).expect_err("must be rejected");
    (e.kind, e.offset)
}

const GOOD: &str =
    r#"<RobData Id="7" Ts="1.5"><RobMode>ManRS</RobMode><Ts_act>1.2</Ts_act></RobData>"#;

#[test]
fn m9_manual_robdata_decodes_to_the_manuals_values() {
    let mut data = anydevice::RobotData::default();
    let d =
        decode::<anydevice::RobDataMessage>(&manual("RobData.xml"), &mut data).expect("decodes");
    assert_eq!(d.id, 111);
    assert_eq!(d.ts, Some(Time::from_micros(1_202_000)));
    assert_eq!(
        d.tally,
        Tally::default(),
        "nothing to tolerate in the manual's message"
    );
    assert_eq!(data.operation_mode, anydevice::OperationMode::Automatic);
    assert_eq!(data.feedback_time, Time::from_micros(1_200_000));
    assert_eq!(data.predicted_time, Time::from_micros(1_200_000));
    let pose = Frame {
        x: 1620.0,
        y: 1620.0,
        z: 1620.0,
        rx: 100.0,
        ry: 100.0,
        rz: 100.0,
    };
    assert_eq!(data.feedback_pose, pose);
    assert_eq!(data.planned_pose, pose);
    assert_eq!(data.feedback_joints, [1.0; 6]);
    assert_eq!(data.planned_joints, [1.0; 6]);
    let mut app = [1620.0f32; 18];
    app[0] = 1.0;
    assert_eq!(data.application_data, app);
}

/// The manual's text without its line breaks and indentation.
fn compact(xml: &[u8]) -> String {
    let text = String::from_utf8(xml.to_vec()).expect("utf-8");
    let spaced = text.split_whitespace().collect::<Vec<_>>().join(" ");
    spaced
        .replace("> <", "><")
        .replace(" />", "/>")
        .replace(" >", ">")
}

#[test]
fn m9_encoding_the_manuals_sensdata_values_reproduces_it() {
    let mut reply = anydevice::SensorData::default();
    reply.error_string.push_str("xxxx").expect("fits");
    reply.application_data = [
        232.661, 1620.293, 463.932, 1231.053, 735.874, 948.263, 2103.584, 574.228, 65.406,
        2372.633, 20.475, 96.729, 884.382, 927.954, 748.294, 3285.574, 583.293, 684.338,
    ];
    let mut buf = [0u8; anydevice::MAX_SEND_LEN];
    let out = encode::<anydevice::SensDataMessage>(
        &reply,
        111,
        Time::from_millis(1234),
        anydevice::FORMAT,
        &mut buf,
    )
    .expect("fits the generated maximum");
    let ours = std::str::from_utf8(&buf[..out.len]).expect("utf-8");
    assert_eq!(ours, compact(&manual("SensData.xml")));
    assert!(
        !ours.contains(['\n', '\t']) && !ours.contains("> <"),
        "compact output"
    );
    assert_eq!(out.non_finite, 0);
}

#[test]
fn real_irc5_capture_decodes_with_counted_mismatches() {
    let bytes =
        std::fs::read(shared_rri().join("real-world/captured-RobData.xml")).expect("capture");
    let mut data = udptest::Robdata::default();
    data.operation_mode = udptest::Opmode::FullSpeed;
    data.application_data = [7.0; 20];
    let d = decode::<udptest::RsRobDataMessage>(&bytes, &mut data).expect("no error");
    assert_eq!(d.id, 5986);
    assert_eq!(d.ts, Some(Time::from_micros(765_315_969)));
    assert_eq!(
        d.tally,
        Tally {
            missing_fields: 1,   // no RobMode
            shape_mismatches: 1, // <AppData>0</AppData>
            ..Tally::default()
        }
    );
    assert_eq!(
        data.operation_mode,
        udptest::Opmode::FullSpeed,
        "M2: previous value kept"
    );
    assert_eq!(
        data.application_data, [7.0; 20],
        "wrong shape: previous value kept"
    );
    assert_eq!(data.feedback_time, Time::from_micros(765_311_368));
    assert_eq!(data.predicted_time, Time::from_micros(765_356_440));
    assert_eq!(data.feedback_joints[3], 1.21592e-06);
    assert_eq!(data.feedback_pose.ry, -0.000497347);
    assert_eq!(data.planned_pose.y, -34.9865);
}

// --- M1/M2/M3/M7 acceptance -------------------------------------------------

#[test]
fn m1_declaration_whitespace_and_comments_may_surround_the_message() {
    let text = format!(
        "\r\n  <?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- hi -->{GOOD}\n<!-- bye -->\n"
    );
    let (d, data) = rob(&text).expect("accepted");
    assert_eq!(d.id, 7);
    assert_eq!(data.operation_mode, anydevice::OperationMode::ReducedSpeed);
}

#[test]
fn m2_fields_in_any_order() {
    let (_, data) = rob(r#"<RobData Id="1"><Ts_act>2</Ts_act><P_act X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><RobMode>ManFS</RobMode></RobData>"#).expect("ok");
    assert_eq!(data.feedback_time, Time::from_micros(2_000_000));
    assert_eq!(data.feedback_pose.rz, 6.0);
    assert_eq!(data.operation_mode, anydevice::OperationMode::FullSpeed);
}

#[test]
fn m5_numbers_with_whitespace_sign_and_exponent() {
    let (_, data) = rob(r#"<RobData Id="1"><P_act X=" -1.5e2 " Y="+3" Z="1.21592e-06" Rx=".5" Ry="7." Rz="-0"/><Ts_act>
        12.5
    </Ts_act></RobData>"#)
    .expect("ok");
    assert_eq!(
        data.feedback_pose,
        Frame {
            x: -150.0,
            y: 3.0,
            z: 1.21592e-06,
            rx: 0.5,
            ry: 7.0,
            rz: -0.0
        }
    );
    assert_eq!(data.feedback_time, Time::from_micros(12_500_000));
}

#[test]
fn m7_bools_in_any_case_and_as_digits() {
    for (text, want) in [
        ("TRUE", true),
        ("false", false),
        ("1", true),
        (" 0 ", false),
        ("True", true),
    ] {
        let msg = format!("<RobData Id=\"1\"><Enabled>{text}</Enabled></RobData>");
        let mut data = every_type::Robdata::default();
        data.enabled = !want;
        decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect("ok");
        assert_eq!(data.enabled, want, "{text}");
    }
}

#[test]
fn m6_strings_decode_references_and_keep_spaces() {
    let msg = r#"<RobData Id="1"><Note> a&amp;b &lt;&#x263A;&#65;&quot; </Note><Labels X1="x&amp;y" X2=""/></RobData>"#;
    let mut data = every_type::Robdata::default();
    decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect("ok");
    assert_eq!(data.note.as_str(), " a&b <\u{263A}A\" ");
    assert_eq!(data.labels[0].as_str(), "x&y");
    assert_eq!(data.labels[1].as_str(), "");
}

#[test]
fn g3_enum_by_alias_escaped_on_the_wire_and_without_alias() {
    let msg = r#"<RobData Id="1"><Phase>Welding &amp; seam</Phase></RobData>"#;
    let mut data = every_type::Robdata::default();
    decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect("ok");
    assert_eq!(data.phase, every_type::Phase::Weld);
    let msg = r#"<RobData Id="1"><Phase>Approach</Phase></RobData>"#;
    decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect("ok");
    assert_eq!(data.phase, every_type::Phase::Approach);
}

// --- counted tolerances (M2) ---------------------------------------------------

#[test]
fn m2_unknown_elements_and_attributes_are_skipped_and_counted() {
    let (d, data) = rob(r#"<RobData Id="1" Ts="2" Extra="x"><Foo a="1">bar</Foo><Bar/><P_act X="1" W="9" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><Ts_act unit="s">3</Ts_act></RobData>"#).expect("ok");
    assert_eq!(d.tally.unknown_elements, 2);
    assert_eq!(d.tally.unknown_attributes, 3); // Extra, W, unit
    assert_eq!(data.feedback_pose.x, 1.0);
    assert_eq!(data.feedback_time, Time::from_micros(3_000_000));
}

#[test]
fn m2_missing_fields_keep_their_value_and_are_counted() {
    let mut data = anydevice::RobotData::default();
    data.feedback_time = Time::from_micros(42);
    let d = decode::<anydevice::RobDataMessage>(
        br#"<RobData Id="1"><RobMode>Auto</RobMode></RobData>"#,
        &mut data,
    )
    .expect("ok");
    assert_eq!(d.tally.missing_fields, 7);
    assert_eq!(data.feedback_time, Time::from_micros(42));
}

#[test]
fn m4_missing_attributes_keep_their_value_and_are_counted() {
    let mut data = anydevice::RobotData::default();
    data.feedback_pose.rz = 9.0;
    let d = decode::<anydevice::RobDataMessage>(
        br#"<RobData Id="1"><P_act X="1"/></RobData>"#,
        &mut data,
    )
    .expect("ok");
    assert_eq!(d.tally.missing_values, 5);
    assert_eq!((data.feedback_pose.x, data.feedback_pose.rz), (1.0, 9.0));
}

#[test]
fn m4_wrong_shapes_keep_their_value_and_are_counted() {
    let mut data = anydevice::RobotData::default();
    data.application_data[0] = 5.0;
    data.feedback_time = Time::from_micros(5);
    let msg = br#"<RobData Id="1"><AppData>0</AppData><Ts_act X="1"/><J_act/><Ts_des></Ts_des></RobData>"#;
    let d = decode::<anydevice::RobDataMessage>(msg, &mut data).expect("ok");
    assert_eq!(d.tally.shape_mismatches, 4);
    assert_eq!(d.tally.unknown_attributes, 1);
    assert_eq!(data.application_data[0], 5.0);
    assert_eq!(data.feedback_time, Time::from_micros(5));
}

#[test]
fn m6_long_strings_are_cut_at_80_bytes_and_counted() {
    let long = "ü".repeat(50);
    let msg = format!("<RobData Id=\"1\"><Note>{long}</Note></RobData>");
    let mut data = every_type::Robdata::default();
    let d = decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect("ok");
    assert_eq!(d.tally.truncated_strings, 1);
    assert_eq!(data.note.len(), 80);
    assert_eq!(data.note.as_str(), "ü".repeat(40));
}

#[test]
fn m2_stray_text_between_fields_is_counted() {
    let (d, _) = rob(r#"<RobData Id="1">oops<Ts_act>1</Ts_act></RobData>"#).expect("ok");
    assert_eq!(d.tally.stray_text, 1);
}

#[test]
fn m1_missing_ts_is_accepted() {
    let (d, _) = rob(r#"<RobData Id="3"/>"#).expect("ok");
    assert_eq!((d.id, d.ts), (3, None));
}

// --- rejections: kind and byte offset ---------------------------------------

#[test]
fn reject_not_utf8() {
    let mut bytes = GOOD.as_bytes().to_vec();
    bytes[30] = 0xff;
    let mut data = anydevice::RobotData::default();
    let e = decode::<anydevice::RobDataMessage>(&bytes, &mut data).expect_err("rejected");
    assert_eq!((e.kind, e.offset), (K::NotUtf8, 30));
}

#[test]
fn reject_doctype_without_expanding_entities() {
    let text = r#"<!DOCTYPE RobData [<!ENTITY e "x">]><RobData Id="1">&e;</RobData>"#;
    assert_eq!(kind_at(text), (K::Doctype, 0));
    let text = r#"<?xml version="1.0"?><!DOCTYPE RobData SYSTEM "x.dtd"><RobData Id="1"/>"#;
    assert_eq!(kind_at(text), (K::Doctype, 21));
}

#[test]
fn reject_wrong_root() {
    assert_eq!(
        kind_at(r#"<SensData Id="1"></SensData>"#),
        (K::WrongRoot, 0)
    );
    assert_eq!(kind_at(r#" <x:RobData Id="1"/>"#), (K::WrongRoot, 1));
}

#[test]
fn reject_missing_id() {
    assert_eq!(kind_at(r#"<RobData Ts="1"></RobData>"#), (K::MissingId, 15));
    assert_eq!(kind_at(r#"<RobData/>"#), (K::MissingId, 8));
}

#[test]
fn reject_invalid_id() {
    assert_eq!(kind_at(r#"<RobData Id="abc"/>"#), (K::InvalidId, 13));
    assert_eq!(kind_at(r#"<RobData Id="4294967296"/>"#), (K::InvalidId, 13));
    assert_eq!(kind_at(r#"<RobData Id="-1"/>"#), (K::InvalidId, 13));
}

#[test]
fn reject_invalid_ts() {
    assert_eq!(kind_at(r#"<RobData Id="1" Ts="now"/>"#), (K::InvalidTs, 20));
}

#[test]
fn reject_longer_than_the_compile_time_maximum() {
    let mut text = String::from(GOOD);
    text.push_str(&" ".repeat(anydevice::RobDataMessage::MAX_RECEIVE_LEN));
    let max = anydevice::RobDataMessage::MAX_RECEIVE_LEN;
    assert_eq!(kind_at(&text), (K::TooLong, max));
    // Exactly the maximum is still read.
    let text = format!("{GOOD}{}", " ".repeat(max - GOOD.len()));
    assert!(rob(&text).is_ok());
}

#[test]
fn reject_nesting_deeper_than_the_layout() {
    assert_eq!(
        kind_at(r#"<RobData Id="1"><P_act><X>1</X></P_act></RobData>"#),
        (K::TooDeep, 23)
    );
    assert_eq!(
        kind_at(r#"<RobData Id="1"><Foo><Bar/></Foo></RobData>"#),
        (K::TooDeep, 21)
    );
}

#[test]
fn reject_truncated_documents_at_every_length() {
    let full = String::from_utf8(manual("RobData.xml")).expect("utf-8");
    let full = full.trim_end();
    for cut in 1..full.len() {
        let e = rob(&full[..cut]).expect_err("truncated");
        assert_eq!(e.kind, K::Truncated, "cut at {cut}: {:?}", &full[..cut]);
        assert!(e.offset <= cut, "cut at {cut}: offset {}", e.offset);
    }
    assert_eq!(kind_at(""), (K::Truncated, 0));
}

#[test]
fn reject_trailing_garbage() {
    let n = GOOD.len();
    assert_eq!(kind_at(&format!("{GOOD}x")), (K::TrailingGarbage, n));
    assert_eq!(
        kind_at(&format!("{GOOD}<RobData Id=\"2\"/>")),
        (K::TrailingGarbage, n)
    );
    assert!(rob(&format!("{GOOD} \n<!-- ok -->")).is_ok());
}

#[test]
fn reject_mismatched_end_tags() {
    assert_eq!(
        kind_at(r#"<RobData Id="1"><Ts_act>1</Ts_des></RobData>"#),
        (K::MismatchedTag, 25)
    );
    assert_eq!(
        kind_at(r#"<RobData Id="1"></SensData>"#),
        (K::MismatchedTag, 16)
    );
}

#[test]
fn reject_malformed_xml() {
    assert_eq!(
        kind_at(r#"<RobData Id="1" <Ts_act/></RobData>"#).0,
        K::Malformed
    );
    assert_eq!(kind_at(r#"<RobData Id=1/>"#).0, K::Malformed);
}

#[test]
fn reject_invalid_and_out_of_range_numbers() {
    let text = r#"<RobData Id="1"><P_act X="abc" Y="1" Z="1" Rx="1" Ry="1" Rz="1"/></RobData>"#;
    assert_eq!(kind_at(text), (K::InvalidNumber, 26));
    let text = r#"<RobData Id="1"><P_act X="1e39"/></RobData>"#;
    assert_eq!(kind_at(text), (K::NumberOutOfRange, 26));
    let text = r#"<RobData Id="1"><AppData X1="NaN"/></RobData>"#;
    assert_eq!(kind_at(text), (K::InvalidNumber, 29));
}

#[test]
fn reject_invalid_time() {
    assert_eq!(
        kind_at(r#"<RobData Id="1"><Ts_act> soon</Ts_act></RobData>"#),
        (K::InvalidTime, 25)
    );
    assert_eq!(
        kind_at(r#"<RobData Id="1"><Ts_act>1e300</Ts_act></RobData>"#),
        (K::InvalidTime, 24)
    );
}

#[test]
fn reject_invalid_bool() {
    let msg = r#"<RobData Id="1"><Enabled>yes</Enabled></RobData>"#;
    let mut data = every_type::Robdata::default();
    let e =
        decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect_err("bad bool");
    assert_eq!((e.kind, e.offset), (K::InvalidBool, 25));
}

#[test]
fn reject_unknown_enum_member_keeping_the_previous_value() {
    let mut data = anydevice::RobotData::default();
    data.operation_mode = anydevice::OperationMode::FullSpeed;
    let msg = br#"<RobData Id="1"><RobMode>Manual</RobMode></RobData>"#;
    let e = decode::<anydevice::RobDataMessage>(msg, &mut data).expect_err("unknown member");
    assert_eq!((e.kind, e.offset), (K::UnknownEnumMember, 25));
    assert_eq!(data.operation_mode, anydevice::OperationMode::FullSpeed);
    // The RAPID name is not the wire name when there is an alias.
    let msg = br#"<RobData Id="1"><RobMode>Automatic</RobMode></RobData>"#;
    assert_eq!(
        decode::<anydevice::RobDataMessage>(msg, &mut data).map_err(|e| e.kind),
        Err(K::UnknownEnumMember)
    );
}

#[test]
fn reject_undefined_references_in_strings() {
    let msg = r#"<RobData Id="1"><Note>ab&bogus;</Note></RobData>"#;
    let mut data = every_type::Robdata::default();
    let e = decode::<every_type::RsRobDataMessage>(msg.as_bytes(), &mut data).expect_err("bad ref");
    assert_eq!((e.kind, e.offset), (K::BadReference, 24));
}

// --- encoding ----------------------------------------------------------------

#[test]
fn m5_non_finite_reals_are_sent_as_zero_and_counted() {
    let mut reply = anydevice::SensorData::default();
    reply.application_data[0] = f32::NAN;
    reply.application_data[1] = f32::NEG_INFINITY;
    let mut buf = [0u8; anydevice::MAX_SEND_LEN];
    let out =
        encode::<anydevice::SensDataMessage>(&reply, 1, Time::ZERO, anydevice::FORMAT, &mut buf)
            .expect("fits");
    assert_eq!(out.non_finite, 2);
    let text = std::str::from_utf8(&buf[..out.len]).expect("utf-8");
    assert!(text.contains(r#"X1="0.000" X2="0.000""#), "{text}");
}

#[test]
fn m6_strings_are_escaped_on_the_way_out() {
    let mut reply = anydevice::SensorData::default();
    reply
        .error_string
        .push_str("<a & \"b\" 'c'>")
        .expect("fits");
    let mut buf = [0u8; anydevice::MAX_SEND_LEN];
    let out =
        encode::<anydevice::SensDataMessage>(&reply, 1, Time::ZERO, anydevice::FORMAT, &mut buf)
            .expect("fits");
    let text = std::str::from_utf8(&buf[..out.len]).expect("utf-8");
    assert!(
        text.contains("<EStr>&lt;a &amp; &quot;b&quot; &apos;c&apos;&gt;</EStr>"),
        "{text}"
    );
}

#[test]
fn m8_reply_carries_the_robot_id_and_the_device_time() {
    let reply = anydevice::SensorData::default();
    let mut buf = [0u8; anydevice::MAX_SEND_LEN];
    let out = encode::<anydevice::SensDataMessage>(
        &reply,
        u32::MAX,
        Time::from_micros(86_400_123_456),
        anydevice::FORMAT,
        &mut buf,
    )
    .expect("fits");
    let text = std::str::from_utf8(&buf[..out.len]).expect("utf-8");
    assert!(
        text.starts_with(r#"<SensData Id="4294967295" Ts="86400.123">"#),
        "{text}"
    );
}

#[test]
fn worst_case_reply_fits_the_generated_maximum_exactly() {
    // Every field at its longest: the generated MAX_ENCODED_LEN is a true
    // bound and not absurdly loose.
    let mut reply = anydevice::SensorData::default();
    for _ in 0..80 {
        reply.error_string.push('"').expect("fits");
    }
    reply.application_data = [f32::MIN; 18];
    let mut buf = [0u8; anydevice::MAX_SEND_LEN];
    let out = encode::<anydevice::SensDataMessage>(
        &reply,
        u32::MAX,
        Time::from_micros(i64::MIN),
        anydevice::FORMAT,
        &mut buf,
    )
    .expect("fits");
    assert_eq!(out.len, anydevice::SensDataMessage::MAX_ENCODED_LEN);
    // One byte less is an error, not an overrun.
    let mut small = [0u8; anydevice::MAX_SEND_LEN - 1];
    assert!(encode::<anydevice::SensDataMessage>(
        &reply,
        u32::MAX,
        Time::from_micros(i64::MIN),
        anydevice::FORMAT,
        &mut small
    )
    .is_err());
}

#[test]
fn value_properties_travel_on_the_root_element() {
    let mut buf = [0u8; 512];
    let out = encode::<every_type::SpeedMessage>(
        &2.5,
        9,
        Time::from_millis(1),
        every_type::FORMAT,
        &mut buf,
    )
    .expect("fits");
    assert_eq!(
        &buf[..out.len],
        br#"<Speed Id="9" Ts="0.001">2.500</Speed>"#
    );
    let out = encode::<every_type::OffsetsMessage>(
        &[1.0, -2.0, 0.5],
        9,
        Time::ZERO,
        every_type::FORMAT,
        &mut buf,
    )
    .expect("fits");
    assert_eq!(
        &buf[..out.len],
        br#"<Offsets Id="9" Ts="0.000" X1="1.000" X2="-2.000" X3="0.500"/>"#
    );
    let mut v = [0.0f32; 3];
    let d =
        decode::<every_type::OffsetsMessage>(br#"<Offsets Id="4" X3="3" X1="1" X2="2"/>"#, &mut v)
            .expect("ok");
    assert_eq!((d.id, v), (4, [1.0, 2.0, 3.0]));
    let mut s = 0.0f32;
    decode::<every_type::SpeedMessage>(br#"<Speed Id="4"> 7.25 </Speed>"#, &mut s).expect("ok");
    assert_eq!(s, 7.25);
}

#[test]
fn generated_names_and_directions() {
    use rri_firmware::schema::Direction;
    assert_eq!(every_type::RsRobDataMessage::WIRE_NAME, "RobData");
    assert_eq!(every_type::RsRobDataMessage::NAME, "RsRobData");
    assert_eq!(every_type::SharedMessage::DIRECTION, Direction::Both);
    assert_eq!(every_type::UnusedMessage::DIRECTION, Direction::None);
    assert_eq!(every_type::RECEIVED, ["RobData", "Shared", "Speed"]);
    assert_eq!(every_type::SENT, ["SensData", "Shared", "Speed", "Offsets"]);
    let _: RriString = every_type::Sensdata::default().status;
    assert_eq!(<every_type::SharedMessage as MessageCodec>::FIELDS.len(), 8);
}
