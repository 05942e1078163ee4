//! What `cargo demo` and `cargo hil` share: a running device with a log
//! ([`Device`]: the QEMU board, or a NUCLEO through probe-rs), driven by the
//! robot simulator after a warm-up, judged the same way with the same exit
//! statuses.
//!
//! The warm-up: QEMU translates the firmware's machine code to the host's
//! the first time it runs, so the first messages take tens of milliseconds
//! and the replies of the next few dozen queue behind them. On a busy
//! two-core machine that backlog alone can exceed `MaxLost` late replies in
//! a row. A real MCU has no such start-up, but the same warm-up also lets
//! its ARP and the controller's supervision settle; its figures are
//! printed, its timing is not judged, and the counted run continues its Id
//! sequence. A wrong or malformed reply fails in either.

use crate::robot::{run, RobotOptions};
use std::io::{IsTerminal, Write};
use std::net::SocketAddr;
use std::time::Duration;

pub use crate::device::{Device, Unlogged};
pub use crate::run_args::RunArgs;
pub use crate::setup::Setup;
pub use crate::verdict::{host_timer, timer_verdict, verdict, Failure, Ran, LATE_ONLY};

/// What the QEMU board logs when it is ready: its banner, and for UDP the
/// first state change (a TCP device waits for its connection instead).
pub fn qemu_ready(setup: &Setup) -> Vec<(&'static str, Duration)> {
    let mut ready = vec![("rri-sensor", Duration::from_secs(20))];
    if setup.device.channel.protocol != gsi_config::Protocol::Tcp {
        ready.push(("state CONNECTED", Duration::from_secs(10)));
    }
    ready
}

/// Right after start-up the device's uptime must be small: an uptime that
/// does not start at zero cannot show a restart (issue 42 #8: the QEMU
/// board's clock started at 171.8 s). Start-up takes seconds; a minute is
/// far above it and far below the 171.8 s of that fault.
fn uptime_starts_at_zero(http: SocketAddr) -> Result<(), String> {
    let url = format!("http://{http}/status.json");
    let r = crate::robot::device_status::get(&url, Duration::from_secs(5))?;
    let v: serde_json::Value =
        serde_json::from_slice(&r.body).map_err(|e| format!("{url}: not JSON ({e})"))?;
    let up = v["device"]["uptime_us"]
        .as_u64()
        .ok_or_else(|| format!("{url}: no device.uptime_us"))?;
    if up > 60_000_000 {
        return Err(format!(
            "the device's uptime reads {:.1} s right after start-up: its clock does not start at zero, so the page cannot show a restart",
            up as f64 / 1e6
        ));
    }
    Ok(())
}

/// Waits for the device to start (its banner, then `ready`, each within
/// its timeout), warms it up, drives it for `args.cycles`, takes one more
/// counter line and stops it. Prints the device's log as it comes
/// (prefixed `device:`) and the simulator's summary.
pub fn drive(
    mut dev: Box<dyn Device>,
    setup: &Setup,
    args: &RunArgs,
    to: SocketAddr,
    http: Option<SocketAddr>,
    ready: &[(&str, Duration)],
    out: &mut dyn Write,
) -> Result<Ran, Failure> {
    for (needle, timeout) in ready {
        if let Err(e) = dev.wait_for(needle, *timeout) {
            for line in dev.take_new() {
                println!("device: {line}");
            }
            return Err(e.into());
        }
    }
    if setup.device.channel.protocol == gsi_config::Protocol::Tcp {
        // The TCP task listens right after the banner; give it a moment.
        std::thread::sleep(Duration::from_millis(500));
    }
    for line in dev.take_new() {
        println!("device: {line}");
    }
    if let Some(http) = http {
        println!("== the device's status page: http://{http}/ (for machines: /status.json, for Prometheus: /metrics)");
        uptime_starts_at_zero(http)?;
    }
    let web = crate::diagnostics::Web::new(args, http)?;
    host_timer(4);
    let mut opts = RobotOptions::new(setup.gsi.clone(), to);
    opts.device = setup.device_name.clone();
    opts.cycles = args.cycles;
    // The transport the configuration says (the TCP demo's is TCP).
    opts.tcp = setup.device.channel.protocol == gsi_config::Protocol::Tcp;
    args.properties.apply(&mut opts);
    args.show.apply(&mut opts);
    opts.plot = args.plot.clone();
    opts.progress = std::io::stderr().is_terminal();
    opts.device_log = Some(dev.live_lines());
    let mut warm = (0, 0);
    // A replay's warm-up ends just below the capture's first Id, so the
    // device counts no Id gap (S3) between the two.
    let replay_first = match &args.replay.replay {
        Some(_) => {
            let mut o = opts.clone();
            args.replay.apply(&mut o);
            let r = o.replay.as_ref().ok_or_else(|| "--replay".to_string())?;
            let conv = rri_robot::replay::load(r, &setup.device)?;
            conv.messages
                .iter()
                .filter(|m| m.direction == rri_robot::replay::conversation::Direction::ToDevice)
                .find_map(|m| rri_robot::replay::message_id(&m.payload))
        }
        None => None,
    };
    if args.warm_up > 0 {
        if let Some(first) = replay_first {
            opts.first_id = first.wrapping_sub(args.warm_up as u32);
            if first < args.warm_up as u32 {
                // Said, so the device's "wraps 1" is not taken for the
                // capture's (issue 42 #8).
                println!(
                    "== the warm-up's {} Ids end just below the capture's first ({first}): they run through 4294967295 to 0, so the device counts one Id wrap (S3) that is the warm-up's, not the capture's",
                    args.warm_up
                );
            }
        }
        let (first_id, sent, answered) = warm_up(&opts, &setup.device, args.warm_up)?;
        opts.first_id = first_id;
        warm = (sent, answered);
    }
    args.replay.apply(&mut opts);
    opts.device_status = web.status_url();
    opts.faults = args.fault.clone();
    opts.seed = args.seed;
    if args.oversize_attack {
        oversize_attack(to)?;
    }
    match args.properties.send.as_slice() {
        _ if args.replay.replay.is_some() => println!("== robot simulator: replaying a capture"),
        [] => println!("== robot simulator: {} cycles every 4 ms", args.cycles),
        sends => println!(
            "== robot simulator: {} cycles, sending {}",
            args.cycles,
            sends
                .iter()
                .map(|(n, ms)| format!("{n} every {ms} ms"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
    let during = web.start();
    let result = run(&opts, &setup.device, out);
    let http_failures = web.finish(
        during,
        &setup.device.name,
        warm,
        result.as_ref().ok().map(|r| &r.0),
    );
    // One more counter line from the device.
    std::thread::sleep(Duration::from_millis(1100));
    let figures = args.figures_from_status.then(|| {
        http.ok_or_else(|| "no diagnostics to read".to_string())
            .and_then(crate::diagnostics::figures_over_ethernet)
    });
    let stopped = dev.stopped();
    for line in dev.take_new() {
        println!("device: {line}");
    }
    let (mut summary, _) = result?;
    if let Some(r) = &mut summary.replay {
        crate::replay::explain(r);
    }
    let _ = summary.print(out);
    let _ = out.flush();
    let mut ran = Ran {
        summary,
        log: dev.log(),
        stopped,
        attacked: args.oversize_attack,
        http_attacked: args.http_attack,
        http_failures,
        figures,
        warm,
    };
    if args.serve {
        serve(&mut *dev, http, &mut ran);
    }
    let rest = dev.take_new();
    ran.log = dev.stop();
    for line in rest {
        println!("device: {line}");
    }
    Ok(ran)
}

/// `--serve`, once the counted run is over: its verdict first, then the
/// device kept running until Ctrl-C (issue 42 #18: the verdict came only
/// after Ctrl-C, which the terminal also sends to QEMU, and QEMU's exit
/// then failed a run whose every reply was right). Ctrl-C is the user's
/// stop, not the firmware's; the firmware stopping by itself while served
/// is still a failure.
fn serve(dev: &mut dyn Device, http: Option<SocketAddr>, ran: &mut Ran) {
    println!("== the counted run's verdict (the device keeps running for --serve):");
    if let Err(f) = verdict("the counted run", ran) {
        eprintln!("error: {}", f.reason);
    }
    let _ = std::io::stdout().flush();
    if let Err(e) = crate::diagnostics::serve_until_ctrl_c(dev, http) {
        ran.stopped = Some(e);
    }
}

/// The attack of S5's issue: two 9,000-byte datagrams to the device's
/// channel from another port of this computer. Through QEMU's user
/// networking every host sender shows as one address, so this is another
/// port of the controller's address; with smoltcp's own reassembly every
/// fragmented robot message after it was dropped for 60 s.
fn oversize_attack(to: SocketAddr) -> Result<(), String> {
    let attacker = std::net::UdpSocket::bind(("0.0.0.0", 0)).map_err(|e| e.to_string())?;
    for _ in 0..2 {
        attacker
            .send_to(&[b'<'; 9000], to)
            .map_err(|e| format!("S5 attack to {to}: {e}"))?;
    }
    std::thread::sleep(Duration::from_millis(50));
    println!(
        "== S5: two 9,000-byte datagrams sent to {to} from another port of the controller's address"
    );
    Ok(())
}

/// Sends `cycles` robot cycles with `opts` and prints one line of figures;
/// returns the first Id of the counted run and what the warm-up sent and
/// had answered. Fails on no reply at all, or on a wrong or malformed
/// reply, never on timing.
fn warm_up(
    opts: &RobotOptions,
    device: &gsi_config::Device,
    cycles: u64,
) -> Result<(u32, u64, u64), String> {
    let mut w = opts.clone();
    w.cycles = cycles;
    w.plot = None;
    w.show = Vec::new();
    w.show_csv = None;
    w.show_plot = None;
    w.progress = false;
    w.device_log = None;
    w.faults = Vec::new();
    // Its state transitions are the counted run's to show.
    let mut quiet = Vec::new();
    let (s, _) = run(&w, device, &mut quiet)?;
    println!(
        "== warm-up (timing not judged; an emulator translates the firmware's code on first use): sent {} answered {} late {} latency us median {} max {}",
        s.sent, s.answered, s.late, s.latency_us.median, s.latency_us.max
    );
    if s.answered == 0 {
        return Err(format!(
            "warm-up: no reply from {} (is this computer on the device's network, and the channel's port open?)",
            opts.to
        ));
    }
    if s.wrong_id > 0 || s.malformed > 0 {
        let why = s.failure().unwrap_or_else(|| "a wrong reply".into());
        return Err(format!("warm-up: {why}"));
    }
    let sent = u32::try_from(s.sent).map_err(|_| "warm-up: too many messages")?;
    Ok((w.first_id.wrapping_add(sent), s.sent, s.answered))
}
