//! The fuzz targets' bodies, shared by `cargo fuzz` (host-tests/fuzz, a
//! crate outside the workspace: it needs nightly and sanitizer builds) and
//! the fuzz-free replay of every target's corpus that `cargo test` runs
//! (tests/fuzz_replay.rs). Each body panics when an invariant breaks; that
//! is what libFuzzer reports as a finding.
//!
//! | target | what | invariants |
//! |---|---|---|
//! | `decode_manual` | the manual's RobData (M1–M5) | offsets inside the input; what is accepted re-encodes, re-decodes clean and encodes the same again |
//! | `decode_every_type` | every message of the every-type layout | the same, for every type and both bodies (record, value) |
//! | `tcp_framer` | M10's stream splitter | any chunking gives the same messages; each is a piece of the stream ending in `>`, within the buffer |
//! | `cycle` | datagrams and clock steps through the engine | S-rules: a reply's Id is the request's (M8), replies go only to valid, admitted sources (peer rule), counters add up |
//! | `gsi` | Settings/Description/Configuration parsing and code generation | no panic; every diagnostic points inside its file |
//! | `decode_paths` | every property the controller sends, of four layouts, through the compiled and the general decode path | where the compiled path takes a datagram, the general path accepts it with the same header, tally and record; `decode` answers as the general path ([`crate::differential`]) |

use crate::layouts::{anydevice as manual, every_type as et};
use rri_firmware::codec::{decode, encode, Tally};
use rri_firmware::engine::{Clock, Config, DropReason, Endpoint, Engine, Instant, Outcome, Pinned};
use rri_firmware::schema::{Format, MessageCodec};
use rri_firmware::tcp::Framer;
use rri_firmware::value::Time;
use std::cell::Cell;
use std::path::Path;

/// A target's body: one input, a panic when an invariant breaks.
pub type Target = fn(&[u8]);

/// Every target by name (the names of host-tests/fuzz/fuzz_targets/*.rs).
pub const TARGETS: &[(&str, Target)] = &[
    ("decode_manual", decode_manual),
    ("decode_every_type", decode_every_type),
    ("tcp_framer", tcp_framer),
    ("cycle", cycle),
    ("gsi", gsi),
    ("decode_paths", crate::differential::decode_paths),
];

/// The manual's layout: RobData as the robot sends it.
pub fn decode_manual(data: &[u8]) {
    round_trip::<manual::RobDataMessage>(data, manual::FORMAT);
}

/// The every-type layout: the first byte picks the message, the rest is
/// the datagram.
pub fn decode_every_type(data: &[u8]) {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    match pick % 5 {
        0 => round_trip::<et::RsRobDataMessage>(bytes, et::FORMAT),
        1 => round_trip::<et::RsSensDataMessage>(bytes, et::FORMAT),
        2 => round_trip::<et::SharedMessage>(bytes, et::FORMAT),
        3 => round_trip::<et::SpeedMessage>(bytes, et::FORMAT),
        _ => round_trip::<et::OffsetsMessage>(bytes, et::FORMAT),
    }
}

/// Decodes `bytes` as `M`; a rejection must point inside the input, and an
/// accepted message must survive our own encoder: its encoding decodes
/// with nothing tolerated, to the same Id, and encodes to the same bytes.
fn round_trip<M: MessageCodec>(bytes: &[u8], format: Format)
where
    M::Data: Default,
{
    let mut data = M::Data::default();
    let first = match decode::<M>(bytes, &mut data) {
        Err(e) => {
            assert!(
                e.offset <= bytes.len(),
                "{e:?} beyond {} bytes",
                bytes.len()
            );
            return;
        }
        Ok(d) => d,
    };
    assert!(
        bytes.len() <= M::MAX_RECEIVE_LEN,
        "accepted beyond MAX_RECEIVE_LEN"
    );
    let ts = first.ts.unwrap_or(Time::ZERO);
    let mut once = vec![0u8; M::MAX_ENCODED_LEN];
    let e1 = encode::<M>(&data, first.id, ts, format, &mut once)
        .expect("MAX_ENCODED_LEN holds any value");
    let once = &once[..e1.len];
    assert!(once.len() <= M::MAX_RECEIVE_LEN, "what we send, we accept");

    let mut back = M::Data::default();
    let second = decode::<M>(once, &mut back)
        .unwrap_or_else(|e| panic!("{e:?} in our own {}", String::from_utf8_lossy(once)));
    assert_eq!(second.id, first.id, "Id changed on the way (M8)");
    assert_eq!(
        second.tally,
        Tally::default(),
        "our own message needed tolerance"
    );
    let mut twice = vec![0u8; M::MAX_ENCODED_LEN];
    let e2 = encode::<M>(
        &back,
        second.id,
        second.ts.unwrap_or(Time::ZERO),
        format,
        &mut twice,
    )
    .expect("MAX_ENCODED_LEN holds any value");
    assert_eq!(
        String::from_utf8_lossy(&twice[..e2.len]),
        String::from_utf8_lossy(once),
        "a second trip through the codec changed the message"
    );
}

/// The framer's buffer in this target: the manual's message fits, and
/// overflow is within libFuzzer's default input length (4 KiB).
const FRAMER_LEN: usize = 1024;

/// M10: the stream (after the first byte, which seeds the chunking) split
/// whole and split in chunks must give the same messages and end the same.
pub fn tcp_framer(data: &[u8]) {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let (whole, whole_err) = frame_all(stream, &mut |rest| rest.len());
    let mut state = u32::from(seed) | 0x100;
    let (chunked, chunked_err) = frame_all(stream, &mut |rest| {
        // xorshift: chunk lengths 1..=16, deterministic per input.
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state as usize % 16 + 1).min(rest.len())
    });
    assert_eq!(whole, chunked, "chunking changed the messages");
    // The framer does not say at which byte of a chunk it overflowed, only
    // that it did.
    assert_eq!(
        whole_err.is_some(),
        chunked_err.is_some(),
        "chunking changed whether framing failed"
    );

    let mut from = 0;
    for m in &whole {
        assert!(!m.is_empty() && m.len() <= FRAMER_LEN);
        assert_eq!(m.last(), Some(&b'>'), "a message ends with its root's '>'");
        assert!(
            !m[0].is_ascii_whitespace(),
            "whitespace between messages is dropped"
        );
        let at = find(&stream[from..], m).expect("a message is a piece of the stream");
        from += at + m.len();
    }
}

/// Feeds `stream` through a framer in chunks of `next(rest)` bytes;
/// returns the messages and the stream offset of a framing error.
fn frame_all(stream: &[u8], next: &mut dyn FnMut(&[u8]) -> usize) -> (Vec<Vec<u8>>, Option<usize>) {
    let mut framer = Framer::<FRAMER_LEN>::new();
    let mut messages = Vec::new();
    let mut pos = 0;
    while pos < stream.len() {
        let chunk_len = next(&stream[pos..]).max(1);
        let mut chunk = &stream[pos..pos + chunk_len];
        while !chunk.is_empty() {
            let at = pos + (chunk_len - chunk.len());
            match framer.feed(chunk) {
                Err(_) => return (messages, Some(at)),
                Ok((used, done)) => {
                    assert!(used >= 1 && used <= chunk.len(), "feed used {used}");
                    if let Some(m) = done {
                        messages.push(m.to_vec());
                    }
                    chunk = &chunk[used..];
                }
            }
            assert!(framer.pending() <= FRAMER_LEN);
        }
        pos += chunk_len;
    }
    (messages, None)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// Sources the cycle target sends from: the controller on two ports, a
/// foreign address, and sources no controller can have.
const SOURCES: [Endpoint; 6] = [
    Endpoint::new([192, 168, 125, 1], 50_000),
    Endpoint::new([192, 168, 125, 1], 50_001),
    Endpoint::new([192, 168, 125, 66], 50_000),
    Endpoint::new([192, 168, 125, 1], 0),
    Endpoint::new([255, 255, 255, 255], 50_000),
    Endpoint::new([224, 0, 0, 1], 50_000),
];

struct StepClock(Cell<u64>);

impl Clock for StepClock {
    fn now(&self) -> Instant {
        Instant(self.0.get())
    }
}

/// Reads the input as a small program. Two header bytes set the
/// supervision (TimeOut, MaxLost, DryRun, a pinned controller, periodic
/// sends); then each op byte: `op % 4` = 0 a good message with an Id near
/// the last one, 1 raw bytes, 2 a clock step and `poll`, 3 a long step.
/// `op / 4 % 6` picks the source.
pub fn cycle(data: &[u8]) {
    let mut input = data.iter().copied();
    let (Some(a), Some(b)) = (input.next(), input.next()) else {
        return;
    };
    let config = Config {
        timeout_ms: 20 + u32::from(a & 0x3f) * 4,
        max_lost: u32::from(b & 7),
        dry_run: a & 0x40 != 0,
        controller: (b & 8 != 0).then_some(Pinned {
            ip: SOURCES[0].ip,
            port: (b & 16 != 0).then_some(SOURCES[0].port),
        }),
        reply: 0,
        send_period_ms: if b & 32 != 0 { 4 } else { 0 },
        periodic: &[],
        format: manual::FORMAT,
    };
    let mut engine: Engine<manual::RobotProperties, manual::DeviceProperties> = Engine::new(config);
    engine.listening();
    let clock = StepClock(Cell::new(1_000_000));
    let mut out = [0u8; manual::MAX_SEND_LEN];
    let mut calls = 0u32;
    let mut next_id = 1u32;
    // The peer rule restated: who was answered last, and when.
    let mut peer: Option<(Endpoint, u64)> = None;

    while let Some(op) = input.next() {
        let from = SOURCES[usize::from(op / 4) % SOURCES.len()];
        let bytes = match op % 4 {
            0 => {
                let delta = input.next().unwrap_or(1) as i8;
                next_id = next_id.wrapping_add(delta as u32);
                good_message(next_id).into_bytes()
            }
            1 => {
                let len = usize::from(input.next().unwrap_or(0));
                input.by_ref().take(len).collect()
            }
            2 => {
                let ms = u64::from(input.next().unwrap_or(0));
                clock.0.set(clock.0.get() + ms * 1000);
                if let Some((to, len)) = engine.poll(&mut (), &clock, &mut out) {
                    assert!(to.is_valid_source(), "periodic send to {to:?}");
                    assert_eq!(
                        Some(to),
                        engine.peer().or(config
                            .controller
                            .and_then(|p| { p.port.map(|port| Endpoint::new(p.ip, port)) }))
                    );
                    let mut reply = manual::SensorData::default();
                    decode::<manual::SensDataMessage>(&out[..len], &mut reply)
                        .expect("a periodic send decodes");
                }
                continue;
            }
            _ => {
                let ms = u64::from(u16::from_le_bytes([
                    input.next().unwrap_or(0),
                    input.next().unwrap_or(0),
                ]));
                clock.0.set(clock.0.get() + ms * 1000);
                continue;
            }
        };
        let now = clock.0.get();
        calls += 1;
        let outcome = engine.on_message(&mut (), &clock, from, &bytes, Instant(now), &mut out);
        if !from.is_valid_source() {
            assert_eq!(outcome, Outcome::Dropped(DropReason::InvalidSource));
        }
        if let Outcome::Reply { to, len } = outcome {
            assert_eq!(to, from, "a reply goes where the request came from");
            assert!(from.is_valid_source());
            if let Some(p) = config.controller {
                assert_eq!(from.ip, p.ip, "a pinned controller only");
            }
            if let Some((old, heard)) = peer {
                if old.ip != from.ip {
                    assert!(
                        now - heard >= u64::from(config.timeout_ms) * 1000,
                        "{from:?} answered while {old:?} spoke {} µs ago",
                        now - heard
                    );
                }
            }
            peer = Some((from, now));
            let mut request = manual::RobotData::default();
            let asked = decode::<manual::RobDataMessage>(&bytes, &mut request)
                .expect("only a decodable message is answered");
            let mut reply = manual::SensorData::default();
            let answered = decode::<manual::SensDataMessage>(&out[..len], &mut reply)
                .expect("the reply decodes");
            assert_eq!(
                answered.id, asked.id,
                "M8: the reply carries the request's Id"
            );
        }
        let s = engine.stats();
        assert_eq!(s.received, u64::from(calls));
        let dropped = s.dropped_foreign
            + s.dropped_invalid_source
            + s.dropped_throttled
            + s.dropped_decode
            + s.dropped_encode;
        assert_eq!(
            s.received,
            s.answered + dropped,
            "every message answered or dropped"
        );
        assert_eq!(s.decode_errors.iter().sum::<u64>(), s.dropped_decode);
        assert_eq!(s.sent, s.answered + s.periodic_sent);
    }
}

fn good_message(id: u32) -> String {
    format!(
        r#"<RobData Id="{id}" Ts="1.5"><P_act X="1" Y="2" Z="3" Rx="0" Ry="0" Rz="0"/></RobData>"#
    )
}

/// Settings.xml, Description.xml and Configuration.xml, separated by NUL
/// bytes, parsed and checked as the build script does; a configuration
/// without errors is then generated into code (with the fuzzed
/// description when it is valid, else the manual example's).
pub fn gsi(data: &[u8]) {
    use gsi_config::{configuration, description, settings, xml, Device, Sink};
    let mut parts = data.splitn(3, |&b| b == 0);
    let texts: Vec<String> = (0..3)
        .map(|_| String::from_utf8_lossy(parts.next().unwrap_or(b"")).into_owned())
        .collect();
    let path = Path::new("fuzz.xml");
    let mut diags = Vec::new();

    let mut sink = Sink::new(path, &mut diags);
    if let Some(root) = xml::parse(&texts[0], &mut sink) {
        let s = settings::read(&root, &mut sink);
        let _ = settings::choose(&s, None, &mut sink);
    }
    check_positions(&texts[0], &diags);

    let mut diags = Vec::new();
    let mut sink = Sink::new(path, &mut diags);
    let desc = xml::parse(&texts[1], &mut sink)
        .map(|root| description::read(&root, "AnyDevice", &mut sink));
    check_positions(&texts[1], &diags);

    let mut diags = Vec::new();
    let mut sink = Sink::new(path, &mut diags);
    let config = xml::parse(&texts[2], &mut sink).map(|root| configuration::read(&root, &mut sink));
    check_positions(&texts[2], &diags);
    let Some(config) = config.filter(|_| !diags.iter().any(|d| d.is_error())) else {
        return;
    };
    let example = example_device();
    let mut device = Device {
        enums: config.enums,
        records: config.records,
        properties: config.properties,
        ..example.clone()
    };
    if let Some(d) = desc {
        if let (Some(name), Some(network), Some(channel), Some(supervision)) =
            (d.name, d.network, d.channel, d.supervision)
        {
            device.name = name;
            device.network = network;
            device.channel = channel;
            device.supervision = supervision;
        }
    }
    let opts = gsi_codegen::Options {
        crate_path: "::rri_firmware".into(),
        ..Default::default()
    };
    if let Err(errors) = gsi_codegen::generate(&device, &opts) {
        assert!(!errors.is_empty());
    }
}

/// A diagnostic names a line and column of its file (a build error the
/// user can act on).
fn check_positions(text: &str, diags: &[gsi_config::Diagnostic]) {
    let lines = text.split('\n').count() as u32;
    for d in diags {
        assert!(
            d.pos.line >= 1 && d.pos.line <= lines && d.pos.col >= 1,
            "{d:?} outside a text of {lines} lines"
        );
    }
}

fn example_device() -> &'static gsi_config::Device {
    static DEVICE: std::sync::OnceLock<gsi_config::Device> = std::sync::OnceLock::new();
    DEVICE.get_or_init(|| {
        gsi_config::load(&crate::shared_rri().join("examples/GSI"), None)
            .unwrap_or_else(|failed| panic!("the manual's example does not load: {failed}"))
            .device
    })
}

/// Seed inputs of a target, built from the protocol material beside the
/// checkout (the manual's and the real-world messages and GSI files), so
/// the corpora start from what controllers really send.
pub fn seeds(target: &str) -> Vec<Vec<u8>> {
    let rri = crate::shared_rri();
    let read = |p: &str| std::fs::read(rri.join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let messages = [
        read("examples/messages/RobData.xml"),
        read("real-world/captured-RobData.xml"),
        good_message(7).into_bytes(),
    ];
    match target {
        "decode_manual" => messages.to_vec(),
        "decode_every_type" => every_type_seeds(),
        "decode_paths" => crate::differential::seeds(),
        "tcp_framer" => messages
            .iter()
            .map(|m| {
                let mut stream = vec![3u8];
                for _ in 0..2 {
                    stream.extend_from_slice(m);
                    stream.extend_from_slice(b"\r\n");
                }
                stream
            })
            .collect(),
        "cycle" => {
            // TimeOut 100 ms, MaxLost 3; good messages, a raw manual
            // message, a foreign source, a step past TimeOut, a takeover.
            let mut p = vec![20, 3, 0, 1, 0, 1, 2, 4];
            let raw = &messages[0];
            p.extend_from_slice(&[1, raw.len().min(255) as u8]);
            p.extend_from_slice(&raw[..raw.len().min(255)]);
            p.extend_from_slice(&[8, 1, 2, 200, 8, 1, 0, 1]);
            vec![p]
        }
        "gsi" => {
            let mut all = Vec::new();
            for (dir, device) in [("examples/GSI", "AnyDevice"), ("real-world/GSI", "UdpTest")] {
                let mut seed = read(&format!("{dir}/Settings.xml"));
                for file in ["Description.xml", "Configuration.xml"] {
                    seed.push(0);
                    seed.extend_from_slice(&read(&format!("{dir}/{device}/{file}")));
                }
                all.push(seed);
            }
            all
        }
        other => panic!("no fuzz target {other}"),
    }
}

/// One message of each kind of the every-type layout, written by our
/// encoder (the selector byte first).
fn every_type_seeds() -> Vec<Vec<u8>> {
    fn one<M: MessageCodec>(pick: u8) -> Vec<u8>
    where
        M::Data: Default,
    {
        let mut buf = vec![0u8; M::MAX_ENCODED_LEN];
        let e =
            encode::<M>(&M::Data::default(), 42, Time::ZERO, et::FORMAT, &mut buf).expect("fits");
        let mut seed = vec![pick];
        seed.extend_from_slice(&buf[..e.len]);
        seed
    }
    vec![
        one::<et::RsRobDataMessage>(0),
        one::<et::RsSensDataMessage>(1),
        one::<et::SharedMessage>(2),
        one::<et::SpeedMessage>(3),
        one::<et::OffsetsMessage>(4),
    ]
}
