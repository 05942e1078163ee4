//! `--corpus DIR`: the worst case on the user's own messages. Every file of
//! DIR (one robot message each, as `cargo robot -- --replay CAPTURE
//! --extract DIR` writes them from a cell's capture) goes to the bench
//! build for this GSI folder (`RRI_GSI_DIR`, else the manual's) under
//! `-icount`, `--repeat` times, with a fresh Id each time; per message the
//! compute and full-path instructions, and the costliest named.

use crate::run::{booted, corpus_socket, finish, measure};
use crate::{instructions, Args, CYCLE_AT_216MHZ, SHIFT};
use host_tests::qemu::{self, Boot};
use host_tests::qemu_bench::{templated, Input, Record};
use std::path::Path;

/// The hostile budget (a quarter of a cycle at 216 MHz): a message of
/// the user's that costs more is reported as over it.
const BUDGET: u64 = CYCLE_AT_216MHZ / 4;

/// The messages of `dir`, sorted by file name; the firmware's decoder
/// says which it takes (the device answers those).
/// Each with the decoder's refusal (if any) and the file's length.
fn inputs(dir: &Path) -> Result<Vec<(Input, Option<String>, usize)>, String> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(|e| format!("--corpus {}: {e}", dir.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(format!("--corpus {}: no files", dir.display()));
    }
    let mut out = Vec::new();
    for path in files {
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Ok(text) = String::from_utf8(bytes.clone()) else {
            return Err(format!(
                "{}: not UTF-8 (the decoder refuses it at once: nothing to measure); take it out of the corpus",
                path.display()
            ));
        };
        let refused = host_tests::replay::refused(&bytes);
        out.push((
            Input {
                name,
                text: templated(&text),
                accepted: refused.is_none(),
            },
            refused,
            bytes.len(),
        ));
    }
    Ok(out)
}

/// Measures every message of `dir`; `Ok(false)` when one costs more than
/// the hostile budget.
pub fn run(args: &Args, dir: &Path) -> Result<bool, String> {
    let inputs = inputs(dir)?;
    qemu::ensure_qemu(&mut std::io::stdout())?;
    let gsi = std::env::var_os("RRI_GSI_DIR")
        .filter(|g| !g.is_empty())
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| host_tests::workspace().join("firmware/gsi/GSI"));
    let device = gsi_config::load(&gsi, std::env::var("RRI_DEVICE").ok().as_deref())
        .map_err(|f| f.to_string())?
        .device;
    if device.channel.protocol != gsi_config::Protocol::Udp {
        return Err(format!(
            "--corpus measures over UDP; {} is configured for {:?} (build a UDP copy of the GSI folder to measure its messages)",
            device.name, device.channel.protocol
        ));
    }
    println!(
        "== building the bench firmware for {} ({}), {} messages from {}",
        device.name,
        gsi.display(),
        inputs.len(),
        dir.display()
    );
    let boot = Boot {
        elf: qemu::build_firmware(&["bench"], Some(&gsi), "bench-corpus")?,
        device,
        host_port: qemu::free_port()?,
        icount_shift: Some(SHIFT),
        http_port: None,
    };
    let (board, to) = booted(&boot)?;
    let socket = corpus_socket()?;
    let mut next_id = 1000;
    // The first datagram waits for ARP through slirp: not measured.
    if let Some((first, ..)) = inputs.iter().find(|(i, ..)| i.accepted) {
        measure(&board, &socket, to, first, 1, &mut next_id)?;
    }
    println!(
        "== your corpus, x{} each (instructions; full path = frame in to reply frame out)",
        args.repeat
    );
    // Issue 42 #9: what is sent is not byte for byte the file.
    println!(
        "   bytes: the file's, then as sent: each send carries a fresh Id written as 10 digits (Id=\"0000001001\"), so every send of a message is as long as the others and costs the same; a file's Id=\"7\" is 9 bytes shorter"
    );
    let mut worst: Option<(u64, String)> = None;
    for (input, refused, file_len) in &inputs {
        let got: Vec<Record> = measure(&board, &socket, to, input, args.repeat, &mut next_id)?;
        let max = |f: fn(&Record) -> u32| got.iter().map(|r| instructions(f(r))).max().unwrap_or(0);
        let (compute, full) = (max(|r| r.compute), max(|r| r.full));
        println!(
            "  {:<40} {:>6} B (sent {:>6} B)  {}  compute max {:>7}  full max {:>7}",
            input.name,
            file_len,
            input.len(),
            if input.accepted {
                "answered"
            } else {
                "refused "
            },
            compute,
            full
        );
        if let Some(why) = refused {
            println!("      {why}");
        }
        // A refused message has no reply frame (full 0): what it costs is
        // its compute, the decoding that refused it.
        let cost = if input.accepted { full } else { compute };
        if worst.as_ref().is_none_or(|(w, _)| cost > *w) {
            worst = Some((cost, input.name.clone()));
        }
    }
    finish(board, "during the corpus")?;
    let Some((full, name)) = worst else {
        return Ok(true);
    };
    println!(
        "  the costliest: {name}, {full} instructions ({:.0} µs @216 MHz, {:.0} % of the quarter-cycle budget of {BUDGET}; full path, or compute for a refused message)",
        full as f64 / 216.0,
        full as f64 * 100.0 / BUDGET as f64
    );
    if full > BUDGET {
        println!("FAIL: {name} costs more than the quarter-cycle budget");
        return Ok(false);
    }
    Ok(true)
}
