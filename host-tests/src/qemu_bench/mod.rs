//! The QEMU bench's inputs and arithmetic (`cargo qemu-bench`): the
//! realistic and hostile corpora ([`corpus`]), the flood ([`flood`]), the
//! firmware's bench log lines, percentiles, and the baseline file CI gates
//! on.

mod corpus;
mod flood;

pub use corpus::{hostile, realistic, templated, Input};
pub use flood::{drain_replies, flood, flood_datagram, flood_datagrams, Flooded, Pacer, FLOOD_LEN};

use serde::{Deserialize, Serialize};

/// A `bench …` line of the firmware's log: the firmware's own definition
/// and reader.
pub use rri_firmware::bench_line::Record;

fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let i = line.find(&format!(" {key}="))? + key.len() + 2;
    line[i..].split_whitespace().next()
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

/// A `copy …` line: the bytes `memcpy` copied, and its counts with the
/// two ends aligned alike and unlike.
pub fn parse_copy(line: &str) -> Option<(u32, u32, u32)> {
    line.find("] copy ")?;
    Some((
        field(line, "bytes")?.parse().ok()?,
        field(line, "alike")?.parse().ok()?,
        field(line, "unlike")?.parse().ok()?,
    ))
}

/// Under this much stack margin the bench (and `cargo hil`) fails.
pub const MIN_STACK_MARGIN_PERCENT: u64 = 25;

/// The device's stack use in bytes: (start-up, running, budget), from its
/// last `stack: boot B running R of S bytes` line (logged once a second
/// when the high-water mark grew).
pub fn last_stack(log: &[String]) -> Option<(u64, u64, u64)> {
    log.iter().rev().find_map(|l| {
        let (_, rest) = l.split_once("] stack: ")?;
        let w: Vec<&str> = rest.split_whitespace().collect();
        match w.as_slice() {
            ["boot", b, "running", r, "of", s, ..] => {
                Some((b.parse().ok()?, r.parse().ok()?, s.parse().ok()?))
            }
            _ => None,
        }
    })
}

/// Percent of `size` left at the deeper of `boot` and `running` (the
/// firmware's own rule, `hal_board::stack::StackUse::margin_percent`).
pub fn stack_margin_percent((boot, running, size): (u64, u64, u64)) -> u64 {
    let used = boot.max(running).min(size);
    (size - used) * 100 / size.max(1)
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
    crate::robot::plot::ensure_font()?;
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
    fn codec_lines_parse() {
        assert_eq!(
            parse_codec("[ 0.1 INFO ] codec manual bytes=648 ours=11 tokenizer=7 baseline=21"),
            Some(("manual".into(), 648, 11, 7, 21))
        );
        assert_eq!(
            parse_copy("[ 0.1 INFO ] copy bytes=3557 alike=771 unlike=2511"),
            Some((3557, 771, 2511))
        );
        assert_eq!(parse_copy("[ 0.1 INFO ] codec manual bytes=648"), None);
    }

    #[test]
    fn stack_lines_parse() {
        let log = [
            "[ 1.0 INFO ] stack: boot 56248 running 9000 of 98304 bytes, 42% margin".to_string(),
            "[ 2.0 INFO ] stack: boot 56248 running 11896 of 98304 bytes, 42% margin".to_string(),
            "[ 2.0 INFO ] counters: received 1".to_string(),
        ];
        assert_eq!(last_stack(&log), Some((56248, 11896, 98304)));
        assert_eq!(stack_margin_percent((56248, 11896, 98304)), 42);
        assert_eq!(stack_margin_percent((200, 0, 100)), 0);
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
