//! `cargo demo [-- --tcp] [--cycles N] [--warm-up N] [--send NAME=MS]…
//! [--reply NAME]`: the whole product in one command.
//! Installs QEMU when it is missing, builds the sensor firmware for QEMU's
//! `mps2-an500` board (Cortex-M7, LAN9118 Ethernet), boots it, warms it up,
//! drives it with the robot-controller simulator (2,500 cycles at 4 ms: 10 s
//! of robot time) while showing the device's own log, and exits 0 only when
//! every reply was right and on time and the firmware is still running.
//! `--oversize-attack` sends the attack of S5's issue first (two 9,000-byte
//! datagrams) and then requires every robot message answered.
//!
//! The warm-up: QEMU translates the firmware's machine code to the host's
//! the first time it runs, so the first messages take tens of milliseconds
//! and the replies of the next few dozen queue behind them. On a busy
//! two-core machine that backlog alone can exceed `MaxLost` late replies in
//! a row. A real MCU has no such start-up, so the demo sends a short
//! warm-up stream first (same properties, the same Id sequence continued
//! by the counted run), prints its figures, and judges only the counted
//! run's timing; a wrong or malformed reply fails the demo in either.

use clap::Parser;
use host_tests::qemu::{self, Boot, Qemu};
use host_tests::robot::args::{plot_path, Properties};
use host_tests::robot::{run, RobotOptions};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Parser, Debug)]
#[command(
    name = "cargo demo",
    about = "Boot the sensor firmware on QEMU (mps2-an500) and drive it with the robot simulator"
)]
struct Args {
    /// Over a TCP channel: the manual's device with Protocol="Tcp"
    /// (host-tests/gsi/anydevice-tcp) instead of the configured one.
    #[arg(long)]
    tcp: bool,
    /// Robot messages to send, one per 4 ms cycle.
    #[arg(long, default_value_t = 2500, value_parser = clap::value_parser!(u64).range(1..))]
    cycles: u64,
    /// Robot cycles sent before the counted run so that QEMU has translated
    /// the firmware's code (their figures are printed, their timing is not
    /// judged; 0: none).
    #[arg(long, default_value_t = 250)]
    warm_up: u64,
    /// Write the simulator's latency plot (.svg or .png) here.
    #[arg(long, value_parser = plot_path)]
    plot: Option<PathBuf>,
    /// S5: after the warm-up, send the attack of "Fragments never lock the
    /// controller out" (two 9,000-byte datagrams from a second port of the
    /// controller's address), then fail unless every robot message of the
    /// counted run is answered (build with a configuration whose robot
    /// messages are fragmented: host-tests/gsi/fragmented).
    #[arg(long)]
    oversize_attack: bool,
    #[command(flatten)]
    properties: Properties,
}

/// Exit status when the only failure was lateness: every reply came and
/// was right, but `MaxLost` of them in a row came later than one cycle
/// ([`host_tests::robot::report::Summary::late_only`]). Apart from 1 (anything
/// else) so that a script on a shared machine can tell a host stall from
/// a wrong firmware; 2 is clap's, for bad arguments.
const LATE_ONLY: u8 = 3;

/// Why the demo failed, and whether it was lateness alone.
struct Failure {
    reason: String,
    late_only: bool,
}

impl From<String> for Failure {
    fn from(reason: String) -> Self {
        Failure {
            reason,
            late_only: false,
        }
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    match demo(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.reason);
            if f.late_only {
                eprintln!(
                    "every reply was right; only their timing failed (exit status {LATE_ONLY})"
                );
                ExitCode::from(LATE_ONLY)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

fn demo(args: &Args) -> Result<(), Failure> {
    let mut out = std::io::stdout();
    qemu::ensure_qemu(&mut out)?;
    let (gsi, device_name, build_gsi) = if args.tcp {
        let dir = host_tests::workspace().join("host-tests/gsi/anydevice-tcp/GSI");
        (dir.clone(), None, Some(dir))
    } else {
        let (dir, name) = host_tests::built_gsi();
        (dir, name, None)
    };
    let device = gsi_config::load(&gsi, device_name.as_deref())
        .map_err(|f| f.to_string())?
        .device;
    println!(
        "== building the firmware for QEMU {} ({})",
        qemu::MACHINE,
        gsi.display()
    );
    let name = if args.tcp { "demo-tcp" } else { "demo" };
    let elf = qemu::build_firmware(&[], build_gsi.as_deref(), name)?;
    let host_port = qemu::free_port()?;
    let boot = Boot {
        elf,
        device: device.clone(),
        host_port,
        icount_shift: None,
    };
    println!(
        "== booting {} on {} (device {} port {} forwarded from 127.0.0.1:{host_port})",
        boot.elf.display(),
        qemu::MACHINE,
        device.network.address,
        device.channel.port
    );
    let mut board = Qemu::boot(&boot)?;
    board.wait_for("rri-sensor", Duration::from_secs(20))?;
    if !args.tcp {
        board.wait_for("state CONNECTED", Duration::from_secs(10))?;
    } else {
        // The TCP task listens right after the banner; give it a moment.
        std::thread::sleep(Duration::from_millis(500));
    }
    for line in board.take_new() {
        println!("device: {line}");
    }

    let mut opts = RobotOptions::new(gsi, ([127, 0, 0, 1], host_port).into());
    opts.device = device_name;
    opts.cycles = args.cycles;
    // The transport the configuration says (the TCP demo's is TCP).
    opts.tcp = device.channel.protocol == gsi_config::Protocol::Tcp;
    args.properties.apply(&mut opts);
    opts.plot = args.plot.clone();
    opts.progress = std::io::stderr().is_terminal();
    opts.device_log = Some(board.new_lines.clone());
    if args.warm_up > 0 {
        opts.first_id = warm_up(&opts, &device, args.warm_up)?;
    }
    if args.oversize_attack {
        // Through QEMU's user networking every host sender shows as one
        // address: another port of it is another port of the controller's.
        let attacker = std::net::UdpSocket::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
        for _ in 0..2 {
            attacker
                .send_to(&[b'<'; 9000], ("127.0.0.1", host_port))
                .map_err(|e| e.to_string())?;
        }
        std::thread::sleep(Duration::from_millis(50));
        println!(
            "== S5: two 9,000-byte datagrams sent from another port of the controller's address (smoltcp alone then dropped every fragmented robot message for 60 s)"
        );
    }
    match args.properties.send.as_slice() {
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
    let result = run(&opts, &device, &mut out);
    // One more counter line from the device.
    std::thread::sleep(Duration::from_millis(1100));
    let exited = board.exited();
    let rest = board.take_new();
    let log = board.stop();
    for line in rest {
        println!("device: {line}");
    }
    let (summary, _) = result?;
    let _ = summary.print(&mut out);
    let _ = out.flush();
    if let Some(status) = exited {
        return Err(format!("the firmware stopped during the run (QEMU {status})").into());
    }
    if let Some(panic) = log.iter().find(|l| l.contains("panic")) {
        return Err(format!("the firmware panicked: {panic}").into());
    }
    if args.oversize_attack {
        let counters = log
            .iter()
            .rev()
            .find_map(|l| host_tests::counters::DeviceCounters::parse(l));
        if let Some(c) = counters {
            let f = c.fragments;
            println!(
                "device fragments: {} in, {} reassembled, {} oversize dropped, {} sets spoiled",
                f.fragments, f.reassembled, f.oversize, f.spoiled
            );
        }
        if summary.lost > 0 {
            return Err(format!(
                "S5: {} of {} fragmented robot messages not answered after two 9,000-byte datagrams",
                summary.lost, summary.sent
            )
            .into());
        }
    }
    match summary.failure() {
        None => {
            println!(
                "demo: every reply was right ({} answered)",
                summary.answered
            );
            Ok(())
        }
        Some(reason) => Err(Failure {
            reason,
            late_only: summary.late_only(),
        }),
    }
}

/// Sends `cycles` robot cycles with `opts` and prints one line of figures;
/// returns the first Id of the counted run. Fails on no reply at all, or on
/// a wrong or malformed reply, never on timing.
fn warm_up(opts: &RobotOptions, device: &gsi_config::Device, cycles: u64) -> Result<u32, String> {
    let mut w = opts.clone();
    w.cycles = cycles;
    w.plot = None;
    w.progress = false;
    w.device_log = None;
    // Its state transitions are the counted run's to show.
    let mut quiet = Vec::new();
    let (s, _) = run(&w, device, &mut quiet)?;
    println!(
        "== warm-up (QEMU translates the firmware's code on first use; timing not judged): sent {} answered {} late {} latency us median {} max {}",
        s.sent, s.answered, s.late, s.latency_us.median, s.latency_us.max
    );
    if s.answered == 0 || s.wrong_id > 0 || s.malformed > 0 {
        let why = s.failure().unwrap_or_else(|| "no reply".into());
        return Err(format!("warm-up: {why}"));
    }
    let sent = u32::try_from(s.sent).map_err(|_| "warm-up: too many messages")?;
    Ok(w.first_id.wrapping_add(sent))
}
