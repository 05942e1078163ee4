//! `cargo codec-bench -- <robot-message.xml> <N> [--callgrind]`
//!
//! Decodes a robot message and encodes a reply N times with the manual
//! example's layout (AnyDevice), and in the same run does the same work
//! with a naive baseline (xmlparser + `write!` with `{:.3}` into a
//! `heapless::String`), printing both and the ratio. A counting global
//! allocator proves that our path makes no heap allocation.
//!
//! Time on a shared machine is noisy; the figure that counts is
//! instructions per message under callgrind, which is deterministic:
//! `--callgrind` re-runs this binary under `valgrind --tool=callgrind` for
//! N=1000 and N=2000 and prints (Ir(2000) − Ir(1000)) / 1000 for each path.
//!
//! `cargo codec-bench -- --hostile` measures the hostile corpus of the
//! QEMU bench (every input `MAX_RECEIVE_LEN` bytes, accepted or rejected)
//! the same way, decode only, and prints instructions per message and per
//! byte beside the manual's message. `--hostile --keep DIR` writes the
//! inputs to DIR (`0.xml`, `1.xml`, … in the table's order) and keeps them,
//! for a per-function look: `valgrind --tool=callgrind <this binary>
//! DIR/5.xml 100 --only decode-any`, then `callgrind_annotate`.

use host_tests::layouts::anydevice::{self as layout, RobDataMessage, SensDataMessage};
use rri_firmware::baseline::{self, Naive};
use rri_firmware::codec::{decode, decode_general, encode};
use rri_firmware::schema::MessageCodec;
use rri_firmware::value::Time;
use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::process::{Command, ExitCode};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Counts every allocation, so the bench can prove ours makes none.
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Our path: the firmware's codec, buffers sized by the generated maxima.
fn ours(bytes: &[u8], n: u64) -> Result<usize, String> {
    let mut robot = layout::RobotData::default();
    let mut reply = layout::SensorData::default();
    let _ = reply.error_string.push_str("ok");
    let mut buf = [0u8; layout::MAX_SEND_LEN];
    let mut total = 0;
    for _ in 0..n {
        let d = decode::<RobDataMessage>(black_box(bytes), &mut robot)
            .map_err(|e| format!("our decoder rejected the message: {e:?}"))?;
        reply.application_data = robot.application_data;
        let ts = d.ts.unwrap_or(Time::ZERO);
        let out = encode::<SensDataMessage>(&reply, d.id, ts, layout::FORMAT, &mut buf)
            .map_err(|_| "reply larger than MAX_SEND_LEN".to_string())?;
        total += black_box(&buf[..out.len]).len();
    }
    Ok(total)
}

/// Our path with the general decoder only (xmlparser; what every message
/// cost before the compiled path, and what a message the compiled path
/// hands over costs on top of it).
fn general(bytes: &[u8], n: u64) -> Result<usize, String> {
    let mut robot = layout::RobotData::default();
    let reply = layout::SensorData::default();
    let mut buf = [0u8; layout::MAX_SEND_LEN];
    let mut total = 0;
    for _ in 0..n {
        let d = decode_general::<RobDataMessage>(black_box(bytes), &mut robot)
            .map_err(|e| format!("the general decoder rejected the message: {e:?}"))?;
        let out = encode::<SensDataMessage>(&reply, d.id, Time::ZERO, layout::FORMAT, &mut buf)
            .map_err(|_| "reply larger than MAX_SEND_LEN".to_string())?;
        total += black_box(&buf[..out.len]).len();
    }
    Ok(total)
}

/// One half of our path, for the breakdown: `decode` or `encode` only.
fn ours_half(bytes: &[u8], n: u64, encode_only: bool) -> Result<usize, String> {
    let mut robot = layout::RobotData::default();
    let mut reply = layout::SensorData::default();
    let _ = reply.error_string.push_str("ok");
    let mut buf = [0u8; layout::MAX_SEND_LEN];
    let d = decode::<RobDataMessage>(bytes, &mut robot).map_err(|e| format!("{e:?}"))?;
    reply.application_data = robot.application_data;
    let mut total = 0;
    for _ in 0..n {
        if encode_only {
            let out = encode::<SensDataMessage>(
                black_box(&reply),
                d.id,
                Time::ZERO,
                layout::FORMAT,
                &mut buf,
            )
            .map_err(|_| "reply larger than MAX_SEND_LEN".to_string())?;
            total += black_box(&buf[..out.len]).len();
        } else {
            let d = decode::<RobDataMessage>(black_box(bytes), &mut robot)
                .map_err(|e| format!("{e:?}"))?;
            total += black_box(d.id) as usize;
        }
    }
    Ok(total)
}

/// Decodes `bytes` N times whatever the outcome (hostile inputs may be
/// rejected: their cost counts all the same).
fn decode_any(bytes: &[u8], n: u64) -> Result<usize, String> {
    let mut robot = layout::RobotData::default();
    let mut total = 0;
    for _ in 0..n {
        total += usize::from(decode::<RobDataMessage>(black_box(bytes), &mut robot).is_ok());
    }
    Ok(total)
}

/// `--hostile`: decode cost of each hostile input and of the manual's
/// message under callgrind; the inputs are kept in `keep` when given.
fn hostile(manual: &str, keep: Option<&str>) -> ExitCode {
    let inputs = host_tests::qemu_bench::hostile();
    let dir = match keep {
        Some(d) => std::path::PathBuf::from(d),
        None => std::env::temp_dir().join(format!("codec-bench-hostile-{}", std::process::id())),
    };
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let mut files = vec![(
        "manual RobData (reference)".to_string(),
        manual.to_string(),
        true,
    )];
    let all = inputs
        .iter()
        .map(|i| (i.name.clone(), i.with_id(1_234_567_890), i.accepted));
    for (i, (name, bytes, accepted)) in all.enumerate() {
        let path = dir.join(format!("{i}.xml"));
        if let Err(e) = std::fs::write(&path, bytes) {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
        files.push((name, path.display().to_string(), accepted));
    }
    println!("decode cost per message under callgrind ((Ir(N=200) - Ir(N=100)) / 100), layout AnyDevice:");
    println!(
        "  {:<34} {:>6} {:>10} {:>8}  outcome",
        "input", "bytes", "Ir/msg", "Ir/byte"
    );
    let mut reference = None;
    let mut worst = (0.0f64, String::new());
    for (name, file, accepted) in &files {
        let bytes = std::fs::read(file).unwrap_or_default();
        let outcome = {
            let mut robot = layout::RobotData::default();
            match decode::<RobDataMessage>(&bytes, &mut robot) {
                Ok(_) => "accepted".to_string(),
                Err(e) => format!("rejected: {:?} at byte {}", e.kind, e.offset),
            }
        };
        if outcome.starts_with("accepted") != *accepted {
            eprintln!(
                "error: {name}: expected {}, got {outcome}",
                if *accepted { "accepted" } else { "rejected" }
            );
            return ExitCode::FAILURE;
        }
        let ir = callgrind_ir(file, 100, "decode-any")
            .and_then(|a| Ok((a, callgrind_ir(file, 200, "decode-any")?)));
        let (a, b) = match ir {
            Ok(v) => v,
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::FAILURE;
            }
        };
        let per = b.saturating_sub(a) / 100;
        let per_byte = per as f64 / bytes.len().max(1) as f64;
        println!(
            "  {name:<34} {:>6} {per:>10} {per_byte:>8.1}  {outcome}",
            bytes.len()
        );
        match reference {
            None => reference = Some(per_byte),
            Some(_) if per_byte > worst.0 => worst = (per_byte, name.clone()),
            Some(_) => {}
        }
    }
    if keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    if let Some(r) = reference {
        println!(
            "  worst per byte: {:.1} ({}), {:.2}x the manual's message ({r:.1})",
            worst.0,
            worst.1,
            worst.0 / r.max(1e-9)
        );
    }
    ExitCode::SUCCESS
}

/// The floor under any decoder built on xmlparser: tokenizing the message
/// and nothing else.
fn tokenizer_only(bytes: &[u8], n: u64) -> Result<usize, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| e.to_string())?;
    let mut total = 0;
    for _ in 0..n {
        total += baseline::tokenize(black_box(text)).ok_or("xmlparser rejected the message")?;
    }
    Ok(total)
}

fn baseline(bytes: &[u8], n: u64) -> Result<usize, String> {
    let mut robot = Naive::default();
    let mut out = heapless::String::<2048>::new();
    let mut total = 0;
    for _ in 0..n {
        let text = std::str::from_utf8(black_box(bytes)).map_err(|e| e.to_string())?;
        total += baseline::cycle(text, &mut robot, &mut out)
            .ok_or("the baseline could not decode the message or its reply is too long")?;
        black_box(out.as_bytes());
    }
    Ok(total)
}

/// Instructions of one run of this binary under callgrind.
fn callgrind_ir(file: &str, n: u64, only: &str) -> Result<u64, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let out = Command::new("valgrind")
        .args(["--tool=callgrind", "--callgrind-out-file=/dev/null"])
        .arg(&exe)
        .args([file, &n.to_string(), "--only", only])
        .output()
        .map_err(|e| format!("cannot run valgrind ({e}); install it: apt-get install valgrind"))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("callgrind run failed:\n{stderr}"));
    }
    stderr
        .lines()
        .find_map(|l| l.split("Collected :").nth(1))
        .and_then(|v| v.trim().parse().ok())
        .ok_or_else(|| format!("no `Collected` line in callgrind output:\n{stderr}"))
}

fn usage() -> ExitCode {
    eprintln!("usage: cargo codec-bench -- <robot-message.xml> <N> [--callgrind] [--only ours|baseline|tokenizer|decode|encode|decode-any|general]");
    eprintln!("       cargo codec-bench -- --hostile   (the hostile corpus under callgrind)");
    eprintln!("       cargo codec-bench -- --hostile --keep DIR   (and keep its inputs in DIR)");
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--hostile") {
        let manual = host_tests::shared_rri().join("examples/messages/RobData.xml");
        let keep = match args.get(1).map(String::as_str) {
            Some("--keep") => match args.get(2) {
                Some(dir) => Some(dir.as_str()),
                None => return usage(),
            },
            Some(_) => return usage(),
            None => None,
        };
        return hostile(&manual.display().to_string(), keep);
    }
    let (Some(file), Some(n)) = (
        args.first(),
        args.get(1).and_then(|n| n.parse::<u64>().ok()),
    ) else {
        return usage();
    };
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1));
    let bytes = match std::fs::read(file) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("cannot read {file}: {e}");
            return ExitCode::from(2);
        }
    };

    // Under callgrind: run one path only, nothing else.
    if let Some(which) = only {
        let r = match which.as_str() {
            "ours" => ours(&bytes, n),
            "baseline" => baseline(&bytes, n),
            "tokenizer" => tokenizer_only(&bytes, n),
            "decode" => ours_half(&bytes, n, false),
            "encode" => ours_half(&bytes, n, true),
            "decode-any" => decode_any(&bytes, n),
            "general" => general(&bytes, n),
            _ => return usage(),
        };
        return match r {
            Ok(_) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("{e}");
                ExitCode::FAILURE
            }
        };
    }

    if args.iter().any(|a| a == "--callgrind") {
        // Which decode path the message takes: the compiled one, or the
        // general one after the compiled one handed it over.
        let compiled =
            RobDataMessage::decode_compiled(&bytes, &mut layout::RobotData::default()).is_some();
        println!(
            "instructions per message (callgrind, (Ir(N=2000) - Ir(N=1000)) / 1000), {file} ({}):",
            if compiled {
                "the compiled path takes it"
            } else {
                "handed over to the general path"
            }
        );
        let mut per = Vec::new();
        for which in [
            "ours",
            "baseline",
            "tokenizer",
            "decode",
            "encode",
            "general",
        ] {
            let ir = callgrind_ir(file, 1000, which)
                .and_then(|a| Ok((a, callgrind_ir(file, 2000, which)?)));
            match ir {
                Ok((a, b)) => {
                    let p = b.saturating_sub(a) / 1000;
                    let what = match which {
                        "ours" => "ours (decode + encode)",
                        "baseline" => "baseline (xmlparser + write! {:.3})",
                        "tokenizer" => "  xmlparser alone (tokenizing, nothing else)",
                        "decode" => "  ours, decode only",
                        "encode" => "  ours, encode only",
                        _ => "  ours with the general decoder only (decode + encode)",
                    };
                    println!("  {p:>8} Ir/message  {what}");
                    per.push(p);
                }
                Err(e) => {
                    eprintln!("{e}");
                    return ExitCode::FAILURE;
                }
            }
        }
        if let [o, b, t, _, _, g] = per[..] {
            println!(
                "  {:>8.2}x    fewer instructions than the baseline",
                b as f64 / o.max(1) as f64
            );
            // The targets, printed, not asserted: at most 0.5x
            // xmlparser alone where the compiled path takes the message,
            // at most 2.0x where it hands it over. Three decimals, so 0.504
            // does not read as 0.50.
            let (limit, name) = if compiled {
                (50, "0.5x")
            } else {
                (200, "2.0x")
            };
            let target = t * limit / 100;
            println!(
                "  {:>8.3}x    xmlparser alone ({name} is {target} Ir, {}); the general decoder alone {:.3}x",
                o as f64 / t.max(1) as f64,
                if o <= target {
                    "met".to_string()
                } else {
                    format!("{} over", o - target)
                },
                g as f64 / t.max(1) as f64,
            );
        }
        return ExitCode::SUCCESS;
    }

    // Warm up, then time both paths in the same run.
    if let Err(e) = ours(&bytes, n.min(100)).and_then(|_| baseline(&bytes, n.min(100))) {
        eprintln!("{e}");
        return ExitCode::FAILURE;
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let t0 = Instant::now();
    let ours_bytes = match ours(&bytes, n) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let ours_time = t0.elapsed();
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    let t1 = Instant::now();
    let base_bytes = match baseline(&bytes, n) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let base_time = t1.elapsed();

    let per = |d: std::time::Duration| d.as_nanos() as f64 / n as f64;
    println!("codec bench: {file}, N = {n}, layout AnyDevice (manual example)");
    println!(
        "  ours      {:>9.0} ns/message  (decode + encode, reply {} bytes)",
        per(ours_time),
        ours_bytes / n.max(1) as usize
    );
    println!(
        "  baseline  {:>9.0} ns/message  (xmlparser + write! {{:.3}}, reply {} bytes)",
        per(base_time),
        base_bytes / n.max(1) as usize
    );
    println!(
        "  ratio     {:>9.2}x faster than the baseline",
        per(base_time) / per(ours_time).max(1e-9)
    );
    println!("  heap allocations on our path: {allocations}");
    if allocations != 0 {
        eprintln!("error: our path allocated {allocations} times");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
