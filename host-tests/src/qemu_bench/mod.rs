//! The QEMU bench's inputs and arithmetic (`cargo qemu-bench`): the
//! realistic and hostile corpora, the flood datagram, the firmware's bench
//! log lines, percentiles, and the baseline file CI gates on.

use crate::layouts::anydevice as layout;
use serde::{Deserialize, Serialize};

/// One corpus message. `{ID}` in `text` is replaced by a fresh 10-digit
/// Id for every send (so the length never changes).
#[derive(Clone, Debug)]
pub struct Input {
    pub name: String,
    pub text: String,
    /// The decoder must accept it (and the device answer it).
    pub accepted: bool,
}

impl Input {
    pub fn with_id(&self, id: u32) -> Vec<u8> {
        self.text.replace("{ID}", &format!("{id:010}")).into_bytes()
    }

    pub fn len(&self) -> usize {
        self.with_id(0).len()
    }

    pub fn is_empty(&self) -> bool {
        self.text.is_empty()
    }
}

/// Puts the `{ID}` placeholder in place of a message's `Id` value.
pub fn templated(message: &str) -> String {
    match (
        message.find("Id=\""),
        message
            .find("Id=\"")
            .and_then(|i| message[i + 4..].find('"')),
    ) {
        (Some(i), Some(len)) => format!(
            "{}Id=\"{{ID}}\"{}",
            &message[..i],
            &message[i + 4 + len + 1..]
        ),
        _ => message.to_string(),
    }
}

/// The manual's message, the real IRC5 capture and the maximum-value
/// message.
pub fn realistic(
    shared_rri: &std::path::Path,
    bench_dir: &std::path::Path,
) -> Result<Vec<Input>, String> {
    let files = [
        (
            "manual RobData",
            shared_rri.join("examples/messages/RobData.xml"),
        ),
        (
            "IRC5 capture",
            shared_rri.join("real-world/captured-RobData.xml"),
        ),
        ("maximum values", bench_dir.join("RobData-max.xml")),
    ];
    files
        .iter()
        .map(|(name, path)| {
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(Input {
                name: name.to_string(),
                text: templated(&text),
                accepted: true,
            })
        })
        .collect()
}

/// The manual's message without whitespace between elements.
fn compact_manual() -> String {
    templated(include_str!("../bench/RobData-compact.xml"))
}

/// Fills `open` + `unit`* + `close` to exactly `total` bytes (the unit
/// repeated, then `filler` bytes of spaces).
fn fill(open: &str, unit: &str, close: &str, total: usize) -> String {
    // `{ID}` becomes 10 digits on the wire.
    let wire = |s: &str| s.len() + 6 * s.matches("{ID}").count();
    let room = total.saturating_sub(wire(open) + wire(close));
    let n = room / unit.len().max(1);
    let mut s = String::with_capacity(total);
    s.push_str(open);
    for _ in 0..n {
        s.push_str(unit);
    }
    s.push_str(&" ".repeat(room - n * unit.len()));
    s.push_str(close);
    s
}

/// The most expensive inputs the decoder accepts or rejects late, each
/// exactly `layout::MAX_RECEIVE_LEN` bytes (longer ones are rejected at
/// once by length). Those the decoder rejects early (too many extras, a
/// repeated field) stay in the corpus: the bench shows what they cost now.
pub fn hostile() -> Vec<Input> {
    let max = layout::MAX_RECEIVE_LEN;
    let manual = compact_manual();
    let (head, rest) = manual.split_at(manual.find("><").map(|i| i + 1).unwrap_or(0));
    let body_end = rest.rfind("</RobData>").unwrap_or(rest.len());
    let (body, close) = rest.split_at(body_end);
    let inside = |unit: &str, tail: &str| fill(head, unit, &format!("{body}{tail}{close}"), max);
    // An f32 halfway case as long as a number may be (MAX_NUMBER_LEN): its
    // exact decimal expansion, then digits that only the last place
    // decides (the exact slow path of the number parser).
    let halfway = format!(
        "1.000000059604644775390625{}1",
        "0".repeat(rri_firmware::codec::number::MAX_NUMBER_LEN - 27)
    );
    assert_eq!(halfway.len(), rri_firmware::codec::number::MAX_NUMBER_LEN);
    let attrs = |names: &[&str]| -> String {
        names
            .iter()
            .map(|n| format!(" {n}=\"{halfway}\""))
            .collect()
    };
    let frame = attrs(&["X", "Y", "Z", "Rx", "Ry", "Rz"]);
    let joints = attrs(&["J1", "J2", "J3", "J4", "J5", "J6"]);
    let app: Vec<String> = (1..=18).map(|i| format!("X{i}")).collect();
    let app = attrs(&app.iter().map(String::as_str).collect::<Vec<_>>());
    // Every real of the layout once, each a halfway case: the most slow
    // paths a message without repeats can hold.
    let every_real_halfway = fill(
        &format!(
            "<RobData Id=\"{{ID}}\" Ts=\"1.202\"><P_act{frame}/><J_act{joints}/><P_des{frame}/><J_des{joints}/><AppData{app}/>"
        ),
        " ",
        "</RobData>",
        max,
    );
    let repeated_field = {
        let s = format!("<RobData Id=\"{{ID}}\" Ts=\"1.202\"><AppData{app}/>");
        fill(&s, &format!("<P_act{frame}/>"), "</RobData>", max)
    };
    // One number as long as the datagram allows: refused unread.
    let one_long_number = {
        let open = "<RobData Id=\"{ID}\" Ts=\"1.202\"><AppData X1=\"1.";
        fill(open, "0", "1\"/></RobData>", max)
    };
    vec![
        Input {
            name: "whitespace padding".into(),
            text: fill(head, " ", &format!("{body}{close}"), max),
            accepted: true,
        },
        Input {
            name: "every real a halfway case".into(),
            text: every_real_halfway,
            accepted: true,
        },
        Input {
            name: "entity references".into(),
            text: inside("", &fill("<U>", "&amp;", "</U>", max / 2)),
            accepted: true,
        },
        Input {
            name: "one long number".into(),
            text: one_long_number,
            accepted: false,
        },
        Input {
            name: "repeated field".into(),
            text: repeated_field,
            accepted: false,
        },
        Input {
            name: "unknown attributes".into(),
            text: fill(
                "<RobData Id=\"{ID}\" Ts=\"1.202\"",
                " u=\"1\"",
                "></RobData>",
                max,
            ),
            accepted: false,
        },
        Input {
            name: "unknown empty elements".into(),
            text: inside("<U/>", ""),
            accepted: false,
        },
        Input {
            name: "attributes of an unknown element".into(),
            text: inside("", &fill("<U", " u=\"1\"", "/>", max / 2)),
            accepted: false,
        },
        Input {
            name: "comments".into(),
            text: inside("<!---->", ""),
            accepted: false,
        },
        Input {
            name: "processing instructions".into(),
            text: inside("<?p?>", ""),
            accepted: false,
        },
        Input {
            name: "rejected at the last byte".into(),
            text: {
                let ok = fill(head, " ", &format!("{body}{close}"), max);
                // A bad number in the last attribute of the last element.
                let i = ok.rfind("Rz=\"").map(|i| i + 4).unwrap_or(0);
                format!("{}x{}", &ok[..i], &ok[i + 1..])
            },
            accepted: false,
        },
        Input {
            name: "truncated".into(),
            text: fill(head, " ", body, max),
            accepted: false,
        },
    ]
}

/// The flood datagram: not a robot message. Slirp shows every host
/// sender with the same address, so the flood cannot come from a foreign
/// address (which the peer filter drops before decoding); from a second
/// port it is admitted, decoded and rejected at its first byte.
pub const FLOOD_LEN: usize = 64;

/// What the flood sends, in turn: the garbage datagram, the two costliest
/// rejected inputs of [`hostile`] (a whole `MAX_RECEIVE_LEN` decoded before
/// the rejection), and a 9,000-byte datagram (IP fragments on the wire,
/// which the device's stack drops). Each is rejected, so the controller's
/// Id accounting (S3) is not disturbed; valid messages from the
/// controller's second port would take the peer over (the peer rule's
/// reconnecting controller), as the engine tests show.
pub fn flood_datagrams() -> Vec<(String, Vec<u8>)> {
    let mut all = vec![("garbage".to_string(), flood_datagram())];
    for input in hostile() {
        if input.name == "rejected at the last byte" || input.name == "truncated" {
            all.push((input.name.clone(), input.with_id(7)));
        }
    }
    all.push(("9000-byte (fragmented)".to_string(), vec![b'<'; 9000]));
    all
}

/// What a flooder did: datagrams sent per kind (in [`flood`]'s order), and
/// replies it received (none may come: every flood datagram is rejected or
/// from a source the device never answers).
#[derive(Clone, Debug, Default)]
pub struct Flooded {
    pub sent: Vec<(String, u64)>,
    pub replies: u64,
}

impl Flooded {
    pub fn total(&self) -> u64 {
        self.sent.iter().map(|(_, n)| n).sum()
    }
}

/// A flooder thread: sends `datagrams` in turn to `to`, one every `period`,
/// from a socket bound to `from`, until `stop`; counts what it sent and
/// any reply (`cargo qemu-bench`'s second port, `cargo flood`'s stranger
/// and second port).
pub fn flood(
    from: std::net::SocketAddr,
    to: std::net::SocketAddr,
    datagrams: Vec<(String, Vec<u8>)>,
    period: std::time::Duration,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<std::thread::JoinHandle<Flooded>, String> {
    use std::sync::atomic::Ordering;
    use std::time::{Duration, Instant};
    let socket = std::net::UdpSocket::bind(from).map_err(|e| format!("bind {from}: {e}"))?;
    socket.set_nonblocking(true).map_err(|e| e.to_string())?;
    Ok(std::thread::spawn(move || {
        let mut sent = vec![0u64; datagrams.len()];
        let mut replies = 0u64;
        let mut buf = [0u8; 2048];
        let mut next = Instant::now();
        let mut turn = (0..datagrams.len()).cycle();
        while !stop.load(Ordering::Relaxed) {
            let Some(i) = turn.next() else { break };
            if socket.send_to(&datagrams[i].1, to).is_ok() {
                sent[i] += 1;
            }
            while socket.recv_from(&mut buf).is_ok() {
                replies += 1;
            }
            next += period;
            match next.checked_duration_since(Instant::now()) {
                Some(wait) => std::thread::sleep(wait),
                None => next = Instant::now(),
            }
        }
        // Late replies.
        std::thread::sleep(Duration::from_millis(200));
        while socket.recv_from(&mut buf).is_ok() {
            replies += 1;
        }
        let names = datagrams.into_iter().map(|(n, _)| n);
        Flooded {
            sent: names.zip(sent).collect(),
            replies,
        }
    }))
}

pub fn flood_datagram() -> Vec<u8> {
    let mut d = b"FLOOD not a robot message; ".to_vec();
    d.resize(FLOOD_LEN, b'#');
    d
}

/// A `bench …` line of the firmware's log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    pub bytes: u32,
    pub answered: bool,
    pub compute: u32,
    pub full: u32,
}

fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let i = line.find(&format!(" {key}="))? + key.len() + 2;
    line[i..].split_whitespace().next()
}

impl Record {
    pub fn parse(line: &str) -> Option<Record> {
        if !line.contains("] bench ") {
            return None;
        }
        Some(Record {
            bytes: field(line, "bytes")?.parse().ok()?,
            answered: field(line, "answered")?.parse().ok()?,
            compute: field(line, "compute")?.parse().ok()?,
            full: field(line, "full")?.parse().ok()?,
        })
    }
}

/// A `codec …` line: per-message counts of ours, the tokenizer alone and the
/// naive baseline.
pub fn parse_codec(line: &str) -> Option<(String, u32, u32, u32, u32)> {
    let i = line.find("] codec ")? + 8;
    let name = line[i..].split_whitespace().next()?.to_string();
    Some((
        name,
        field(line, "bytes")?.parse().ok()?,
        field(line, "ours")?.parse().ok()?,
        field(line, "tokenizer")?.parse().ok()?,
        field(line, "baseline")?.parse().ok()?,
    ))
}

/// min / median / p99 / max of instruction counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    pub min: u64,
    pub median: u64,
    pub p99: u64,
    pub max: u64,
}

impl Spread {
    /// The same percentile rule as the simulator's latency figures.
    pub fn of(v: Vec<u64>) -> Spread {
        let l = crate::robot::report::Latency::of(v);
        Spread {
            min: l.min,
            median: l.median,
            p99: l.p99,
            max: l.max,
        }
    }
}

/// The figures CI compares with the baseline file
/// (`host-tests/bench/qemu-baseline.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Gated {
    pub compute_median: u64,
    pub compute_max: u64,
    pub full_median: u64,
    pub hostile_max: u64,
}

impl Gated {
    /// The figures more than `tolerance` (0.05 = 5 %) above the baseline,
    /// as readable lines.
    pub fn regressions(&self, baseline: &Gated, tolerance: f64) -> Vec<String> {
        let pairs = [
            (
                "compute median",
                self.compute_median,
                baseline.compute_median,
            ),
            ("compute max", self.compute_max, baseline.compute_max),
            ("full-path median", self.full_median, baseline.full_median),
            ("hostile max", self.hostile_max, baseline.hostile_max),
        ];
        pairs
            .iter()
            .filter(|(_, now, base)| (*now as f64) > (*base as f64) * (1.0 + tolerance))
            .map(|(name, now, base)| {
                format!(
                    "{name}: {now} instructions, baseline {base} (+{:.1} %)",
                    (*now as f64 / *base as f64 - 1.0) * 100.0
                )
            })
            .collect()
    }
}

/// Histograms of the compute and full-path instruction counts (SVG).
pub fn histogram(path: &std::path::Path, compute: &[u64], full: &[u64]) -> Result<(), String> {
    use plotters::prelude::*;
    crate::robot::report::ensure_font()?;
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = SVGBackend::new(path, (1000, 760)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, bottom) = root.split_vertically(380);
        for (area, title, data, color) in [
            (
                &top,
                "compute: decode + application + encode",
                compute,
                BLUE,
            ),
            (&bottom, "full path: frame in to reply frame out", full, RED),
        ] {
            let max = data.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.05;
            let min = data.iter().copied().min().unwrap_or(0) as f64 * 0.95;
            let bucket = ((max - min) / 60.0).max(1.0);
            let mut counts = vec![0u32; 61];
            for &v in data {
                counts[(((v as f64 - min) / bucket) as usize).min(60)] += 1;
            }
            let top_count = counts.iter().copied().max().unwrap_or(1).max(1);
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 22))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(min..max, (1u32..top_count * 2).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("Thumb-2 instructions (QEMU -icount)")
                .y_desc("messages (log)")
                .x_label_formatter(&|x| format!("{x:.0}"))
                .draw()?;
            chart.draw_series(counts.iter().enumerate().filter(|(_, n)| **n > 0).map(
                |(i, &n)| {
                    let x0 = min + i as f64 * bucket;
                    Rectangle::new([(x0, 1), (x0 + bucket * 0.9, n + 1)], color.filled())
                },
            ))?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("cannot draw {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_inputs_are_exactly_the_receive_bound() {
        for input in hostile() {
            assert_eq!(input.len(), layout::MAX_RECEIVE_LEN, "{}", input.name);
            assert!(
                input.text.contains("{ID}") || !input.accepted,
                "{}",
                input.name
            );
        }
    }

    #[test]
    fn accepted_hostile_inputs_decode_and_rejected_ones_do_not() {
        use rri_firmware::codec::decode;
        for input in hostile() {
            let mut robot = layout::RobotData::default();
            let r = decode::<layout::RobDataMessage>(&input.with_id(7), &mut robot);
            assert_eq!(r.is_ok(), input.accepted, "{}: {r:?}", input.name);
        }
    }

    #[test]
    fn flood_datagram_is_rejected_at_once() {
        use rri_firmware::codec::decode;
        let mut robot = layout::RobotData::default();
        let e = decode::<layout::RobDataMessage>(&flood_datagram(), &mut robot).unwrap_err();
        assert_eq!(e.offset, 0, "{e:?}");
        assert_eq!(flood_datagram().len(), FLOOD_LEN);
    }

    #[test]
    fn every_flood_datagram_is_rejected() {
        use rri_firmware::codec::decode;
        let flood = flood_datagrams();
        assert_eq!(flood.len(), 4, "garbage, two hostile, oversize");
        for (name, d) in &flood {
            let mut robot = layout::RobotData::default();
            assert!(
                decode::<layout::RobDataMessage>(d, &mut robot).is_err(),
                "{name} would be answered"
            );
        }
    }

    #[test]
    fn log_lines_parse() {
        let r = Record::parse(
            "[    1.000 INFO ] bench bytes=698 answered=true compute=11420 full=13000 lost=0",
        );
        assert_eq!(
            r,
            Some(Record {
                bytes: 698,
                answered: true,
                compute: 11420,
                full: 13000
            })
        );
        assert_eq!(
            parse_codec("[ 0.1 INFO ] codec manual bytes=648 ours=11 tokenizer=7 baseline=21"),
            Some(("manual".into(), 648, 11, 7, 21))
        );
    }

    #[test]
    fn spread_and_regressions() {
        let s = Spread::of((1..=100).collect());
        assert_eq!((s.min, s.median, s.p99, s.max), (1, 51, 99, 100));
        let base = Gated {
            compute_median: 100,
            compute_max: 100,
            full_median: 100,
            hostile_max: 100,
        };
        let now = Gated {
            compute_median: 105,
            compute_max: 106,
            ..base
        };
        assert_eq!(now.regressions(&base, 0.05).len(), 1);
    }
}
