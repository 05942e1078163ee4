//! What a run produced: per-cycle records, the summary, and the files a
//! user asked for (CSV, JSON, a plot, a pcap).

use serde::Serialize;
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
            return Some(format!("supervision tripped: {s}"));
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
        writeln!(
            out,
            "robot simulator: {} cycles to {} ({} over {}, every {} ms) in {:.2} s",
            self.cycles, self.device, self.target, self.transport, self.rate_ms, self.elapsed_s
        )?;
        writeln!(out, "  sent {}  answered {}  late {}  lost {}  wrong Id {}  malformed {}  duplicate replies {}", self.sent, self.answered, self.late, self.lost, self.wrong_id, self.malformed, self.duplicate_replies)?;
        writeln!(
            out,
            "  latency us: min {}  median {}  p99 {}  p99.9 {}  max {}",
            l.min, l.median, l.p99, l.p99_9, l.max
        )?;
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
    let candidates = [
        std::env::var("RRI_PLOT_FONT").unwrap_or_default(),
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf".into(),
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

pub fn write_plot(path: &Path, cycles: &[Cycle], rate_us: u64) -> Result<(), String> {
    use plotters::prelude::*;
    ensure_font()?;
    let points: Vec<(f64, f64)> = cycles
        .iter()
        .filter_map(|c| c.latency_us().map(|l| (c.sent_us as f64 / 1e6, l as f64)))
        .collect();
    let max_lat = points.iter().map(|p| p.1).fold(rate_us as f64, f64::max) * 1.05;
    let t_end = points.last().map(|p| p.0).unwrap_or(1.0).max(0.001);
    let bucket = (max_lat / 60.0).max(1.0);
    let mut counts = vec![0u32; 61];
    for p in &points {
        counts[((p.1 / bucket) as usize).min(60)] += 1;
    }
    let max_count = counts.iter().copied().max().unwrap_or(1).max(1);

    let data = PlotData {
        points,
        counts,
        bucket,
        max_lat,
        max_count,
        t_end,
        rate_us,
    };
    let size = (1000, 760);
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
    counts: Vec<u32>,
    bucket: f64,
    max_lat: f64,
    max_count: u32,
    t_end: f64,
    rate_us: u64,
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    d: &PlotData,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let PlotData {
        points,
        counts,
        bucket,
        max_lat,
        max_count,
        t_end,
        rate_us,
    } = d;
    let (bucket, max_lat, max_count, t_end, rate_us) =
        (*bucket, *max_lat, *max_count, *t_end, *rate_us);
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(380);
    let mut h = ChartBuilder::on(&top)
        .caption("Reply latency histogram", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..max_lat, 0u32..(max_count + max_count / 10 + 1))?;
    h.configure_mesh()
        .x_desc("latency (µs)")
        .y_desc("replies")
        .draw()?;
    h.draw_series(counts.iter().enumerate().map(|(i, &n)| {
        let x0 = i as f64 * bucket;
        Rectangle::new([(x0, 0), (x0 + bucket * 0.9, n)], BLUE.filled())
    }))?;
    h.draw_series(std::iter::once(PathElement::new(
        vec![(rate_us as f64, 0), (rate_us as f64, max_count)],
        RED,
    )))?
    .label("one cycle")
    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    h.configure_series_labels().border_style(BLACK).draw()?;
    let mut t = ChartBuilder::on(&bottom)
        .caption("Reply latency over time", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..t_end, 0f64..max_lat)?;
    t.configure_mesh()
        .x_desc("time (s)")
        .y_desc("latency (µs)")
        .draw()?;
    t.draw_series(
        points
            .iter()
            .map(|&(x, y)| Circle::new((x, y), 1, BLUE.filled())),
    )?;
    t.draw_series(LineSeries::new(
        vec![(0.0, rate_us as f64), (t_end, rate_us as f64)],
        RED,
    ))?;
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

fn checksum(data: &[u8]) -> u16 {
    let mut sum: u32 = 0;
    for pair in data.chunks(2) {
        let word = u16::from_be_bytes([pair[0], *pair.get(1).unwrap_or(&0)]);
        sum += u32::from(word);
    }
    while sum > 0xffff {
        sum = (sum & 0xffff) + (sum >> 16);
    }
    !(sum as u16)
}

fn v4(a: SocketAddr) -> [u8; 4] {
    match a {
        SocketAddr::V4(a) => a.ip().octets(),
        SocketAddr::V6(_) => [0; 4],
    }
}

/// Writes the exchanged messages as a pcap file Wireshark opens: raw IPv4
/// packets (link type 101) with UDP, or TCP segments with running sequence
/// numbers so Wireshark can follow the stream.
pub fn write_pcap(
    path: &Path,
    packets: &[Packet],
    start_unix_us: u64,
    tcp: bool,
) -> io::Result<()> {
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    // Global header: magic, v2.4, tz 0, sigfigs 0, snaplen, LINKTYPE_RAW.
    f.write_all(&0xa1b2_c3d4u32.to_le_bytes())?;
    f.write_all(&2u16.to_le_bytes())?;
    f.write_all(&4u16.to_le_bytes())?;
    f.write_all(&0i32.to_le_bytes())?;
    f.write_all(&0u32.to_le_bytes())?;
    f.write_all(&65_535u32.to_le_bytes())?;
    f.write_all(&101u32.to_le_bytes())?;
    let mut seq: std::collections::HashMap<SocketAddr, u32> = std::collections::HashMap::new();
    for p in packets {
        let (proto, l4_len) = if tcp { (6u8, 20) } else { (17u8, 8) };
        let total = 20 + l4_len + p.payload.len();
        let mut pkt = Vec::with_capacity(total);
        pkt.extend_from_slice(&[0x45, 0]);
        pkt.extend_from_slice(&(total as u16).to_be_bytes());
        pkt.extend_from_slice(&[0, 0, 0x40, 0, 64, proto, 0, 0]);
        pkt.extend_from_slice(&v4(p.from));
        pkt.extend_from_slice(&v4(p.to));
        let c = checksum(&pkt[..20]);
        pkt[10..12].copy_from_slice(&c.to_be_bytes());
        pkt.extend_from_slice(&p.from.port().to_be_bytes());
        pkt.extend_from_slice(&p.to.port().to_be_bytes());
        if tcp {
            let ack = *seq.get(&p.to).unwrap_or(&1);
            let s_now = *seq.get(&p.from).unwrap_or(&1);
            pkt.extend_from_slice(&s_now.to_be_bytes());
            pkt.extend_from_slice(&ack.to_be_bytes());
            pkt.extend_from_slice(&[0x50, 0x18, 0xff, 0xff, 0, 0, 0, 0]); // PSH|ACK, no checksum
            let next = s_now.wrapping_add(p.payload.len() as u32);
            seq.insert(p.from, next);
        } else {
            pkt.extend_from_slice(&((8 + p.payload.len()) as u16).to_be_bytes());
            pkt.extend_from_slice(&[0, 0]); // UDP checksum optional on IPv4
        }
        pkt.extend_from_slice(&p.payload);
        let t = start_unix_us + p.at_us;
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
    fn percentiles() {
        let l = Latency::of((1..=1000).collect());
        assert_eq!(
            (l.min, l.median, l.p99, l.p99_9, l.max),
            (1, 501, 990, 999, 1000)
        );
        assert_eq!(Latency::of(vec![]), Latency::default());
    }

    #[test]
    fn ipv4_header_checksum() {
        // RFC 1071 example header.
        let h = [
            0x45, 0x00, 0x00, 0x73, 0x00, 0x00, 0x40, 0x00, 0x40, 0x11, 0x00, 0x00, 0xc0, 0xa8,
            0x00, 0x01, 0xc0, 0xa8, 0x00, 0xc7,
        ];
        assert_eq!(checksum(&h), 0xb861);
    }
}
