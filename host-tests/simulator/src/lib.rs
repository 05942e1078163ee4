//! The robot-controller simulator: plays the IRC5 side of RRI as the manual
//! describes, against any sensor, from a GSI folder read at run time.
//!
//! Every `rate` ms it sends the controller's property with changing data
//! (or, with `--send NAME=MS`, several properties each at its own rate, in
//! one Id sequence as a controller numbers one channel, M11), checks each
//! reply (M8 Id echo, the reply property's root and fields against the
//! layout, decodable values), accepts the device's periodic properties,
//! supervises like the controller (S1: `TimeOut`, `MaxLost`, `DryRun`), and
//! summarises: sent, answered, late, lost, wrong Id, malformed, latency
//! percentiles, and per property.

pub mod args;
pub mod device_status;
pub mod fault;
pub mod font;
pub mod http_get;
mod link;
pub mod motion;
pub mod numbers;
mod options;
pub mod pcap;
pub mod plot;
pub mod record;
pub mod replay;
pub mod report;
pub mod show;
mod show_plot;
pub mod shown;
mod sim;
mod stream;
pub mod wire;

pub use options::{RobotOptions, UdpSend};

use fault::{Fault, Faults};
use gsi_config::{Device, Property};
use link::Link;
use pcap::Packet;
use report::{Cycle, Summary};
use sim::Sim;
use std::io::Write;
use std::time::Duration;
use stream::Stream;

/// Loads the device or says exactly why not.
pub fn load(opts: &RobotOptions) -> Result<Device, String> {
    gsi_config::load(&opts.gsi, opts.device.as_deref())
        .map(|l| l.device)
        .map_err(|f| f.to_string())
}

/// `name` among `props` by Name or Alias, in any case (G4), or why not.
fn find_property<'d>(
    device: &'d Device,
    name: &str,
    robot_sends: bool,
) -> Result<&'d Property, String> {
    let (list, who): (Vec<&Property>, &str) = if robot_sends {
        (device.received().collect(), "the controller sends")
    } else {
        (device.sent().collect(), "the device sends")
    };
    list.iter()
        .copied()
        .find(|p| p.is_named(name))
        .ok_or_else(|| {
            let choices: Vec<&str> = list.iter().map(|p| p.name.as_str()).collect();
            format!(
                "no property \"{}\" that {who} in {}; choose one of: {}",
                name.trim(),
                device.name,
                choices.join(", ")
            )
        })
}

/// The properties to send and their periods (M11): `--send`, or the first
/// robot property every `--rate-ms`.
fn sends<'d>(opts: &RobotOptions, device: &'d Device) -> Result<Vec<(&'d Property, u32)>, String> {
    if opts.sends.is_empty() {
        let first = device.received().next().ok_or(
            "the configuration has no property the controller sends (Flag WriteOnly or ReadWrite)",
        )?;
        return Ok(vec![(first, opts.rate_ms)]);
    }
    let mut out: Vec<(&Property, u32)> = Vec::new();
    for (name, ms) in &opts.sends {
        let p =
            find_property(device, name, true).map_err(|e| format!("--send {name}={ms}: {e}"))?;
        if *ms == 0 || !ms.is_multiple_of(4) {
            return Err(format!(
                "--send {name}={ms}: the period must be a positive multiple of 4 ms"
            ));
        }
        if out.iter().any(|(q, _)| q.name == p.name) {
            return Err(format!("--send {name}: given twice"));
        }
        out.push((p, *ms));
    }
    Ok(out)
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Runs the simulation; `log` gets state transitions.
/// Runs the simulated controller against `opts.to` as `opts` says, logging
/// state transitions to `log`; returns the summary and every message's
/// record. An `Err` is a run that could not start or a transport that
/// failed; a run that tripped supervision is an `Ok` whose
/// [`Summary::failure`] says so.
pub fn run(
    opts: &RobotOptions,
    device: &Device,
    log: &mut dyn Write,
) -> Result<(Summary, Vec<Cycle>), String> {
    if let Some(r) = &opts.replay {
        return replayed(opts, r, device, log);
    }
    if opts.rate_ms == 0 || !opts.rate_ms.is_multiple_of(4) {
        return Err(format!(
            "--rate-ms {}: must be a positive multiple of 4 (the controller's cycle)",
            opts.rate_ms
        ));
    }
    if opts.cycles == 0 {
        return Err("--cycles 0: nothing to send; give at least 1".into());
    }
    check_outputs(opts)?;
    let sends = sends(opts, device)?;
    // One controller cycle of the simulation: every period is a multiple.
    let tick_ms = sends.iter().fold(0, |g, &(_, ms)| gcd(g, ms));
    let reply_prop = reply_property(opts, device)?;
    let show = shown_fields(opts, device, reply_prop)?;
    let faults = Faults::new(opts.faults.clone(), opts.seed);
    if opts.tcp {
        if let Some(f) = faults.udp_only() {
            return Err(format!(
                "--fault {f} only works over UDP ({} need datagrams)",
                fault::UDP_ONLY
            ));
        }
    }
    let link = if opts.tcp {
        Link::tcp(opts.to).map_err(|e| format!("cannot connect to {} over TCP: {e}", opts.to))?
    } else {
        let second = opts
            .faults
            .iter()
            .any(|f| matches!(f, Fault::SecondPort { .. }));
        Link::udp(opts.to, second).map_err(|e| format!("cannot open a UDP socket: {e}"))?
    };
    // The device's own counters before the first message, for
    // `--device-status` (an unreadable status fails the run at once).
    let device_before = match &opts.device_status {
        Some(url) => Some(
            device_status::DeviceCounts::read(url).map_err(|e| format!("--device-status: {e}"))?,
        ),
        None => None,
    };
    let start_unix_us = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let mut sim = Sim::new(opts, device, reply_prop, link, tick_ms, log);
    sim.show = show.clone();
    let sending: Vec<String> = sends
        .iter()
        .map(|(p, ms)| format!("{} every {ms} ms", p.wire()))
        .collect();
    sim.transition(&format!(
        "CONNECTED to {} ({}, {} over {}, DryRun={}, TimeOut={} ms, MaxLost={})",
        device.name,
        opts.to,
        sending.join(", "),
        sim.s.transport,
        device.supervision.dry_run,
        device.supervision.timeout_ms,
        device.supervision.max_lost
    ));
    let tick = Duration::from_millis(u64::from(tick_ms));
    let mut stream = Stream::new(device, faults, sim.start);
    for c in 0..opts.cycles {
        let planned = stream.schedule;
        if opts.pacing {
            sim.pump(planned, None);
            stream.schedule += tick;
        }
        sim.judge_previous(&mut stream.previous);
        let now_ms = c * u64::from(tick_ms);
        for (which, &(robot_prop, period)) in sends.iter().enumerate() {
            if now_ms % u64::from(period) == 0 {
                stream.send(&mut sim, c, which, robot_prop, planned, tick)?;
            }
        }
        if c % 50 == 0 {
            sim.show_progress(c);
        }
    }
    stream.release_held(&mut sim)?;
    sim.collect_last(tick);
    let (mut s, cycles, packets) = sim.finish(&sends);
    if let (Some(url), Some(before)) = (&opts.device_status, &device_before) {
        // The device's last turn is published before its reply leaves.
        match device_status::DeviceCounts::read(url) {
            Ok(after) => {
                s.device_status = Some(device_status::compare(&s.counts(), before, &after))
            }
            Err(e) => s.output_errors.push(format!("--device-status: {e}")),
        }
    }
    let shown = show.as_ref();
    write_outputs(
        opts,
        &cycles,
        &packets,
        shown,
        &mut s,
        tick_ms,
        start_unix_us,
    );
    Ok((s, cycles))
}

/// `--replay`: the capture's conversation against the sensor, with the
/// device's own counts before and after (`--device-status`) and the
/// summary's outputs (`--csv`, `--json`; the replay writes its own plot).
fn replayed(
    opts: &RobotOptions,
    r: &replay::ReplayOptions,
    device: &Device,
    log: &mut dyn Write,
) -> Result<(Summary, Vec<Cycle>), String> {
    check_outputs(opts)?;
    let reply = reply_property(opts, device)?;
    let before = match &opts.device_status {
        Some(url) => Some(
            device_status::DeviceCounts::read(url).map_err(|e| format!("--device-status: {e}"))?,
        ),
        None => None,
    };
    let (mut s, cycles) = replay::run(opts, r, device, reply, log)?;
    if let (Some(url), Some(before)) = (&opts.device_status, &before) {
        match device_status::DeviceCounts::read(url) {
            Ok(after) => {
                s.device_status = Some(device_status::compare(&s.counts(), before, &after))
            }
            Err(e) => s.output_errors.push(format!("--device-status: {e}")),
        }
    }
    if let Some(p) = &opts.csv {
        if let Err(e) = report::write_csv(p, &cycles, u64::from(s.rate_ms) * 1000) {
            s.output_errors.push(format!("--csv {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.json {
        if let Err(e) = report::write_json(p, &s) {
            s.output_errors.push(format!("--json {}: {e}", p.display()));
        }
    }
    Ok((s, cycles))
}

/// `--replay FILE --describe`: the capture's conversation described (what
/// the controller sent, what came back, when), with no sensor.
pub fn describe(
    opts: &RobotOptions,
    device: &Device,
) -> Result<replay::describe::Description, String> {
    let r = opts
        .replay
        .as_ref()
        .ok_or("--describe describes the capture given with --replay FILE")?;
    replay::describe_file(r, device, reply_property(opts, device)?)
}

/// The reply property `--reply` names (else the device's first).
fn reply_property<'d>(opts: &RobotOptions, device: &'d Device) -> Result<&'d Property, String> {
    match &opts.reply {
        Some(name) => {
            find_property(device, name, false).map_err(|e| format!("--reply {name}: {e}"))
        }
        None => device.sent().next().ok_or_else(|| {
            "the configuration has no property the device sends (Flag ReadOnly or ReadWrite)"
                .to_string()
        }),
    }
}

/// `--show`'s columns for the reply property, `None` without `--show`;
/// an unknown field is an error listing the ones there are.
fn shown_fields(
    opts: &RobotOptions,
    device: &Device,
    reply: &Property,
) -> Result<Option<show::Show>, String> {
    if opts.show.is_empty() {
        if opts.show_csv.is_some() || opts.show_plot.is_some() {
            return Err("--show-csv and --show-plot need --show FIELD,...".into());
        }
        return Ok(None);
    }
    show::Show::resolve(device, reply, &opts.show).map(Some)
}

/// Checks `--reply` and `--show` against the device before anything runs
/// (`cargo demo` calls it before building the firmware).
pub fn check_show(opts: &RobotOptions, device: &Device) -> Result<(), String> {
    let reply = reply_property(opts, device)?;
    shown_fields(opts, device, reply).map(|_| ())
}

/// `--show-csv` and `--show-plot`; failures join the summary's output
/// errors.
fn write_shown(
    opts: &RobotOptions,
    show: Option<&show::Show>,
    cycles: &[Cycle],
    s: &mut Summary,
    start_unix_us: u64,
) {
    let Some(show) = show else { return };
    if let Some(p) = &opts.show_csv {
        if let Err(e) = show::write_csv(p, show, cycles) {
            s.output_errors
                .push(format!("--show-csv {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.show_plot {
        if let Err(e) = show_plot::write(p, show, cycles, s, start_unix_us) {
            s.output_errors
                .push(format!("--show-plot {}: {e}", p.display()));
        }
    }
}

/// Every output is checked before the first message, so a bad path costs
/// no run.
fn check_outputs(opts: &RobotOptions) -> Result<(), String> {
    for (flag, path) in [
        ("--csv", &opts.csv),
        ("--plot", &opts.plot),
        ("--pcap", &opts.pcap),
        ("--json", &opts.json),
        ("--show-csv", &opts.show_csv),
        ("--show-plot", &opts.show_plot),
    ] {
        if let Some(p) = path {
            std::fs::File::create(p).map_err(|e| format!("{flag} {}: {e}", p.display()))?;
        }
    }
    if opts.plot.is_some() {
        plot::ensure_font().map_err(|e| format!("--plot: {e}"))?;
    }
    if opts.show_plot.is_some() {
        plot::ensure_font().map_err(|e| format!("--show-plot: {e}"))?;
    }
    Ok(())
}

/// Writes every output that can be written; the others are reported in the
/// summary (the JSON last, so it lists them).
fn write_outputs(
    opts: &RobotOptions,
    cycles: &[Cycle],
    packets: &[Packet],
    show: Option<&show::Show>,
    s: &mut Summary,
    tick_ms: u32,
    start_unix_us: u64,
) {
    let rate_us = u64::from(tick_ms) * 1000;
    let mut errors = Vec::new();
    if let Some(p) = &opts.csv {
        if let Err(e) = report::write_csv(p, cycles, rate_us) {
            errors.push(format!("--csv {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.plot {
        if let Err(e) = plot::write_plot(p, cycles, rate_us, s, start_unix_us) {
            errors.push(format!("--plot {}: {e}", p.display()));
        }
    }
    if let Some(p) = &opts.pcap {
        if let Err(e) = pcap::write_pcap(p, packets, start_unix_us, opts.tcp) {
            errors.push(format!("--pcap {}: {e}", p.display()));
        }
    }
    s.output_errors = errors;
    write_shown(opts, show, cycles, s, start_unix_us);
    if let Some(p) = &opts.json {
        if let Err(e) = report::write_json(p, s) {
            s.output_errors.push(format!("--json {}: {e}", p.display()));
        }
    }
}
