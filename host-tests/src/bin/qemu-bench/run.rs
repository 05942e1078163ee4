//! Driving the booted board: the simulator (with or without a flood), one
//! corpus message at a time, and reading the device's log (bench records,
//! counters, stack).

use host_tests::counters::DeviceCounters;
use host_tests::qemu::{Boot, Qemu};
use host_tests::qemu_bench::{self as qb, Input, Record};
use host_tests::robot::report::Summary;
use host_tests::robot::{run, RobotOptions};
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Boots `boot` and waits for the device to come up: the board and where
/// its channel port is forwarded on 127.0.0.1.
pub fn booted(boot: &Boot) -> Result<(Qemu, SocketAddr), String> {
    let mut board = Qemu::boot(boot)?;
    board.wait_for("state CONNECTED", Duration::from_secs(30))?;
    Ok((board, SocketAddr::from(([127, 0, 0, 1], boot.host_port))))
}

/// The socket [`measure`] sends corpus messages from.
pub fn corpus_socket() -> Result<UdpSocket, String> {
    let socket = UdpSocket::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    socket
        .set_read_timeout(Some(Duration::from_millis(50)))
        .map_err(|e| e.to_string())?;
    Ok(socket)
}

/// What one simulator run gave.
pub struct Driven {
    pub summary: Summary,
    pub flood_sent: u64,
    /// The device's log lines during the run.
    pub lines: Vec<String>,
}

/// Runs the robot simulator for `cycles` against `to`, with a flood of
/// rejected datagrams ([`qb::flood_datagrams`], in turn) from a second port
/// every `flood_us` (0: none). The flood starts once the robot is the
/// device's peer, so that every robot message the device counts as the
/// controller's is the robot's (the split of the losses needs it).
pub fn drive(
    board: &Qemu,
    to: std::net::SocketAddr,
    gsi: &std::path::Path,
    device: &gsi_config::Device,
    cycles: u64,
    flood_us: u64,
    paced: bool,
) -> Result<Driven, String> {
    let stop = Arc::new(AtomicBool::new(false));
    let mut opts = RobotOptions::new(gsi.to_path_buf(), to);
    opts.cycles = cycles;
    opts.pacing = paced;
    opts.progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let start = board.lines();
    let robot = {
        let device = device.clone();
        std::thread::spawn(move || run(&opts, &device, &mut std::io::sink()))
    };
    let flood = if flood_us > 0 {
        wait_for_peer(board, start)?;
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
    let result = robot
        .join()
        .map_err(|_| "the robot simulator panicked".to_string())?;
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

/// Waits (up to 10 s) until the device logged `state OPERATING` after line
/// `start`: the robot's first message made it the peer.
fn wait_for_peer(board: &Qemu, start: usize) -> Result<(), String> {
    let end = Instant::now() + Duration::from_secs(10);
    while !board
        .since(start)
        .iter()
        .any(|l| l.contains("state OPERATING"))
    {
        if Instant::now() > end {
            return Err("the robot never became the device's peer".into());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(())
}

/// Stops QEMU and returns the whole log; an error if the firmware had
/// already stopped (panicked or exited) `when`.
pub fn finish(mut board: Qemu, when: &str) -> Result<Vec<String>, String> {
    let exited = board.exited();
    let log = board.stop();
    match exited {
        Some(status) => Err(format!("the firmware stopped {when} (QEMU {status})")),
        None => Ok(log),
    }
}

pub fn last_counters(log: &[String]) -> String {
    log.iter()
        .rev()
        .find_map(|l| l.split_once("] counters: ").map(|(_, c)| c.to_string()))
        .unwrap_or_default()
}

pub use host_tests::qemu_bench::{last_stack, MIN_STACK_MARGIN_PERCENT};

/// Waits (up to 10 s: under -icount the guest's second can be longer) for a
/// counter line newer than everything the bench did, then returns the last
/// stack figures: the stack line is logged just before the counter line,
/// and only when the mark grew.
pub fn wait_for_stack(board: &Qemu) -> Result<(u64, u64, u64), String> {
    DeviceCounters::fresh(board, board.lines(), Duration::from_secs(10))?;
    last_stack(&board.log()).ok_or_else(|| "the device logged no stack line".to_string())
}

pub fn records(lines: &[String]) -> Vec<Record> {
    lines.iter().filter_map(|l| Record::parse(l)).collect()
}

/// Sends `input` `repeat` times, one at a time, each with the next Id, and
/// returns the bench record the device logged for each. Fails when the
/// device answers an input it should reject or the other way round.
pub fn measure(
    board: &Qemu,
    socket: &UdpSocket,
    to: SocketAddr,
    input: &Input,
    repeat: u32,
    next_id: &mut u32,
) -> Result<Vec<Record>, String> {
    let mut got = Vec::new();
    for _ in 0..repeat {
        let before = board.lines();
        *next_id += 1;
        socket
            .send_to(&input.with_id(*next_id), to)
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
}
