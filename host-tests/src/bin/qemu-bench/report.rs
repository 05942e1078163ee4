//! The bench's figures, in four steps: computed from what the two boots
//! measured ([`Figures::of`]), printed ([`print`]), written to
//! `target/qemu-bench/` ([`write_files`]) and gated on the baseline
//! ([`gate`]).

use crate::layers::{self, Split};
use crate::paths::{hostile_cost, hostile_counts, spreads};
use crate::run::MIN_STACK_MARGIN_PERCENT;
use crate::scraped::ScrapeFigures;

/// The hostile corpus's worst full path may take a quarter of a 4 ms
/// cycle at 216 MHz, one instruction a cycle (the README's target): the
/// rest of the cycle is the sensor's, the network's and flash wait
/// states'. Gated quiet and while the diagnostics are read.
const HOSTILE_BUDGET: u64 = 216_000;
use crate::{instructions, Args, Flooded, Measured, INSTRUCTIONS_PER_COUNT, SHIFT};
use host_tests::qemu;
use host_tests::qemu_bench::{Gated, Input, Record, Spread};
use serde_json::json;

/// Prints every figure, writes the summary, log and histogram files, and
/// returns whether the gated figures passed.
pub fn report(
    args: &Args,
    m: &Measured,
    floor: &[(Input, Vec<Record>)],
    fl: &Flooded,
) -> Result<bool, String> {
    let figures = Figures::of(m, floor, fl);
    print(args, m, fl, &figures);
    write_files(m, fl, &figures)?;
    gate(args, &figures)
}

/// What the report says, computed once from the two boots.
struct Figures {
    /// Instructions per cycle: message in to reply composed, and message
    /// in to reply sent (answered cycles only), over the simulator run
    /// and the realistic inputs.
    compute: Spread,
    full: Spread,
    /// Late as the device measures it (deterministic): a full path longer
    /// than one 4 ms cycle at 216 MHz. The simulator's own "late" is host
    /// wall-clock time through slirp, reported but not gated.
    late_device: u64,
    /// Replies lost, wrong or late in the deterministic run, wrong or
    /// malformed under the flood.
    missed: u64,
    /// Each hostile input's worst cost, in `m.hostile`'s order, and the
    /// worst of them.
    hostile: Vec<u64>,
    hostile_max: u64,
    /// Each hostile input's worst row, per layer.
    hostile_split: Vec<Split>,
    /// Answered rows whose per-layer counts cannot be right
    /// ([`layers::misfits`]).
    misfits: usize,
    /// The in-guest codec's cost on the manual's message.
    baseline_median: u64,
    /// Stack: start-up, running, budget (bytes) and the margin left (%).
    stack: (u64, u64, u64),
    stack_margin: u64,
    /// The floor build's full path per input (name, bytes, median, max),
    /// realistic inputs first, and its max over the realistic ones.
    floor: Vec<(String, usize, u64, u64)>,
    floor_max: u64,
    /// The floor's longest full span per input, per layer.
    floor_split: Vec<Split>,
    /// The scrape run: the same figures while the diagnostics were read.
    scraped: Option<ScrapeFigures>,
    /// The upload run: the same figures while an update arrived.
    uploaded: Option<ScrapeFigures>,
}

impl Figures {
    fn of(m: &Measured, floor: &[(Input, Vec<Record>)], fl: &Flooded) -> Self {
        let (compute, full, late_device) = spreads(&m.sim_records, &m.realistic);
        let f = &fl.driven.summary;
        // Gated: the deterministic run. Under the flood (real time) a wrong
        // or malformed reply fails too, and so does a robot message lost in
        // the firmware (reassembly, socket queue, engine: S5); the ones
        // that never reached it whole are reported, not gated: they depend
        // on how QEMU is scheduled on the host.
        let in_firmware = fl.split.map_or(0, |s| s.reassembly + s.engine);
        let missed = m.summary.lost
            + m.summary.wrong_id
            + m.summary.malformed
            + late_device
            + f.wrong_id
            + f.malformed
            + in_firmware;
        let hostile: Vec<u64> = m.hostile.iter().map(|(_, r)| hostile_cost(r)).collect();
        let hostile_max = hostile.iter().copied().max().unwrap_or(0);
        let split = |rows: &[Record], cost: &dyn Fn(&Record) -> u32| {
            layers::worst(rows, cost).map(Split::of).unwrap_or_default()
        };
        let hostile_split = m
            .hostile
            .iter()
            .map(|(_, rows)| split(rows, &|r| hostile_counts(r)))
            .collect();
        let floor_split = floor
            .iter()
            .map(|(_, rows)| split(rows, &|r| r.full))
            .collect();
        let inputs = [&m.realistic, &m.hostile, floor].into_iter().flatten();
        let misfits = layers::misfits(
            m.sim_records
                .iter()
                .chain(inputs.flat_map(|(_, rows)| rows.iter())),
        );
        let baseline_median = m
            .codec
            .iter()
            .find(|c| c.0 == "manual")
            .map(|c| u64::from(c.4) * INSTRUCTIONS_PER_COUNT)
            .unwrap_or(0);
        let (stack_boot, stack_running, stack_size) = m.stack;
        let stack_used = stack_boot.max(stack_running);
        let stack_margin = (stack_size - stack_used.min(stack_size)) * 100 / stack_size.max(1);
        let floor: Vec<(String, usize, u64, u64)> = floor
            .iter()
            .map(|(input, rows)| {
                let s = Spread::of(rows.iter().map(|r| instructions(r.full)).collect());
                (input.name.clone(), input.len(), s.median, s.max)
            })
            .collect();
        let floor_max = floor
            .iter()
            .take(m.realistic.len())
            .map(|f| f.3)
            .max()
            .unwrap_or(0);
        let scraped = m
            .scraped
            .as_ref()
            .map(|(p, scraper)| ScrapeFigures::of("scrape run", p, scraper, full.max));
        let uploaded = m
            .uploaded
            .as_ref()
            .map(|(p, got)| ScrapeFigures::of("upload run", p, got, full.max));
        Figures {
            compute,
            full,
            late_device,
            missed,
            hostile,
            hostile_max,
            hostile_split,
            misfits,
            floor_split,
            baseline_median,
            stack: m.stack,
            stack_margin,
            floor,
            floor_max,
            scraped,
            uploaded,
        }
    }

    /// The figures the baseline file holds.
    fn gated(&self) -> Gated {
        Gated {
            compute_median: self.compute.median,
            compute_max: self.compute.max,
            full_median: self.full.median,
            hostile_max: self.hostile_max,
        }
    }
}

/// Every figure, on stdout.
fn print(args: &Args, m: &Measured, fl: &Flooded, x: &Figures) {
    let f = &fl.driven.summary;
    println!("\n== codec on Thumb-2, instructions per message (decode + encode; in-guest, interrupts masked)");
    println!(
        "  {:<8} {:>6} {:>10} {:>16} {:>18} {:>8}",
        "message", "bytes", "ours", "xmlparser alone", "naive baseline", "ratio"
    );
    for (name, bytes, ours, tok, base) in &m.codec {
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
    if let Some((bytes, alike, unlike)) = m.copy {
        let i = |c: u32| u64::from(c) * INSTRUCTIONS_PER_COUNT;
        println!(
            "  memcpy of {bytes} B (every layer's copies): {} instructions with both ends aligned alike, {} unlike ({:.1}×)",
            i(alike),
            i(unlike),
            i(unlike) as f64 / i(alike).max(1) as f64
        );
    }
    println!("\n== realistic: simulator ({} cycles, the first one warm-up) + manual, IRC5 capture, maximum values ×{}", m.sim_records.len(), args.repeat);
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
    row("compute", &x.compute);
    row("full", &x.full);
    for (input, rows) in &m.realistic {
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
        m.summary.sent, m.summary.answered, m.summary.lost, m.summary.wrong_id, m.summary.malformed, x.late_device, m.summary.late,
    );
    println!("  device: {}", m.counters);
    crate::held::Held::of(
        m.sim_records
            .iter()
            .chain(m.realistic.iter().flat_map(|(_, rows)| rows.iter())),
    )
    .print();
    println!(
        "\n== the floor: the same inputs to a build that answers with a fixed reply and decodes nothing (driver + smoltcp + executor), full path"
    );
    for (name, bytes, median, max) in &x.floor {
        println!("  {name:<32} {bytes:>5} B  floor median {median:>7}  max {max:>7}");
    }
    let named = |splits: &[Split], names: &mut dyn Iterator<Item = &str>| -> Vec<(String, Split)> {
        names
            .map(String::from)
            .zip(splits.iter().copied())
            .collect()
    };
    let floor_rows = named(&x.floor_split, &mut x.floor.iter().map(|f| f.0.as_str()));
    layers::print(
        "the floor per layer, its longest full span per input: the completing frame's driver, fragment guard and smoltcp shares, the reply sent (compute), the rest (executor, socket copy, reply out); before the span: that frame read from the NIC, the earlier fragments",
        &floor_rows,
    );
    println!(
        "  realistic full path: max {} over a floor of {} (the cycle's own work {}, {:.2}× the floor)",
        x.full.max,
        x.floor_max,
        x.full.max.saturating_sub(x.floor_max),
        x.full.max as f64 / x.floor_max.max(1) as f64
    );
    println!(
        "\n== under the flood (real time, {} flood datagrams sent)\n  robot: sent {} answered {} lost {} wrong Id {} malformed {}; late (host wall clock through slirp) {}; latency µs median {} p99 {} max {}",
        fl.driven.flood_sent, f.sent, f.answered, f.lost, f.wrong_id, f.malformed, f.late,
        f.latency_us.median, f.latency_us.p99, f.latency_us.max
    );
    println!("  device: {}", fl.counters);
    if let Some(split) = &fl.split {
        println!("  robot messages {}", split.line());
    }
    println!(
        "\n== hostile: every input {} bytes (MAX_RECEIVE_LEN), ×{} each",
        host_tests::layouts::anydevice::MAX_RECEIVE_LEN,
        args.repeat
    );
    for ((input, _), worst) in m.hostile.iter().zip(&x.hostile) {
        println!(
            "  {:<28} {:<9} worst {:>8} instructions = {:>5.1} per byte",
            input.name,
            if input.accepted {
                "answered"
            } else {
                "rejected"
            },
            worst,
            *worst as f64 / input.len() as f64
        );
    }
    println!(
        "  worst {} instructions ({:.0} µs @216 MHz; budget {HOSTILE_BUDGET} = a quarter cycle)",
        x.hostile_max,
        x.hostile_max as f64 / 216.0
    );
    let hostile_rows = named(
        &x.hostile_split,
        &mut m.hostile.iter().map(|(i, _)| i.name.as_str()),
    );
    layers::print(
        "the hostile inputs per layer, each one's worst row (a rejected input has no full span)",
        &hostile_rows,
    );
    for sc in x.scraped.iter().chain(&x.uploaded) {
        sc.print(
            (x.compute.max, x.compute.median),
            (x.full.max, x.full.median),
            x.hostile_max,
        );
    }
    let (stack_boot, stack_running, stack_size) = x.stack;
    println!(
        "\n== stack (painted; thread mode and every interrupt share the one main stack)\n  start-up {stack_boot} bytes (building the network stack), running {stack_running} bytes (after the bench and the hostile inputs), of a {stack_size}-byte budget: {}% margin (fails under {MIN_STACK_MARGIN_PERCENT}%)",
        x.stack_margin
    );
    println!("\nQEMU counts instructions, not cycles: no caches, flash wait states, bus contention or Ethernet DMA are modelled; µs figures assume one instruction per cycle.");
}

/// `summary.json`, both device logs and `histogram.svg` under
/// `target/qemu-bench/`.
fn write_files(m: &Measured, fl: &Flooded, x: &Figures) -> Result<(), String> {
    let f = &fl.driven.summary;
    let dir = qemu::target_dir().join("qemu-bench");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let hostile_json: Vec<_> = m
        .hostile
        .iter()
        .zip(x.hostile.iter().zip(&x.hostile_split))
        .map(|((input, _), (worst, split))| json!({"name": input.name, "bytes": input.len(), "answered": input.accepted, "worst": worst, "per_byte": *worst as f64 / input.len() as f64, "layers": split.json()}))
        .collect();
    let (stack_boot, stack_running, stack_size) = x.stack;
    let summary_json = json!({
        "shift": SHIFT,
        "cycles": m.summary.sent,
        "missed": x.missed,
        "late": x.late_device,
        "late_host_wall_clock": m.summary.late,
        "lost": m.summary.lost,
        "compute": x.compute,
        "full": x.full,
        "hostile_max": x.hostile_max,
        "hostile": hostile_json,
        "floor": x.floor.iter().zip(&x.floor_split).map(|((n, b, med, max), split)| json!({"name": n, "bytes": b, "median": med, "max": max, "layers": split.json()})).collect::<Vec<_>>(),
        "floor_realistic_max": x.floor_max,
        "scraped": x.scraped.as_ref().map(|sc| json!({"compute": sc.compute, "full": sc.full,
                        "hostile_max": sc.hostile_max, "full_over_5_percent": sc.full_over, "missed": sc.missed, "scraper": sc.scraper})),
        "uploaded": x.uploaded.as_ref().map(|sc| json!({"compute": sc.compute, "full": sc.full,
            "hostile_max": sc.hostile_max, "full_over_5_percent": sc.full_over, "missed": sc.missed, "uploader": sc.scraper})),
        "stack": {"boot": stack_boot, "running": stack_running, "budget": stack_size, "margin_percent": x.stack_margin},
        "baseline_compute_median": x.baseline_median,
        "memcpy": m.copy.map(|(bytes, alike, unlike)| json!({"bytes": bytes,
            "alike": u64::from(alike) * INSTRUCTIONS_PER_COUNT, "unlike": u64::from(unlike) * INSTRUCTIONS_PER_COUNT})),
        "codec": m.codec.iter().map(|(n, b, o, t, base)| json!({"message": n, "bytes": b,
            "ours": u64::from(*o) * INSTRUCTIONS_PER_COUNT, "tokenizer": u64::from(*t) * INSTRUCTIONS_PER_COUNT,
            "baseline": u64::from(*base) * INSTRUCTIONS_PER_COUNT})).collect::<Vec<_>>(),
        "flood": {"sent": fl.driven.flood_sent, "robot_sent": f.sent, "answered": f.answered,
            "lost": f.lost, "late_host_wall_clock": f.late,
            "lost_where": fl.split.map(|s| json!({"nic": s.nic, "reassembly": s.reassembly,
                "engine": s.engine, "way_back": s.way_back}))},
    });
    let _ = std::fs::write(dir.join("device.log"), m.log.join("\n") + "\n");
    let _ = std::fs::write(dir.join("device-flood.log"), fl.log.join("\n") + "\n");
    let path = dir.join("summary.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&summary_json).map_err(|e| e.to_string())?,
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let svg = dir.join("histogram.svg");
    host_tests::qemu_bench::histogram(
        &svg,
        &m.sim_records
            .iter()
            .map(|r| instructions(r.compute))
            .collect::<Vec<_>>(),
        &m.sim_records
            .iter()
            .filter(|r| r.answered)
            .map(|r| instructions(r.full))
            .collect::<Vec<_>>(),
    )?;
    println!("\nwrote {} and {}", path.display(), svg.display());
    Ok(())
}

/// Updates the baseline file when asked, then fails on missed replies, a
/// thin stack margin or a gated figure more than 5 % over the baseline.
fn gate(args: &Args, x: &Figures) -> Result<bool, String> {
    let gated = x.gated();
    let baseline_path = host_tests::workspace().join(&args.baseline);
    if args.update_baseline {
        std::fs::write(
            &baseline_path,
            serde_json::to_string_pretty(&gated).map_err(|e| e.to_string())? + "\n",
        )
        .map_err(|e| format!("{}: {e}", baseline_path.display()))?;
        println!("baseline updated: {}", baseline_path.display());
    }
    let mut ok = true;
    if x.missed > 0 {
        println!("FAIL: {} replies missed, late or wrong", x.missed);
        ok = false;
    }
    if x.misfits > 0 {
        println!(
            "FAIL: {} answered messages' per-layer counts saw no frame or add up past their full span",
            x.misfits
        );
        ok = false;
    }
    if x.stack_margin < MIN_STACK_MARGIN_PERCENT {
        println!(
            "FAIL: stack margin {}% is under {MIN_STACK_MARGIN_PERCENT}%",
            x.stack_margin
        );
        ok = false;
    }
    // The hostile budget, with and without a client on the diagnostics.
    let scraped_hostile = x.scraped.as_ref().map(|sc| sc.hostile_max);
    let uploaded_hostile = x.uploaded.as_ref().map(|sc| sc.hostile_max);
    for (run, worst) in [
        ("", Some(x.hostile_max)),
        ("scrape run: ", scraped_hostile),
        ("upload run: ", uploaded_hostile),
    ] {
        if let Some(worst) = worst.filter(|&w| w > HOSTILE_BUDGET) {
            println!("FAIL: {run}hostile worst {worst} is over the budget of {HOSTILE_BUDGET} instructions");
            ok = false;
        }
    }
    for sc in x.scraped.iter().chain(&x.uploaded) {
        ok &= sc.gate(x.compute.max, x.full.max, x.hostile_max);
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
