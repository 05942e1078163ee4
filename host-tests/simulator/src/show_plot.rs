//! `--show-plot FILE.svg|.png`: the shown reply values over time, one
//! panel per numeric column (text columns are named in the title, not
//! drawn), drawn with plotters like the latency plot ([`crate::plot`]).

use crate::plot::{ensure_font, seconds, utc};
use crate::report::{Cycle, Summary};
use crate::show::Show;
use std::path::Path;

/// One panel: a column's label and its (reply time s, value) points.
struct Panel {
    label: String,
    points: Vec<(f64, f64)>,
}

/// Draws every numeric shown column against the reply's arrival time.
pub(crate) fn write(
    path: &Path,
    show: &Show,
    cycles: &[Cycle],
    summary: &Summary,
    start_unix_us: u64,
) -> Result<(), String> {
    use plotters::prelude::*;
    ensure_font()?;
    let panels: Vec<Panel> = show
        .columns
        .iter()
        .enumerate()
        .filter(|(_, c)| c.numeric)
        .map(|(i, c)| Panel {
            label: c.label.clone(),
            points: cycles
                .iter()
                .filter_map(|cy| {
                    let v = cy.shown.as_ref()?.values.get(i)?.number()?;
                    Some((cy.reply_us? as f64 / 1e6, v))
                })
                .collect(),
        })
        .collect();
    let text: Vec<&str> = show
        .columns
        .iter()
        .filter(|c| !c.numeric)
        .map(|c| c.label.as_str())
        .collect();
    let mut title = format!(
        "{}: reply values over {}, {}",
        summary.device,
        summary.transport,
        utc(start_unix_us)
    );
    if !text.is_empty() {
        title.push_str(&format!(" (text, not plotted: {})", text.join(", ")));
    }
    let t_end = cycles
        .iter()
        .filter_map(|c| c.reply_us)
        .max()
        .map_or(1.0, |us| us as f64 / 1e6)
        .max(0.001);
    let size = (1000, 60 + 240 * panels.len().max(1) as u32);
    let r = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("svg") => draw(
            SVGBackend::new(path, size).into_drawing_area(),
            &title,
            &panels,
            t_end,
        ),
        Some("png") => draw(
            BitMapBackend::new(path, size).into_drawing_area(),
            &title,
            &panels,
            t_end,
        ),
        _ => return Err("the file must end in .svg or .png".into()),
    };
    r.map_err(|e| format!("cannot draw {}: {e}", path.display()))
}

/// The y range of a panel: its values with a margin (a constant gets ±1).
fn y_range(points: &[(f64, f64)]) -> (f64, f64) {
    let lo = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let hi = points.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let margin = ((hi - lo) * 0.05).max(if hi == lo { 1.0 } else { 0.0 });
    (lo - margin, hi + margin)
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    panels: &[Panel],
    t_end: f64,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 20))?;
    if panels.is_empty() {
        root.present()?;
        return Ok(());
    }
    for (area, p) in root.split_evenly((panels.len(), 1)).iter().zip(panels) {
        let (lo, hi) = y_range(&p.points);
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("{} ({} replies)", p.label, p.points.len()),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..t_end, lo..hi)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc(p.label.as_str())
            .x_label_formatter(&seconds)
            .draw()?;
        chart.draw_series(LineSeries::new(p.points.iter().copied(), BLUE))?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::y_range;

    #[test]
    fn y_range_has_room_around_the_values() {
        assert_eq!(y_range(&[]), (0.0, 1.0));
        assert_eq!(y_range(&[(0.0, 5.0), (1.0, 5.0)]), (4.0, 6.0));
        let (lo, hi) = y_range(&[(0.0, 0.0), (1.0, 10.0)]);
        assert!((lo + 0.5).abs() < 1e-9 && (hi - 10.5).abs() < 1e-9);
    }
}
