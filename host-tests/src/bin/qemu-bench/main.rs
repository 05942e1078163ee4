//! `cargo qemu-bench [-- --cycles N] [--update-baseline] | [-- --corpus DIR]`: worst-case cycle
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

mod held;
mod layers;
mod paths;
mod report;
mod run;
mod scrape;
mod scraped;
mod upload;
mod user_corpus;

use clap::Parser;
use host_tests::counters::{DeviceCounters, LossSplit};
use host_tests::qemu::{self, Boot, Qemu};
use host_tests::qemu_bench::{self as qb, Input, Record};
use host_tests::robot::report::Summary;
use run::{
    booted, corpus_socket, drive, finish, last_counters, measure, records, wait_for_stack, Driven,
};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

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
    /// Measure the messages in DIR instead (one robot message per file, e.g. from
    /// `cargo robot -- --replay CAPTURE --extract DIR`), built for RRI_GSI_DIR: the worst case
    /// on your own controller's traffic. Exit 1 when one costs more than a quarter cycle.
    #[arg(long, value_name = "DIR", conflicts_with = "update_baseline")]
    corpus: Option<PathBuf>,
}

/// `-icount shift=3`: 8 ns per instruction; the counter ticks at 25 MHz.
const SHIFT: u8 = 3;
const INSTRUCTIONS_PER_COUNT: u64 = 40 >> SHIFT;
/// One 4 ms robot cycle at 216 MHz, one instruction per cycle.
const CYCLE_AT_216MHZ: u64 = 864_000;

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match &args.corpus {
        Some(dir) => user_corpus::run(&args, dir),
        None => bench(&args),
    };
    match result {
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

/// What the `-icount` boot measured.
struct Measured {
    /// The in-guest codec comparison: (message, bytes, ours, xmlparser
    /// alone, naive baseline), in counts.
    codec: Vec<(String, u32, u32, u32, u32)>,
    /// `memcpy` at boot: (bytes, counts with the ends aligned alike,
    /// unlike).
    copy: Option<(u32, u32, u32)>,
    /// The lock-step simulator run.
    summary: Summary,
    /// Its bench records (the first answer, ARP warm-up, left out).
    sim_records: Vec<Record>,
    realistic: Vec<(Input, Vec<Record>)>,
    hostile: Vec<(Input, Vec<Record>)>,
    /// The same again while the diagnostics were scraped, and what the
    /// scraper got.
    scraped: Option<(Phase, String)>,
    /// The same again while an update was uploaded, and what the uploader
    /// got.
    uploaded: Option<(Phase, String)>,
    /// Stack use: (start-up, running, budget) bytes.
    stack: (u64, u64, u64),
    log: Vec<String>,
    counters: String,
}

/// What the real-time boot under the flood gave.
struct Flooded {
    driven: Driven,
    log: Vec<String>,
    counters: String,
    /// Where the lost robot messages went (from the device's last counter
    /// line; `None` when it logged none).
    split: Option<LossSplit>,
}

fn bench(args: &Args) -> Result<bool, String> {
    let ws = host_tests::workspace();
    qemu::ensure_qemu(&mut std::io::stdout())?;
    // The corpus and the in-guest baseline are the manual's AnyDevice.
    let gsi = ws.join("firmware/gsi/GSI");
    let device = gsi_config::load(&gsi, None)
        .map_err(|f| f.to_string())?
        .device;
    println!(
        "== building the bench firmware (features bench) for QEMU {}",
        qemu::MACHINE
    );
    let boot = Boot {
        elf: qemu::build_firmware(&["bench"], Some(&gsi), "bench")?,
        device: device.clone(),
        host_port: qemu::free_port()?,
        icount_shift: Some(SHIFT),
        http_port: Some(qemu::free_tcp_port()?),
    };
    let measured = counted(args, &boot, &gsi, &device)?;
    let floor = floor(args, &boot, &gsi)?;
    let flooded = flood(args, &boot, &gsi, &device)?;
    report::report(args, &measured, &floor, &flooded)
}

/// The floor: the same corpora sent to a build that answers every
/// datagram with one fixed reply, decoding nothing (feature
/// `bench-floor`), under the same `-icount`: what the driver, smoltcp and
/// the executor cost without the cycle, per input.
fn floor(
    args: &Args,
    boot: &Boot,
    gsi: &std::path::Path,
) -> Result<Vec<(Input, Vec<Record>)>, String> {
    println!("== the floor: a build that answers every datagram with a fixed reply, no decoding");
    let floor_boot = Boot {
        elf: qemu::build_firmware(&["bench", "bench-floor"], Some(gsi), "bench-floor")?,
        host_port: qemu::free_port()?,
        ..boot.clone()
    };
    let (board, to) = booted(&floor_boot)?;
    let socket = corpus_socket()?;
    let ws = host_tests::workspace();
    let mut inputs = qb::realistic(&host_tests::shared_rri(), &ws.join("host-tests/bench"))?;
    inputs.extend(qb::hostile());
    // The first datagram waits for ARP through slirp: not measured.
    let mut next_id = 1;
    measure(
        &board,
        &socket,
        to,
        &Input {
            accepted: true,
            ..inputs[0].clone()
        },
        1,
        &mut next_id,
    )?;
    let rows = inputs
        .into_iter()
        .map(|input| {
            // The floor answers everything.
            let input = Input {
                accepted: true,
                ..input
            };
            let got = measure(&board, &socket, to, &input, args.repeat, &mut next_id)?;
            Ok((input, got))
        })
        .collect::<Result<Vec<_>, String>>()?;
    finish(board, "during the floor")?;
    Ok(rows)
}

/// Boots the bench build under `-icount` and measures: the codec
/// comparison it ran at boot, the simulator lock-step, every corpus
/// message, the stack.
fn counted(
    args: &Args,
    boot: &Boot,
    gsi: &std::path::Path,
    device: &gsi_config::Device,
) -> Result<Measured, String> {
    println!(
        "== booting with -icount shift={SHIFT} ({INSTRUCTIONS_PER_COUNT} instructions per count)"
    );
    let (board, to) = booted(boot)?;

    // 1. The codec comparison ran at boot.
    let codec = board
        .log()
        .iter()
        .filter_map(|l| qb::parse_codec(l))
        .collect();
    let copy = board.log().iter().find_map(|l| qb::parse_copy(l));

    // 2.–3. The simulator, every message measured, then the corpora; then
    // all of it again while a client scrapes the diagnostics (the scrape
    // run: the service's cost to the cycle, measured).
    let quiet = phase(args, &board, to, gsi, device, 0)?;
    let http = boot
        .http_port
        .map(|p| SocketAddr::from(([127, 0, 0, 1], p)))
        .ok_or("the bench boot forwards no diagnostics port")?;
    println!("== the scrape run: the same again while a client reads /metrics 10 times a second, / once a second, and opens 8 connections at once every second");
    let scraper = scrape::Scraper::start(http);
    let scraped = phase(args, &board, to, gsi, device, 1_000_000);
    let got = scraper.stop();
    let scraped = scraped?;
    println!("== the upload run: the same again while an update file of the bench image is uploaded over and over (PUT /firmware: written to the update partition, hashed, refused at its signature)");
    let uploader = upload::Uploader::start(http, upload::file(&boot.elf)?);
    let uploaded = phase(args, &board, to, gsi, device, 2_000_000);
    let sent = uploader.stop();
    let uploaded = uploaded?;
    let others = sent.other.lock().map(|o| o.len()).unwrap_or(1);
    if sent.checked.load(std::sync::atomic::Ordering::Relaxed) == 0 || others > 0 {
        return Err(format!(
            "the upload run's uploads did not all go as meant: {}",
            sent.line()
        ));
    }
    // The stack's high-water mark reaches the log within a second.
    let stack = wait_for_stack(&board)?;
    let log = finish(board, "during the bench")?;
    Ok(Measured {
        codec,
        copy,
        summary: quiet.summary,
        sim_records: quiet.sim_records,
        realistic: quiet.realistic,
        hostile: quiet.hostile,
        scraped: Some((scraped, got.line())),
        uploaded: Some((uploaded, sent.line())),
        stack,
        counters: last_counters(&log),
        log,
    })
}

/// One measured phase of the `-icount` boot.
pub struct Phase {
    pub summary: Summary,
    /// The simulator's bench records (the first answer, ARP warm-up, left
    /// out).
    pub sim_records: Vec<Record>,
    pub realistic: Vec<(Input, Vec<Record>)>,
    pub hostile: Vec<(Input, Vec<Record>)>,
}

/// The simulator lock-step for `args.cycles`, then every corpus message
/// `args.repeat` times; Ids from `first_id` on.
fn phase(
    args: &Args,
    board: &Qemu,
    to: SocketAddr,
    gsi: &std::path::Path,
    device: &gsi_config::Device,
    first_id: u32,
) -> Result<Phase, String> {
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
    let sim = drive(board, to, gsi, device, args.cycles, 0, false)?;
    // The first answer waits for ARP through slirp (idle time in the
    // count): warm-up, not a cycle.
    let sim_records = records(&sim.lines)
        .into_iter()
        .skip_while(|r| !r.answered)
        .skip(1)
        .collect();
    let ws = host_tests::workspace();
    let socket = corpus_socket()?;
    let mut next_id = first_id + sim.summary.sent as u32 + 1000;
    let mut rows = |inputs: Vec<Input>| -> Result<Vec<(Input, Vec<Record>)>, String> {
        inputs
            .into_iter()
            .map(|input| {
                let got = measure(board, &socket, to, &input, args.repeat, &mut next_id)?;
                Ok((input, got))
            })
            .collect()
    };
    let realistic = rows(qb::realistic(
        &host_tests::shared_rri(),
        &ws.join("host-tests/bench"),
    )?)?;
    let hostile = rows(qb::hostile())?;
    Ok(Phase {
        summary: sim.summary,
        sim_records,
        realistic,
        hostile,
    })
}

/// The flood, in real time: under -icount QEMU's user networking hands the
/// guest host datagrams in bursts that overflow the emulated LAN9118's RX
/// FIFO (a few % lost at any shift, none without -icount), so misses under
/// a flood are counted on a real-time boot of the production firmware (no
/// bench records to log).
fn flood(
    args: &Args,
    boot: &Boot,
    gsi: &std::path::Path,
    device: &gsi_config::Device,
) -> Result<Flooded, String> {
    let flood_boot = Boot {
        elf: qemu::build_firmware(&[], Some(gsi), "bench-flood")?,
        icount_shift: None,
        http_port: None,
        host_port: qemu::free_port()?,
        ..boot.clone()
    };
    let (board, to) = booted(&flood_boot)?;
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
    let driven = drive(&board, to, gsi, device, args.cycles, args.flood_us, true)?;
    let log = finish(board, "under the flood")?;
    let s = &driven.summary;
    let split = log
        .iter()
        .rev()
        .find_map(|l| DeviceCounters::parse(l))
        .map(|c| LossSplit::of(s.sent, s.answered, &c));
    Ok(Flooded {
        driven,
        counters: last_counters(&log),
        split,
        log,
    })
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
