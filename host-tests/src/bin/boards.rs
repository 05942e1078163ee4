//! `cargo boards [-- --board f767|h743]`: builds each STM32 board once
//! through its alias (`cargo build-f767`, `cargo build-h743`) from the
//! manual's configuration, checks its ELF against the board's memory map
//! and placement rules (`host_tests::board_map`: DMA rings uncached and
//! reachable, stack and statics in the DTCM), prints its sections (as
//! `size -A` does) and fails when one is broken or flash or static RAM is
//! over the board's budget. It builds the board's bootloader too
//! (`cargo build-f767-boot`, `build-h743-boot`), checks that each image
//! lies in its partition and prints the partition table with what each
//! image leaves free. CI runs it; no board is needed.

use clap::{Parser, ValueEnum};
use host_tests::boards::{self, Board, BOARDS};
use std::process::ExitCode;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Which {
    F767,
    H743,
    All,
}

#[derive(Parser, Debug)]
#[command(
    name = "cargo boards",
    about = "Build the STM32 boards' firmware and check it against their memory maps and budgets"
)]
struct Args {
    /// Which board to build.
    #[arg(long, value_enum, default_value_t = Which::All)]
    board: Which,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let chosen: Vec<&Board> = BOARDS
        .iter()
        .filter(|b| match args.board {
            Which::F767 => b.alias == "build-f767",
            Which::H743 => b.alias == "build-h743",
            Which::All => true,
        })
        .collect();
    let mut failed = false;
    let mut table = Vec::new();
    for board in chosen {
        let mut stack = None;
        let mut sensor = None;
        let result = boards::build(board).and_then(|elf| {
            // Printed first, so an image over budget shows where the bytes
            // went.
            stack = print_sections(board, &elf, &host_tests::memory_map::sections(&elf)?);
            sensor = host_tests::memory_map::sensor_statics(&elf)?;
            let usage = boards::check(board, &elf)?;
            // The bootloader the chip starts (issue 43), and where both
            // images lie in the board's flash.
            let boot = boards::build_boot(board)?;
            let map = boards::flash_map(board)?;
            host_tests::flash_map::check(&map, &boot, &elf)?;
            println!("partitions ({}):", board.flash_map);
            for line in host_tests::flash_map::table(&map, &boot, &elf)? {
                println!("  {line}");
            }
            Ok(usage)
        });
        if let Err(e) = &result {
            eprintln!("error: {e}");
            failed = true;
        }
        table.push((board, result, stack, sensor));
    }
    // Whatever failed: a row per board.
    println!();
    println!("| board | flash | budget | static RAM | budget | the sensor's statics | statics may still grow by |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (b, result, stack, sensor) in &table {
        let sensor = sensor.map_or("?".to_string(), |s| format!("{s} B"));
        // What the statics may still take before the stack rule (80 KiB of
        // the DTCM for the stack): a sensor's statics come out of this.
        let room = stack.map_or("?".to_string(), |s| {
            let room = s as i64 - host_tests::board_map::MIN_STACK as i64;
            format!("{room} B")
        });
        match result {
            Ok(u) => println!(
                "| {} | {} B ({:.1} KiB) | {:.1} KiB | {} B ({:.1} KiB) | {:.1} KiB | {sensor} | {room} |",
                b.name,
                u.flash,
                kib(u.flash),
                kib(b.flash_budget),
                u.ram,
                kib(u.ram),
                kib(b.ram_budget)
            ),
            Err(e) => println!(
                "| {} | failed: {} | | | | {sensor} | {room} |",
                b.name,
                e.lines().last().unwrap_or("").trim()
            ),
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn kib(bytes: u64) -> f64 {
    bytes as f64 / 1024.0
}

/// Prints the sections as `size -A` does; returns the stack region.
fn print_sections(
    board: &Board,
    elf: &std::path::Path,
    sections: &[(String, u64, u64)],
) -> Option<u64> {
    println!("\n{} ({}):", board.name, elf.display());
    println!("{:<16} {:>8} {:>12}", "section", "size", "addr");
    for (name, addr, size) in sections {
        println!("{name:<16} {size:>8} {addr:>#12x}");
    }
    if let Some(stack) = host_tests::board_map::Image::read(elf)
        .ok()
        .as_ref()
        .and_then(host_tests::board_map::stack_bytes)
    {
        println!("stack region     {stack:>8} (the DTCM the statics leave)");
        return Some(stack);
    }
    None
}

#[cfg(test)]
mod command_line {
    /// clap's own consistency checks (unique names and flags): a clash
    /// would otherwise show only as a panic in a debug build.
    #[test]
    fn is_consistent() {
        <super::Args as clap::CommandFactory>::command().debug_assert();
    }
}
