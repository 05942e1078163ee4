//! The QEMU board from the host (`cargo demo`, `cargo qemu-bench`, tests):
//! make sure QEMU is installed, build the firmware for `mps2-an500`, boot
//! it with user-mode networking forwarding the device's channel port from
//! 127.0.0.1, and decode its defmt log (semihosting writes it to QEMU's
//! stdout) with the ELF's own table.

use gsi_config::{Device, Protocol};
use std::io::{Read, Write};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// QEMU's system emulator for Arm and the machine we boot.
pub const QEMU: &str = "qemu-system-arm";
pub const MACHINE: &str = "mps2-an500";
/// The firmware's target, profile and cargo's target directory
/// (`mcu_target`'s, which installs the target).
pub use crate::mcu_target::{target_dir, PROFILE, TARGET};
/// The features that pick the QEMU board (its flash map's module builds
/// the bootloader with them).
pub use crate::qemu_flash::BOARD_FEATURES;

/// Finds `qemu-system-arm`; installs Debian's package when we are root,
/// else says exactly what to install.
pub fn ensure_qemu(out: &mut dyn Write) -> Result<(), String> {
    if Command::new(QEMU)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root || Command::new("apt-get").arg("--version").output().is_err() {
        return Err(format!(
            "{QEMU} is not installed. Install it (Debian/Ubuntu: `sudo apt-get install qemu-system-arm`; \
             macOS: `brew install qemu`) and run this again."
        ));
    }
    let _ = writeln!(out, "installing qemu-system-arm with apt-get (once)…");
    for args in [
        &["update", "-qq"][..],
        &["install", "-y", "-qq", "qemu-system-arm"][..],
    ] {
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

/// Builds the firmware for the QEMU board with `extra` features (e.g.
/// `bench`), showing cargo's output, and copies the ELF to
/// `target/qemu/<name>.elf` so builds with other features do not replace
/// it.
/// `gsi`: the GSI folder to build from (`RRI_GSI_DIR`), `None` for the
/// caller's environment.
pub fn build_firmware(extra: &[&str], gsi: Option<&Path>, name: &str) -> Result<PathBuf, String> {
    build_board(BOARD_FEATURES, extra, gsi, &[], "qemu", name)
}

/// Builds the firmware for the board `board_features` selects (e.g.
/// `board,hal-board/nucleo-f767zi`) with `extra` features and `env`,
/// showing cargo's output, and copies the ELF to `target/<dir>/<name>.elf`.
/// `gsi` as for [`build_firmware`].
pub fn build_board(
    board_features: &str,
    extra: &[&str],
    gsi: Option<&Path>,
    env: &[(&str, &str)],
    dir: &str,
    name: &str,
) -> Result<PathBuf, String> {
    crate::mcu_target::ensure()?;
    let ws = crate::workspace();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut features = board_features.to_string();
    for f in extra {
        features.push(',');
        features.push_str(f);
    }
    let mut cmd = Command::new(&cargo);
    if let Some(dir) = gsi {
        cmd.env("RRI_GSI_DIR", dir).env_remove("RRI_DEVICE");
    }
    cmd.envs(env.iter().copied());
    let status = cmd
        .current_dir(&ws)
        .args([
            "build",
            "-p",
            "rri-sensor",
            "--bin",
            "rri-sensor",
            "--profile",
            PROFILE,
        ])
        .args(["--target", TARGET, "--features", &features])
        .status()
        .map_err(|e| format!("cannot run {cargo}: {e}"))?;
    if !status.success() {
        return Err(format!("the firmware build failed ({status})"));
    }
    keep_image(dir, name)
}

/// Copies the firmware image cargo just built to `target/<dir>/<name>.elf`,
/// so the next build (other features, another board) does not replace it.
pub fn keep_image(dir: &str, name: &str) -> Result<PathBuf, String> {
    keep_image_from(&target_dir(), dir, name)
}

/// [`keep_image`] for an image cargo built in target directory `built_in`
/// (the STM32 boards' aliases each have their own).
pub fn keep_image_from(built_in: &Path, dir: &str, name: &str) -> Result<PathBuf, String> {
    let built = image_in(built_in);
    let dir = target_dir().join(dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let elf = dir.join(format!("{name}.elf"));
    std::fs::copy(&built, &elf)
        .map_err(|e| format!("{} → {}: {e}", built.display(), elf.display()))?;
    Ok(elf)
}

/// Where cargo puts the firmware image in target directory `dir`.
pub fn image_in(dir: &Path) -> PathBuf {
    dir.join(TARGET).join(PROFILE).join("rri-sensor")
}

/// A free TCP port on 127.0.0.1 for QEMU to forward the diagnostics to.
pub fn free_tcp_port() -> Result<u16, String> {
    let tcp =
        std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| format!("no free port: {e}"))?;
    tcp.local_addr()
        .map(|a| a.port())
        .map_err(|e| e.to_string())
}

/// Whether a log line of the firmware (QEMU's or a probe's) is shown as it
/// comes: everything but the bench build's record per message (`bench
/// bytes=…`), which the tools read from the whole log and `cargo hil`
/// summarises.
pub fn shown_live(line: &str) -> bool {
    !line.contains("] bench ")
}

/// A free port on 127.0.0.1 for QEMU to forward (released just before
/// QEMU binds it).
pub fn free_port() -> Result<u16, String> {
    for _ in 0..20 {
        let tcp =
            std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| format!("no free port: {e}"))?;
        let port = tcp.local_addr().map_err(|e| e.to_string())?.port();
        if UdpSocket::bind(("127.0.0.1", port)).is_ok() {
            return Ok(port);
        }
    }
    Err("no port free for both UDP and TCP on 127.0.0.1".into())
}

/// Boots `elf` as `device` on QEMU's user networking, the channel port and
/// the status page forwarded from free ports on 127.0.0.1, and says so:
/// the board, where the robot reaches it and where its status page is
/// (`cargo demo` and `cargo hil -- --board qemu`).
pub fn boot_local(
    elf: PathBuf,
    device: &Device,
) -> Result<(Qemu, std::net::SocketAddr, Option<std::net::SocketAddr>), String> {
    let host_port = free_port()?;
    let boot = Boot {
        elf,
        device: device.clone(),
        host_port,
        icount_shift: None,
        http_port: Some(free_tcp_port()?),
    };
    println!(
        "== booting {} on {MACHINE} (device {} port {} forwarded from 127.0.0.1:{host_port})",
        boot.elf.display(),
        device.network.address,
        device.channel.port
    );
    let http = boot.http_port.map(|p| ([127, 0, 0, 1], p).into());
    Ok((Qemu::boot(&boot)?, ([127, 0, 0, 1], host_port).into(), http))
}

/// How to boot.
#[derive(Clone, Debug)]
pub struct Boot {
    pub elf: PathBuf,
    /// The device the firmware was built for (its address, channel port
    /// and protocol set up the forward).
    pub device: Device,
    /// 127.0.0.1 port forwarded to the device's channel port.
    pub host_port: u16,
    /// `-icount shift=N`: the virtual clock advances 2^N ns per
    /// instruction (deterministic counts); `None` runs in real time.
    pub icount_shift: Option<u8>,
    /// 127.0.0.1 port forwarded to the device's diagnostics (TCP port
    /// [`HTTP_PORT`]); `None`: not forwarded.
    pub http_port: Option<u16>,
}

/// The diagnostics service's port on the device (the firmware's default
/// `RRI_HTTP_PORT`).
pub const HTTP_PORT: u16 = 80;

/// The device's IPv4 address and the user-mode network around it: QEMU's
/// slirp must own the device's /24 for the forward to reach it.
/// (`restrict=off`: with `restrict=on` slirp drops the guest's UDP
/// replies.)
fn slirp_network(boot: &Boot) -> Result<String, String> {
    let address = &boot.device.network.address;
    let octets: Option<Vec<u8>> = address.split('.').map(|p| p.parse().ok()).collect();
    let Some([a, b, c, d]) = octets.and_then(|o| <[u8; 4]>::try_from(o).ok()) else {
        return Err(format!(
            "Description.xml's Network Address {address} is not an IPv4 address; the QEMU board needs one"
        ));
    };
    let host = if d == 1 { 2 } else { 1 };
    let proto = match boot.device.channel.protocol {
        Protocol::Tcp => "tcp",
        Protocol::Udp | Protocol::HpUdp => "udp",
    };
    let http = match boot.http_port {
        Some(hp) => format!(",hostfwd=tcp:127.0.0.1:{hp}-{a}.{b}.{c}.{d}:{HTTP_PORT}"),
        None => String::new(),
    };
    Ok(format!(
        "user,id=n0,model=lan9118,net={a}.{b}.{c}.0/24,host={a}.{b}.{c}.{host},restrict=off,hostfwd={proto}:127.0.0.1:{hp}-{a}.{b}.{c}.{d}:{port}{http}",
        hp = boot.host_port,
        port = boot.device.channel.port
    ))
}

/// A running QEMU board and its decoded log.
pub struct Qemu {
    child: Child,
    /// Lines not yet taken by [`Qemu::take_new`] (shared with the robot
    /// simulator's `device_log`), without the bench records
    /// ([`shown_live`]).
    pub new_lines: Arc<Mutex<Vec<String>>>,
    all: Arc<Mutex<Vec<String>>>,
    reader: Option<JoinHandle<()>>,
}

impl Qemu {
    /// The QEMU command line for `boot`.
    pub fn command(boot: &Boot) -> Result<Command, String> {
        Self::command_on(boot, &slirp_network(boot)?)
    }

    /// The QEMU command line for `boot` with the NIC option `nic` (e.g. a
    /// tap device instead of user networking).
    pub fn command_on(boot: &Boot, nic: &str) -> Result<Command, String> {
        let mut cmd = Command::new(QEMU);
        cmd.args([
            "-M", MACHINE, "-display", "none", "-serial", "none", "-monitor", "none",
        ])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-nic", nic])
        .args(crate::qemu_flash::load_args(&boot.elf)?);
        if let Ok(dump) = std::env::var("RRI_QEMU_DUMP") {
            cmd.args([
                "-object",
                &format!("filter-dump,id=fd0,netdev=n0,file={dump}"),
            ]);
        }
        if let Some(shift) = boot.icount_shift {
            cmd.args(["-icount", &format!("shift={shift}")]);
        }
        Ok(cmd)
    }

    pub fn boot(boot: &Boot) -> Result<Qemu, String> {
        Self::start(boot, Self::command(boot)?)
    }

    /// Boots `boot` with the NIC option `nic` (see [`Qemu::command_on`]).
    pub fn boot_on(boot: &Boot, nic: &str) -> Result<Qemu, String> {
        Self::start(boot, Self::command_on(boot, nic)?)
    }

    fn start(boot: &Boot, mut command: Command) -> Result<Qemu, String> {
        let elf = std::fs::read(&boot.elf).map_err(|e| format!("{}: {e}", boot.elf.display()))?;
        let mut child = command
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("cannot start {QEMU}: {e}"))?;
        let stdout = child.stdout.take().ok_or("no stdout from QEMU")?;
        let new_lines = Arc::new(Mutex::new(Vec::new()));
        let all = Arc::new(Mutex::new(Vec::new()));
        let (n, a) = (new_lines.clone(), all.clone());
        let reader = std::thread::spawn(move || decode(elf, stdout, &n, &a));
        Ok(Qemu {
            child,
            new_lines,
            all,
            reader: Some(reader),
        })
    }

    /// Lines logged since the last call.
    pub fn take_new(&self) -> Vec<String> {
        self.new_lines
            .lock()
            .map(|mut l| l.drain(..).collect())
            .unwrap_or_default()
    }

    /// Every line logged so far.
    pub fn log(&self) -> Vec<String> {
        self.since(0)
    }

    /// How many lines have been logged so far.
    pub fn lines(&self) -> usize {
        self.all.lock().map(|l| l.len()).unwrap_or(0)
    }

    /// The lines logged after the first `start` (only those are copied).
    pub fn since(&self, start: usize) -> Vec<String> {
        self.all
            .lock()
            .map(|l| l.get(start..).unwrap_or_default().to_vec())
            .unwrap_or_default()
    }

    /// Waits until a logged line contains `needle`.
    pub fn wait_for(&mut self, needle: &str, timeout: Duration) -> Result<(), String> {
        let end = Instant::now() + timeout;
        let mut seen = 0;
        loop {
            let new = self.since(seen);
            seen += new.len();
            if new.iter().any(|l| l.contains(needle)) {
                return Ok(());
            }
            if let Ok(Some(status)) = self.child.try_wait() {
                return Err(format!(
                    "QEMU exited ({status}) before the device logged \"{needle}\""
                ));
            }
            if Instant::now() > end {
                let log = self.log();
                let tail: Vec<String> = log
                    .iter()
                    .take(3)
                    .chain(log.iter().skip(3.max(log.len().saturating_sub(5))))
                    .cloned()
                    .collect();
                return Err(format!(
                    "the device did not log \"{needle}\" within {timeout:?}; its last lines:\n  {}",
                    if tail.is_empty() {
                        "(nothing)".to_string()
                    } else {
                        tail.join("\n  ")
                    }
                ));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// QEMU's exit status if it has ended (the firmware panicked or exited).
    pub fn exited(&mut self) -> Option<ExitStatus> {
        self.child.try_wait().ok().flatten()
    }

    /// Stops QEMU and returns the whole log.
    pub fn stop(mut self) -> Vec<String> {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        self.log()
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Decodes the defmt stream into `[time LEVEL] message` lines.
fn decode(elf: Vec<u8>, mut stdout: impl Read, new: &Mutex<Vec<String>>, all: &Mutex<Vec<String>>) {
    let push = |line: String| {
        if shown_live(&line) {
            if let Ok(mut n) = new.lock() {
                n.push(line.clone());
            }
        }
        if let Ok(mut a) = all.lock() {
            a.push(line);
        }
    };
    let table = match defmt_decoder::Table::parse(&elf) {
        Ok(Some(t)) => t,
        Ok(None) => return push("(the firmware has no defmt table)".into()),
        Err(e) => return push(format!("(cannot read the defmt table: {e})")),
    };
    let mut decoder = table.new_stream_decoder();
    let mut buf = [0u8; 4096];
    loop {
        let n = match stdout.read(&mut buf) {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        decoder.received(&buf[..n]);
        loop {
            match decoder.decode() {
                Ok(frame) => {
                    let level = frame
                        .level()
                        .map(|l| l.as_str().to_uppercase())
                        .unwrap_or_default();
                    let ts = frame
                        .display_timestamp()
                        .map(|t| t.to_string())
                        .unwrap_or_default();
                    push(format!("[{ts:>12} {level:<5}] {}", frame.display_message()));
                }
                Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
                Err(defmt_decoder::DecodeError::Malformed) => {
                    push("(malformed defmt frame)".into())
                }
            }
        }
    }
}

/// The QEMU board's memory map (the root `memory.x` is the F767's).
pub const MEMORY_MAP: &str = "hal-board/memory/mps2-an500.x";
