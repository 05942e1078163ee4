//! A NUCLEO board on USB through its ST-LINK, with probe-rs: whether
//! probe-rs and a probe are there, and `probe-rs run` (flash, reset, the
//! defmt log over RTT, decoded by probe-rs with the ELF's table) as a
//! [`Device`] for `cargo hil`.
//!
//! probe-rs is not a dependency of this workspace (it takes about 20
//! minutes of two cores to build): it is run as the user installed it, or
//! as `PROBE_RS` names it.

use crate::device::Device;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The environment variable that overrides the `probe-rs` executable.
pub const PROBE_RS_ENV: &str = "PROBE_RS";

/// How to install probe-rs, for the messages.
pub const INSTALL: &str = "cargo install probe-rs-tools --locked";

/// The `probe-rs` to run.
pub fn program() -> String {
    std::env::var(PROBE_RS_ENV).unwrap_or_else(|_| "probe-rs".into())
}

/// What is missing to run on a real board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Missing {
    /// No `probe-rs` executable.
    ProbeRs(String),
    /// probe-rs found no debug probe (or none matching `--probe`).
    Probe(Option<String>),
    /// `probe-rs list` failed.
    List(String),
}

impl Missing {
    /// One line: what is missing and what to do.
    pub fn line(&self) -> String {
        match self {
            Missing::ProbeRs(program) => format!(
                "probe-rs is not installed (`{program}` not found): install it with `{INSTALL}` (about 20 minutes), add its udev rules on Linux (https://probe.rs/docs/getting-started/probe-setup/), then run this again"
            ),
            Missing::Probe(None) => "no debug probe found (`probe-rs list`): connect the NUCLEO's ST-LINK USB port (CN1) to this computer; on Linux check probe-rs's udev rules".into(),
            Missing::Probe(Some(wanted)) => format!(
                "no debug probe matching `{wanted}` (`probe-rs list` shows the connected ones)"
            ),
            Missing::List(why) => format!("`probe-rs list` failed: {why}"),
        }
    }
}

/// The probes in `probe-rs list`'s output (`[0]: STLink V2-1 -- 0483:374b:…`).
pub fn parse_list(stdout: &str) -> Vec<String> {
    stdout
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with('[') && l.contains("]:"))
        .map(str::to_string)
        .collect()
}

/// Checks that probe-rs runs and sees a probe (the one `selector` names,
/// `VID:PID[:SERIAL]`, when given); returns the probe's line.
pub fn check(selector: Option<&str>) -> Result<String, Missing> {
    let program = program();
    let list = match Command::new(&program).arg("list").output() {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Missing::ProbeRs(program));
        }
        Err(e) => return Err(Missing::List(e.to_string())),
    };
    if !list.status.success() {
        let err = String::from_utf8_lossy(&list.stderr);
        return Err(Missing::List(format!(
            "{} ({})",
            err.lines().last().unwrap_or("no output").trim(),
            list.status
        )));
    }
    let probes = parse_list(&String::from_utf8_lossy(&list.stdout));
    let found = match selector {
        None => probes.first(),
        Some(s) => probes
            .iter()
            .find(|p| p.to_lowercase().contains(&s.to_lowercase())),
    };
    found
        .cloned()
        .ok_or_else(|| Missing::Probe(selector.map(str::to_string)))
}

/// `probe-rs run` for `elf` on `chip`: one log line per defmt frame
/// (`[time LEVEL] message`, the QEMU board's format). `catch_faults`:
/// probe-rs stops the core at a HardFault or reset and prints a stack
/// trace (the default, best for a crash); off, the firmware's own
/// handlers run (`cargo hil -- --fault`).
pub fn command(chip: &str, elf: &Path, selector: Option<&str>, catch_faults: bool) -> Command {
    let mut cmd = Command::new(program());
    cmd.args(["run", "--chip", chip, "--log-format", "[{t} {L}] {s}"]);
    if let Some(s) = selector {
        cmd.args(["--probe", s]);
    }
    if !catch_faults {
        cmd.args(["--no-catch-hardfault", "--no-catch-reset"]);
    }
    cmd.arg(elf);
    cmd
}

/// `probe-rs download` of `elf` on `chip` (the board's bootloader, issue
/// 43: the application is linked into the active partition, and the chip
/// starts the bootloader, which `probe-rs run` of the application alone
/// does not write). Only the sectors it holds are erased.
pub fn download(chip: &str, elf: &Path, selector: Option<&str>) -> Result<(), String> {
    let mut cmd = Command::new(program());
    cmd.args(["download", "--chip", chip]);
    if let Some(s) = selector {
        cmd.args(["--probe", s]);
    }
    let status = cmd
        .arg(elf)
        .status()
        .map_err(|e| format!("{}: {e}", program()))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "`probe-rs download` of {} failed ({status})",
            elf.display()
        ))
    }
}

/// A running `probe-rs run` and the log lines it printed.
pub struct ProbeRun {
    child: Child,
    new_lines: Arc<Mutex<Vec<String>>>,
    all: Arc<Mutex<Vec<String>>>,
    reader: Option<JoinHandle<()>>,
    /// Its stderr's reader, joined at the stop as `reader` is, so that
    /// the log is whole when it is returned.
    err_reader: Option<JoinHandle<()>>,
}

impl ProbeRun {
    /// Starts `cmd` (see [`command`]); probe-rs's own progress goes to this
    /// terminal's stderr, the log lines into the device's log.
    ///
    /// Its stderr lines go into the log as well: the rehosting engine
    /// says there why it stopped the image, and a run's failure prints
    /// the log's tail, which must show it (a CI run once failed with
    /// only "the device does not answer" in its tail, the engine's reason
    /// hundreds of lines above).
    pub fn start(mut cmd: Command) -> Result<ProbeRun, String> {
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", program()))?;
        let stdout = child.stdout.take().ok_or("no stdout from probe-rs")?;
        let stderr = child.stderr.take().ok_or("no stderr from probe-rs")?;
        let new_lines = Arc::new(Mutex::new(Vec::new()));
        let all = Arc::new(Mutex::new(Vec::new()));
        let a = all.clone();
        let err_reader = std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                eprintln!("{line}");
                if let Ok(mut v) = a.lock() {
                    v.push(format!("(stderr) {line}"));
                }
            }
        });
        let (n, a) = (new_lines.clone(), all.clone());
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if crate::qemu::shown_live(&line) {
                    if let Ok(mut v) = n.lock() {
                        v.push(line.clone());
                    }
                }
                if let Ok(mut v) = a.lock() {
                    v.push(line);
                }
            }
        });
        Ok(ProbeRun {
            child,
            new_lines,
            all,
            reader: Some(reader),
            err_reader: Some(err_reader),
        })
    }
}

impl Device for ProbeRun {
    fn wait_for(&mut self, needle: &str, timeout: Duration) -> Result<(), String> {
        let end = Instant::now() + timeout;
        loop {
            if self.log().iter().any(|l| l.contains(needle)) {
                return Ok(());
            }
            if let Ok(Some(status)) = self.child.try_wait() {
                return Err(format!(
                    "probe-rs exited ({status}) before the device logged \"{needle}\""
                ));
            }
            if Instant::now() > end {
                let log = self.log();
                let tail = log[log.len().saturating_sub(8)..].join("\n  ");
                return Err(format!(
                    "the device did not log \"{needle}\" within {timeout:?}; its last lines:\n  {}",
                    if tail.is_empty() { "(nothing)" } else { &tail }
                ));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn take_new(&self) -> Vec<String> {
        self.new_lines
            .lock()
            .map(|mut l| l.drain(..).collect())
            .unwrap_or_default()
    }

    fn live_lines(&self) -> Arc<Mutex<Vec<String>>> {
        self.new_lines.clone()
    }

    fn log(&self) -> Vec<String> {
        self.all.lock().map(|l| l.clone()).unwrap_or_default()
    }

    fn stopped(&mut self) -> Option<String> {
        self.child
            .try_wait()
            .ok()
            .flatten()
            .map(|s| format!("probe-rs exited: {s}"))
    }

    fn stop(mut self: Box<Self>) -> Vec<String> {
        let _ = self.child.kill();
        let _ = self.child.wait();
        for r in [self.reader.take(), self.err_reader.take()]
            .into_iter()
            .flatten()
        {
            let _ = r.join();
        }
        self.log()
    }
}

impl Drop for ProbeRun {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probes_are_read_from_probe_rs_list() {
        let out = "The following debug probes were found:\n[0]: STLink V2-1 -- 0483:374b:066DFF555052836687031626 (ST-LINK)\n[1]: STLink V3 -- 0483:374e:002A00 (ST-LINK)\n";
        let probes = parse_list(out);
        assert_eq!(probes.len(), 2);
        assert!(probes[1].contains("0483:374e"));
        assert!(parse_list("No debug probes were found.\n").is_empty());
    }

    #[test]
    fn the_run_command_names_chip_format_and_image() {
        let cmd = command(
            "STM32F767ZITx",
            Path::new("target/hil/f767.elf"),
            Some("0483:374b"),
            false,
        );
        let args: Vec<_> = cmd
            .get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            args,
            [
                "run",
                "--chip",
                "STM32F767ZITx",
                "--log-format",
                "[{t} {L}] {s}",
                "--probe",
                "0483:374b",
                "--no-catch-hardfault",
                "--no-catch-reset",
                "target/hil/f767.elf"
            ]
        );
    }

    #[test]
    fn each_missing_thing_is_one_line() {
        for m in [
            Missing::ProbeRs("probe-rs".into()),
            Missing::Probe(None),
            Missing::Probe(Some("0483:374b".into())),
            Missing::List("permission denied".into()),
        ] {
            assert!(!m.line().contains('\n'), "{}", m.line());
        }
        assert!(Missing::ProbeRs("probe-rs".into()).line().contains(INSTALL));
    }

    #[test]
    fn the_log_keeps_what_the_program_said_on_stderr() {
        // As the rehosting engine says why it stopped an image.
        let mut cmd = Command::new("sh");
        cmd.args([
            "-c",
            "echo '[0.1 INFO] up'; echo 'rehost: stopped: a rule' >&2",
        ]);
        let mut run = ProbeRun::start(cmd).unwrap();
        // It ends by itself, as an engine that stopped the image does.
        let end = Instant::now() + Duration::from_secs(10);
        while run.stopped().is_none() && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        let log = Box::new(run).stop();
        assert!(log.contains(&"[0.1 INFO] up".to_string()), "{log:?}");
        assert!(
            log.contains(&"(stderr) rehost: stopped: a rule".to_string()),
            "{log:?}"
        );
    }
}
