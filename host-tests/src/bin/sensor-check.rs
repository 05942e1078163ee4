//! `cargo sensor-check [-- --sensor FILE]`: everything CI would say about
//! *your* sensor, in one command (issue 35): its file formatted, linted for
//! the host and the MCU (in `rri-active-sensor`, the crate that holds the
//! chosen sensor, and the firmware binary), its tests (the module in your
//! file: `cargo test -p rri-active-sensor`), both STM32 boards built with
//! their budgets and stack rule (`cargo boards`: the sensor's statics and
//! how much room is left), and the cycle path's panic check (`cargo
//! panic-check`), ending in one table. It installs what it needs first:
//! the MCU target, rustfmt, clippy, llvm-tools (rustup) and flip-link
//! (`cargo install`).
//!
//! The sensor is `--sensor FILE`, else `RRI_SENSOR` (from the command line
//! or `.cargo/config.toml`'s `[env]`), else the distance example. The GSI
//! settings (`RRI_GSI_DIR`, `RRI_DEVICE`, …) go to every step but `cargo
//! boards`, which always builds the manual's configuration (its budgets
//! are stated for it).
//!
//! Every step runs, whatever failed before it; exit 0 only when all
//! passed, 1 otherwise, 2 for a bad command line or a missing file.

use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

#[derive(Parser, Debug)]
#[command(
    name = "cargo sensor-check",
    about = "Format, lint (host and MCU), test, build both boards with their rules and check the panic paths, for your sensor",
    after_help = "The sensor: --sensor FILE, else RRI_SENSOR, else firmware/src/sensors/distance.rs. Exit 0: every step passed; 1: one failed; 2: bad arguments."
)]
struct Args {
    /// The sensor's Rust file (relative to the current directory); default RRI_SENSOR's.
    #[arg(long, value_name = "FILE")]
    sensor: Option<PathBuf>,
}

/// One step: what the table calls it, and the command.
struct Step {
    name: &'static str,
    program: String,
    args: Vec<String>,
    /// Whether the GSI settings of the caller reach it.
    gsi: bool,
}

impl Step {
    /// The command as the table names it: the program's name and the
    /// cargo subcommand (`cargo boards`, `rustfmt --check`).
    fn shown(&self) -> String {
        let program = Path::new(&self.program)
            .file_name()
            .map_or(self.program.clone(), |n| n.to_string_lossy().into_owned());
        match self.args.first() {
            Some(first) => format!("{program} {first}"),
            None => program,
        }
    }
}

/// The firmware's target (the QEMU board's features for the MCU lint:
/// the sensor is board-independent, and that board builds without
/// embassy-stm32).
const TARGET: &str = host_tests::qemu::TARGET;

fn steps(sensor: &Path) -> Vec<Step> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let step = |name, program: &str, args: &[&str], gsi| Step {
        name,
        program: program.into(),
        args: args.iter().map(|a| a.to_string()).collect(),
        gsi,
    };
    let file = sensor.display().to_string();
    vec![
        step(
            "format",
            "rustfmt",
            &["--check", "--edition", "2021", &file],
            false,
        ),
        step(
            "lint (host)",
            &cargo,
            &[
                "clippy",
                "-p",
                "rri-active-sensor",
                "--lib",
                "--tests",
                "--",
                "-D",
                "warnings",
            ],
            true,
        ),
        step(
            "lint (MCU)",
            &cargo,
            &[
                "clippy",
                "-p",
                "rri-active-sensor",
                "-p",
                "rri-sensor",
                "--lib",
                "--bins",
                "--release",
                "--target",
                TARGET,
                "--features",
                "rri-sensor/board,hal-board/mps2-an500",
                "--",
                "-D",
                "warnings",
            ],
            true,
        ),
        step(
            "tests",
            &cargo,
            &["test", "-p", "rri-active-sensor", "--lib"],
            true,
        ),
        step("both boards", &cargo, &["boards"], false),
        step("panic paths", &cargo, &["panic-check"], true),
    ]
}

/// The sensor file to check: `--sensor` (from the current directory),
/// else `RRI_SENSOR` (from the workspace root, as the build takes it),
/// else the distance example.
fn sensor_file(args: &Args, workspace: &Path) -> Result<PathBuf, String> {
    let (path, from) = match (&args.sensor, std::env::var("RRI_SENSOR")) {
        (Some(p), _) => (
            std::env::current_dir()
                .map_err(|e| format!("the current directory: {e}"))?
                .join(p),
            "--sensor",
        ),
        (None, Ok(p)) if !p.trim().is_empty() => (workspace.join(p.trim()), "RRI_SENSOR"),
        _ => (
            workspace.join("firmware/src/sensors/distance.rs"),
            "the default",
        ),
    };
    path.canonicalize()
        .map_err(|e| format!("{} ({from}): {e}", path.display()))
}

/// What is needed before any step: the MCU target, rustup's components,
/// flip-link. Each line says what was done; an error ends the check.
fn install() -> Result<(), String> {
    host_tests::mcu_target::ensure()?;
    let added = Command::new("rustup")
        .args(["component", "add", "rustfmt", "clippy", "llvm-tools"])
        .current_dir(host_tests::workspace())
        .status()
        .map_err(|e| format!("cannot run rustup: {e}"))?;
    if !added.success() {
        return Err(format!(
            "`rustup component add rustfmt clippy llvm-tools` failed ({added})"
        ));
    }
    if !on_path("flip-link") {
        println!("== flip-link is not installed: `cargo install flip-link --locked` (once)");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["install", "flip-link", "--locked"])
            .status()
            .map_err(|e| format!("cannot run cargo install: {e}"))?;
        if !status.success() {
            return Err(format!(
                "`cargo install flip-link --locked` failed ({status})"
            ));
        }
    }
    Ok(())
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(program).is_file()))
}

/// A row of the table: step, result, seconds.
fn table(rows: &[(&str, Result<(), String>, Duration)], sensor: &Path) -> String {
    let mut out = format!("\nyour sensor: {}\n\n", sensor.display());
    out.push_str("| step | result | seconds |\n|---|---|---:|\n");
    for (name, result, took) in rows {
        let verdict = match result {
            Ok(()) => "passed".to_string(),
            Err(e) => format!("**FAILED**: {e}"),
        };
        out.push_str(&format!(
            "| {name} | {verdict} | {:.0} |\n",
            took.as_secs_f64()
        ));
    }
    out
}

fn main() -> ExitCode {
    let args = Args::parse();
    let ws = host_tests::workspace();
    let sensor = match sensor_file(&args, &ws) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: no sensor file: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = install() {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let mut rows = Vec::new();
    for step in steps(&sensor) {
        println!("== {}: {} {}", step.name, step.program, step.args.join(" "));
        let mut cmd = Command::new(&step.program);
        cmd.args(&step.args).current_dir(&ws);
        // Only `--sensor` changes the environment: a build with the
        // sensor the caller already set (or the default) stays the one
        // cargo has, not a rebuild for the same file named otherwise.
        if args.sensor.is_some() {
            cmd.env("RRI_SENSOR", &sensor);
        }
        if !step.gsi {
            for var in gsi_config::BUILD_SETTINGS {
                cmd.env_remove(var);
            }
        }
        let start = Instant::now();
        let result = match cmd.status() {
            Ok(s) if s.success() => Ok(()),
            Ok(s) => Err(format!("`{}` exited with {s}", step.shown())),
            Err(e) => Err(format!("cannot run {}: {e}", step.program)),
        };
        rows.push((step.name, result, start.elapsed()));
    }
    print!("{}", table(&rows, &sensor));
    if rows.iter().all(|(_, r, _)| r.is_ok()) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_consistent() {
        Args::command().debug_assert();
    }

    #[test]
    fn every_step_the_issue_names_runs_on_the_sensor_given() {
        let steps = steps(Path::new("/x/seam.rs"));
        let names: Vec<&str> = steps.iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            [
                "format",
                "lint (host)",
                "lint (MCU)",
                "tests",
                "both boards",
                "panic paths"
            ]
        );
        assert_eq!(steps[0].args.last().map(String::as_str), Some("/x/seam.rs"));
        assert!(steps[2].args.iter().any(|a| a == TARGET));
        // The boards' budgets are stated for the manual's configuration.
        assert!(!steps[4].gsi && steps[1].gsi);
        assert_eq!(steps[4].shown(), "cargo boards");
        assert_eq!(steps[0].shown(), "rustfmt --check");
    }

    #[test]
    fn a_missing_file_is_named_with_where_it_came_from() {
        let args = Args::parse_from(["sensor-check", "--sensor", "no/such/sensor.rs"]);
        let e = sensor_file(&args, Path::new("/")).unwrap_err();
        assert!(e.contains("no/such/sensor.rs (--sensor)"), "{e}");
    }

    #[test]
    fn the_table_names_each_failure() {
        let rows = [
            ("format", Ok(()), Duration::from_secs(1)),
            (
                "both boards",
                Err("`cargo` exited with exit status: 1".to_string()),
                Duration::from_secs(70),
            ),
        ];
        let t = table(&rows, Path::new("/x/seam.rs"));
        assert!(t.contains("| format | passed | 1 |"), "{t}");
        assert!(
            t.contains("| both boards | **FAILED**: `cargo` exited"),
            "{t}"
        );
        assert!(t.contains("your sensor: /x/seam.rs"), "{t}");
    }
}
