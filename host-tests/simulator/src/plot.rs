//! The latency plot (`--plot FILE.svg|.png`): a log-scale histogram over
//! latency against time, drawn with plotters.

use crate::record::Cycle;
use crate::report::Summary;
use std::path::Path;

pub use crate::font::ensure_font;

/// `YYYY-MM-DD HH:MM UTC` of a Unix time in µs (civil-from-days, so no
/// date crate is needed for one caption).
pub(crate) fn utc(unix_us: u64) -> String {
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
pub(crate) fn seconds(v: &f64) -> String {
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
}
