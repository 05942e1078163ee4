//! `cargo rehost -- --board f767|h743 [--elf FILE] [ENGINE ARGS]`: boots
//! the NUCLEO image on a strict model of its chip (host-tests/rehost):
//! installs cmake and libclang for the engine's build when missing, builds
//! the board's image through its alias unless `--elf` names one, builds
//! the engine and runs it. `cargo rehost -- --broken` builds every broken
//! variant and checks that the model stops each with its defect named.
//! Every other argument goes to the engine (`--robot N` for a
//! deterministic run with the engine's own robot, `--tcp`, `--listen
//! ADDR`, `--until main`, `--cycles N`, `--expect-stop TEXT`; `--help`
//! lists them). The device's address and channel come from the GSI folder
//! the image is built from (the manual's; with `--tcp` the manual's device
//! over TCP, host-tests/gsi/anydevice-tcp).

use host_tests::rehost;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut take = |flag: &str| -> Option<String> {
        let i = args.iter().position(|a| a == flag)?;
        args.remove(i);
        (i < args.len()).then(|| args.remove(i))
    };
    let board = take("--board");
    let elf = take("--elf").map(PathBuf::from);
    let broken = args
        .iter()
        .position(|a| a == "--broken")
        .map(|i| args.remove(i))
        .is_some();
    let mut out = std::io::stdout();
    let engine = match rehost::ensure_build_tools(&mut out).and_then(|()| rehost::build_engine()) {
        Ok(e) => e,
        Err(e) => return fail(&e),
    };
    if broken {
        let mut failed = 0;
        for variant in rehost::BROKEN {
            println!(
                "== broken variant {} ({}): {}",
                variant.feature, variant.board, variant.defect
            );
            let result = rehost::broken_image(variant).and_then(|elf| {
                let mut a = args.clone();
                a.extend(["--expect-stop".to_string(), variant.expect.to_string()]);
                if variant.traffic {
                    // The robot of the manual's device, for a few messages.
                    let setup = host_tests::demo::Setup::new(false)?;
                    a.extend([
                        "--device".to_string(),
                        format!(
                            "{}:{}",
                            setup.device.network.address, setup.device.channel.port
                        ),
                        "--gsi".to_string(),
                        setup.gsi.display().to_string(),
                        "--robot".to_string(),
                        "20".to_string(),
                        "--deterministic".to_string(),
                    ]);
                }
                rehost::run_engine(&engine, variant.board, &elf, &a)
            });
            match result {
                Ok(0) => {}
                Ok(_) => failed += 1,
                Err(e) => {
                    eprintln!("error: {e}");
                    failed += 1;
                }
            }
        }
        println!(
            "rehost: {} of {} broken variants stopped with their defect named",
            rehost::BROKEN.len() - failed,
            rehost::BROKEN.len()
        );
        return if failed == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        };
    }
    let Some(board) = board else {
        return fail("say which board: --board f767 or --board h743 (or --broken)");
    };
    let tcp = args.iter().any(|a| a == "--tcp");
    let corpus = args
        .iter()
        .position(|a| a == "--corpus")
        .map(|i| args.remove(i))
        .is_some();
    if corpus && (tcp || elf.is_some()) {
        return fail("--corpus runs the bench image over UDP: no --tcp, no --elf");
    }
    // The device the image is built for: its address, channel and GSI
    // folder (the manual's; with --tcp the manual's device over TCP).
    let setup = match host_tests::demo::Setup::new(tcp) {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    let image = match (elf, &setup.build_gsi) {
        _ if corpus => rehost::bench_image(&board),
        (Some(e), _) => Ok(e),
        (None, Some(gsi)) => rehost::tcp_image(&board, gsi),
        (None, None) => rehost::board_image(&board),
    };
    let elf = match image {
        Ok(e) => e,
        Err(e) => return fail(&e),
    };
    let device = format!(
        "{}:{}",
        setup.device.network.address, setup.device.channel.port
    );
    let mut engine_args = vec![
        "--device".to_string(),
        device,
        "--gsi".to_string(),
        setup.gsi.display().to_string(),
    ];
    if corpus {
        match rehost::corpus_file() {
            Ok(path) => engine_args.extend(["--corpus".to_string(), path.display().to_string()]),
            Err(e) => return fail(&e),
        }
    }
    engine_args.extend(args);
    let ran = rehost::run_engine(&engine, &board, &elf, &engine_args);
    if corpus {
        print_qemu_baseline();
    }
    match ran {
        Ok(0) => ExitCode::SUCCESS,
        Ok(code) => ExitCode::from(code as u8),
        Err(e) => fail(&e),
    }
}

/// Beside the corpus on the model: the QEMU board's gated figures (its
/// LAN9118 driver, `-icount`), from the baseline file CI gates on.
fn print_qemu_baseline() {
    let path = host_tests::workspace().join("host-tests/bench/qemu-baseline.json");
    let base: Option<host_tests::qemu_bench::Gated> = std::fs::read_to_string(&path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    match base {
        Some(b) => println!(
            "bytes: the datagram as sent, its Id written with 10 digits (a few bytes more than the file).\nthe QEMU board beside it (mps2-an500, its LAN9118 driver; {}): compute median {}, compute max {}, full path median {}, hostile max {} instructions",
            path.display(),
            b.compute_median,
            b.compute_max,
            b.full_median,
            b.hostile_max
        ),
        None => println!("(no QEMU baseline at {})", path.display()),
    }
}

fn fail(message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}
