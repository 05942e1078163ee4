//! What a run produced: per-cycle records, the summary, and the files a
//! user asked for (CSV, JSON, a plot, a pcap).

use serde::Serialize;
use smoltcp::phy::ChecksumCapabilities;
use smoltcp::wire::{
    IpAddress, IpProtocol, Ipv4Address, Ipv4Packet, Ipv4Repr, TcpControl, TcpPacket, TcpRepr,
    TcpSeqNumber, UdpPacket, UdpRepr, UDP_HEADER_LEN,
};
use std::collections::HashMap;
use std::io::{self, Write};
use std::net::SocketAddr;
use std::path::Path;

/// One robot message and what came back.
#[derive(Clone, Debug, Default)]
pub struct Cycle {
    pub cycle: u64,
    pub id: u32,
    /// µs since the run started.
    pub sent_us: u64,
    pub reply_us: Option<u64>,
    /// Not sent (a `drop` fault).
    pub dropped_by_fault: bool,
    /// Which `--send` property (position in the list; 0 by default).
    pub property: usize,
}

impl Cycle {
    pub fn latency_us(&self) -> Option<u64> {
        self.reply_us.map(|r| r.saturating_sub(self.sent_us))
    }
}

/// The end-of-run summary (also `--json`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Summary {
    pub device: String,
    pub target: String,
    pub transport: String,
    pub rate_ms: u32,
    pub cycles: u64,
    pub sent: u64,
    pub answered: u64,
    /// Answered later than one cycle.
    pub late: u64,
    /// Never answered.
    pub lost: u64,
    /// Replies whose Id matches no message sent (M8).
    pub wrong_id: u64,
    /// Replies that are not the expected message (root, fields, values).
    pub malformed: u64,
    /// Extra replies to messages sent twice (a `duplicate` fault).
    pub duplicate_replies: u64,
    /// What `--fault` injected, to check a device's counters against.
    pub injected: Injected,
    /// `false` with `--no-pacing` (lock-step: each message after the last
    /// reply, as fast as the sensor answers).
    pub paced: bool,
    /// Paced runs: the most a message went out after its scheduled time
    /// (the simulator's own scheduling jitter, not the sensor's).
    pub send_lag_max_us: u64,
    /// Outputs (`--csv`, `--plot`, `--pcap`, `--json`) that could not be
    /// written after the run.
    pub output_errors: Vec<String>,
    pub latency_us: Latency,
    /// The controller's supervision verdict (S1): `None` = never tripped.
    pub supervision_tripped: Option<String>,
    /// The first problem with a reply, for the user.
    pub first_error: Option<String>,
    pub elapsed_s: f64,
    /// Per property (M11): each one sent, then each device property
    /// received (the reply, periodic ones).
    pub properties: Vec<PropertyFigures>,
}

/// Faults injected by `--fault`, by kind.
#[derive(Clone, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Injected {
    /// Messages not sent (their Ids skipped).
    pub dropped: u64,
    /// Messages sent twice.
    pub duplicated: u64,
    /// Messages held back and sent after the next one.
    pub reordered: u64,
    /// Garbage datagrams sent besides the messages.
    pub garbage: u64,
    /// 9,000-byte datagrams sent besides the messages.
    pub oversize: u64,
    /// Pauses in sending.
    pub pauses: u64,
    /// Messages sent from the second source port.
    pub second_port: u64,
}

impl Injected {
    fn is_empty(&self) -> bool {
        *self == Injected::default()
    }
}

/// One property's share of a run.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct PropertyFigures {
    pub name: String,
    /// `sent` (by the simulator), `reply` or `periodic` (by the device).
    pub direction: String,
    /// Sending period (sent properties).
    pub period_ms: Option<u32>,
    /// Messages sent, or received from the device.
    pub messages: u64,
    /// Of the sent ones: answered, never answered.
    pub answered: u64,
    pub lost: u64,
}

#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Latency {
    pub min: u64,
    pub median: u64,
    pub p99: u64,
    pub p99_9: u64,
    pub max: u64,
}

impl Latency {
    pub fn of(mut samples: Vec<u64>) -> Latency {
        if samples.is_empty() {
            return Latency::default();
        }
        samples.sort_unstable();
        let at = |q: f64| samples[(((samples.len() - 1) as f64) * q).round() as usize];
        Latency {
            min: samples[0],
            median: at(0.5),
            p99: at(0.99),
            p99_9: at(0.999),
            max: samples[samples.len() - 1],
        }
    }
}

impl Summary {
    /// Exit status 0 if and only if supervision never tripped and every
    /// reply was correct.
    pub fn passed(&self) -> bool {
        self.supervision_tripped.is_none() && self.wrong_id == 0 && self.malformed == 0
    }

    /// Why the run did not pass.
    pub fn failure(&self) -> Option<String> {
        if let Some(s) = &self.supervision_tripped {
            let hint = if self.answered == 0 && self.malformed == 0 {
                format!(
                    "; no reply at all from {}: is a sensor for device {} listening there?",
                    self.target, self.device
                )
            } else {
                String::new()
            };
            return Some(format!("supervision tripped: {s}{hint}"));
        }
        if !self.output_errors.is_empty() {
            return Some(format!(
                "the run passed but not every output was written: {}",
                self.output_errors.join("; ")
            ));
        }
        if self.wrong_id > 0 {
            return Some(format!("{} replies with a wrong Id (M8)", self.wrong_id));
        }
        if self.malformed > 0 {
            return Some(format!(
                "{} malformed replies; first: {}",
                self.malformed,
                self.first_error.as_deref().unwrap_or("?")
            ));
        }
        None
    }

    pub fn print(&self, out: &mut dyn Write) -> io::Result<()> {
        let l = &self.latency_us;
        let pace = if self.paced {
            format!("every {} ms", self.rate_ms)
        } else {
            "lock-step, no pacing".to_string()
        };
        writeln!(
            out,
            "robot simulator: {} cycles to {} ({} over {}, {pace}) in {:.2} s",
            self.cycles, self.device, self.target, self.transport, self.elapsed_s
        )?;
        let i = &self.injected;
        if !i.is_empty() {
            writeln!(
                out,
                "  injected: dropped {}  duplicated {}  reordered {}  garbage {}  oversize {}  pauses {}  second-port {}",
                i.dropped, i.duplicated, i.reordered, i.garbage, i.oversize, i.pauses, i.second_port
            )?;
        }
        writeln!(out, "  sent {}  answered {}  late {}  lost {}  wrong Id {}  malformed {}  duplicate replies {}", self.sent, self.answered, self.late, self.lost, self.wrong_id, self.malformed, self.duplicate_replies)?;
        writeln!(
            out,
            "  latency us (reply - actual send; late = more than one cycle): min {}  median {}  p99 {}  p99.9 {}  max {}",
            l.min, l.median, l.p99, l.p99_9, l.max
        )?;
        if self.paced {
            writeln!(
                out,
                "  sending lag behind schedule (the simulator's own jitter) us: max {}",
                self.send_lag_max_us
            )?;
        }
        if self.properties.len() > 2 {
            for p in &self.properties {
                match p.period_ms {
                    Some(ms) => writeln!(
                        out,
                        "  {} every {ms} ms: sent {}  answered {}  lost {}",
                        p.name, p.messages, p.answered, p.lost
                    )?,
                    None => writeln!(
                        out,
                        "  {} ({}): received {}",
                        p.name, p.direction, p.messages
                    )?,
                }
            }
        }
        match &self.supervision_tripped {
            None => writeln!(out, "  supervision: never tripped"),
            Some(s) => writeln!(out, "  supervision: TRIPPED ({s})"),
        }
    }
}

pub fn write_csv(path: &Path, cycles: &[Cycle], rate_us: u64) -> io::Result<()> {
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "cycle,id,sent_us,reply_us,latency_us,late,verdict,property"
    )?;
    for c in cycles {
        let verdict = if c.dropped_by_fault {
            "dropped-by-fault"
        } else if c.reply_us.is_none() {
            "lost"
        } else {
            "answered"
        };
        let lat = c.latency_us();
        writeln!(
            f,
            "{},{},{},{},{},{},{},{}",
            c.cycle,
            c.id,
            c.sent_us,
            c.reply_us.map(|v| v.to_string()).unwrap_or_default(),
            lat.map(|v| v.to_string()).unwrap_or_default(),
            lat.is_some_and(|l| l > rate_us),
            verdict,
            c.property
        )?;
    }
    f.flush()
}

pub fn write_json(path: &Path, summary: &Summary) -> io::Result<()> {
    let text = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
    std::fs::write(path, text + "\n")
}

/// A font for plot labels: plotters renders text with ab_glyph and needs a
/// TrueType file (Debian: fonts-dejavu-core); `RRI_PLOT_FONT` overrides.
fn font() -> Result<&'static [u8], String> {
    // A font the user named must be the one used.
    if let Some(path) = std::env::var_os("RRI_PLOT_FONT").filter(|p| !p.is_empty()) {
        return std::fs::read(&path)
            .map(|bytes| &*Box::leak(bytes.into_boxed_slice()))
            .map_err(|e| format!("RRI_PLOT_FONT={}: {e}", path.to_string_lossy()));
    }
    let candidates = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf".to_string(),
        "/usr/share/fonts/TTF/DejaVuSans.ttf".into(),
        "/Library/Fonts/Arial.ttf".into(),
        "C:\\Windows\\Fonts\\arial.ttf".into(),
    ];
    for c in candidates.iter().filter(|c| !c.is_empty()) {
        if let Ok(bytes) = std::fs::read(c) {
            return Ok(Box::leak(bytes.into_boxed_slice()));
        }
    }
    Err("no TrueType font for the plot labels: install fonts-dejavu-core or set RRI_PLOT_FONT=/path/to/font.ttf".into())
}

/// A latency histogram over a latency-over-time plot, as SVG or PNG (by
/// the file's extension).
/// Registers the TrueType font plotters draws labels with (once).
pub fn ensure_font() -> Result<(), String> {
    static FONT: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    FONT.get_or_init(|| {
        let bytes = font()?;
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .map_err(|_| "font not usable".to_string())
    })
    .clone()
}

/// `YYYY-MM-DD HH:MM UTC` of a Unix time in µs (civil-from-days, so no
/// date crate is needed for one caption).
fn utc(unix_us: u64) -> String {
    let secs = unix_us / 1_000_000;
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60
    )
}

/// Latency histogram (log-scale counts, so the tail shows next to the
/// median's bars) and latency over time, with the run in the title,
/// median, p99 and one cycle marked, and lost messages marked at the top
/// of the time plot.
pub fn write_plot(
    path: &Path,
    cycles: &[Cycle],
    rate_us: u64,
    summary: &Summary,
    start_unix_us: u64,
) -> Result<(), String> {
    use plotters::prelude::*;
    ensure_font()?;
    let points: Vec<(f64, f64)> = cycles
        .iter()
        .filter_map(|c| c.latency_us().map(|l| (c.sent_us as f64 / 1e6, l as f64)))
        .collect();
    let lost: Vec<f64> = cycles
        .iter()
        .filter(|c| !c.dropped_by_fault && c.reply_us.is_none())
        .map(|c| c.sent_us as f64 / 1e6)
        .collect();
    let max_lat = points.iter().map(|p| p.1).fold(rate_us as f64, f64::max) * 1.05;
    let t_end = cycles
        .last()
        .map(|c| c.sent_us as f64 / 1e6)
        .unwrap_or(1.0)
        .max(0.001);
    let bucket = (max_lat / 60.0).max(1.0);
    let mut counts = vec![0u32; 61];
    for p in &points {
        counts[((p.1 / bucket) as usize).min(60)] += 1;
    }
    let max_count = counts.iter().copied().max().unwrap_or(1).max(1);
    let pace = if summary.paced {
        format!("every {} ms", summary.rate_ms)
    } else {
        "lock-step".to_string()
    };
    let data = PlotData {
        points,
        lost,
        counts,
        bucket,
        max_lat,
        max_count,
        t_end,
        rate_us,
        median: summary.latency_us.median as f64,
        p99: summary.latency_us.p99 as f64,
        title: format!(
            "{} over {}, {} cycles {pace}, {}",
            summary.device,
            summary.transport,
            summary.cycles,
            utc(start_unix_us)
        ),
    };
    let size = (1000, 800);
    let r = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("svg") => draw(SVGBackend::new(path, size).into_drawing_area(), &data),
        Some("png") => draw(BitMapBackend::new(path, size).into_drawing_area(), &data),
        _ => {
            return Err(format!(
                "--plot {}: the file must end in .svg or .png",
                path.display()
            ))
        }
    };
    r.map_err(|e| format!("cannot draw {}: {e}", path.display()))
}

struct PlotData {
    points: Vec<(f64, f64)>,
    /// Send times (s) of messages never answered.
    lost: Vec<f64>,
    counts: Vec<u32>,
    bucket: f64,
    max_lat: f64,
    max_count: u32,
    t_end: f64,
    rate_us: u64,
    median: f64,
    p99: f64,
    title: String,
}

/// Tick labels as whole numbers (`250`, not `250.0`).
fn whole(v: &f64) -> String {
    format!("{v:.0}")
}

/// Tick labels of seconds: `0.5`, `2` (not `2.0`).
fn seconds(v: &f64) -> String {
    let s = format!("{v:.1}");
    s.strip_suffix(".0").map(String::from).unwrap_or(s)
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    d: &PlotData,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let (bucket, max_lat, t_end, rate_us) = (d.bucket, d.max_lat, d.t_end, d.rate_us as f64);
    root.fill(&WHITE)?;
    let root = root.titled(&d.title, ("sans-serif", 20))?;
    let (top, bottom) = root.split_vertically(390);
    let top_count = f64::from(d.max_count) * 2.0;
    let mut h = ChartBuilder::on(&top)
        .caption("Reply latency histogram (log scale)", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..max_lat, (0.8f64..top_count).log_scale())?;
    h.configure_mesh()
        .x_desc("latency (µs)")
        .y_desc("replies")
        .x_label_formatter(&whole)
        .y_label_formatter(&whole)
        .draw()?;
    h.draw_series(
        d.counts
            .iter()
            .enumerate()
            .filter(|(_, &n)| n > 0)
            .map(|(i, &n)| {
                let x0 = i as f64 * bucket;
                Rectangle::new(
                    [(x0, 0.8), (x0 + bucket * 0.9, f64::from(n))],
                    BLUE.filled(),
                )
            }),
    )?;
    for (x, color, label) in [
        (d.median, GREEN, format!("median {:.0} µs", d.median)),
        (d.p99, MAGENTA, format!("p99 {:.0} µs", d.p99)),
        (rate_us, RED, format!("one cycle ({rate_us:.0} µs)")),
    ] {
        h.draw_series(std::iter::once(PathElement::new(
            vec![(x, 0.8), (x, top_count)],
            color.stroke_width(2),
        )))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    h.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    let mut t = ChartBuilder::on(&bottom)
        .caption("Reply latency over time", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..t_end, 0f64..max_lat)?;
    t.configure_mesh()
        .x_desc("time (s)")
        .y_desc("latency (µs)")
        .x_label_formatter(&seconds)
        .y_label_formatter(&whole)
        .draw()?;
    t.draw_series(
        d.points
            .iter()
            .map(|&(x, y)| Circle::new((x, y), 1, BLUE.filled())),
    )?;
    t.draw_series(LineSeries::new(vec![(0.0, rate_us), (t_end, rate_us)], RED))?;
    t.draw_series(
        d.lost
            .iter()
            .map(|&x| Cross::new((x, max_lat * 0.98), 4, RED.stroke_width(2))),
    )?
    .label(format!("lost ({})", d.lost.len()))
    .legend(|(x, y)| Cross::new((x + 10, y), 4, RED.stroke_width(2)));
    t.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// A captured datagram (or TCP segment payload).
#[derive(Clone, Debug)]
pub struct Packet {
    pub at_us: u64,
    pub from: SocketAddr,
    pub to: SocketAddr,
    pub payload: Vec<u8>,
}

fn v4(a: SocketAddr) -> Ipv4Address {
    match a {
        SocketAddr::V4(a) => *a.ip(),
        SocketAddr::V6(_) => Ipv4Address::UNSPECIFIED,
    }
}

/// One IPv4 packet with its transport header and payload, every checksum
/// computed (smoltcp's wire layer).
fn ipv4_packet(from: SocketAddr, to: SocketAddr, l4: &L4<'_>, payload: &[u8]) -> Vec<u8> {
    let caps = ChecksumCapabilities::default();
    let (src, dst) = (v4(from), v4(to));
    let (protocol, l4_len) = match l4 {
        L4::Udp => (IpProtocol::Udp, UDP_HEADER_LEN + payload.len()),
        L4::Tcp(repr) => (IpProtocol::Tcp, repr.buffer_len()),
    };
    let ip = Ipv4Repr {
        src_addr: src,
        dst_addr: dst,
        next_header: protocol,
        payload_len: l4_len,
        hop_limit: 64,
    };
    let mut buf = vec![0u8; ip.buffer_len() + l4_len];
    ip.emit(&mut Ipv4Packet::new_unchecked(&mut buf[..]), &caps);
    let body = &mut buf[ip.buffer_len()..];
    let (src, dst) = (IpAddress::Ipv4(src), IpAddress::Ipv4(dst));
    match l4 {
        L4::Udp => UdpRepr {
            src_port: from.port(),
            dst_port: to.port(),
        }
        .emit(
            &mut UdpPacket::new_unchecked(body),
            &src,
            &dst,
            payload.len(),
            |b| b.copy_from_slice(payload),
            &caps,
        ),
        L4::Tcp(repr) => repr.emit(&mut TcpPacket::new_unchecked(body), &src, &dst, &caps),
    }
    buf
}

enum L4<'a> {
    Udp,
    Tcp(TcpRepr<'a>),
}

/// The TCP segment `from` → `to` with `control` and `payload`, sequence
/// and acknowledgement numbers from `next` (each side's next sequence
/// number), which it advances.
fn segment<'a>(
    next: &mut HashMap<SocketAddr, u32>,
    from: SocketAddr,
    to: SocketAddr,
    control: TcpControl,
    payload: &'a [u8],
) -> TcpRepr<'a> {
    let seq = *next.get(&from).unwrap_or(&0);
    let ack = next.get(&to).copied();
    let len =
        payload.len() as u32 + u32::from(matches!(control, TcpControl::Syn | TcpControl::Fin));
    next.insert(from, seq.wrapping_add(len));
    TcpRepr {
        src_port: from.port(),
        dst_port: to.port(),
        control,
        seq_number: TcpSeqNumber(seq as i32),
        ack_number: ack.map(|a| TcpSeqNumber(a as i32)),
        window_len: 65_535,
        window_scale: None,
        max_seg_size: None,
        sack_permitted: false,
        sack_ranges: [None; 3],
        timestamp: None,
        payload,
    }
}

/// Writes the exchanged messages as a pcap file Wireshark and tshark read
/// cleanly: raw IPv4 packets (link type 101) with real IPv4, UDP and TCP
/// checksums. A TCP capture opens with the three-way handshake and closes
/// with the FIN exchange around the messages, with running sequence and
/// acknowledgement numbers, so the stream can be followed.
pub fn write_pcap(
    path: &Path,
    packets: &[Packet],
    start_unix_us: u64,
    tcp: bool,
) -> io::Result<()> {
    let mut frames: Vec<(u64, Vec<u8>)> = Vec::new();
    if tcp {
        if let (Some(first), Some(last)) = (packets.first(), packets.last()) {
            let (robot, sensor) = (first.from, first.to);
            let mut next: HashMap<SocketAddr, u32> = HashMap::new();
            next.insert(robot, 1_000);
            next.insert(sensor, 5_000);
            let open = first.at_us.saturating_sub(3);
            let mut push = |next: &mut HashMap<SocketAddr, u32>, at, from, to, control, payload| {
                let repr = segment(next, from, to, control, payload);
                frames.push((at, ipv4_packet(from, to, &L4::Tcp(repr), payload)));
            };
            // SYN carries no Ack; the robot's Ack starts with the SYN-ACK.
            let syn_ack_from = next.remove(&sensor).unwrap_or(5_000);
            push(&mut next, open, robot, sensor, TcpControl::Syn, &[]);
            next.insert(sensor, syn_ack_from);
            push(&mut next, open + 1, sensor, robot, TcpControl::Syn, &[]);
            push(&mut next, open + 2, robot, sensor, TcpControl::None, &[]);
            for p in packets {
                push(
                    &mut next,
                    p.at_us,
                    p.from,
                    p.to,
                    TcpControl::Psh,
                    &p.payload,
                );
            }
            let close = last.at_us + 1;
            push(&mut next, close, robot, sensor, TcpControl::Fin, &[]);
            push(&mut next, close + 1, sensor, robot, TcpControl::Fin, &[]);
            push(&mut next, close + 2, robot, sensor, TcpControl::None, &[]);
        }
    } else {
        for p in packets {
            frames.push((p.at_us, ipv4_packet(p.from, p.to, &L4::Udp, &p.payload)));
        }
    }
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    // Global header: magic, v2.4, tz 0, sigfigs 0, snaplen, LINKTYPE_RAW.
    f.write_all(&0xa1b2_c3d4u32.to_le_bytes())?;
    f.write_all(&2u16.to_le_bytes())?;
    f.write_all(&4u16.to_le_bytes())?;
    f.write_all(&0i32.to_le_bytes())?;
    f.write_all(&0u32.to_le_bytes())?;
    f.write_all(&65_535u32.to_le_bytes())?;
    f.write_all(&101u32.to_le_bytes())?;
    for (at_us, pkt) in frames {
        let t = start_unix_us + at_us;
        f.write_all(&((t / 1_000_000) as u32).to_le_bytes())?;
        f.write_all(&((t % 1_000_000) as u32).to_le_bytes())?;
        f.write_all(&(pkt.len() as u32).to_le_bytes())?;
        f.write_all(&(pkt.len() as u32).to_le_bytes())?;
        f.write_all(&pkt)?;
    }
    f.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_without_a_trailing_zero() {
        assert_eq!(
            (whole(&250.0), seconds(&2.0), seconds(&0.5)),
            ("250".into(), "2".into(), "0.5".into())
        );
    }

    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00 UTC");
        // 2026-11-23 21:34:56 UTC.
        assert_eq!(utc(1_795_469_696_000_000), "2026-11-23 21:34 UTC");
        assert_eq!(utc(951_782_400_000_000), "2000-02-29 00:00 UTC");
    }

    #[test]
    fn percentiles() {
        let l = Latency::of((1..=1000).collect());
        assert_eq!(
            (l.min, l.median, l.p99, l.p99_9, l.max),
            (1, 501, 990, 999, 1000)
        );
        assert_eq!(Latency::of(vec![]), Latency::default());
    }
}
