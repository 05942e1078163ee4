//! The bad-input catalogue: named malformed and hostile datagrams, each
//! handed to the cycle engine (the manual's layout) with its asserted
//! outcome — a typed rejection, or a counted tolerance — and each followed
//! by a good message that must be answered with its own Id (M8): nothing a
//! datagram holds stops the device answering its controller. Then the
//! same for TCP streams (M10): split at every byte, pipelined, half-closed.
//! Rules cited per case (PROTOCOL.md).

use host_tests::layouts::anydevice::{self as layout, RobDataMessage, SensDataMessage};
use host_tests::sensor::Background;
use rri_firmware::codec::{decode, DecodeErrorKind as K, EXTRA_ITEMS};
use rri_firmware::engine::{Clock, Config, DropReason, Endpoint, Engine, Instant, Outcome, Stats};
use rri_firmware::tcp::Framer;
use std::cell::Cell;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::Duration;

/// What a catalogue entry must do.
enum Expect {
    /// Rejected with this kind (S1: no reply; counted per kind).
    Reject(K),
    /// Answered; the named counter grows by this much (M2 tolerances).
    Tolerate(&'static str, fn(&Stats) -> u64, u64),
    /// Answered, nothing to count.
    Answer,
}

use Expect::{Answer, Reject, Tolerate};

struct Case {
    name: String,
    bytes: Vec<u8>,
    expect: Expect,
}

fn case(name: &str, text: &str, expect: Expect) -> Case {
    Case {
        name: name.to_string(),
        bytes: text.as_bytes().to_vec(),
        expect,
    }
}

fn bytes(name: &str, bytes: Vec<u8>, expect: Expect) -> Case {
    Case {
        name: name.to_string(),
        bytes,
        expect,
    }
}

/// `<RobData Id="1" Ts="1.5">` + `body` + `</RobData>`.
fn rob(body: &str) -> String {
    format!(r#"<RobData Id="1" Ts="1.5">{body}</RobData>"#)
}

/// A good message with every field (M9's shape).
fn good(id: u32) -> String {
    let app: String = (1..=18).map(|i| format!(r#" X{i}="{i}.5""#)).collect();
    format!(
        r#"<?xml version="1.0"?><RobData Id="{id}" Ts="1.5"><RobMode>Auto</RobMode><Ts_act>1.2</Ts_act><P_act X="{id}" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><J_act J1="1" J2="2" J3="3" J4="4" J5="5" J6="6"/><Ts_des>1.2</Ts_des><P_des X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/><J_des J1="1" J2="2" J3="3" J4="4" J5="5" J6="6"/><AppData{app}/></RobData>"#
    )
}

const GOOD_SHORT: &str = r#"<RobData Id="1" Ts="1.5"><RobMode>Auto</RobMode><Ts_act>1.2</Ts_act><P_act X="1" Y="2" Z="3" Rx="4" Ry="5" Rz="6"/></RobData>"#;

fn catalogue() -> Vec<Case> {
    let max = layout::MAX_RECEIVE_LEN;
    let p_act = |x: &str| {
        rob(&format!(
            r#"<P_act X="{x}" Y="0" Z="0" Rx="0" Ry="0" Rz="0"/>"#
        ))
    };
    let mode = |m: &str| rob(&format!("<RobMode>{m}</RobMode>"));
    let mut utf16 = vec![0xff, 0xfe];
    for u in GOOD_SHORT.encode_utf16() {
        utf16.extend_from_slice(&u.to_le_bytes());
    }
    let deep = format!(
        r#"<RobData Id="1">{}{}</RobData>"#,
        "<a>".repeat(500),
        "</a>".repeat(500)
    );
    let many_unknown = rob(&"<U/>".repeat(40));
    vec![
        // M1: shape of a message.
        case("empty datagram", "", Reject(K::Truncated)),
        case("whitespace only", " \r\n\t ", Reject(K::Truncated)),
        case("a lone <", "<", Reject(K::Truncated)),
        case("cut inside the root's name", "<RobD", Reject(K::Truncated)),
        case(
            "cut inside an attribute",
            r#"<RobData Id="1"#,
            Reject(K::Truncated),
        ),
        case("not XML", "hello robot", Reject(K::Malformed)),
        case(
            "wrong root (M1)",
            r#"<SensData Id="1"/>"#,
            Reject(K::WrongRoot),
        ),
        case(
            "namespaced root (M1)",
            r#"<a:RobData xmlns:a="x" Id="1"/>"#,
            Reject(K::WrongRoot),
        ),
        case(
            "two roots",
            &format!("{GOOD_SHORT}{GOOD_SHORT}"),
            Reject(K::TrailingGarbage),
        ),
        case(
            "text after the root",
            &format!("{GOOD_SHORT}x"),
            Reject(K::TrailingGarbage),
        ),
        case(
            "mismatched end tag",
            &rob("<Ts_act>1</Ts_des>"),
            Reject(K::MismatchedTag),
        ),
        case("deep nesting (500 levels)", &deep, Reject(K::TooDeep)),
        case(
            "a child inside a field",
            &rob("<Ts_act><x/></Ts_act>"),
            Reject(K::TooDeep),
        ),
        case(
            "unquoted attribute",
            "<RobData Id=1/>",
            Reject(K::Malformed),
        ),
        case(
            "attribute without value",
            "<RobData Id/>",
            Reject(K::Malformed),
        ),
        // M8 / S3: the Id.
        case(
            "missing Id (M8)",
            r#"<RobData Ts="1"/>"#,
            Reject(K::MissingId),
        ),
        case(
            "duplicate Id",
            r#"<RobData Id="1" Id="2"/>"#,
            Reject(K::Duplicate),
        ),
        case(
            "overflowing Id (S3)",
            r#"<RobData Id="4294967296"/>"#,
            Reject(K::InvalidId),
        ),
        case(
            "negative Id (S3)",
            r#"<RobData Id="-1"/>"#,
            Reject(K::InvalidId),
        ),
        case("hex Id", r#"<RobData Id="0x10"/>"#, Reject(K::InvalidId)),
        case("empty Id", r#"<RobData Id=""/>"#, Reject(K::InvalidId)),
        case(
            "bad Ts",
            r#"<RobData Id="1" Ts="soon"/>"#,
            Reject(K::InvalidTs),
        ),
        case(
            "duplicate Ts",
            r#"<RobData Id="1" Ts="1" Ts="2"/>"#,
            Reject(K::Duplicate),
        ),
        // M5: numbers.
        case(
            "huge exponent (M5)",
            &p_act("1e999999999"),
            Reject(K::NumberOutOfRange),
        ),
        case(
            "beyond f32 (M5)",
            &p_act("3.5e38"),
            Reject(K::NumberOutOfRange),
        ),
        case(
            "tiny exponent rounds to zero (M5)",
            &p_act("1e-999999999"),
            Answer,
        ),
        case("NaN text (M5)", &p_act("NaN"), Reject(K::InvalidNumber)),
        case("inf text (M5)", &p_act("inf"), Reject(K::InvalidNumber)),
        case(
            "Infinity text (M5)",
            &p_act("-Infinity"),
            Reject(K::InvalidNumber),
        ),
        case("hex float (M5)", &p_act("0x1p3"), Reject(K::InvalidNumber)),
        case(
            "decimal comma (M5)",
            &p_act("1,5"),
            Reject(K::InvalidNumber),
        ),
        case("empty number (M5)", &p_act(""), Reject(K::InvalidNumber)),
        case(
            "character reference in a number",
            &p_act("&#49;"),
            Reject(K::InvalidNumber),
        ),
        case(
            "49-character number (M5)",
            &p_act(&format!("1.{}", "0".repeat(47))),
            Reject(K::NumberTooLong),
        ),
        case(
            "10,000-digit number",
            &p_act(&"1".repeat(10_000)),
            Reject(K::TooLong),
        ),
        case(
            "time with a huge exponent (M5)",
            &rob("<Ts_act>1e30</Ts_act>"),
            Reject(K::InvalidTime),
        ),
        case(
            "whitespace around a number",
            &rob("<Ts_act>\n\t 1.2 \r\n</Ts_act>"),
            Answer,
        ),
        case(
            "comment splitting a number",
            &rob("<Ts_act>1.<!--x-->2</Ts_act>"),
            Reject(K::InvalidTime),
        ),
        // M6 / G3: text, references, enums.
        case(
            "unknown enum member (G3)",
            &mode("Fly"),
            Reject(K::UnknownEnumMember),
        ),
        case("enum by character reference", &mode("&#65;uto"), Answer),
        case(
            "enum by hex character reference",
            &mode("&#x41;uto"),
            Answer,
        ),
        case("enum in CDATA", &mode("<![CDATA[Auto]]>"), Answer),
        // CDATA is literal (XML 1.0 §2.7): a reference in it is its own
        // characters, so no member (exactness list of issue 36).
        case(
            "character reference inside CDATA, taken literally",
            &mode("<![CDATA[&#x41;uto]]>"),
            Reject(K::UnknownEnumMember),
        ),
        case(
            "predefined entity, no such member",
            &mode("&lt;"),
            Reject(K::UnknownEnumMember),
        ),
        case(
            "undefined entity (M6)",
            &mode("&bogus;"),
            Reject(K::BadReference),
        ),
        case(
            "character reference to NUL (M6)",
            &mode("&#0;"),
            Reject(K::BadReference),
        ),
        case(
            "character reference to a surrogate (M6)",
            &mode("&#xD800;"),
            Reject(K::BadReference),
        ),
        case(
            "character reference beyond Unicode (M6)",
            &mode("&#1114112;"),
            Reject(K::BadReference),
        ),
        case(
            "DOCTYPE with an entity definition",
            &format!(r#"<!DOCTYPE RobData [<!ENTITY x "Auto">]>{}"#, mode("&x;")),
            Reject(K::Doctype),
        ),
        case(
            "billion laughs",
            r#"<!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><RobData Id="1">&b;</RobData>"#,
            Reject(K::Doctype),
        ),
        // The rules the code follows where the README once said more
        // (exactness list of issue 36; firmware/README.md, "What the
        // decoder reads, exactly"): content the layout does not hold is
        // skipped unread, references in it included; the declaration and
        // processing instructions are skipped, their content unchecked; a
        // value's attribute repeated before all its components are set
        // replaces the first.
        case(
            "malformed reference in an attribute the layout does not hold: skipped unread",
            r#"<RobData Id="4" o="&"></RobData>"#,
            Tolerate("unknown_attributes", |s| s.unknown_attributes, 1),
        ),
        case(
            "malformed reference in an element the layout does not hold: skipped unread",
            r#"<RobData Id="5"><Bar>&</Bar></RobData>"#,
            Tolerate("unknown_elements", |s| s.unknown_elements, 1),
        ),
        case(
            "declaration with an odd version and an empty encoding: skipped",
            &format!(r#"<?xml version="1." encoding=""?>{GOOD_SHORT}"#),
            Answer,
        ),
        // Issue 42 #16: the declaration's content is not checked, as the
        // firmware README says (both were Malformed at byte 0).
        case(
            "declaration with an empty version: skipped",
            &format!(r#"<?xml version=""?>{GOOD_SHORT}"#),
            Answer,
        ),
        case(
            "declaration with an empty version and standalone: skipped",
            &format!(r#"<?xml version="" standalone=""?>{GOOD_SHORT}"#),
            Answer,
        ),
        case(
            "declaration with what no declaration has: skipped",
            &format!(r#"<?xml  version='2' foo="bar" <x> ?>{GOOD_SHORT}"#),
            Answer,
        ),
        case(
            "empty declaration: skipped",
            &format!("<?xml?>{GOOD_SHORT}"),
            Answer,
        ),
        case(
            "reserved processing instruction XML: skipped",
            &format!("<?XML?>{GOOD_SHORT}"),
            Answer,
        ),
        case(
            "attribute repeated before the frame is complete: the second replaces the first",
            &rob(r#"<P_act X="1" X="2" Y="0" Z="0" Rx="0" Ry="0"/>"#),
            Tolerate("missing_values", |s| s.missing_values, 0),
        ),
        case(
            "least time (-2^63 µs)",
            &rob("<Ts_act>-9223372036854.775808</Ts_act>"),
            Answer,
        ),
        // Comments, processing instructions, CDATA in odd places.
        case(
            "comment before the root",
            &format!("<!--hi-->{GOOD_SHORT}"),
            Answer,
        ),
        case(
            "processing instruction inside the root",
            &rob("<?robot go?><Ts_act>1</Ts_act>"),
            Answer,
        ),
        case(
            "comment after the root",
            &format!("{GOOD_SHORT}<!--bye-->"),
            Answer,
        ),
        case(
            "second XML declaration",
            &format!(r#"<?xml version="1.0"?><?xml version="1.0"?>{GOOD_SHORT}"#),
            Reject(K::Malformed),
        ),
        case(
            "CDATA between fields (M2)",
            &rob("<![CDATA[x]]><Ts_act>1</Ts_act>"),
            Tolerate("stray_text", |s| s.stray_text, 1),
        ),
        // M2 tolerances and their limits.
        case(
            "text where attributes belong (M2)",
            &rob("<P_act>1</P_act>"),
            Tolerate("shape_mismatches", |s| s.shape_mismatches, 1),
        ),
        case(
            "a frame with one value (M2)",
            &rob(r#"<P_act X="1"/>"#),
            Tolerate("missing_values", |s| s.missing_values, 5),
        ),
        case(
            "unknown attribute (M2)",
            &rob(r#"<P_act Q="1" X="1" Y="0" Z="0" Rx="0" Ry="0" Rz="0"/>"#),
            Tolerate("unknown_attributes", |s| s.unknown_attributes, 1),
        ),
        case(
            "array element X0 (M4)",
            &rob(r#"<AppData X0="1"/>"#),
            Tolerate("unknown_attributes", |s| s.unknown_attributes, 1),
        ),
        case(
            "array element X19 of 18 (M4)",
            &rob(r#"<AppData X19="1"/>"#),
            Tolerate("unknown_attributes", |s| s.unknown_attributes, 1),
        ),
        case(
            "array element with a leading zero (M4)",
            &rob(r#"<AppData X01="1"/>"#),
            Tolerate("unknown_attributes", |s| s.unknown_attributes, 1),
        ),
        case(
            "namespaced field (M2)",
            &rob(r#"<x:Ts_act xmlns:x="y">1</x:Ts_act>"#),
            Tolerate("unknown_elements", |s| s.unknown_elements, 1),
        ),
        case(
            "more extras than a message can hold",
            &many_unknown,
            Reject(K::TooManyExtras),
        ),
        case(
            "repeated field",
            &rob("<Ts_act>1</Ts_act><Ts_act>2</Ts_act>"),
            Reject(K::Duplicate),
        ),
        case(
            "repeated array element",
            &rob(&format!(
                "<AppData{}/>",
                r#" X1="1""#.repeat(18 + EXTRA_ITEMS + 20)
            )),
            Reject(K::TooManyExtras),
        ),
        // Encodings and sizes.
        bytes(
            "non-UTF-8 byte",
            [
                b"<RobData Id=\"1\"><RobMode>Au".as_slice(),
                &[0xFF],
                b"to</RobMode></RobData>",
            ]
            .concat(),
            Reject(K::NotUtf8),
        ),
        bytes(
            "overlong UTF-8",
            [
                b"<RobData Id=\"1\"><RobMode>".as_slice(),
                &[0xC0, 0xAF],
                b"</RobMode></RobData>",
            ]
            .concat(),
            Reject(K::NotUtf8),
        ),
        bytes(
            "UTF-8 byte order mark (XML allows it)",
            [[0xEF, 0xBB, 0xBF].as_slice(), GOOD_SHORT.as_bytes()].concat(),
            Answer,
        ),
        bytes("UTF-16 with its byte order mark", utf16, Reject(K::NotUtf8)),
        case(
            "NUL inside a value",
            &rob("<Ts_act>1\u{0}</Ts_act>"),
            Reject(K::Malformed),
        ),
        case(
            "multi-byte UTF-8 in an enum",
            &mode("Autö"),
            Reject(K::UnknownEnumMember),
        ),
        case(
            "one byte over MAX_RECEIVE_LEN",
            &format!("{GOOD_SHORT}{}", " ".repeat(max + 1 - GOOD_SHORT.len())),
            Reject(K::TooLong),
        ),
        case(
            "exactly MAX_RECEIVE_LEN",
            &format!("{GOOD_SHORT}{}", " ".repeat(max - GOOD_SHORT.len())),
            Answer,
        ),
    ]
}

/// Device time for the engine: a millisecond per message.
struct Tick(Cell<u64>);

impl Clock for Tick {
    fn now(&self) -> Instant {
        Instant::from_millis(self.0.get())
    }
}

const ROBOT: Endpoint = Endpoint::new([192, 168, 125, 1], 50_000);

/// Every catalogue entry, then a good message: the entry's outcome as
/// asserted, and the good message answered with its own Id (M8).
#[test]
fn every_bad_datagram_has_its_outcome_and_the_next_message_is_answered() {
    let cases = catalogue();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut engine: Engine<layout::RobotProperties, layout::DeviceProperties> =
        Engine::new(Config {
            dry_run: true,
            ..layout::ENGINE_CONFIG
        });
    engine.listening();
    let clock = Tick(Cell::new(0));
    let mut out = [0u8; layout::MAX_SEND_LEN];
    let mut rejected = 0;
    let mut failures = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        clock.0.set(clock.0.get() + 1);
        let before = engine.stats();
        let outcome = engine.on_message(&mut (), &clock, ROBOT, &c.bytes, clock.now(), &mut out);
        let after = engine.stats();
        let ok = match (&c.expect, outcome) {
            (Reject(k), Outcome::Dropped(DropReason::Decode(got))) if *k == got => {
                rejected += 1;
                after.decode_errors_of(*k) == before.decode_errors_of(*k) + 1
            }
            (Tolerate(_, counter, n), Outcome::Reply { .. }) => {
                counter(&after) == counter(&before) + n
            }
            (Answer, Outcome::Reply { .. }) => true,
            _ => false,
        };
        if !ok {
            let want = match &c.expect {
                Reject(k) => format!("rejected as {k:?}"),
                Tolerate(name, _, n) => format!("answered, {name} +{n}"),
                Answer => "answered".to_string(),
            };
            failures.push(format!("{}: wanted {want}, got {outcome:?}", c.name));
        }
        // The next good message: answered, with its own Id.
        let id = 1_000 + i as u32;
        clock.0.set(clock.0.get() + 1);
        let next = engine.on_message(
            &mut (),
            &clock,
            ROBOT,
            good(id).as_bytes(),
            clock.now(),
            &mut out,
        );
        match next {
            Outcome::Reply { to, len } => {
                assert_eq!(to, ROBOT);
                let mut reply = layout::SensorData::default();
                let d = decode::<SensDataMessage>(&out[..len], &mut reply)
                    .unwrap_or_else(|e| panic!("after {}: reply does not decode: {e:?}", c.name));
                assert_eq!(d.id, id, "after {}: M8", c.name);
            }
            other => failures.push(format!("{}: the next good message got {other:?}", c.name)),
        }
        assert_eq!(
            engine.robot().rob_data.feedback_pose.x,
            id as f32,
            "after {}: the good message's values are the device's",
            c.name
        );
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
    let s = engine.stats();
    assert_eq!(s.dropped_decode, rejected);
    assert_eq!(s.received, 2 * cases.len() as u64);
    assert_eq!(s.answered + s.dropped_decode, s.received);
    println!(
        "catalogue: {} datagrams, {rejected} rejected by kind, {} answered",
        cases.len(),
        cases.len() as u64 - rejected
    );
}

/// M1: every prefix of a good message is rejected (mostly as truncated at
/// an element boundary), never answered, and never panics.
#[test]
fn every_truncation_of_a_good_message_is_rejected() {
    let text = good(5);
    let mut robot = layout::RobotData::default();
    let mut boundaries = 0;
    for cut in 0..text.len() {
        let r = decode::<RobDataMessage>(&text.as_bytes()[..cut], &mut robot);
        let e = r.expect_err("a prefix is never a message");
        let at_boundary = cut > 0 && matches!(text.as_bytes()[cut - 1], b'>');
        if at_boundary {
            boundaries += 1;
            assert_eq!(e.kind, K::Truncated, "cut after byte {cut}");
        }
    }
    assert!(boundaries > 10);
}

/// M10: a TCP stream split at every byte yields the message once, whole.
#[test]
fn a_stream_split_at_every_byte_frames_one_message_m10() {
    let text = good(9);
    for split in 1..text.len() {
        let mut framer = Framer::<{ layout::MAX_RECEIVE_LEN }>::new();
        let mut got = Vec::new();
        for part in [&text.as_bytes()[..split], &text.as_bytes()[split..]] {
            framer.push(part, |m| got.push(m.to_vec())).expect("fits");
        }
        assert_eq!(got, vec![text.as_bytes().to_vec()], "split at {split}");
    }
    // And one byte at a time.
    let mut framer = Framer::<{ layout::MAX_RECEIVE_LEN }>::new();
    let mut got = 0;
    for b in text.as_bytes() {
        framer.push(&[*b], |_| got += 1).expect("fits");
    }
    assert_eq!(got, 1);
}

fn reply_ids(stream: &mut TcpStream, n: usize) -> Vec<u32> {
    let mut framer = Framer::<{ layout::MAX_SEND_LEN }>::new();
    let mut ids = Vec::new();
    let mut chunk = [0u8; 4096];
    while ids.len() < n {
        let k = stream.read(&mut chunk).expect("reads");
        assert!(k > 0, "closed after {} replies", ids.len());
        framer
            .push(&chunk[..k], |m| {
                let mut data = layout::SensorData::default();
                ids.push(decode::<SensDataMessage>(m, &mut data).expect("reply").id);
            })
            .expect("fits");
    }
    ids
}

/// M10 over the host sensor: three messages pipelined in one write, with
/// a bad one between them, then the write side half-closed: every good
/// message is answered in order, and the replies still arrive after the
/// half-close.
#[test]
fn pipelined_and_half_closed_streams_are_answered_m10() {
    let sensor = Background::start(true, layout::ENGINE_CONFIG).expect("sensor");
    let mut s = TcpStream::connect(sensor.addr).expect("connects");
    s.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let stream = format!("{}{}<RobData Id=\"x\"/>{}", good(1), good(2), good(3));
    s.write_all(stream.as_bytes()).expect("writes");
    s.shutdown(Shutdown::Write).expect("half-close");
    assert_eq!(reply_ids(&mut s, 3), vec![1, 2, 3]);
    let r = sensor.stop().expect("sensor ran");
    assert_eq!((r.stats.answered, r.stats.dropped_decode), (3, 1));
}
