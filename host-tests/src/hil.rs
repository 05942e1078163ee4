//! `cargo hil`'s parts that are not the command line: the boards it runs
//! on, the device's own figures read from its log (the bench records'
//! per-message cycle counts, the in-guest codec comparison, the stack),
//! and the HardFault check of `--fault`.

use crate::device::Device;
use crate::qemu_bench::{
    last_stack, parse_codec, stack_margin_percent, Record, Spread, MIN_STACK_MARGIN_PERCENT,
};
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

/// A board `cargo hil` runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HilBoard {
    /// `--board` value.
    pub key: &'static str,
    /// The hal-board feature.
    pub feature: &'static str,
    /// probe-rs's chip name, for a real board.
    pub chip: Option<&'static str>,
    /// The rehosting engine's board (`cargo rehost -- --board`), for the
    /// image run on the model of its chip. Neither this nor `chip`: the
    /// QEMU board.
    pub rehosted: Option<&'static str>,
    /// The board's name in [`crate::boards::BOARDS`] (its memory map and
    /// placement rules), for the real boards.
    pub map: Option<&'static str>,
    /// What `board::cycle_counter` counts, per second.
    pub counter_hz: u64,
    /// What one count is, for the report.
    pub counter: &'static str,
}

/// The boards: QEMU's, tested in CI, and the two NUCLEOs.
pub const HIL_BOARDS: [HilBoard; 5] = [
    HilBoard {
        key: "qemu",
        feature: "hal-board/mps2-an500",
        chip: None,
        rehosted: None,
        map: None,
        counter_hz: 25_000_000,
        counter: "counts of QEMU's 25 MHz timer in real time: how fast this host emulates the board, not an MCU's figures",
    },
    HilBoard {
        key: "f767",
        feature: "hal-board/nucleo-f767zi",
        chip: Some("STM32F767ZITx"),
        rehosted: None,
        map: Some("nucleo-f767zi"),
        counter_hz: 216_000_000,
        counter: "DWT core cycles at 216 MHz",
    },
    HilBoard {
        key: "h743",
        feature: "hal-board/nucleo-h743zi",
        chip: Some("STM32H743ZITx"),
        rehosted: None,
        map: Some("nucleo-h743zi"),
        counter_hz: 400_000_000,
        counter: "DWT core cycles at 400 MHz",
    },
    HilBoard {
        key: "f767-rehosted",
        feature: "hal-board/nucleo-f767zi",
        chip: None,
        rehosted: Some("f767"),
        map: Some("nucleo-f767zi"),
        counter_hz: 216_000_000,
        counter: "DWT cycles of the model of the chip (one instruction a cycle; no cache, flash or bus timing): not the board's",
    },
    HilBoard {
        key: "h743-rehosted",
        feature: "hal-board/nucleo-h743zi",
        chip: None,
        rehosted: Some("h743"),
        map: Some("nucleo-h743zi"),
        counter_hz: 400_000_000,
        counter: "DWT cycles of the model of the chip (one instruction a cycle; no cache, flash or bus timing): not the board's",
    },
];

impl HilBoard {
    /// QEMU's board (neither a probe's chip nor a rehosted image).
    pub fn is_qemu(&self) -> bool {
        self.chip.is_none() && self.rehosted.is_none()
    }
}

/// The board with `--board` value `key`.
pub fn board(key: &str) -> Option<&'static HilBoard> {
    HIL_BOARDS.iter().find(|b| b.key == key)
}

/// Checks a real board's image against its memory map and placement rules
/// (as `cargo boards` does, without the budgets: the bench build is
/// larger than the product).
pub fn check_image(board: &HilBoard, elf: &Path) -> Result<(), String> {
    let Some(name) = board.map else {
        return Ok(());
    };
    let b = crate::boards::BOARDS
        .iter()
        .find(|b| b.name == name)
        .ok_or_else(|| format!("{name} is not in boards::BOARDS"))?;
    let map_path = crate::workspace().join(b.memory_map);
    let map =
        std::fs::read_to_string(&map_path).map_err(|e| format!("{}: {e}", map_path.display()))?;
    let regions = crate::memory_map::regions(&map)?;
    crate::memory_map::check_memory_map(&crate::memory_map::sections(elf)?, &regions)?;
    let rules = crate::board_map::placement(name).ok_or("no placement rules")?;
    crate::board_map::check(rules, &crate::board_map::Image::read(elf)?)
        .map_err(|e| format!("{name}: memory placement:\n  {e}"))
}

/// What the device itself measured, from its log.
#[derive(Clone, Debug, Default)]
pub struct DeviceFigures {
    /// Every bench record (one per robot message the engine handled).
    pub records: Vec<Record>,
    /// Compute (decode + application + encode) and full path (frame in to
    /// reply frame out) of the answered messages, in counts.
    pub compute: Spread,
    pub full: Spread,
    /// In-guest codec comparison at boot: (message, bytes, ours,
    /// tokenizer, baseline) counts per message.
    pub codec: Vec<(String, u32, u32, u32, u32)>,
    /// (start-up, running, budget) bytes.
    pub stack: Option<(u64, u64, u64)>,
    /// Messages the device says it answered (its last counter line).
    pub answered: Option<u64>,
}

impl DeviceFigures {
    /// The figures in a device's whole log.
    pub fn of(log: &[String]) -> DeviceFigures {
        let records: Vec<Record> = log.iter().filter_map(|l| Record::parse(l)).collect();
        let answered: Vec<&Record> = records
            .iter()
            .filter(|r| r.answered && r.full > 0)
            .collect();
        DeviceFigures {
            compute: Spread::of(answered.iter().map(|r| u64::from(r.compute)).collect()),
            full: Spread::of(answered.iter().map(|r| u64::from(r.full)).collect()),
            codec: log.iter().filter_map(|l| parse_codec(l)).collect(),
            stack: last_stack(log),
            answered: log
                .iter()
                .rev()
                .find_map(|l| crate::counters::DeviceCounters::parse(l))
                .map(|c| c.answered),
            records,
        }
    }

    /// Prints the figures; `Err` when the stack margin is under
    /// [`MIN_STACK_MARGIN_PERCENT`] or there is no stack figure at all.
    pub fn print(&self, board: &HilBoard, out: &mut dyn Write) -> Result<(), String> {
        let us = |counts: u64| counts as f64 * 1e6 / board.counter_hz as f64;
        let row = |name: &str, s: &Spread| {
            format!(
                "  {name:<42} min {:>9} median {:>9} p99 {:>9} max {:>9}  (max {:.1} µs)",
                s.min,
                s.median,
                s.p99,
                s.max,
                us(s.max)
            )
        };
        let _ = writeln!(out, "\n== the device's own figures ({})", board.counter);
        let answered_records = self.records.iter().filter(|r| r.answered).count();
        let _ = writeln!(
            out,
            "  bench records: {} ({} answered); the device counted {} answered{}",
            self.records.len(),
            answered_records,
            self.answered.map_or("?".into(), |a| a.to_string()),
            match self.answered {
                Some(a) if a > answered_records as u64 => format!(
                    " ({} answered messages have no record: see the README's `cargo hil`)",
                    a - answered_records as u64
                ),
                _ => String::new(),
            }
        );
        let _ = writeln!(
            out,
            "{}",
            row("compute (decode + application + encode)", &self.compute)
        );
        let _ = writeln!(
            out,
            "{}",
            row("full path (frame in -> reply frame out)", &self.full)
        );
        for (name, bytes, ours, tokenizer, baseline) in &self.codec {
            let _ = writeln!(
                out,
                "  codec at boot, {name} ({bytes} B), per message: ours {ours}, xmlparser alone {tokenizer}, naive baseline {baseline}"
            );
        }
        let Some(stack) = self.stack else {
            return Err("the device logged no stack line".into());
        };
        let margin = stack_margin_percent(stack);
        let _ = writeln!(
            out,
            "  stack: start-up {} bytes, running {} bytes, of {}: {margin}% margin (fails under {MIN_STACK_MARGIN_PERCENT}%)",
            stack.0, stack.1, stack.2
        );
        if margin < MIN_STACK_MARGIN_PERCENT {
            return Err(format!(
                "stack margin {margin}% is under {MIN_STACK_MARGIN_PERCENT}%"
            ));
        }
        Ok(())
    }

    /// The records as CSV (one row per robot message).
    pub fn write_csv(&self, path: &Path) -> Result<(), String> {
        let mut text = String::from("bytes,answered,compute,full\n");
        for r in &self.records {
            text.push_str(&format!(
                "{},{},{},{}\n",
                r.bytes, r.answered, r.compute, r.full
            ));
        }
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// A `HardFault at PC … ` line's registers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fault {
    pub pc: u32,
    pub lr: u32,
    pub cfsr: u32,
    pub hfsr: u32,
}

impl Fault {
    /// The registers of a `HardFault at PC …` log line.
    pub fn parse(line: &str) -> Option<Fault> {
        let (_, rest) = line.split_once("HardFault at ")?;
        let words: Vec<&str> = rest.split_whitespace().collect();
        let reg = |key: &str| -> Option<u32> {
            let i = words.iter().position(|w| w.trim_end_matches(':') == key)?;
            let v = words.get(i + 1)?.trim_end_matches([':', ';', ',']);
            u32::from_str_radix(v.strip_prefix("0x")?, 16).ok()
        };
        Some(Fault {
            pc: reg("PC")?,
            lr: reg("LR")?,
            cfsr: reg("CFSR")?,
            hfsr: reg("HFSR")?,
        })
    }
}

/// CFSR: UsageFault, undefined instruction (what `fault-selftest`
/// executes); HFSR: escalated to HardFault.
const CFSR_UNDEFINSTR: u32 = 1 << 16;
const HFSR_FORCED: u32 = 1 << 30;

/// How many lines of `dev`'s log contain `needle`, waiting up to
/// `timeout` for at least `n`.
fn wait_count(
    dev: &mut dyn Device,
    needle: &str,
    n: usize,
    timeout: Duration,
) -> Result<Vec<String>, String> {
    let end = Instant::now() + timeout;
    loop {
        let log = dev.log();
        if log.iter().filter(|l| l.contains(needle)).count() >= n {
            return Ok(log);
        }
        if let Some(why) = dev.stopped() {
            return Err(format!(
                "the device stopped ({why}) before logging \"{needle}\" {n} times"
            ));
        }
        if Instant::now() > end {
            return Err(format!(
                "the device logged \"{needle}\" fewer than {n} times within {timeout:?}; its last lines:\n  {}",
                log[log.len().saturating_sub(8)..].join("\n  ")
            ));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `--fault`: the image faults on purpose at the end of its `init` (once:
/// not in the start after a HardFault). Passes when the handler logged
/// the fault with the registers an undefined instruction sets and, when
/// `restart` is required, the board reset and its next start logged the
/// same PC from the crash record kept across the reset (the diagnostics'
/// "last reset"). Returns what was seen.
pub fn fault_check(dev: &mut dyn Device, start: Duration, restart: bool) -> Result<String, String> {
    let log = wait_count(dev, "HardFault at ", 1, start)?;
    let line = log
        .iter()
        .find(|l| l.contains("HardFault at "))
        .cloned()
        .unwrap_or_default();
    let fault = Fault::parse(&line).ok_or_else(|| format!("unreadable fault line: {line}"))?;
    if fault.cfsr & CFSR_UNDEFINSTR == 0 || fault.hfsr & HFSR_FORCED == 0 {
        return Err(format!(
            "the fault was logged, but not as an undefined instruction escalated to HardFault (CFSR {:#010x}, HFSR {:#010x}): {line}",
            fault.cfsr, fault.hfsr
        ));
    }
    let mut seen = format!(
        "HardFault logged: PC {:#010x}, LR {:#010x}, CFSR {:#010x} (UNDEFINSTR), HFSR {:#010x} (FORCED)",
        fault.pc, fault.lr, fault.cfsr, fault.hfsr
    );
    let kept = format!(
        "last reset: HardFault at PC {:#010x} LR {:#010x}",
        fault.pc, fault.lr
    );
    match wait_count(dev, &kept, 1, Duration::from_secs(10)) {
        Ok(_) => seen.push_str(
            "; the board reset, and its next start read the same PC and LR from the crash record",
        ),
        Err(e) if restart => {
            return Err(format!(
            "the fault was logged but the next start did not report it from the crash record: {e}"
        ))
        }
        Err(_) => {
            seen.push_str(
                "; the restart was not seen through the probe (check that the board starts over: LD1 stays dark, the log repeats after a power cycle)",
            );
            return Ok(seen);
        }
    }
    seen.push_str("; ");
    seen.push_str(&overflow_check(dev)?);
    seen.push_str("; ");
    seen.push_str(&log_fault_check(dev)?);
    Ok(seen)
}

/// The start after the overflow faults inside a log call, the logger held
/// (issue 42 #13): passes when the next start reports a HardFault from
/// the crash record (not a panic: the handler must not log through the
/// held logger, whose own panic would overwrite the record and recurse)
/// and the firmware then goes on.
fn log_fault_check(dev: &mut dyn Device) -> Result<String, String> {
    const MARK: &str = "fault self-test: an undefined instruction inside a log call";
    wait_count(dev, MARK, 1, Duration::from_secs(10))
        .map_err(|e| format!("the fault inside a log call was not tried: {e}"))?;
    let log = wait_count(
        dev,
        "last reset: HardFault at PC ",
        2,
        Duration::from_secs(10),
    )
    .map_err(|e| {
        format!("after a fault inside a log call, the next start did not report a HardFault: {e}")
    })?;
    let after: Vec<&String> = log.iter().skip_while(|l| !l.contains(MARK)).collect();
    if let Some(bad) = after
        .iter()
        .find(|l| l.contains("panic") || l.contains("last reset: stack overflow"))
    {
        return Err(format!(
            "after the fault inside a log call the record or the log names another cause: {bad}"
        ));
    }
    Ok("a fault inside a log call (the logger held) left a HardFault in the crash record, logged nothing through the held logger, and the next start reported it".into())
}

/// The start after the HardFault recurses until the stack reaches its
/// guard (`hal_board::stack_guard`): passes when the overflow was logged
/// as one, with a stack pointer at the guard, and the start after it
/// read it back from the crash record.
fn overflow_check(dev: &mut dyn Device) -> Result<String, String> {
    let log = wait_count(dev, "stack overflow at PC ", 1, Duration::from_secs(10))
        .map_err(|e| format!("the stack overflow self-test did not fault: {e}"))?;
    let line = log
        .iter()
        .find(|l| l.contains("stack overflow at PC "))
        .cloned()
        .unwrap_or_default();
    let word = |key: &str| -> Option<u32> {
        let (_, rest) = line.split_once(key)?;
        let v = rest
            .split_whitespace()
            .next()?
            .trim_end_matches([':', ';', ',', ')']);
        u32::from_str_radix(v.strip_prefix("0x")?, 16).ok()
    };
    let (guard, sp) = word("its guard at ")
        .zip(word("(SP "))
        .ok_or_else(|| format!("unreadable stack overflow line: {line}"))?;
    if sp >= guard + 1024 {
        return Err(format!(
            "a stack overflow was logged with the stack pointer far from the guard: {line}"
        ));
    }
    wait_count(
        dev,
        "last reset: stack overflow",
        1,
        Duration::from_secs(10),
    )
    .map_err(|e| format!("the overflow was logged but the next start did not report it: {e}"))?;
    Ok(format!(
        "the stack overflow self-test reached the guard at {guard:#010x} (SP {sp:#010x}), was logged as a stack overflow, and the next start reported it"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boards_are_known() {
        assert_eq!(board("f767").and_then(|b| b.chip), Some("STM32F767ZITx"));
        assert_eq!(board("qemu").and_then(|b| b.chip), None);
        for b in HIL_BOARDS.iter().filter_map(|b| b.map) {
            assert!(crate::boards::BOARDS.iter().any(|x| x.name == b), "{b}");
            assert!(crate::board_map::placement(b).is_some(), "{b}");
        }
    }

    #[test]
    fn fault_lines_parse() {
        let f = Fault::parse("[0.000 ERROR] HardFault at PC 0x08001234 LR 0x080004f1 xPSR 0x01000003: CFSR 0x00010000 HFSR 0x40000000 MMFAR 0xe000ed34 BFAR 0xe000ed38; resetting").unwrap();
        assert_eq!(
            f,
            Fault {
                pc: 0x0800_1234,
                lr: 0x0800_04f1,
                cfsr: CFSR_UNDEFINSTR,
                hfsr: HFSR_FORCED
            }
        );
        assert_eq!(Fault::parse("[0.0 INFO] state CONNECTED"), None);
    }

    #[test]
    fn figures_come_from_the_log() {
        let log: Vec<String> = [
            "[0.0 INFO ] codec manual bytes=648 ours=11 tokenizer=7 baseline=21",
            "[0.1 INFO ] bench bytes=698 answered=true compute=1000 full=1500 frames=1 read=1 driver=1 guard=2 smoltcp=3 before=0 held_in=2 held_out=0 lost=0",
            "[0.1 INFO ] bench bytes=698 answered=true compute=3000 full=3500 frames=1 read=1 driver=1 guard=2 smoltcp=3 before=0 held_in=2 held_out=0 lost=0",
            "[0.1 INFO ] bench bytes=20 answered=false compute=50 full=0 frames=1 read=1 driver=1 guard=2 smoltcp=3 before=0 held_in=2 held_out=0 lost=0",
            "[1.0 INFO ] stack: boot 50000 running 9000 of 87776 bytes, 43% margin",
            "[1.0 INFO ] counters: messages: received 4 answered 3 | dropped: foreign 0 invalid_source 0 throttled 0 decode 1 | transport: send_errors 0 tcp_stalled 0 | ids: lost 0 duplicates 0 reordered 0 | supervision: timeouts 0 | engine latency (message in to reply ready; the page and /metrics show the driver's, frame to frame) us: max 9 mean 5 | fragments: fragments 0 reassembled 0 oversize 0 unwanted 0 malformed 0 no_buffer 0 duplicate 0 timed_out 0 evicted 0 spoiled 0 | controller: in 4 incomplete 0 dropped 0 | nic n/a: rx_frames 0 rx_dropped 0 status_full 0 fifo_max 0",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let f = DeviceFigures::of(&log);
        assert_eq!(f.records.len(), 3);
        assert_eq!((f.compute.min, f.compute.max), (1000, 3000));
        assert_eq!(f.full.max, 3500);
        assert_eq!(f.codec.len(), 1);
        assert_eq!(f.answered, Some(3));
        let mut out = Vec::new();
        assert!(f.print(board("f767").unwrap(), &mut out).is_ok());
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.contains("1 answered messages have no record"),
            "{text}"
        );
        assert!(text.contains("43% margin"), "{text}");
        let thin = DeviceFigures {
            stack: Some((80_000, 0, 87_776)),
            ..f.clone()
        };
        assert!(thin.print(board("f767").unwrap(), &mut Vec::new()).is_err());
        let none = DeviceFigures { stack: None, ..f };
        assert!(none.print(board("f767").unwrap(), &mut Vec::new()).is_err());
    }
}
