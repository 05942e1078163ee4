//! What the service writes, read back with real parsers: `/status.json`
//! with serde_json, `/metrics` with a strict parser of the Prometheus
//! text exposition format (openmetrics-parser, not ours), the page
//! through gzip. Every string that comes from a file or the network is
//! made hostile here (quotes, backslashes, newlines, markup, every byte
//! value) and must come back exactly.

use super::events::{EventKind, EventLog};
use super::http::{Parsed, Parser, Request, Route};
use super::status::*;
use super::*;
use rri_firmware::codec::{DecodeError, DecodeErrorKind};
use rri_firmware::engine::{Endpoint, ErrorCode, Histogram, Instant, SensorState};
use rri_firmware::schema::{PropertyInfo, Protocol};
use rri_firmware::snapshot::Snapshot;
use std::io::Read;

struct All(Vec<u8>);

impl Out for All {
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
}

const HOSTILE: &str = "Any\"Device\\</script><b>&amp;\n\u{7}é";

fn identity() -> Identity {
    Identity {
        device: HOSTILE,
        device_type: "Type \"x\"",
        device_class: "a\\b",
        version: "0.1.0",
        commit: "abc\"def",
        board: "QEMU mps2-an500",
        sensor: "sensors::Distance<\"x\">",
        sensor_file: "my dir/sensor.rs",
        mac: Some([2, 0, 0x52, 0x52, 0x49, 1]),
        ip: [10, 49, 65, 74],
        prefix: 24,
        gateway: None,
        protocol: Protocol::Udp,
        port: 3002,
        http_port: 80,
        config: rri_firmware::layout::ENGINE_CONFIG,
        received: &[PropertyInfo {
            name: "Rob\"Data",
            wire: "RobData",
            ty: "RobotData",
            fields: &[("P\"act", "frame"), ("AppData", "real[18]")],
        }],
        sent: &[PropertyInfo {
            name: "SensData",
            wire: "SensData",
            ty: "SensorData",
            fields: &[("EStr", "string")],
        }],
    }
}

/// Every byte value once: what a hostile robot message may hold.
fn every_byte() -> Vec<u8> {
    (0..=255u8).collect()
}

fn status() -> Status {
    let mut snapshot = Snapshot {
        state: SensorState::Error,
        error: Some(ErrorCode::Communication),
        peer: Some(Endpoint::new([10, 49, 65, 1], 40_000)),
        last_message: Some(Instant(1_000)),
        ..Snapshot::default()
    };
    snapshot.stats.received = 1234;
    snapshot.stats.answered = 1200;
    snapshot.stats.dropped_decode = 34;
    snapshot.stats.decode_errors[DecodeErrorKind::BadReference.index()] = 34;
    snapshot.stats.fragments.no_buffer = 7;
    snapshot.robot_seen[0].messages = 1200;
    snapshot.robot_seen[0].interval_us = 4_000;
    let mut latency = Histogram::default();
    for (us, at) in [(300, 10), (450, 20), (17_000, 30), (600, 40)] {
        latency.record_at(us, at);
    }
    let last_bad = LastBad::new();
    last_bad.record(
        Instant(900),
        Endpoint::new([10, 49, 65, 1], 40_000),
        DecodeError {
            kind: DecodeErrorKind::BadReference,
            offset: 17,
        },
        &every_byte(),
    );
    let mut events = EventLog::EMPTY;
    events.push(Instant(5), EventKind::Started(ResetCause::Watchdog));
    events.push(
        Instant(900),
        EventKind::Peer(Endpoint::new([10, 49, 65, 1], 40_000)),
    );
    events.push(
        Instant(950),
        EventKind::State(SensorState::Error, Some(ErrorCode::Communication)),
    );
    let mut file = [0u8; PANIC_FILE_BYTES];
    file[..9].copy_from_slice(b"src/\"x\".r");
    Status {
        snapshot,
        now: Instant(2_000_000),
        link: LinkInfo {
            up: true,
            speed_mbps: Some(100),
            full_duplex: Some(true),
        },
        nic: Some(NicCounters {
            rx_dropped: 3,
            ..NicCounters::default()
        }),
        stack: Some(StackFigures {
            boot: 27_000,
            running: 8_000,
            size: 98_304,
        }),
        latency: Latency {
            source: LatencySource::Driver,
            histogram: latency,
        },
        bad: last_bad.get(),
        events,
        reset: Some(ResetInfo {
            cause: ResetCause::Panic,
            pc: None,
            panic: Some((file, 9, 42)),
            boots: 3,
        }),
        update: Some(crate::update::Update {
            swaps: true,
            last: rri_update::Outcome::Refused(rri_update::Refused::OtherBoard),
            image: rri_update::lifecycle::Image::OnTrial,
            previous: rri_update::Version::parse("0.9.1"),
        }),
    }
}

fn response(route: Route, gzip: bool) -> (String, Vec<u8>) {
    response_to(route, gzip, &status())
}

/// The response to `route` for `status`: its head and body, the body as
/// long as its `Content-Length`.
fn response_to(route: Route, gzip: bool, status: &Status) -> (String, Vec<u8>) {
    let mut out = All(Vec::new());
    respond(
        &mut out,
        Request {
            route,
            head_only: false,
            gzip,
            body: None,
            cancel: false,
        },
        &identity(),
        status,
    );
    let split = out.0.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8(out.0[..split].to_vec()).unwrap();
    let body = out.0[split + 4..].to_vec();
    assert!(
        head.contains(&format!("\r\nContent-Length: {}\r\n", body.len())),
        "{head}"
    );
    (head, body)
}

/// The JSON's strings back as bytes: every char a byte (the bad message
/// is written byte by byte, `\u00NN` from 0x80).
fn latin1(s: &str) -> Vec<u8> {
    s.chars()
        .map(|c| u8::try_from(u32::from(c)).unwrap())
        .collect()
}

#[test]
fn status_json_is_json_and_every_hostile_string_comes_back_exactly() {
    let (head, body) = response(Route::Json, false);
    assert!(head.contains("Content-Type: application/json"));
    let v: serde_json::Value = serde_json::from_slice(&body).expect("valid JSON");
    assert_eq!(v["schema"], 1);
    assert_eq!(v["device"]["name"], HOSTILE);
    assert_eq!(v["device"]["type"], "Type \"x\"");
    assert_eq!(v["device"]["class"], "a\\b");
    assert_eq!(v["device"]["firmware"]["commit"], "abc\"def");
    assert_eq!(v["device"]["sensor"]["type"], "sensors::Distance<\"x\">");
    assert_eq!(v["device"]["mac"], "02:00:52:52:49:01");
    assert_eq!(v["device"]["reset"]["cause"], "panic");
    assert_eq!(v["device"]["reset"]["panic_file"], "src/\"x\".r");
    assert_eq!(v["device"]["reset"]["panic_line"], 42);
    assert_eq!(v["config"]["properties"][0]["name"], "Rob\"Data");
    assert_eq!(v["config"]["properties"][0]["fields"][0]["name"], "P\"act");
    assert_eq!(v["config"]["properties"][1]["reply"], true);
    assert_eq!(v["state"]["state"], "ERROR");
    assert_eq!(v["state"]["error_code"], 112602);
    assert_eq!(v["state"]["peer"], "10.49.65.1:40000");
    assert_eq!(v["state"]["since_last_message_us"], 1_999_000);
    assert_eq!(v["counters"]["messages"]["received"], 1234);
    assert_eq!(v["counters"]["decode_errors"]["bad_reference"], 34);
    assert_eq!(v["counters"]["fragments"]["no_buffer"], 7);
    assert_eq!(v["counters"]["nic"]["rx_dropped"], 3);
    assert_eq!(v["counters"]["robot_properties"][0]["interval_us"], 4000);
    assert_eq!(v["update"]["outcome"], "refused");
    assert_eq!(v["update"]["image"], "on trial");
    assert_eq!(v["update"]["previous"], "0.9.1");
    let bad = &v["last_bad_message"];
    assert_eq!(latin1(bad["bytes"].as_str().unwrap()), every_byte());
    assert_eq!(
        (bad["error"].as_str(), bad["offset"].as_u64()),
        (Some("bad_reference"), Some(17))
    );
    assert_eq!(bad["length"], 256);
    assert_eq!(v["events"][0]["event"], "state");
    assert_eq!(v["events"][1]["peer"], "10.49.65.1:40000");
    assert_eq!(
        (&v["events"][2]["event"], &v["events"][2]["cause"]),
        (&"started".into(), &"watchdog".into())
    );
    assert_eq!(v["events"][0]["state"], "ERROR");
    assert_eq!(
        v["events"][0]["error_code"],
        u64::from(ErrorCode::Communication.code())
    );
}

/// The page words what the JSON names: every decode error kind's text
/// (the firmware's own, `DecodeErrorKind::text`) is in the page's table
/// under the kind's JSON name, and every event name has its wording.
#[test]
fn the_page_words_every_decode_error_and_event_the_json_names() {
    let page = include_str!("page.html");
    for kind in DecodeErrorKind::ALL {
        let entry = format!("{}:\"{}\"", kind.name(), kind.text());
        assert!(page.contains(&entry), "page.html lacks {entry}");
    }
    for name in [
        "started",
        "state",
        "timeout",
        "max_lost",
        "link_up",
        "link_down",
        "peer",
    ] {
        assert!(
            page.contains(&format!("{name}:")),
            "page.html lacks the event {name}"
        );
    }
}

/// Issue 42 #11: past 2^32 (199 days at 250 Hz) the counters go on and
/// the histogram stays valid: `+Inf` equals `_count` (were: counters
/// stopped at u32::MAX while `+Inf` summed saturated buckets past it).
#[test]
fn counters_past_two_to_the_32_go_on_in_every_form() {
    let mut st = status();
    let big = (1u64 << 32) + 5;
    st.snapshot.stats.received = big;
    let mut h = Histogram::default();
    h.buckets[9] = u64::from(u32::MAX);
    h.buckets[10] = 10;
    h.count = u64::from(u32::MAX) + 10;
    h.record(600);
    h.record(300);
    st.latency.histogram = h;
    let body = |route| String::from_utf8(response_to(route, false, &st).1).unwrap();
    let metrics = body(Route::Metrics);
    assert!(
        metrics.contains("rri_messages_total{outcome=\"received\"} 4294967301\n"),
        "{metrics}"
    );
    let inf = metrics
        .lines()
        .find(|l| l.contains("le=\"+Inf\""))
        .and_then(|l| l.rsplit(' ').next())
        .unwrap();
    let count = metrics
        .lines()
        .find(|l| l.starts_with("rri_reply_latency_seconds_count "))
        .and_then(|l| l.rsplit(' ').next())
        .unwrap();
    assert_eq!(inf, count);
    assert_eq!(count, (u64::from(u32::MAX) + 12).to_string());
    let json: serde_json::Value = serde_json::from_str(&body(Route::Json)).unwrap();
    assert_eq!(json["counters"]["messages"]["received"].as_u64(), Some(big));
    assert_eq!(
        json["latency"]["count"].as_u64(),
        Some(u64::from(u32::MAX) + 12)
    );
}

#[test]
fn latency_histogram_adds_up_in_json() {
    let (_, body) = response(Route::Json, false);
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let l = &v["latency"];
    assert_eq!(
        (
            l["count"].as_u64(),
            l["max_us"].as_u64(),
            l["max_at_us"].as_u64()
        ),
        (Some(4), Some(17_000), Some(30))
    );
    let buckets = l["buckets"].as_array().unwrap();
    assert_eq!(buckets.len(), Histogram::BUCKETS);
    let total: u64 = buckets.iter().map(|b| b["count"].as_u64().unwrap()).sum();
    assert_eq!(total, 4);
    // 300 and 450 are below 512, 600 below 1024, 17000 below 32768.
    let at =
        |below: u64| buckets.iter().find(|b| b["below_us"] == below).unwrap()["count"].as_u64();
    assert_eq!((at(512), at(1024), at(32_768)), (Some(2), Some(1), Some(1)));
}

/// Issue 42 #8: `/metrics` says in each counter family's `# HELP` what
/// every member counts, in the words of the page (`counters.rs`).
#[test]
fn metrics_help_says_what_each_counter_counts() {
    let (_, body) = response(Route::Metrics, false);
    let metrics = String::from_utf8(body).unwrap();
    let help = metrics
        .lines()
        .find(|l| l.starts_with("# HELP rri_messages_total "))
        .expect("the messages' HELP");
    assert!(
        help.contains(
            "outcome=\"received\": datagrams and TCP messages the engine took in, from any source"
        ),
        "{help}"
    );
    let help = metrics
        .lines()
        .find(|l| l.starts_with("# HELP rri_controller_datagrams_total "))
        .expect("the controller's HELP");
    assert!(
        help.contains("so the first robot message is not among them"),
        "{help}"
    );
}

#[test]
fn metrics_parse_with_a_real_exposition_parser() {
    use openmetrics_parser::prometheus::parse_prometheus;
    use openmetrics_parser::{PrometheusType, PrometheusValue};
    let (head, body) = response(Route::Metrics, false);
    assert!(head.contains("Content-Type: text/plain; version=0.0.4; charset=utf-8"));
    let text = String::from_utf8(body).unwrap();
    let m = parse_prometheus(&text).unwrap_or_else(|e| panic!("{e:?}\n{text}"));
    let family = |name: &str| m.families.get(name).unwrap_or_else(|| panic!("no {name}"));
    // The info gauge's labels carry the hostile strings back exactly.
    let info = family("rri_info");
    let sample = info.iter_samples().next().unwrap();
    let labels = sample.get_labelset().unwrap();
    assert_eq!(labels.get_label_value("device"), Some(HOSTILE));
    assert_eq!(
        labels.get_label_value("sensor"),
        Some("sensors::Distance<\"x\">")
    );
    // A counter with a label per member.
    let messages = family("rri_messages_total");
    assert_eq!(messages.family_type, PrometheusType::Counter);
    let received = messages
        .iter_samples()
        .find(|s| s.get_labelset().unwrap().get_label_value("outcome") == Some("received"))
        .unwrap();
    match &received.value {
        PrometheusValue::Counter(c) => assert_eq!(c.value.as_f64(), 1234.0),
        v => panic!("{v:?}"),
    }
    // The state: one gauge per S2 state, 1 for the current.
    let on: Vec<_> = family("rri_state")
        .iter_samples()
        .filter(|s| matches!(&s.value, PrometheusValue::Gauge(g) if g.as_f64() == 1.0))
        .map(|s| {
            s.get_labelset()
                .unwrap()
                .get_label_value("state")
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(on, ["ERROR"]);
    // The histogram: cumulative, +Inf equal to the count, the sum in s.
    let h = family("rri_reply_latency_seconds");
    assert_eq!(h.family_type, PrometheusType::Histogram);
    let sample = h.iter_samples().next().unwrap();
    let PrometheusValue::Histogram(hv) = &sample.value else {
        panic!("{:?}", sample.value)
    };
    assert_eq!(hv.count, Some(4));
    assert!((hv.sum.as_ref().unwrap().as_f64() - 0.01835).abs() < 1e-9);
    let last = hv.buckets.last().unwrap();
    assert!(last.upper_bound.is_infinite() && last.count.as_f64() == 4.0);
    let le_511us = hv
        .buckets
        .iter()
        .find(|b| (b.upper_bound - 0.000511).abs() < 1e-12)
        .unwrap();
    assert_eq!(le_511us.count.as_f64(), 2.0);
    for pair in hv.buckets.windows(2) {
        assert!(
            pair[0].upper_bound < pair[1].upper_bound
                && pair[0].count.as_f64() <= pair[1].count.as_f64()
        );
    }
}

#[test]
fn the_page_is_the_gzip_of_its_source_and_only_for_clients_that_take_gzip() {
    let (head, body) = response(Route::Page, true);
    assert!(head.contains("Content-Encoding: gzip") && head.contains("Vary: Accept-Encoding"));
    assert!(
        head.contains("script-src 'unsafe-inline'; connect-src 'self'"),
        "{head}"
    );
    let mut page = String::new();
    flate2::read::GzDecoder::new(&body[..])
        .read_to_string(&mut page)
        .unwrap();
    let source: String = include_str!("page.html")
        .lines()
        .map(str::trim_start)
        .collect::<Vec<_>>()
        .join("\n")
        .replace(
            "const MEANS={};",
            include_str!(concat!(env!("OUT_DIR"), "/means.js")),
        );
    assert_eq!(page, source);
    // Issue 42 #8: the page says what each counter counts, from the table.
    assert!(
        page.contains(
            "\"controller.in\":\"the controller's datagrams that reached the device whole"
        ),
        "the page does not explain controller: in"
    );
    // Strings reach the DOM as text only: no markup built from data.
    assert!(
        !page.contains("innerHTML")
            && !page.contains("outerHTML")
            && !page.contains("insertAdjacentHTML")
    );
    let (head, body) = response(Route::Page, false);
    assert!(!head.contains("Content-Encoding"));
    assert!(String::from_utf8(body).unwrap().contains("/status.json"));
}

#[test]
fn a_request_through_the_parser_gets_its_response() {
    let mut p = Parser::new();
    let Parsed::Request(r) = p.feed(b"HEAD /metrics HTTP/1.1\r\nAccept-Encoding: gzip\r\n\r\n")
    else {
        panic!()
    };
    let mut out = All(Vec::new());
    respond(&mut out, r, &identity(), &status());
    let text = String::from_utf8(out.0).unwrap();
    assert!(
        text.starts_with("HTTP/1.1 200 OK\r\n") && text.ends_with("\r\n\r\n"),
        "{text}"
    );
    assert!(
        !text.contains("Content-Encoding"),
        "only the page is compressed"
    );
}
