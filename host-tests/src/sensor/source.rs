//! Where the host sensor's samples come from: the sensor's own
//! `simulate`, or a CSV file of recorded samples replayed at their times.
//! Either way they go through the same `Sampler` and history as on a
//! board, so the sensor's cycle half meets what it will meet there.

use rri_firmware::engine::{Clock, Instant};
use rri_firmware::sensor::{Sampler, Sensor, Simulated, Stamped};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// The host sensor's sample source.
#[derive(Clone, Debug, Default)]
pub enum Source {
    /// The sensor's `simulate`, every `SAMPLE_EVERY_US`.
    #[default]
    Simulated,
    /// Recorded samples, replayed at their times, over and over.
    Replay(Recording),
}

/// A CSV file of recorded samples: a time in seconds, then the sample's
/// columns (what the sensor's `replay` takes), one row per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Where it was read from, for messages.
    pub name: String,
    /// (µs from the recording's start, columns).
    pub rows: Vec<(u64, Vec<f32>)>,
}

impl Recording {
    /// Reads `path` ([`Recording::parse`]).
    pub fn read(path: &Path) -> Result<Recording, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Recording::parse(&path.display().to_string(), &text)
    }

    /// Rows `time_s,col1,col2,…`: comma-separated numbers, the time in
    /// seconds from the recording's start, never decreasing. Empty lines
    /// and lines starting with `#` are skipped; a first line that does not
    /// start with a number is a header. Every problem names its line.
    pub fn parse(name: &str, text: &str) -> Result<Recording, String> {
        let mut rows: Vec<(u64, Vec<f32>)> = Vec::new();
        let mut first = true;
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let header = first && fields[0].parse::<f64>().is_err();
            first = false;
            if header {
                continue;
            }
            let at = |why: &str| format!("{name}:{}: {why}: `{line}`", n + 1);
            let t: f64 = fields[0]
                .parse()
                .map_err(|_| at("the time is not a number"))?;
            if !(t.is_finite() && t >= 0.0) {
                return Err(at("the time must be seconds from the start, 0 or more"));
            }
            let us = (t * 1e6).round() as u64;
            if rows.last().is_some_and(|(prev, _)| us < *prev) {
                return Err(at("the time goes backwards"));
            }
            let columns = fields[1..]
                .iter()
                .map(|f| {
                    f.parse::<f32>()
                        .map_err(|_| at(&format!("`{f}` is not a number")))
                })
                .collect::<Result<Vec<f32>, String>>()?;
            rows.push((us, columns));
        }
        if rows.is_empty() {
            return Err(format!("{name}: no samples (rows `time_s,value,…`)"));
        }
        Ok(Recording {
            name: name.to_string(),
            rows,
        })
    }

    /// Checks every row against the sensor's `replay` before the run.
    pub fn check<S: Sensor<R, D>, R, D>(&self) -> Result<(), String> {
        match self.rows.iter().position(|(_, c)| S::replay(c).is_none()) {
            None => Ok(()),
            Some(i) => Err(format!(
                "{}: sample {} ({:?}) refused by {}::replay (does the sensor take recorded samples, and these columns?)",
                self.name,
                i + 1,
                self.rows[i].1,
                std::any::type_name::<S>()
            )),
        }
    }

    /// One pass of the file: its last time plus one sampling period, after
    /// which it starts over.
    pub fn loop_us(&self, every_us: u32) -> u64 {
        self.rows.last().map_or(0, |(t, _)| *t) + u64::from(every_us.max(1))
    }
}

impl Source {
    /// One line for the log: what the samples are.
    pub fn describe<S: Sensor<R, D>, R, D>(&self) -> String {
        let every = S::SAMPLE_EVERY_US;
        match self {
            Source::Simulated => format!(
                "{} sampled every {every} us (simulated: its `simulate`)",
                std::any::type_name::<S>()
            ),
            Source::Replay(r) => format!(
                "{} fed {} recorded samples from {}, over and over every {:.3} s",
                std::any::type_name::<S>(),
                r.rows.len(),
                r.name,
                r.loop_us(every) as f64 / 1e6
            ),
        }
    }

    /// Feeds `sampler` until `stop`: the sampling half of the host sensor,
    /// on a thread of its own (the board's background executor).
    pub fn run<S: Sensor<R, D>, R, D>(
        &self,
        sampler: &mut Sampler<'_, S, R, D>,
        clock: &dyn Clock,
        stop: &AtomicBool,
    ) {
        let every = u64::from(S::SAMPLE_EVERY_US.max(1));
        match self {
            Source::Simulated => {
                let mut next = clock.now().as_micros();
                while !stop.load(Ordering::Relaxed) {
                    sampler.step(&mut Simulated, clock.now());
                    next += every;
                    sleep_until(clock, next, stop);
                }
            }
            Source::Replay(r) => {
                let length = r.loop_us(S::SAMPLE_EVERY_US);
                for pass in 0u64.. {
                    for (t, columns) in &r.rows {
                        let due = pass * length + t;
                        sleep_until(clock, due, stop);
                        if stop.load(Ordering::Relaxed) {
                            return;
                        }
                        // Checked before the run ([`Recording::check`]).
                        if let Some(value) = S::replay(columns) {
                            sampler.push(Stamped {
                                time: Instant(due),
                                value,
                            });
                        }
                    }
                }
            }
        }
    }
}

/// Sleeps until device time `due_us` (or `stop`), in short naps so a stop
/// is seen within a few milliseconds.
fn sleep_until(clock: &dyn Clock, due_us: u64, stop: &AtomicBool) {
    loop {
        let now = clock.now().as_micros();
        if now >= due_us || stop.load(Ordering::Relaxed) {
            return;
        }
        std::thread::sleep(Duration::from_micros((due_us - now).min(5_000)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_with_a_header_comments_and_blank_lines() {
        let r = Recording::parse("r.csv", "t_s,mm\n# a comment\n\n0,150\n0.001, 151.5,1\n")
            .expect("parses");
        assert_eq!(r.rows, vec![(0, vec![150.0]), (1_000, vec![151.5, 1.0])]);
        assert_eq!(r.loop_us(1_000), 2_000);
    }

    #[test]
    fn bad_rows_name_their_line() {
        let e = Recording::parse("r.csv", "0,1\n0.5,x\n").unwrap_err();
        assert!(e.starts_with("r.csv:2: `x` is not a number"), "{e}");
        let e = Recording::parse("r.csv", "1,1\n0.5,1\n").unwrap_err();
        assert!(e.contains("r.csv:2: the time goes backwards"), "{e}");
        let e = Recording::parse("r.csv", "t,mm\n").unwrap_err();
        assert!(e.contains("no samples"), "{e}");
        let e = Recording::parse("r.csv", "-1,2\n").unwrap_err();
        assert!(e.contains("r.csv:1:"), "{e}");
    }
}
