//! Command-line options shared by every tool that drives the simulator
//! (`cargo robot`, `cargo demo`, …), defined once with clap so their
//! spelling, help and errors agree.

use crate::RobotOptions;
use std::path::PathBuf;

/// Which properties a run sends and which one it expects back (M11).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Properties {
    /// Send property NAME every MS ms (repeatable, one SiSetCyclic each, one Id sequence);
    /// default: the first property the controller sends, every cycle.
    #[arg(long, value_name = "NAME=MS", value_parser = send_spec)]
    pub send: Vec<(String, u32)>,
    /// The property the device answers with (its RRI_REPLY); default $RRI_REPLY, else the
    /// first property the device sends.
    #[arg(long, value_name = "NAME")]
    pub reply: Option<String>,
}

impl Properties {
    /// Into the simulator's options (`RRI_REPLY` from the environment when
    /// `--reply` is not given, as the firmware's build reads it).
    pub fn apply(&self, o: &mut RobotOptions) {
        o.sends = self.send.clone();
        o.reply = self.reply.clone().or_else(|| {
            std::env::var("RRI_REPLY")
                .ok()
                .filter(|v| !v.trim().is_empty())
        });
    }
}

/// `--show` and its outputs: the reply's values as the controller
/// receives them ([`crate::show`]).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ShowArgs {
    /// Show these fields of each reply (comma-separated or repeated), e.g. AppData.X1,EStr:
    /// a field's Name or Alias, `.X1`/`.X`/`.J1` for one component; printed live (at most one
    /// line per --show-every-ms), and in --show-csv / --show-plot.
    #[arg(long, value_name = "FIELD,...", value_delimiter = ',')]
    pub show: Vec<String>,
    /// The shown values, one row per reply: id, reply_s, reply_ts, one column per field.
    #[arg(long, value_name = "FILE", requires = "show")]
    pub show_csv: Option<PathBuf>,
    /// The shown values over time, one panel per numeric field (.svg or .png).
    #[arg(long, value_name = "FILE", value_parser = plot_path, requires = "show")]
    pub show_plot: Option<PathBuf>,
    /// At most one live line of shown values per this many ms (0: every reply).
    #[arg(long, value_name = "MS", default_value_t = 100)]
    pub show_every_ms: u64,
}

impl ShowArgs {
    /// Into the simulator's options.
    pub fn apply(&self, o: &mut RobotOptions) {
        o.show = self.show.clone();
        o.show_csv = self.show_csv.clone();
        o.show_plot = self.show_plot.clone();
        o.show_every_ms = self.show_every_ms;
    }
}

/// `--replay FILE` and its options: a capture's robot messages instead of
/// the simulator's own ([`crate::replay`]).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ReplayArgs {
    /// Replay the controller's side of a capture (pcap or pcapng, as Wireshark or tcpdump write
    /// it) against the sensor, closed-loop, and compare every reply with the recorded one.
    #[arg(long, value_name = "FILE")]
    pub replay: Option<PathBuf>,
    /// The conversation to replay when the capture has several (or one on another port): the
    /// device's end, ADDR:PORT.
    #[arg(long, value_name = "ADDR:PORT", requires = "replay")]
    pub conversation: Option<std::net::SocketAddrV4>,
    /// Send one recorded message every MS ms instead of at the recorded times.
    #[arg(long, value_name = "MS", value_parser = multiple_of_4, requires = "replay", conflicts_with = "as_fast")]
    pub every: Option<u32>,
    /// Send each recorded message as soon as the reply to the last is in.
    #[arg(long, requires = "replay")]
    pub as_fast: bool,
    /// How far a replayed number may be from the recorded one: TOL for every field, or
    /// FIELD=TOL for one (AppData.X1) or an element's values (AppData); repeatable.
    #[arg(long, value_name = "[FIELD=]TOL", value_parser = tolerance_spec, requires = "replay")]
    pub tolerance: Vec<(Option<String>, f64)>,
    /// Do not compare this field (a live sensor value; AppData.X1, or AppData for all of its
    /// values); repeatable. The reply's Ts, the device's own clock, is never compared.
    #[arg(long, value_name = "FIELD", requires = "replay")]
    pub ignore: Vec<String>,
    /// Compare only Ids, which messages are answered, and timing.
    #[arg(long, requires = "replay")]
    pub ignore_values: bool,
    /// Every difference, one CSV row each (with both latencies).
    #[arg(long, value_name = "FILE.csv", requires = "replay")]
    pub diff: Option<PathBuf>,
}

impl ReplayArgs {
    /// Into the simulator's options (`None` without `--replay`).
    pub fn apply(&self, o: &mut RobotOptions) {
        let Some(file) = &self.replay else {
            o.replay = None;
            return;
        };
        let mut rules = crate::replay::compare::Rules {
            ignore: self.ignore.clone(),
            ignore_values: self.ignore_values,
            ..Default::default()
        };
        for (field, tol) in &self.tolerance {
            match field {
                Some(f) => rules.per_field.push((f.clone(), *tol)),
                None => rules.tolerance = *tol,
            }
        }
        o.replay = Some(crate::replay::ReplayOptions {
            file: file.clone(),
            conversation: self.conversation,
            pace: match (self.every, self.as_fast) {
                (Some(ms), _) => crate::replay::Pace::Every(ms),
                (None, true) => crate::replay::Pace::AsFast,
                (None, false) => crate::replay::Pace::Recorded,
            },
            rules,
            extract: None,
            diff_csv: self.diff.clone(),
        });
    }
}

/// `[FIELD=]TOL` of `--tolerance`.
pub fn tolerance_spec(text: &str) -> Result<(Option<String>, f64), String> {
    let (field, tol) = match text.split_once('=') {
        Some((f, t)) => (Some(f.trim().to_string()), t),
        None => (None, text),
    };
    match tol.trim().parse::<f64>() {
        Ok(t) if t >= 0.0 && t.is_finite() => Ok((field, t)),
        _ => Err(
            "expected TOL or FIELD=TOL with TOL a number ≥ 0, e.g. 0.001 or AppData.X1=0.5".into(),
        ),
    }
}

/// A period: a positive multiple of 4 ms (the controller's cycle).
pub fn multiple_of_4(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(ms) if ms > 0 && ms % 4 == 0 => Ok(ms),
        _ => Err("must be a positive multiple of 4 (the controller's cycle)".into()),
    }
}

/// `NAME=MS` of `--send`.
pub fn send_spec(text: &str) -> Result<(String, u32), String> {
    let (name, ms) = text
        .split_once('=')
        .ok_or("expected NAME=MS, e.g. RobData=4")?;
    Ok((name.trim().to_string(), multiple_of_4(ms)?))
}

/// `--plot`: an .svg or .png file.
pub fn plot_path(text: &str) -> Result<PathBuf, String> {
    let p = PathBuf::from(text);
    match p.extension().and_then(|e| e.to_str()) {
        Some("svg" | "png") => Ok(p),
        _ => Err("the file must end in .svg or .png".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs() {
        assert_eq!(send_spec("RobData=16"), Ok(("RobData".into(), 16)));
        assert!(send_spec("RobData").is_err());
        assert!(send_spec("RobData=6")
            .unwrap_err()
            .contains("multiple of 4"));
        assert!(plot_path("x.gif").is_err());
        assert_eq!(plot_path("t/x.png"), Ok(PathBuf::from("t/x.png")));
        assert_eq!(tolerance_spec("0.5"), Ok((None, 0.5)));
        assert_eq!(
            tolerance_spec("AppData.X1=0.01"),
            Ok((Some("AppData.X1".into()), 0.01))
        );
        assert!(tolerance_spec("X=-1").is_err() && tolerance_spec("X=a").is_err());
    }
}
