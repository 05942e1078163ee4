//! `cargo panic-check [-- --selftest]`: panic-freedom of the firmware's
//! cycle path, from the machine code the MCU would run.
//!
//! Builds `firmware/active-sensor/src/bin/panic-check.rs` (the whole cycle path on
//! inputs the optimizer cannot see) for the MCU with the firmware profile,
//! disassembles it with `llvm-objdump` (rustup's `llvm-tools`), and finds
//! every call that code outside the standard library makes to a panic
//! entry point (`core::panicking::*`, failed slice indexing, `unwrap` on
//! `None`/`Err`, …) or to a standard-library function that may reach one.
//! Each is attributed to the source line the debug info gives for it (the
//! innermost inline frame outside the standard library, read from the
//! image's DWARF with `addr2line`: at opt-level 3 a dependency's code is
//! inlined into ours, and the line table alone names only the innermost
//! frame) and listed by crate.
//!
//! Fails when any remaining panic path lies in the firmware crate
//! (`firmware/src/…`) or the sensor (`firmware/active-sensor/src/…`, and
//! the file `RRI_SENSOR` names wherever it lives: `cargo sensor-check`
//! runs this on yours). Paths inside dependencies are listed, not failed:
//! they are the dependency's own internal checks (see the README).
//! `--selftest` builds the image with a deliberate out-of-bounds index
//! (feature `panic-check-selftest`) and succeeds only if it is found.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const PANIC_ENTRIES: [&str; 9] = [
    "core::panicking::",
    "core::slice::index::slice_index_fail",
    "core::slice::index::slice_end_index_len_fail",
    "core::slice::index::slice_start_index_len_fail",
    "core::option::unwrap_failed",
    "core::option::expect_failed",
    "core::result::unwrap_failed",
    "core::str::slice_error_fail",
    "core::slice::copy_from_slice_impl::len_mismatch_fail",
];

/// One call to a panic entry point.
#[derive(Debug)]
struct Site {
    function: String,
    entry: String,
    /// `file:line` of the innermost frame outside the standard library.
    source: String,
}

fn llvm_objdump() -> Result<PathBuf, String> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    let sysroot = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let host = Command::new("rustc")
        .arg("-vV")
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    let host = String::from_utf8_lossy(&host.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or("no host triple in `rustc -vV`")?;
    let path = Path::new(&sysroot)
        .join("lib/rustlib")
        .join(host)
        .join("bin/llvm-objdump");
    if path.exists() {
        return Ok(path);
    }
    // Installed once, as the MCU target is (`mcu_target::ensure`).
    eprintln!(
        "{} is missing: `rustup component add llvm-tools` (once)…",
        path.display()
    );
    let added = Command::new("rustup")
        .current_dir(host_tests::workspace())
        .args(["component", "add", "llvm-tools"])
        .status()
        .is_ok_and(|s| s.success());
    if added && path.exists() {
        Ok(path)
    } else {
        Err(format!(
            "{} is missing: install it with `rustup component add llvm-tools`",
            path.display()
        ))
    }
}

fn build(selftest: bool) -> Result<PathBuf, String> {
    host_tests::mcu_target::ensure()?;
    let ws = host_tests::workspace();
    let features = if selftest {
        "panic-check,panic-check-selftest"
    } else {
        "panic-check"
    };
    let target_dir = ws.join("target/panic-check");
    let status = Command::new(env!("CARGO"))
        .current_dir(&ws)
        .args([
            "build",
            "-q",
            "-p",
            "rri-active-sensor",
            "--bin",
            "panic-check",
            "--profile",
            "firmware",
            "--target",
            "thumbv7em-none-eabihf",
            "--features",
            features,
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err("building the panic-check image failed".into());
    }
    Ok(target_dir.join("thumbv7em-none-eabihf/firmware/panic-check"))
}

/// Whether a function belongs to the standard library (its panic calls
/// are attributed to the caller outside it).
fn is_core(function: &str) -> bool {
    [
        "core::",
        "<core::",
        "<&",
        "<[",
        "<str",
        "<u",
        "<i",
        "<f32",
        "<f64",
        "compiler_builtins::",
    ]
    .iter()
    .any(|p| function.starts_with(p))
        || function.contains("rust_begin_unwind")
}

type Dwarf<'a> = addr2line::gimli::EndianSlice<'a, addr2line::gimli::RunTimeEndian>;

/// The image's debug info (`elf` is its bytes), for the inline frames of
/// an address.
fn debug_info(elf: &[u8]) -> Result<addr2line::Context<Dwarf<'_>>, String> {
    use addr2line::gimli;
    use object::{Object, ObjectSection};
    let file = object::File::parse(elf).map_err(|e| format!("the image: {e}"))?;
    let endian = if file.is_little_endian() {
        gimli::RunTimeEndian::Little
    } else {
        gimli::RunTimeEndian::Big
    };
    let section = |id: gimli::SectionId| -> Result<Dwarf<'_>, gimli::Error> {
        let bytes = file
            .section_by_name(id.name())
            .and_then(|s| s.data().ok())
            .unwrap_or(&[]);
        Ok(gimli::EndianSlice::new(bytes, endian))
    };
    let dwarf = gimli::Dwarf::load(section).map_err(|e| format!("DWARF: {e}"))?;
    addr2line::Context::from_dwarf(dwarf).map_err(|e| format!("DWARF: {e}"))
}

/// `file:line` of the innermost inline frame at `addr` outside the
/// standard library; empty when the debug info has none.
fn frame_at(lines: &addr2line::Context<Dwarf<'_>>, addr: u64) -> String {
    let Ok(mut frames) = lines.find_frames(addr).skip_all_loads() else {
        return String::new();
    };
    while let Ok(Some(frame)) = frames.next() {
        if let Some(addr2line::Location {
            file: Some(file),
            line: Some(line),
            ..
        }) = frame.location
        {
            if !file.starts_with("/rustc/") {
                return format!("{file}:{line}");
            }
        }
    }
    String::new()
}

fn sites(objdump: &Path, elf: &Path) -> Result<Vec<Site>, String> {
    let image = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let lines = debug_info(&image)?;
    let out = Command::new(objdump)
        .args(["-d", "--demangle"])
        .arg(elf)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", objdump.display()))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // Every call (and tail call): caller, callee, source line at the call.
    let mut calls: Vec<(String, String, String)> = Vec::new();
    let mut function = String::new();
    for line in text.lines() {
        if let Some(name) = line
            .strip_suffix(">:")
            .and_then(|l| l.split_once(" <"))
            .map(|(_, n)| n)
        {
            function = name.to_string();
        } else if let Some(target) = line.split(" <").nth(1).and_then(|t| t.rsplit_once('>')) {
            let is_call = ["\tbl\t", "\tb.w\t", "\tb\t", "\tblx\t"]
                .iter()
                .any(|m| line.contains(m));
            let callee = target.0.split('+').next().unwrap_or(target.0);
            // `  80001f8: f7ff fffe  \tbl\t…`: the call's address.
            let addr = line
                .split_once(':')
                .and_then(|(a, _)| u64::from_str_radix(a.trim(), 16).ok());
            if let (true, Some(addr)) = (is_call && callee != function, addr) {
                calls.push((function.clone(), callee.to_string(), frame_at(&lines, addr)));
            }
        }
    }
    // Standard-library functions that may reach a panic entry.
    let mut may_panic: std::collections::HashSet<String> = calls
        .iter()
        .map(|c| c.1.clone())
        .filter(|c| PANIC_ENTRIES.iter().any(|p| c.starts_with(p)))
        .collect();
    loop {
        let more: Vec<String> = calls
            .iter()
            .filter(|(caller, callee, _)| {
                is_core(caller) && may_panic.contains(callee) && !may_panic.contains(caller)
            })
            .map(|c| c.0.clone())
            .collect();
        if more.is_empty() {
            break;
        }
        may_panic.extend(more);
    }
    Ok(calls
        .into_iter()
        .filter(|(caller, callee, _)| !is_core(caller) && may_panic.contains(callee))
        .map(|(function, entry, source)| Site {
            function,
            entry,
            source,
        })
        .collect())
}

/// Whose a panic path is: the crate of its source line, else (a call with
/// no line outside the standard library) the crate of the function it is
/// in.
fn owner(site: &Site) -> String {
    match source_owner(&site.source) {
        Some(who) => who,
        None => site
            .function
            .trim_start_matches('<')
            .split("::")
            .next()
            .filter(|c| !c.is_empty())
            .map_or("unknown".into(), |c| {
                format!("{} (no source line)", c.replace("rri_firmware", "firmware"))
            }),
    }
}

/// `firmware`, a dependency's name, or `None` without a source line.
fn source_owner(source: &str) -> Option<String> {
    // The firmware crate, the framer it takes from rri-framing, and the
    // active sensor (its crate, and its file wherever it lives: the
    // sensor runs in the cycle too).
    let ours = [
        "firmware/src/",
        "firmware/rri-framing/src/",
        "firmware/active-sensor/src/",
    ];
    let sensor = sensor_file();
    if ours
        .iter()
        .any(|dir| source.contains(&format!("/{dir}")) || source.starts_with(dir))
        || sensor.as_deref().is_some_and(|f| source.starts_with(f))
    {
        Some("firmware".into())
    } else if let Some(rest) = source.split("/registry/src/").nth(1) {
        // `…/registry/src/<index>/<crate>-<version>/src/…`
        Some(rest.split('/').nth(1).unwrap_or("crates.io").to_string())
    } else if source.is_empty() {
        None
    } else {
        source.split('/').next().map(str::to_string)
    }
}

/// The sensor file `RRI_SENSOR` names, absolute (as the image's debug
/// information gives it), when it is set.
fn sensor_file() -> Option<String> {
    let set = std::env::var("RRI_SENSOR").ok()?;
    let path = host_tests::workspace().join(set.trim());
    let path = path.canonicalize().unwrap_or(path);
    Some(path.to_string_lossy().into_owned())
}

fn run(selftest: bool) -> Result<bool, String> {
    let objdump = llvm_objdump()?;
    let elf = build(selftest)?;
    let found = sites(&objdump, &elf)?;
    let mut by_owner: std::collections::BTreeMap<String, Vec<&Site>> = Default::default();
    for s in &found {
        by_owner.entry(owner(s)).or_default().push(s);
    }
    println!(
        "panic paths in the cycle-path image ({}): {} calls",
        elf.display(),
        found.len()
    );
    for (who, list) in &by_owner {
        // One line per panic entry and source line (at opt-level 3 one
        // check is often inlined in several places).
        let mut lines: std::collections::BTreeMap<(String, String), (usize, &str)> =
            Default::default();
        for s in list {
            // `…::contains::h0123…` → `str>::contains`: the name, not the hash.
            let name = match s.entry.rsplit_once("::h") {
                Some((n, hash)) if hash.len() == 16 => n,
                _ => s.entry.as_str(),
            };
            let entry = name.rsplit("::").take(2).collect::<Vec<_>>();
            let entry = entry.iter().rev().cloned().collect::<Vec<_>>().join("::");
            let source = s.source.rsplit("/src/").next().unwrap_or(&s.source);
            let line = lines
                .entry((source.to_string(), entry))
                .or_insert((0, &s.function));
            line.0 += 1;
        }
        println!("  {who}: {} calls at {} places", list.len(), lines.len());
        for ((source, entry), (n, function)) in &lines {
            let f: String = function.chars().take(50).collect();
            println!("    {source:<22} {entry:<34} ×{n:<3} e.g. in {f}");
        }
    }
    let ours: usize = by_owner
        .iter()
        .filter(|(who, _)| who.starts_with("firmware"))
        .map(|(_, l)| l.len())
        .sum();
    if selftest {
        let caught = by_owner
            .get("firmware")
            .is_some_and(|l| l.iter().any(|s| s.source.contains("panic-check.rs")));
        if caught {
            println!("selftest: the deliberate panic path was found");
        } else {
            println!("selftest FAILED: the deliberate panic path was not found");
        }
        return Ok(caught);
    }
    if ours > 0 {
        println!("FAIL: {ours} panic path(s) in the firmware crate or the sensor");
        Ok(false)
    } else {
        println!("ok: no panic path in the firmware crate's cycle path or the sensor");
        Ok(true)
    }
}

fn main() -> ExitCode {
    let selftest = std::env::args().any(|a| a == "--selftest");
    match run(selftest) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
