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
/// The firmware's target and the features that pick the QEMU board.
pub const TARGET: &str = "thumbv7em-none-eabihf";
pub const BOARD_FEATURES: &str = "board,hal-board/mps2-an500";
/// The cargo profile of every firmware build (the root Cargo.toml says why
/// it is not `release`): the figures measured here are what boards run.
pub const PROFILE: &str = "firmware";

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
    let ws = crate::workspace();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut features = BOARD_FEATURES.to_string();
    for f in extra {
        features.push(',');
        features.push_str(f);
    }
    let mut cmd = Command::new(&cargo);
    if let Some(dir) = gsi {
        cmd.env("RRI_GSI_DIR", dir).env_remove("RRI_DEVICE");
    }
    let status = cmd
        .current_dir(&ws)
        .args([
            "build",
            "-p",
            "rri-firmware",
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
    keep_image("qemu", name)
}

/// Copies the firmware image cargo just built to `target/<dir>/<name>.elf`,
/// so the next build (other features, another board) does not replace it.
pub fn keep_image(dir: &str, name: &str) -> Result<PathBuf, String> {
    let built = target_dir().join(TARGET).join(PROFILE).join("rri-sensor");
    let dir = target_dir().join(dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let elf = dir.join(format!("{name}.elf"));
    std::fs::copy(&built, &elf)
        .map_err(|e| format!("{} → {}: {e}", built.display(), elf.display()))?;
    Ok(elf)
}

/// Cargo's target directory (`CARGO_TARGET_DIR` or `target/`).
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) => PathBuf::from(d),
        None => crate::workspace().join("target"),
    }
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
}

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
    Ok(format!(
        "user,model=lan9118,net={a}.{b}.{c}.0/24,host={a}.{b}.{c}.{host},restrict=off,hostfwd={proto}:127.0.0.1:{hp}-{a}.{b}.{c}.{d}:{port}",
        hp = boot.host_port,
        port = boot.device.channel.port
    ))
}

/// A running QEMU board and its decoded log.
pub struct Qemu {
    child: Child,
    /// Lines not yet taken by [`Qemu::take_new`] (shared with the robot
    /// simulator's `device_log`).
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
        .arg("-kernel")
        .arg(&boot.elf);
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
        if let Ok(mut n) = new.lock() {
            n.push(line.clone());
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

/// `MEMORY` regions of a linker script: (name, origin, length).
pub fn regions(script: &str) -> Result<Vec<(String, u64, u64)>, String> {
    let number = |t: &str| -> Option<u64> {
        let t = t.trim().trim_end_matches(',');
        let (digits, scale) = match t.strip_suffix('K') {
            Some(d) => (d, 1024),
            None => match t.strip_suffix('M') {
                Some(d) => (d, 1024 * 1024),
                None => (t, 1),
            },
        };
        let v = match digits.strip_prefix("0x") {
            Some(h) => u64::from_str_radix(h, 16).ok()?,
            None => digits.parse().ok()?,
        };
        Some(v * scale)
    };
    let mut out = Vec::new();
    for line in script.lines() {
        let Some((name, rest)) = line.split_once(':') else {
            continue;
        };
        let (Some(o), Some(l)) = (rest.split("ORIGIN =").nth(1), rest.split("LENGTH =").nth(1))
        else {
            continue;
        };
        let origin =
            number(o.split(',').next().unwrap_or("")).ok_or(format!("bad ORIGIN in `{line}`"))?;
        let length = number(l).ok_or(format!("bad LENGTH in `{line}`"))?;
        out.push((name.trim().to_string(), origin, length));
    }
    if out.is_empty() {
        return Err("no MEMORY regions".into());
    }
    Ok(out)
}

/// Every allocated section lies inside one region, and the vector table
/// starts the first (FLASH): the board's map was used, not another.
pub fn check_memory_map(
    sections: &[(String, u64, u64)],
    regions: &[(String, u64, u64)],
) -> Result<(), String> {
    let (_, flash, _) = regions.first().ok_or("no regions")?;
    match sections.iter().find(|s| s.0 == ".vector_table") {
        Some(v) if v.1 == *flash => {}
        Some(v) => {
            return Err(format!(
                ".vector_table at {:#x}, not at the board's FLASH origin {flash:#x}",
                v.1
            ))
        }
        None => return Err("no .vector_table section".into()),
    }
    for (name, addr, size) in sections.iter().filter(|s| s.2 > 0) {
        let inside = regions
            .iter()
            .any(|(_, o, l)| addr >= o && addr + size <= o + l);
        if !inside {
            return Err(format!(
                "section {name} at {addr:#x} (+{size:#x}) is outside the board's memory"
            ));
        }
    }
    Ok(())
}

/// The firmware ELF's allocated sections: (name, address, size).
pub fn sections(elf: &Path) -> Result<Vec<(String, u64, u64)>, String> {
    use object::{Object, ObjectSection};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    Ok(file
        .sections()
        .filter(|s| s.address() != 0 || s.name() == Ok(".vector_table"))
        .map(|s| (s.name().unwrap_or("?").to_string(), s.address(), s.size()))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(path: &str) -> Vec<(String, u64, u64)> {
        regions(&std::fs::read_to_string(crate::workspace().join(path)).unwrap()).unwrap()
    }

    #[test]
    fn memory_maps_parse() {
        assert_eq!(
            map(MEMORY_MAP),
            [
                ("FLASH".to_string(), 0, 4 << 20),
                ("RAM".to_string(), 0x2000_0000, 4 << 20)
            ]
        );
        assert_eq!(
            map("memory.x")[0],
            ("FLASH".to_string(), 0x0800_0000, 2 << 20)
        );
    }

    #[test]
    fn an_elf_linked_for_the_f767_is_not_one_for_qemu() {
        let f767 = [
            (".vector_table".to_string(), 0x0800_0000, 0x400),
            (".text".to_string(), 0x0800_0400, 0x1000),
            (".data".to_string(), 0x2000_0000, 0x100),
        ];
        assert!(check_memory_map(&f767, &map("memory.x")).is_ok());
        let e = check_memory_map(&f767, &map(MEMORY_MAP)).unwrap_err();
        assert!(e.contains("not at the board's FLASH origin"), "{e}");
        let qemu = [
            (".vector_table".to_string(), 0, 0x400),
            (".text".to_string(), 0x400, 0x1000),
            (".bss".to_string(), 0x2000_0000, 0x100),
        ];
        assert!(check_memory_map(&qemu, &map(MEMORY_MAP)).is_ok());
        let too_big = [
            (".vector_table".to_string(), 0, 0x400),
            (".bss".to_string(), 0x203f_ff00, 0x200),
        ];
        assert!(check_memory_map(&too_big, &map(MEMORY_MAP))
            .unwrap_err()
            .contains(".bss"));
    }
}

/// The device's counters, from its once-a-second `counters:` log line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceCounters {
    pub received: u64,
    pub answered: u64,
    pub foreign: u64,
    pub invalid: u64,
    pub throttled: u64,
    pub decode: u64,
}

impl DeviceCounters {
    /// `[…] counters: received R answered A dropped foreign F invalid-source I throttled T decode D | …`.
    pub fn parse(line: &str) -> Option<DeviceCounters> {
        let (_, rest) = line.split_once("] counters: ")?;
        let words: Vec<&str> = rest.split_whitespace().collect();
        let after = |key: &str| -> Option<u64> {
            let i = words.iter().position(|w| *w == key)?;
            words.get(i + 1)?.parse().ok()
        };
        Some(DeviceCounters {
            received: after("received")?,
            answered: after("answered")?,
            foreign: after("foreign")?,
            invalid: after("invalid-source")?,
            throttled: after("throttled")?,
            decode: after("decode")?,
        })
    }

    /// Every message received was answered or dropped for a counted reason.
    pub fn add_up(&self) -> bool {
        self.received == self.answered + self.foreign + self.invalid + self.throttled + self.decode
    }

    /// Waits (up to `timeout`) for a counter line logged after line
    /// `start` and returns the last one.
    pub fn fresh(board: &Qemu, start: usize, timeout: Duration) -> Result<DeviceCounters, String> {
        let end = std::time::Instant::now() + timeout;
        loop {
            if let Some(c) = board.since(start).iter().rev().find_map(|l| Self::parse(l)) {
                return Ok(c);
            }
            if std::time::Instant::now() > end {
                let tail = board.since(start.saturating_sub(5));
                return Err(format!(
                    "no counter line from the device within {timeout:?}; its last lines:\n{}",
                    tail.join("\n")
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

#[cfg(test)]
mod counter_tests {
    use super::DeviceCounters;

    #[test]
    fn counter_line_parses_and_adds_up() {
        let c = DeviceCounters::parse("[    3.0 INFO ] counters: received 11 answered 6 dropped foreign 1 invalid-source 1 throttled 1 decode 2 | send-errors 0 stalled 0 | lost 0 dup 0").unwrap();
        assert_eq!(
            (
                c.received,
                c.answered,
                c.foreign,
                c.invalid,
                c.throttled,
                c.decode
            ),
            (11, 6, 1, 1, 1, 2)
        );
        assert!(c.add_up());
        assert!(!DeviceCounters { received: 12, ..c }.add_up());
        assert_eq!(DeviceCounters::parse("[ 1 INFO ] state CONNECTED"), None);
    }
}
