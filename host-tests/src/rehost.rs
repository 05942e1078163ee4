//! `cargo rehost` from the host tools' side: what the rehosting engine
//! (`host-tests/rehost`, crate rri-rehost, GPL-2.0 because it links
//! unicorn) needs before it can run. Its CPU emulator is C built by cmake,
//! its bindings generated with libclang: both are installed here when
//! missing (as `cargo demo` installs QEMU); the board's image is built
//! through its alias; the engine is built and run with the arguments.
//! The broken variants (`--broken`) are images built with one defect each
//! (hal-board's `rehost-broken-*` features), every one of which the model
//! must stop with its defect named.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Debian's packages unicorn's build needs, by the command or file that
/// shows each is there.
const PACKAGES: &[(&str, &str)] = &[("cmake", "cmake"), ("libclang-dev", "libclang")];

/// A broken variant of an image: the hal-board feature that breaks it,
/// the board, and the text the model's stop must contain.
pub struct Broken {
    pub feature: &'static str,
    pub board: &'static str,
    pub defect: &'static str,
    pub expect: &'static str,
    /// The defect shows only when frames cross the wire: the model's robot
    /// sends some (a device with nothing to say transmits nothing).
    pub traffic: bool,
}

/// Every broken variant and the stop that proves the model sees it.
pub const BROKEN: &[Broken] = &[
    Broken {
        feature: "hal-board/rehost-broken-bss",
        board: "h743",
        defect: "the DMA RAM's sections inserted after .bss: the reset handler zeroes through the reserved hole after the DTCM",
        expect: "write that no memory or model claims [address 0x20020000] at PC",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-latency",
        board: "f767",
        defect: "one flash wait state fewer than RM0410's table at 216 MHz",
        expect: "FLASH_ACR LATENCY is 6 wait states with HCLK at 216 MHz: the flash needs at least 7",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-latency",
        board: "h743",
        defect: "one flash wait state fewer than RM0433's table at a 200 MHz AXI clock",
        expect: "FLASH_ACR LATENCY is 1 wait states with HCLK at 200 MHz",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-cacheable",
        board: "f767",
        defect: "the MPU's non-cacheable window left out: the Ethernet DMA writes memory the data cache holds",
        expect: "which the data cache may hold",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-dtcm",
        board: "h743",
        defect: "the Ethernet DMA rings in the H743's DTCM",
        expect: "which it cannot reach on STM32H743ZI's bus matrix",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-pll",
        board: "f767",
        defect: "the main PLL started with a 480 MHz VCO, above DS11532's 432 MHz",
        expect: "the PLL's VCO 480 MHz is outside 100-432 MHz (PLLN = 240)",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-pll",
        board: "h743",
        defect: "PLL1 started with a 1000 MHz VCO, above DS12110's 960 MHz",
        expect: "DIVN1 = 499 gives a VCO of 1000 MHz, outside the wide VCO's 192-960 MHz",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-rmii",
        board: "h743",
        defect: "PG13 (RMII_TXD0) moved to AF10 after the MAC started",
        expect: "a frame on the wire while the MAC cannot reach the LAN8742A: PG13 (RMII_TXD0) is in mode 2 with AF10",
        traffic: true,
    },
    Broken {
        feature: "hal-board/rehost-broken-mdc",
        board: "f767",
        defect: "an MDIO read at HCLK/62: MDC at 3.5 MHz from 216 MHz",
        expect: "ETH_MACMIIAR: CR = 001 divides HCLK by 62",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-mdc",
        board: "h743",
        defect: "an MDIO read at HCLK/62: MDC at 3.2 MHz from 200 MHz",
        expect: "ETH_MACMDIOAR: CR = 1",
        traffic: false,
    },
    Broken {
        feature: "hal-board/rehost-broken-stack",
        board: "f767",
        defect: "a recursion that runs the stack into its MPU guard",
        expect: "into the MPU's stack guard",
        traffic: false,
    },
];

fn has_libclang() -> bool {
    if std::env::var_os("LIBCLANG_PATH").is_some() {
        return true;
    }
    // clang-sys looks in LLVM's folders: libclang.so there (not
    // libclang-cpp, which other packages bring).
    std::fs::read_dir("/usr/lib")
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| {
            e.file_name().to_string_lossy().starts_with("llvm-")
                && std::fs::read_dir(e.path().join("lib"))
                    .into_iter()
                    .flatten()
                    .flatten()
                    .any(|f| f.file_name().to_string_lossy().starts_with("libclang.so"))
        })
}

fn has(what: &str) -> bool {
    match what {
        "libclang" => has_libclang(),
        cmd => Command::new(cmd)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success()),
    }
}

/// Installs cmake and libclang with apt-get when missing and we are root;
/// else says what to install.
pub fn ensure_build_tools(out: &mut dyn Write) -> Result<(), String> {
    let missing: Vec<&str> = PACKAGES
        .iter()
        .filter(|(_, probe)| !has(probe))
        .map(|(p, _)| *p)
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root || Command::new("apt-get").arg("--version").output().is_err() {
        return Err(format!(
            "the rehosting engine's CPU emulator (unicorn) builds with cmake and libclang: install {} (Debian/Ubuntu: `sudo apt-get install {}`) and run this again",
            missing.join(" and "),
            missing.join(" ")
        ));
    }
    let _ = writeln!(out, "installing {} with apt-get (once)…", missing.join(" "));
    let mut install = vec!["install", "-y", "-qq", "--no-install-recommends"];
    install.extend(&missing);
    for args in [&["update", "-qq"][..], &install[..]] {
        let status = Command::new("apt-get")
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status()
            .map_err(|e| format!("apt-get: {e}"))?;
        if !status.success() {
            return Err(format!("apt-get {} failed ({status})", args.join(" ")));
        }
    }
    Ok(())
}

/// Builds the engine (release) and returns its path.
pub fn build_engine() -> Result<PathBuf, String> {
    crate::cargo(
        &[
            "build",
            "--release",
            "-p",
            "rri-rehost",
            "--bin",
            "rri-rehost",
        ],
        "building the rehosting engine",
    )?;
    Ok(crate::qemu::target_dir().join("release").join("rri-rehost"))
}

/// The NUCLEO board `board` names ("f767" or "h743").
fn board_named(board: &str) -> Result<&'static crate::boards::Board, String> {
    crate::boards::BOARDS
        .iter()
        .find(|b| b.alias == format!("build-{board}"))
        .ok_or_else(|| format!("no board {board:?} (f767 or h743)"))
}

/// The board's bootloader (`firmware/rri-boot`), built through its
/// alias (`cargo build-f767-boot`, `build-h743-boot`) once per process:
/// every image is linked into the active partition and started by it, so
/// the engine programs both.
pub fn boot_image(board: &str) -> Result<PathBuf, String> {
    crate::boards::build_boot(board_named(board)?)
}

/// The board's image, built through its alias (`cargo build-f767`,
/// `build-h743`) and kept at `target/boards/<name>.elf`.
pub fn board_image(board: &str) -> Result<PathBuf, String> {
    crate::boards::build(board_named(board)?)
}

/// The board's image built from the TCP device's GSI folder (`--tcp`),
/// kept at `target/rehost-tcp/nucleo-<board>.elf`.
pub fn tcp_image(board: &str, gsi: &Path) -> Result<PathBuf, String> {
    build_variant(
        board,
        &[],
        Some(gsi),
        "rehost-tcp",
        &format!("nucleo-{board}"),
    )
}

/// Builds a broken variant and keeps it at
/// `target/rehost-broken/<feature>.elf` (no board's image is replaced).
pub fn broken_image(variant: &Broken) -> Result<PathBuf, String> {
    let name = variant.feature.trim_start_matches("hal-board/");
    build_variant(
        variant.board,
        &[variant.feature],
        None,
        "rehost-broken",
        name,
    )
}

/// Builds the firmware for `board` with `extra` features (and the GSI
/// folder `gsi`) and keeps it at `target/<dir>/<name>.elf`. In cargo's
/// default target directory, as `cargo hil` builds: embassy-stm32 for
/// each chip is compiled once there for every variant, the TCP image and
/// the bench image alike.
fn build_variant(
    board: &str,
    extra: &[&str],
    gsi: Option<&Path>,
    dir: &str,
    name: &str,
) -> Result<PathBuf, String> {
    let features = match board {
        "f767" => "board,hal-board/nucleo-f767zi",
        "h743" => "board,hal-board/nucleo-h743zi",
        other => return Err(format!("no board {other:?} (f767 or h743)")),
    };
    crate::qemu::build_board(features, extra, gsi, &[], dir, name)
}

/// The bench image for `board` (the one `cargo hil -- --board
/// <board>-rehosted` builds and runs: `target/hil/<board>-rehosted.elf`).
pub fn bench_image(board: &str) -> Result<PathBuf, String> {
    let feature = match board {
        "f767" => "board,hal-board/nucleo-f767zi",
        "h743" => "board,hal-board/nucleo-h743zi",
        other => return Err(format!("no board {other:?} (f767 or h743)")),
    };
    // As `cargo hil` builds it, so that the two share one build.
    crate::qemu::build_board(
        feature,
        &["bench"],
        None,
        &[("DEFMT_RTT_BUFFER_SIZE", "4096")],
        "hil",
        &format!("{board}-rehosted"),
    )
}

/// Writes `cargo qemu-bench`'s corpus (its realistic and hostile
/// messages, `{ID}` where the Id goes) in the engine's `--corpus` form to
/// `target/rehost-corpus/corpus.txt`.
pub fn corpus_file() -> Result<PathBuf, String> {
    let ws = crate::workspace();
    let mut inputs =
        crate::qemu_bench::realistic(&crate::shared_rri(), &ws.join("host-tests/bench"))?;
    inputs.extend(crate::qemu_bench::hostile());
    let mut out = Vec::new();
    for i in &inputs {
        out.extend_from_slice(
            format!("{}\n{}\n{}\n", i.name, u8::from(i.accepted), i.text.len()).as_bytes(),
        );
        out.extend_from_slice(i.text.as_bytes());
        out.push(b'\n');
    }
    let dir = crate::qemu::target_dir().join("rehost-corpus");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join("corpus.txt");
    std::fs::write(&path, out).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// Runs the engine on `elf` with `args`; its exit status.
pub fn run_engine(engine: &Path, board: &str, elf: &Path, args: &[String]) -> Result<i32, String> {
    let boot = boot_image(board)?;
    let status = Command::new(engine)
        .current_dir(crate::workspace())
        .args(["--board", board, "--elf"])
        .arg(elf)
        .arg("--boot")
        .arg(boot)
        .args(args)
        .status()
        .map_err(|e| format!("{}: {e}", engine.display()))?;
    Ok(status.code().unwrap_or(1))
}

/// A rehosted NUCLEO board for the demo's harness (`cargo demo -- --board
/// f767`): the engine as a child process, paced to the wall clock, the
/// robot's channel and the status page forwarded from free 127.0.0.1
/// ports, its log read line by line as a probe run's is.
pub struct Rehosted(crate::probe::ProbeRun);

impl crate::device::Device for Rehosted {
    fn wait_for(&mut self, needle: &str, timeout: std::time::Duration) -> Result<(), String> {
        self.0
            .wait_for(needle, timeout)
            .map_err(|e| e.replace("probe-rs", "the rehosting engine"))
    }
    fn take_new(&self) -> Vec<String> {
        self.0.take_new()
    }
    fn live_lines(&self) -> std::sync::Arc<std::sync::Mutex<Vec<String>>> {
        self.0.live_lines()
    }
    fn log(&self) -> Vec<String> {
        self.0.log()
    }
    fn stopped(&mut self) -> Option<String> {
        self.0.stopped().map(|e| {
            e.replace(
                "probe-rs",
                "the rehosting engine (the model stopped the image: see its last lines)",
            )
        })
    }
    fn stop(self: Box<Self>) -> Vec<String> {
        Box::new(self.0).stop()
    }
}

/// Builds what a rehosted `board` ("f767" or "h743") needs for `setup`'s
/// device and boots it; returns it with the robot's and the status page's
/// addresses on 127.0.0.1.
pub fn boot(
    board: &str,
    setup: &crate::demo::Setup,
) -> Result<(Rehosted, std::net::SocketAddr, Option<std::net::SocketAddr>), String> {
    let elf = match &setup.build_gsi {
        Some(gsi) => tcp_image(board, gsi)?,
        None => board_image(board)?,
    };
    boot_elf(board, setup, &elf, &[])
}

/// Boots the image `elf` (built for `setup`'s device) on the engine, with
/// `extra` engine arguments (`--resets N`).
pub fn boot_elf(
    board: &str,
    setup: &crate::demo::Setup,
    elf: &Path,
    extra: &[&str],
) -> Result<(Rehosted, std::net::SocketAddr, Option<std::net::SocketAddr>), String> {
    ensure_build_tools(&mut std::io::stdout())?;
    let boot = boot_image(board)?;
    let engine = build_engine()?;
    let robot = crate::qemu::free_port()?;
    let http = crate::qemu::free_tcp_port()?;
    let mut cmd = Command::new(&engine);
    cmd.current_dir(crate::workspace())
        .args(["--board", board, "--elf"])
        .arg(elf)
        .arg("--boot")
        .arg(&boot)
        .args([
            "--device",
            &format!(
                "{}:{}",
                setup.device.network.address, setup.device.channel.port
            ),
        ])
        .arg("--gsi")
        .arg(&setup.gsi)
        .args([
            "--listen",
            &format!("127.0.0.1:{robot}"),
            "--http",
            &format!("127.0.0.1:{http}"),
        ])
        .args(["--log-prefix", ""])
        .args(extra);
    if setup.device.channel.protocol == gsi_config::Protocol::Tcp {
        cmd.arg("--tcp");
    }
    println!(
        "== booting {} rehosted on the model of its chip (device {}:{} forwarded from 127.0.0.1:{robot})",
        elf.display(),
        setup.device.network.address,
        setup.device.channel.port
    );
    let run = crate::probe::ProbeRun::start(cmd)?;
    Ok((
        Rehosted(run),
        ([127, 0, 0, 1], robot).into(),
        Some(([127, 0, 0, 1], http).into()),
    ))
}

/// What the demo waits for on a rehosted board: the device up, then its
/// link (a robot message before that is lost on the wire, as on a board).
pub fn ready() -> Vec<(&'static str, std::time::Duration)> {
    vec![
        ("state CONNECTED", std::time::Duration::from_secs(120)),
        ("link up", std::time::Duration::from_secs(60)),
    ]
}
