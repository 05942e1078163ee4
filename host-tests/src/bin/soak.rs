//! `cargo soak [-- --cycles 1000000] [--chunk 100000] [--fault SPEC]...`:
//! the firmware on QEMU driven for a long time, as fast as it answers
//! (accelerated pacing: the next message goes when the last is answered),
//! with the robot simulator's faults (lost, duplicated and reordered
//! messages, garbage and oversize datagrams, a short pause, a controller
//! that changes source port).
//!
//! The run is cut into chunks; after each the device's counter line is
//! read. Fails on any wrong or malformed reply, on device counters that do
//! not add up (received = answered + every drop, and every answer it
//! counted reached the robot), on a latency that grows
//! from chunk to chunk (a queue that grows), on a stack margin under 25 %,
//! or when the firmware stopped.

use clap::Parser;
use host_tests::counters::DeviceCounters as Counters;
use host_tests::qemu::{self, Boot, Qemu};
use host_tests::robot::fault::Fault;
use host_tests::robot::{run, RobotOptions};
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Parser, Debug)]
#[command(
    name = "cargo soak",
    about = "Drive the QEMU firmware for many cycles with faults; check nothing drifts"
)]
struct Args {
    /// Robot messages in all.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
    cycles: u64,
    /// Messages per chunk (counters and latency are checked per chunk).
    #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..))]
    chunk: u64,
    /// Faults of the robot simulator (`cargo robot --help` lists them);
    /// replaces the default set.
    #[arg(long = "fault", value_parser = Fault::parse)]
    faults: Vec<Fault>,
}

/// The default faults: each kind, a few times per thousand cycles.
const DEFAULT_FAULTS: &[&str] = &[
    "drop:0.5",
    "duplicate:0.5",
    "reorder:0.5",
    "garbage:0.5",
    "oversize:0.1",
    "pause:1000:40",
];

fn main() -> ExitCode {
    let args = Args::parse();
    match soak(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn soak(args: &Args) -> Result<bool, String> {
    let mut out = std::io::stdout();
    qemu::ensure_qemu(&mut out)?;
    let (gsi, device_name) = host_tests::built_gsi();
    let device = gsi_config::load(&gsi, device_name.as_deref())
        .map_err(|f| f.to_string())?
        .device;
    let faults = if args.faults.is_empty() {
        DEFAULT_FAULTS
            .iter()
            .map(|s| Fault::parse(s))
            .collect::<Result<Vec<_>, _>>()?
    } else {
        args.faults.clone()
    };
    println!("== building the firmware for QEMU {}", qemu::MACHINE);
    let elf = qemu::build_firmware(&[], None, "soak")?;
    let host_port = qemu::free_port()?;
    let mut board = Qemu::boot(&Boot {
        elf,
        device: device.clone(),
        host_port,
        icount_shift: None,
        http_port: None,
    })?;
    board.wait_for("state CONNECTED", Duration::from_secs(30))?;
    println!(
        "== soak: {} cycles in chunks of {}, answered as fast as the device goes; faults {:?}",
        args.cycles, args.chunk, faults
    );
    println!(
        "{:>7} {:>9} {:>8} {:>6} {:>6} {:>9} {:>9} {:>9} {:>9}  device received = answered + dropped (foreign, invalid, throttled, decode)",
        "chunk", "sent", "answered", "lost", "wrong", "p50 µs", "p99 µs", "max µs", "cycles/s"
    );
    let started = Instant::now();
    let mut ok = true;
    let mut first_p50 = None;
    let mut done = 0u64;
    let mut totals = (0u64, 0u64, 0u64, 0u64, 0u64);
    let mut chunk_no = 0u32;
    let mut last = Counters::default();
    while done < args.cycles {
        let n = args.chunk.min(args.cycles - done);
        let mut opts = RobotOptions::new(gsi.clone(), ([127, 0, 0, 1], host_port).into());
        opts.device = device_name.clone();
        opts.cycles = n;
        opts.pacing = false;
        opts.faults = faults.clone();
        opts.seed = u64::from(chunk_no) + 1;
        // Ids continue across chunks (each chunk is a new source port: a
        // controller that reconnected, S3 Ids carry on).
        opts.first_id = (done as u32).wrapping_add(1);
        let start = board.lines();
        let t = Instant::now();
        let (s, _) = run(&opts, &device, &mut std::io::sink())?;
        let rate = s.sent as f64 / t.elapsed().as_secs_f64();
        // Quiet now: the next counter line holds every message of the chunk.
        std::thread::sleep(Duration::from_millis(1100));
        let c = Counters::fresh(&board, start, Duration::from_secs(5))?;
        let p50 = s.latency_us.median;
        let base = *first_p50.get_or_insert(p50);
        println!(
            "{chunk_no:>7} {:>9} {:>8} {:>6} {:>6} {:>9} {:>9} {:>9} {rate:>9.0}  {} = {} + {} + {} + {} + {} ({})",
            s.sent,
            s.answered,
            s.lost,
            s.wrong_id + s.malformed,
            p50,
            s.latency_us.p99,
            s.latency_us.max,
            c.received,
            c.answered,
            c.foreign,
            c.invalid,
            c.throttled,
            c.decode,
            if c.add_up() { "adds up" } else { "DOES NOT ADD UP" },
        );
        if s.wrong_id + s.malformed > 0 {
            println!("FAIL: chunk {chunk_no}: {:?}", s.first_error);
            ok = false;
        }
        if !c.add_up() {
            println!("FAIL: chunk {chunk_no}: the device's counters do not add up");
            ok = false;
        }
        if c.received < last.received || c.answered < last.answered {
            println!("FAIL: chunk {chunk_no}: a device counter went backwards");
            ok = false;
        }
        // Every answer the device counted reached the robot (a duplicated
        // message is answered twice).
        let device_answered = c.answered.saturating_sub(last.answered);
        if device_answered != s.answered + s.duplicate_replies {
            println!(
                "FAIL: chunk {chunk_no}: the device answered {device_answered}, the robot got {} + {} duplicates",
                s.answered, s.duplicate_replies
            );
            ok = false;
        }
        // A queue that grows shows as latency that grows with time.
        if p50 > base.saturating_mul(3).max(base + 500) {
            println!("FAIL: chunk {chunk_no}: median latency {p50} µs, first chunk {base} µs");
            ok = false;
        }
        if let Some(status) = board.exited() {
            return Err(format!(
                "the firmware stopped in chunk {chunk_no} (QEMU {status})"
            ));
        }
        last = c;
        totals.0 += s.sent;
        totals.1 += s.answered;
        totals.2 += s.lost;
        totals.3 += s.wrong_id + s.malformed;
        totals.4 += s.duplicate_replies;
        done += n;
        chunk_no += 1;
    }
    let log = board.stop();
    let panicked = log.iter().find(|l| l.contains("panic"));
    let stack = log
        .iter()
        .rev()
        .find_map(|l| l.split_once("] stack: ").map(|(_, s)| s.to_string()));
    println!(
        "\n== {} cycles in {:.0} s: answered {}, lost {} ({:.3} %), wrong {}, duplicate replies {}",
        totals.0,
        started.elapsed().as_secs_f64(),
        totals.1,
        totals.2,
        totals.2 as f64 * 100.0 / totals.0.max(1) as f64,
        totals.3,
        totals.4
    );
    println!(
        "  device: received {} answered {} dropped foreign {} invalid-source {} throttled {} decode {}",
        last.received, last.answered, last.foreign, last.invalid, last.throttled, last.decode
    );
    println!("  stack: {}", stack.as_deref().unwrap_or("(no stack line)"));
    if let Some(p) = panicked {
        println!("FAIL: the firmware panicked: {p}");
        ok = false;
    }
    println!("{}", if ok { "soak: PASS" } else { "soak: FAIL" });
    Ok(ok)
}

#[cfg(test)]
mod command_line {
    /// clap's own consistency checks (unique names and flags): a clash
    /// would otherwise show only as a panic in a debug build.
    #[test]
    fn is_consistent() {
        <super::Args as clap::CommandFactory>::command().debug_assert();
    }
}
