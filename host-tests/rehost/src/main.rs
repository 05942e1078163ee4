//! The rehosting engine: boots a NUCLEO image on the model of its chip.
//! Users run it through `cargo rehost` (host-tests' launcher, which
//! installs what unicorn's build needs and builds the image first).
//!
//! Exit status: 0 when the run ended as asked (`--until` reached, the
//! cycle budget spent, or with `--expect-stop` the expected stop), 1 when
//! the model stopped the image (or did not, with `--expect-stop`), 2 on a
//! usage or load error.

use clap::Parser;
use main_args::Args;
use rri_rehost::{chip, image::Image, machine::Machine};
use std::path::PathBuf;

mod main_args;

fn main() {
    let mut args = Args::parse();
    let cycles = args.cycles.unwrap_or(if args.device.is_some() {
        u64::MAX / 2
    } else {
        2_000_000_000
    });
    args.cycles = Some(cycles);
    let cycles_limit = cycles;
    let (rebuild, chip, dir): (fn() -> _, _, _) = match (args.board.as_str(), args.dual_bank) {
        ("f767", false) => (rri_rehost::f7::bus, chip::STM32F767ZI, "nucleo-f767zi"),
        ("f767", true) => (
            rri_rehost::f7::bus_dual_bank,
            chip::STM32F767ZI,
            "nucleo-f767zi",
        ),
        ("h743", false) => (rri_rehost::h7::bus, chip::STM32H743ZI, "nucleo-h743zi"),
        ("h743", true) => fail(
            2,
            "--dual-bank: the H743's flash always has its two banks (the option is the F767's)",
        ),
        (other, _) => fail(2, &format!("no board {other:?} (f767 or h743)")),
    };
    let elf = args.elf.unwrap_or_else(|| {
        PathBuf::from(format!(
            "target/{dir}/thumbv7em-none-eabihf/firmware/rri-sensor"
        ))
    });
    let boot = args.boot.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "target/{dir}/thumbv7em-none-eabihf/firmware/rri-boot"
        ))
    });
    let image = if args.no_image {
        Image::read(&boot)
    } else {
        Image::read(&elf).and_then(|image| image.with_boot(Image::read(&boot)?))
    }
    .unwrap_or_else(|e| fail(2, &e));
    let until = args.until.as_ref().map(|name| {
        image
            .symbol(name)
            .unwrap_or_else(|| fail(2, &format!("{}: no symbol {name:?}", elf.display())))
    });
    let (bus, clocks) = rebuild();
    let mut m = Machine::new(chip, image, bus, clocks).unwrap_or_else(|e| fail(2, &e));
    m.uc.get_data_mut().poll.enabled = !args.no_fast_forward;
    m.rebuild = Some(rebuild);
    {
        let flash = &mut m.uc.get_data_mut().shared.flash;
        flash.cut_at = args.power_cut;
        flash.tear = args.tear;
        flash.tear_seed = args.tear_seed;
        if args.flash_census.is_some() {
            flash.census = Some(Vec::new());
        }
    }
    if let Some(path) = &args.flash_in {
        let bytes =
            std::fs::read(path).unwrap_or_else(|e| fail(2, &format!("{}: {e}", path.display())));
        // The core starts from the vector table the flash put in holds.
        m.set_flash(&bytes)
            .and_then(|()| rri_rehost::reset::reset_core(&mut m.uc))
            .unwrap_or_else(|e| fail(2, &format!("{}: {e}", path.display())));
    }
    m.resets_left = args.resets;
    if args.no_ref_clock {
        m.uc.get_data_mut().shared.link.ref_clock = false;
    }
    if let Some(addr) = until {
        m.stop_at(addr).unwrap_or_else(|e| fail(2, &e));
    }
    if args.log && !args.no_image {
        // The log of the image `--log-elf` names (an update's, once it is
        // swapped in: its RTT block and its defmt table), else `--elf`'s.
        let log_elf = args.log_elf.clone().unwrap_or_else(|| elf.clone());
        let elf_bytes = std::fs::read(&log_elf).unwrap_or_default();
        let block = if args.log_elf.is_some() {
            Image::read(&log_elf)
                .unwrap_or_else(|e| fail(2, &e))
                .symbol("_SEGGER_RTT")
        } else {
            m.uc.get_data().image.symbol("_SEGGER_RTT")
        };
        m.rtt = block.and_then(|block| rri_rehost::rtt::Rtt::new(&elf_bytes, block));
    }
    let mut forwards = None;
    if let Some(device) = args.device {
        let mut bridge = rri_rehost::bridge::Bridge::new(device.ip().octets());
        let robot = if args.tcp {
            bridge.forward_tcp(args.listen, device.port())
        } else {
            bridge.forward_udp(args.listen, device.port())
        }
        .unwrap_or_else(|e| fail(2, &e));
        let http = bridge
            .forward_tcp(args.http, 80)
            .unwrap_or_else(|e| fail(2, &e));
        m.bridge = Some(bridge);
        m.pace.on = !args.deterministic && args.robot.is_none();
        m.pace.always = args.pace_always;
        forwards = Some((robot, http, device));
    }
    if args.no_image {
        println!(
            "rehost: {} alone, no image in the active partition ({}) on {}, one instruction a core cycle",
            boot.display(),
            args.board,
            chip.name
        );
    } else {
        println!(
            "rehost: {} started by {} ({}) on {}, one instruction a core cycle",
            elf.display(),
            boot.display(),
            args.board,
            chip.name
        );
    }
    let mut robot = None;
    if let Some(n) = args.robot {
        let gsi = args.gsi.clone().unwrap_or_else(|| {
            fail(
                2,
                "--robot needs --gsi DIR (the folder the image was built from)",
            )
        });
        if args.device.is_none() {
            fail(2, "--robot needs --device ADDR:PORT");
        }
        let device = gsi_config::load(&gsi, None)
            .map(|l| l.device)
            .unwrap_or_else(|e| fail(2, &format!("{}: {e}", gsi.display())));
        robot = Some((n, device));
        m.fine_slices = true;
    }
    // The robot to start again after a power cut.
    let robot_again = robot.clone();
    let mut driver: Option<rri_rehost::robot::Robot> = None;
    // The robot's run is over: the exit status, once the flash is kept.
    let mut robot_verdict = None;
    let mut corpus = None;
    let mut corpus_run: Option<rri_rehost::corpus::Corpus> = None;
    if let Some(path) = &args.corpus {
        let (Some(gsi), Some(_)) = (&args.gsi, args.device) else {
            fail(2, "--corpus needs --device ADDR:PORT and --gsi DIR");
        };
        let inputs = rri_rehost::corpus::read(path).unwrap_or_else(|e| fail(2, &e));
        let device = gsi_config::load(gsi, None)
            .map(|l| l.device)
            .unwrap_or_else(|e| fail(2, &format!("{}: {e}", gsi.display())));
        corpus = Some((inputs, device));
        m.fine_slices = true;
        m.pace.on = false;
    }
    let t = std::time::Instant::now();
    let mut announced = false;
    let stop = loop {
        // A run in steps of 10 ms of virtual time, printing the log as it comes.
        let per = if m.fine_slices { 20_000 } else { 100 };
        let step = m.uc.get_data().shared.clocks.core_hz / per;
        let left = cycles_limit.saturating_sub(m.now());
        let stop = m.run(step.min(left).max(1));
        if let (Some(c), Some(bridge)) = (&mut corpus_run, &mut m.bridge) {
            c.step(bridge, m.time_ns);
            if c.done() {
                print!("{}", c.table(m.uc.get_data().shared.clocks.core_hz));
                if let Some(e) = &c.first_error {
                    println!("corpus: first error: {e}");
                }
                std::process::exit(if c.ok() { 0 } else { 1 });
            }
        }
        if let (Some(d), Some(bridge)) = (&mut driver, &mut m.bridge) {
            if let Err(e) = d.step(bridge, m.time_ns) {
                fail(1, &e);
            }
            if d.done(m.time_ns) {
                println!("{}", d.summary());
                println!("bridge: {:?}", bridge.counts);
                if let Some(e) = &d.first_error {
                    println!("robot: first error: {e}");
                }
                if let Some(want) = &args.expect_stop {
                    fail(
                        1,
                        &format!(
                            "expected a stop naming {want:?}; the robot's run ended without one"
                        ),
                    );
                }
                let ok = d.lost() == 0 && d.wrong == 0 && d.late == 0;
                robot_verdict = Some(if ok { 0 } else { 1 });
                break None;
            }
        }
        for note in m.take_notes() {
            println!("rehost: {note}");
            if note.starts_with("power cut") {
                if let Some(d) = driver.take() {
                    println!("robot before the power cut: {}", d.summary());
                }
                robot = robot_again.clone();
            }
        }
        for line in m.take_log() {
            println!("{}{line}", args.log_prefix);
            // The robot starts once the device's link is up (a robot
            // message before that is lost on the wire, as on a board).
            if let Some(c) = &mut corpus_run {
                c.log_line(&line);
            }
            if line.contains("link up") {
                if let Some((inputs, device)) = corpus.take() {
                    corpus_run = Some(
                        rri_rehost::corpus::Corpus::new(inputs, device, args.repeat)
                            .unwrap_or_else(|e| fail(2, &e)),
                    );
                }
                if let Some((n, device)) = robot.take() {
                    let d = rri_rehost::robot::Robot::new(device, n, m.time_ns)
                        .unwrap_or_else(|e| fail(2, &e));
                    driver = Some(d);
                }
            }
            if !announced && line.contains("state CONNECTED") {
                if let Some((robot, http, device)) = forwards {
                    let proto = if args.tcp { "tcp" } else { "udp" };
                    println!("robot: {proto} {robot} -> device {device}");
                    println!("status page: http://{http}/");
                    announced = true;
                }
            }
        }
        if stop.is_some() || m.now() >= cycles_limit {
            break stop;
        }
    };
    let elapsed = t.elapsed();
    {
        if let Some(why) = &m.uc.get_data().scs.fault_reason {
            // The last fault the core took, whether or not its handler
            // said anything (a bootloader's says nothing).
            eprintln!("rehost: the last fault taken: {why}");
        }
        let flash = &m.uc.get_data().shared.flash;
        eprintln!("rehost: {} flash operations", flash.started);
        if let Some(line) = rri_rehost::torn_word::summary(flash) {
            eprintln!("rehost: {line}");
        }
        if let (Some(path), Some(census)) = (&args.flash_census, &flash.census) {
            let text: String = census
                .iter()
                .map(|op| {
                    let kind = if op.erase { "erase" } else { "program" };
                    format!(
                        "{} {kind} {:#010x} {} {:#010x}\n",
                        op.n, op.addr, op.len, op.pc
                    )
                })
                .collect();
            std::fs::write(path, text)
                .unwrap_or_else(|e| fail(2, &format!("{}: {e}", path.display())));
        }
    }
    if let Some(path) = &args.flash_out {
        let bytes = m.flash().unwrap_or_else(|e| fail(2, &e));
        std::fs::write(path, bytes)
            .unwrap_or_else(|e| fail(2, &format!("{}: {e}", path.display())));
    }
    if let Some(code) = robot_verdict {
        std::process::exit(code);
    }
    {
        let s = m.uc.get_data();
        if std::env::var_os("REHOST_TRACE").is_some() {
            for b in &s.bus.blocks {
                if let Some(t) = b.model.next_event(s.now) {
                    eprintln!("  next event of {}: {t} (now {})", b.model.name(), s.now);
                }
            }
            for (pc, addr, size, write, value) in &s.recent {
                match write {
                    Some(w) => eprintln!(
                        "  {pc:#010x} {}: write{size} {addr:#010x} <- {w:#010x}",
                        s.image.describe(u64::from(*pc))
                    ),
                    None => eprintln!(
                        "  {pc:#010x} {}: read{size}  {addr:#010x} -> {value:#010x}",
                        s.image.describe(u64::from(*pc))
                    ),
                }
            }
        }
        eprintln!(
            "rehost: {} cycles ({} asleep, {} in {} poll loops fast-forwarded), {} slices, {} exceptions taken, {:.2?}; {}",
            s.now,
            s.slept,
            s.poll.skipped,
            s.poll.skips,
            s.slices,
            s.exceptions_taken,
            elapsed,
            m.where_now()
        );
    }
    match (stop, &args.expect_stop) {
        (Some(stop), None) if m.reached() => {
            println!(
                "rehost: reached {} at cycle {} ({:.2?})",
                args.until.as_deref().unwrap_or("?"),
                stop.cycles,
                elapsed
            );
        }
        (Some(stop), None) => fail(1, &format!("stopped: {stop}")),
        (Some(stop), Some(want)) => {
            let text = stop.to_string();
            if text.contains(want.as_str()) && !m.reached() {
                println!("rehost: stopped as expected: {text}");
            } else {
                fail(1, &format!("expected a stop naming {want:?}, got: {text}"));
            }
        }
        (None, Some(want)) => fail(
            1,
            &format!(
                "expected a stop naming {want:?}; the image ran {} cycles without one ({})",
                m.now(),
                m.where_now()
            ),
        ),
        (None, None) => {
            if let Some(name) = &args.until {
                fail(
                    1,
                    &format!(
                        "{name} not reached in {} cycles ({:.2?}); now at {}",
                        m.now(),
                        elapsed,
                        m.where_now()
                    ),
                );
            }
            println!(
                "rehost: ran {} cycles in {:.2?}; now at {}",
                m.now(),
                elapsed,
                m.where_now()
            );
        }
    }
}

fn fail(code: i32, message: &str) -> ! {
    eprintln!("rehost: {message}");
    std::process::exit(code)
}
