//! `cargo qemu-bench [-- --cycles N] [--update-baseline]`: worst-case cycle
//! cost of the firmware on QEMU's Cortex-M7 board, in instructions.
//!
//! Boots the bench build of the firmware under `-icount shift=3` (the
//! virtual clock advances 8 ns per instruction, and the board's 25 MHz
//! counter ticks every 40 ns: 5 instructions a count, identical run to
//! run), then:
//! 1. the in-guest codec comparison (ours, xmlparser alone, the naive
//!    baseline) on the manual's and the maximum-value message;
//! 2. the robot simulator for N cycles at 4 ms;
//! 3. each message of the realistic corpus (manual, IRC5 capture, maximum
//!    values) and of the hostile one (every input `MAX_RECEIVE_LEN` bytes
//!    long) 20 times, one at a time;
//! 4. the production firmware in real time (no `-icount`) driven by the
//!    simulator while a flood of rejected datagrams (garbage, the costliest
//!    rejected hostile inputs, 9,000-byte fragmented ones) arrives from a
//!    second port at ten times the cycle rate (under `-icount` QEMU's user
//!    networking loses a few % of host datagrams under sustained load,
//!    with or without our firmware's help, so the flood runs without it).
//!
//! Per message the firmware logs (a) compute: peer check + decode +
//! application + encode, and (b) full: from the driver handing over the
//! frame to the driver taking the reply's frame. Prints min / median / p99
//! / max, writes `target/qemu-bench/summary.json` and `histogram.svg`, and
//! compares with `host-tests/bench/qemu-baseline.json`: exit 1 when a gated
//! figure is more than 5 % above it or a reply was missed.

use clap::Parser;
use host_tests::qemu::{self, Boot, DeviceCounters, Qemu};
use host_tests::qemu_bench::{self as qb, Gated, Input, Record, Spread};
use host_tests::robot::{run, RobotOptions};
use serde_json::json;
use std::net::UdpSocket;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Parser, Debug)]
#[command(
    name = "cargo qemu-bench",
    about = "Worst-case cycle cost of the firmware on QEMU's Cortex-M7, in instructions"
)]
struct Args {
    /// Robot-simulator cycles (4 ms each) under the flood.
    #[arg(long, default_value_t = 10_000, value_parser = clap::value_parser!(u64).range(1..))]
    cycles: u64,
    /// Sends of each corpus message.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    repeat: u32,
    /// Flood period in µs (400 = ten times the 4 ms cycle rate; 0 = no flood).
    #[arg(long, default_value_t = 400)]
    flood_us: u64,
    /// The baseline file the gated figures are compared with.
    #[arg(long, default_value = "host-tests/bench/qemu-baseline.json")]
    baseline: PathBuf,
    /// Write this run's gated figures to the baseline file.
    #[arg(long)]
    update_baseline: bool,
}

/// `-icount shift=3`: 8 ns per instruction; the counter ticks at 25 MHz.
const SHIFT: u8 = 3;
const INSTRUCTIONS_PER_COUNT: u64 = 40 >> SHIFT;
/// One 4 ms robot cycle at 216 MHz, one instruction per cycle.
const CYCLE_AT_216MHZ: u64 = 864_000;

fn main() -> ExitCode {
    let args = Args::parse();
    match bench(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn instructions(counts: u32) -> u64 {
    u64::from(counts) * INSTRUCTIONS_PER_COUNT
}

/// What one simulator run gave.
struct Driven {
    summary: host_tests::robot::report::Summary,
    flood_sent: u64,
    /// The device's log lines during the run.
    lines: Vec<String>,
}

/// Runs the robot simulator for `cycles` against `to`, with a flood of
/// rejected datagrams ([`qb::flood_datagrams`], in turn) from a second port
/// every `flood_us` (0: none).
fn drive(
    board: &Qemu,
    to: std::net::SocketAddr,
    gsi: &std::path::Path,
    device: &gsi_config::Device,
    cycles: u64,
    flood_us: u64,
    paced: bool,
) -> Result<Driven, String> {
    let stop = Arc::new(AtomicBool::new(false));
    let flood = if flood_us > 0 {
        Some(qb::flood(
            std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
            to,
            qb::flood_datagrams(),
            Duration::from_micros(flood_us),
            stop.clone(),
        )?)
    } else {
        None
    };
    let mut opts = RobotOptions::new(gsi.to_path_buf(), to);
    opts.cycles = cycles;
    opts.pacing = paced;
    opts.progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let start = board.lines();
    let result = run(&opts, device, &mut std::io::sink());
    stop.store(true, Ordering::Relaxed);
    let flooded = flood
        .map(|f| f.join().map_err(|_| "the flooder panicked".to_string()))
        .transpose()?
        .unwrap_or_default();
    // The last records and a counter line reach the log.
    std::thread::sleep(Duration::from_millis(1200));
    let (summary, _) = result?;
    Ok(Driven {
        summary,
        flood_sent: flooded.total(),
        lines: board.since(start),
    })
}

/// Stops QEMU and returns the whole log; an error if the firmware had
/// already stopped (panicked or exited) `when`.
fn finish(mut board: Qemu, when: &str) -> Result<Vec<String>, String> {
    let exited = board.exited();
    let log = board.stop();
    match exited {
        Some(status) => Err(format!("the firmware stopped {when} (QEMU {status})")),
        None => Ok(log),
    }
}

fn last_counters(log: &[String]) -> String {
    log.iter()
        .rev()
        .find_map(|l| l.split_once("] counters: ").map(|(_, c)| c.to_string()))
        .unwrap_or_default()
}

/// Under this much stack margin the bench fails (the rule).
const MIN_STACK_MARGIN_PERCENT: u64 = 25;

/// The device's stack use in bytes: (start-up, running, budget), from its
/// last `stack: boot B running R of S bytes` line (logged once a second
/// when the high-water mark grew).
fn last_stack(log: &[String]) -> Option<(u64, u64, u64)> {
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

/// Waits (up to 10 s: under -icount the guest's second can be longer) for a
/// counter line newer than everything the bench did, then returns the last
/// stack figures: the stack line is logged just before the counter line,
/// and only when the mark grew.
fn wait_for_stack(board: &Qemu) -> Result<(u64, u64, u64), String> {
    DeviceCounters::fresh(board, board.lines(), Duration::from_secs(10))?;
    last_stack(&board.log()).ok_or_else(|| "the device logged no stack line".to_string())
}

fn records(lines: &[String]) -> Vec<Record> {
    lines.iter().filter_map(|l| Record::parse(l)).collect()
}

fn bench(args: &Args) -> Result<bool, String> {
    let ws = host_tests::workspace();
    let mut out = std::io::stdout();
    qemu::ensure_qemu(&mut out)?;
    // The corpus and the in-guest baseline are the manual's AnyDevice.
    let gsi = ws.join("firmware/gsi/GSI");
    let device = gsi_config::load(&gsi, None)
        .map_err(|f| f.to_string())?
        .device;
    println!(
        "== building the bench firmware (features bench) for QEMU {}",
        qemu::MACHINE
    );
    let elf = qemu::build_firmware(&["bench"], Some(&gsi), "bench")?;
    let host_port = qemu::free_port()?;
    let boot = Boot {
        elf,
        device: device.clone(),
        host_port,
        icount_shift: Some(SHIFT),
    };
    println!(
        "== booting with -icount shift={SHIFT} ({INSTRUCTIONS_PER_COUNT} instructions per count)"
    );
    let mut board = Qemu::boot(&boot)?;
    board.wait_for("state CONNECTED", Duration::from_secs(30))?;
    let to = std::net::SocketAddr::from(([127, 0, 0, 1], host_port));

    // 1. The codec comparison ran at boot.
    let codec: Vec<_> = board
        .log()
        .iter()
        .filter_map(|l| qb::parse_codec(l))
        .collect();

    // 2. The simulator, every message measured.
    // Lock-step: each message leaves when the previous one is answered.
    // Under -icount the guest's clock is not the host's, and 4 ms host
    // pacing delivered datagrams in bursts that QEMU's user networking and
    // the emulated NIC's FIFO sometimes dropped (3 to 15 of 2,000 on this
    // machine, before and after the hostile-world changes alike): a loss of
    // the emulation, not of the firmware. What this run measures is the
    // instructions per message; real-time behaviour is the flood run's.
    println!(
        "== robot simulator: {} cycles, lock-step (each message after the previous reply; instructions counted)",
        args.cycles
    );
    let sim = drive(&board, to, &gsi, &device, args.cycles, 0, false)?;
    let summary = sim.summary.clone();
    // The first answer waits for ARP through slirp (idle time in the
    // count): warm-up, not a cycle.
    let sim_records: Vec<Record> = records(&sim.lines)
        .into_iter()
        .skip_while(|r| !r.answered)
        .skip(1)
        .collect();

    // 3. The corpora, one message at a time.
    let realistic = qb::realistic(&host_tests::shared_rri(), &ws.join("host-tests/bench"))?;
    let hostile = qb::hostile();
    let socket = UdpSocket::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    socket
        .set_read_timeout(Some(Duration::from_millis(50)))
        .map_err(|e| e.to_string())?;
    let mut next_id = summary.sent as u32 + 1000;
    let mut measure = |input: &Input| -> Result<Vec<Record>, String> {
        let mut got = Vec::new();
        for _ in 0..args.repeat {
            let before = board.lines();
            next_id += 1;
            socket
                .send_to(&input.with_id(next_id), to)
                .map_err(|e| e.to_string())?;
            let mut buf = [0u8; 65536];
            let answered = socket.recv_from(&mut buf).is_ok();
            if answered != input.accepted {
                return Err(format!(
                    "{}: the device {} it",
                    input.name,
                    if answered {
                        "answered"
                    } else {
                        "did not answer"
                    }
                ));
            }
            let end = Instant::now() + Duration::from_secs(3);
            loop {
                if let Some(record) = records(&board.since(before)).first() {
                    got.push(*record);
                    break;
                }
                if Instant::now() > end {
                    return Err(format!("{}: no bench record from the device", input.name));
                }
                std::thread::sleep(Duration::from_millis(2));
            }
        }
        Ok(got)
    };
    let mut realistic_rows = Vec::new();
    for input in &realistic {
        realistic_rows.push((input.clone(), measure(input)?));
    }
    let mut hostile_rows = Vec::new();
    for input in &hostile {
        hostile_rows.push((input.clone(), measure(input)?));
    }
    // The stack's high-water mark reaches the log within a second.
    let stack = wait_for_stack(&board)?;
    let log = finish(board, "during the bench")?;
    let counters = last_counters(&log);

    // 4. The flood, in real time: under -icount QEMU's user networking
    // hands the guest host datagrams in bursts that overflow the emulated
    // LAN9118's RX FIFO (a few % lost at any shift, none without -icount),
    // so misses under a flood are counted on a real-time boot.
    // The production firmware (no bench records to log).
    let flood_boot = Boot {
        elf: qemu::build_firmware(&[], Some(&gsi), "bench-flood")?,
        icount_shift: None,
        host_port: qemu::free_port()?,
        ..boot.clone()
    };
    let flood_to = std::net::SocketAddr::from(([127, 0, 0, 1], flood_boot.host_port));
    let mut flood_board = Qemu::boot(&flood_boot)?;
    flood_board.wait_for("state CONNECTED", Duration::from_secs(30))?;
    println!(
        "== robot simulator in real time: {} cycles every 4 ms, flood from a second port every {} µs, in turn: {}",
        args.cycles,
        args.flood_us,
        qb::flood_datagrams()
            .iter()
            .map(|(name, d)| format!("{name} ({} B)", d.len()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let flooded = drive(
        &flood_board,
        flood_to,
        &gsi,
        &device,
        args.cycles,
        args.flood_us,
        true,
    )?;
    let flood_log = finish(flood_board, "under the flood")?;
    let flood_counters = last_counters(&flood_log);

    // Figures.
    let mut compute: Vec<u64> = sim_records
        .iter()
        .map(|r| instructions(r.compute))
        .collect();
    let mut full: Vec<u64> = sim_records
        .iter()
        .filter(|r| r.answered)
        .map(|r| instructions(r.full))
        .collect();
    for (_, rows) in &realistic_rows {
        compute.extend(rows.iter().map(|r| instructions(r.compute)));
        full.extend(
            rows.iter()
                .filter(|r| r.answered)
                .map(|r| instructions(r.full)),
        );
    }
    let compute = Spread::of(compute);
    let full = Spread::of(full);
    // Late as the device measures it (deterministic): a full path longer
    // than one 4 ms cycle at 216 MHz. The simulator's own "late" is host
    // wall-clock time through slirp, reported but not gated.
    let late_device = sim_records
        .iter()
        .filter(|r| r.answered && instructions(r.full) > CYCLE_AT_216MHZ)
        .count() as u64;
    let f = &flooded.summary;
    // Gated: the deterministic run. Under the flood (real time) a wrong or
    // malformed reply fails too; lost datagrams there are reported, not
    // gated: they never reach the engine (its Id gaps) and depend on how
    // QEMU is scheduled on the host.
    let missed = summary.lost
        + summary.wrong_id
        + summary.malformed
        + late_device
        + f.wrong_id
        + f.malformed;
    let hostile_cost = |rows: &[Record]| -> u64 {
        rows.iter()
            .map(|r| {
                instructions(if r.answered {
                    r.full.max(r.compute)
                } else {
                    r.compute
                })
            })
            .max()
            .unwrap_or(0)
    };
    let hostile_max = hostile_rows
        .iter()
        .map(|(_, r)| hostile_cost(r))
        .max()
        .unwrap_or(0);
    let baseline_median = codec
        .iter()
        .find(|c| c.0 == "manual")
        .map(|c| u64::from(c.4) * INSTRUCTIONS_PER_COUNT)
        .unwrap_or(0);

    println!("\n== codec on Thumb-2, instructions per message (decode + encode; in-guest, interrupts masked)");
    println!(
        "  {:<8} {:>6} {:>10} {:>16} {:>18} {:>8}",
        "message", "bytes", "ours", "xmlparser alone", "naive baseline", "ratio"
    );
    for (name, bytes, ours, tok, base) in &codec {
        let i = |c: &u32| u64::from(*c) * INSTRUCTIONS_PER_COUNT;
        println!(
            "  {:<8} {:>6} {:>10} {:>16} {:>18} {:>7.2}×",
            name,
            bytes,
            i(ours),
            i(tok),
            i(base),
            i(ours) as f64 / i(tok).max(1) as f64
        );
    }
    println!("\n== realistic: simulator ({} cycles, the first one warm-up) + manual, IRC5 capture, maximum values ×{}", sim_records.len(), args.repeat);
    let row = |name: &str, s: &Spread| {
        println!(
            "  {name:<8} min {:>7}  median {:>7}  p99 {:>7}  max {:>7}  worst/median {:.2}  worst {:.0} µs @216 MHz, {:.0} µs @480 MHz",
            s.min,
            s.median,
            s.p99,
            s.max,
            s.max as f64 / s.median.max(1) as f64,
            s.max as f64 / 216.0,
            s.max as f64 / 480.0
        );
    };
    row("compute", &compute);
    row("full", &full);
    for (input, rows) in &realistic_rows {
        let c = Spread::of(rows.iter().map(|r| instructions(r.compute)).collect());
        let f = Spread::of(rows.iter().map(|r| instructions(r.full)).collect());
        println!(
            "  {:<24} {:>5} B  compute median {:>7}  full median {:>7}",
            input.name,
            input.len(),
            c.median,
            f.median
        );
    }
    println!(
        "  robot: sent {} answered {} lost {} wrong Id {} malformed {}; late: {} by the device's count, {} by the host's wall clock through slirp",
        summary.sent, summary.answered, summary.lost, summary.wrong_id, summary.malformed, late_device, summary.late,
    );
    println!("  device: {}", counters);
    println!(
        "\n== under the flood (real time, {} flood datagrams sent)\n  robot: sent {} answered {} lost {} wrong Id {} malformed {}; late (host wall clock through slirp) {}; latency µs median {} p99 {} max {}",
        flooded.flood_sent, f.sent, f.answered, f.lost, f.wrong_id, f.malformed, f.late,
        f.latency_us.median, f.latency_us.p99, f.latency_us.max
    );
    println!("  device: {}", flood_counters);
    println!(
        "\n== hostile: every input {} bytes (MAX_RECEIVE_LEN), ×{} each",
        host_tests::layouts::anydevice::MAX_RECEIVE_LEN,
        args.repeat
    );
    let mut hostile_json = Vec::new();
    for (input, rows) in &hostile_rows {
        let worst = hostile_cost(rows);
        println!(
            "  {:<28} {:<9} worst {:>8} instructions = {:>5.1} per byte",
            input.name,
            if input.accepted {
                "answered"
            } else {
                "rejected"
            },
            worst,
            worst as f64 / input.len() as f64
        );
        hostile_json.push(json!({"name": input.name, "bytes": input.len(), "answered": input.accepted, "worst": worst, "per_byte": worst as f64 / input.len() as f64}));
    }
    println!(
        "  worst {hostile_max} instructions ({:.0} µs @216 MHz; budget 216,000 = a quarter cycle)",
        hostile_max as f64 / 216.0
    );
    let (stack_boot, stack_running, stack_size) = stack;
    let stack_used = stack_boot.max(stack_running);
    let stack_margin = (stack_size - stack_used.min(stack_size)) * 100 / stack_size.max(1);
    println!(
        "\n== stack (painted; thread mode and every interrupt share the one main stack)\n  start-up {stack_boot} bytes (building the network stack), running {stack_running} bytes (after the bench and the hostile inputs), of a {stack_size}-byte budget: {stack_margin}% margin (fails under {MIN_STACK_MARGIN_PERCENT}%)"
    );
    println!("\nQEMU counts instructions, not cycles: no caches, flash wait states, bus contention or Ethernet DMA are modelled; µs figures assume one instruction per cycle.");

    let gated = Gated {
        compute_median: compute.median,
        compute_max: compute.max,
        full_median: full.median,
        hostile_max,
    };
    let dir = qemu::target_dir().join("qemu-bench");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let summary_json = json!({
        "shift": SHIFT,
        "cycles": summary.sent,
        "missed": missed,
        "late": late_device,
        "late_host_wall_clock": summary.late,
        "lost": summary.lost,
        "compute": compute,
        "full": full,
        "hostile_max": hostile_max,
        "hostile": hostile_json,
        "stack": {"boot": stack_boot, "running": stack_running, "budget": stack_size, "margin_percent": stack_margin},
        "baseline_compute_median": baseline_median,
        "codec": codec.iter().map(|(n, b, o, t, base)| json!({"message": n, "bytes": b,
            "ours": u64::from(*o) * INSTRUCTIONS_PER_COUNT, "tokenizer": u64::from(*t) * INSTRUCTIONS_PER_COUNT,
            "baseline": u64::from(*base) * INSTRUCTIONS_PER_COUNT})).collect::<Vec<_>>(),
        "flood": {"sent": flooded.flood_sent, "robot_sent": f.sent, "answered": f.answered,
            "lost": f.lost, "late_host_wall_clock": f.late},
    });
    let _ = std::fs::write(dir.join("device.log"), log.join("\n") + "\n");
    let _ = std::fs::write(dir.join("device-flood.log"), flood_log.join("\n") + "\n");
    let path = dir.join("summary.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&summary_json).map_err(|e| e.to_string())?,
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let svg = dir.join("histogram.svg");
    host_tests::qemu_bench::histogram(
        &svg,
        &sim_records
            .iter()
            .map(|r| instructions(r.compute))
            .collect::<Vec<_>>(),
        &sim_records
            .iter()
            .filter(|r| r.answered)
            .map(|r| instructions(r.full))
            .collect::<Vec<_>>(),
    )?;
    println!("\nwrote {} and {}", path.display(), svg.display());

    let baseline_path = ws.join(&args.baseline);
    if args.update_baseline {
        std::fs::write(
            &baseline_path,
            serde_json::to_string_pretty(&gated).map_err(|e| e.to_string())? + "\n",
        )
        .map_err(|e| format!("{}: {e}", baseline_path.display()))?;
        println!("baseline updated: {}", baseline_path.display());
    }
    let mut ok = true;
    if missed > 0 {
        println!("FAIL: {missed} replies missed, late or wrong");
        ok = false;
    }
    if stack_margin < MIN_STACK_MARGIN_PERCENT {
        println!("FAIL: stack margin {stack_margin}% is under {MIN_STACK_MARGIN_PERCENT}%");
        ok = false;
    }
    match std::fs::read_to_string(&baseline_path) {
        Ok(text) => {
            let base: Gated = serde_json::from_str(&text)
                .map_err(|e| format!("{}: {e}", baseline_path.display()))?;
            let regressions = gated.regressions(&base, 0.05);
            for r in &regressions {
                println!("FAIL: {r}");
            }
            ok &= regressions.is_empty();
            if regressions.is_empty() {
                println!(
                    "baseline {}: every gated figure within 5 %",
                    baseline_path.display()
                );
            }
        }
        Err(_) => println!(
            "no baseline file {} (run with --update-baseline)",
            baseline_path.display()
        ),
    }
    Ok(ok)
}
