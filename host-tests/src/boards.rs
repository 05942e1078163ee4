//! The STM32 boards' builds as CI checks them: each board built once
//! through its public alias (`cargo build-f767`, `cargo build-h743`), its
//! ELF checked against the board's memory map and placement rules
//! ([`crate::board_map`]), and its flash and static RAM against the
//! budgets.

use crate::memory_map::{check_memory_map, regions, sections};
use std::path::{Path, PathBuf};
use std::process::Command;

/// One STM32 board: how it is built and what it may use.
#[derive(Clone, Copy, Debug)]
pub struct Board {
    /// The name users know (and the ELF's name under `target/boards/`).
    pub name: &'static str,
    /// The cargo alias that builds it.
    pub alias: &'static str,
    /// Its linker memory map, from the workspace root.
    pub memory_map: &'static str,
    /// Flash budget in bytes: code, read-only data and `.data`'s image.
    pub flash_budget: u64,
    /// Static RAM budget in bytes: `.data`, `.bss`, `.uninit` (the stack
    /// takes the rest of RAM).
    pub ram_budget: u64,
    /// The cargo alias that builds its bootloader (`firmware/rri-boot`).
    pub boot_alias: &'static str,
    /// Its flash partitions, the map both images link with.
    pub flash_map: &'static str,
}

const KIB: u64 = 1024;

/// The boards, each within 256 KiB of flash and 96 KiB of static RAM with
/// the manual's configuration and defmt on: room for the integrator's own
/// code, and for a port to a 512 KiB STM32F4 later (both NUCLEOs have
/// 2 MiB of flash and 512 KiB or more of RAM).
pub const BOARDS: [Board; 2] = [
    Board {
        name: "nucleo-f767zi",
        alias: "build-f767",
        memory_map: "memory.x",
        flash_budget: 256 * KIB,
        ram_budget: 96 * KIB,
        boot_alias: "build-f767-boot",
        flash_map: "hal-board/memory/nucleo-f767zi-flash.x",
    },
    Board {
        name: "nucleo-h743zi",
        alias: "build-h743",
        memory_map: "hal-board/memory/nucleo-h743zi.x",
        flash_budget: 256 * KIB,
        ram_budget: 96 * KIB,
        boot_alias: "build-h743-boot",
        flash_map: "hal-board/memory/nucleo-h743zi-flash.x",
    },
];

/// Builds `board` with its alias from the manual's configuration (the
/// firmware's default GSI folder: `RRI_GSI_DIR` and `RRI_DEVICE` are
/// cleared) and copies the ELF to `target/boards/<name>.elf`. The alias
/// builds in the board's own target directory ([`image_dir`]).
pub fn build(board: &Board) -> Result<PathBuf, String> {
    crate::mcu_target::ensure()?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(crate::workspace())
        .env_remove("RRI_GSI_DIR")
        .env_remove("RRI_DEVICE")
        .arg(board.alias)
        .status()
        .map_err(|e| format!("cannot run {cargo}: {e}"))?;
    if !status.success() {
        return Err(format!("`cargo {}` failed ({status})", board.alias));
    }
    crate::qemu::keep_image_from(&image_dir(board), "boards", board.name)
}

/// Builds `board`'s bootloader with its alias (once per process: the
/// rehosted runs each need it) and copies the ELF to
/// `target/boards/<name>-boot.elf`.
pub fn build_boot(board: &Board) -> Result<PathBuf, String> {
    static BUILT: std::sync::Mutex<Vec<(&str, PathBuf)>> = std::sync::Mutex::new(Vec::new());
    let mut built = BUILT
        .lock()
        .map_err(|_| "the bootloaders' build lock is poisoned")?;
    if let Some((_, elf)) = built.iter().find(|(name, _)| *name == board.name) {
        return Ok(elf.clone());
    }
    crate::mcu_target::ensure()?;
    crate::cargo(
        &[board.boot_alias],
        &format!("`cargo {}`", board.boot_alias),
    )?;
    let from = image_dir(board)
        .join(crate::qemu::TARGET)
        .join(crate::qemu::PROFILE)
        .join("rri-boot");
    let dir = crate::qemu::target_dir().join("boards");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let elf = dir.join(format!("{}-boot.elf", board.name));
    std::fs::copy(&from, &elf)
        .map_err(|e| format!("{} → {}: {e}", from.display(), elf.display()))?;
    built.push((board.name, elf.clone()));
    Ok(elf)
}

/// `board`'s flash map's text.
pub fn flash_map(board: &Board) -> Result<String, String> {
    let path = crate::workspace().join(board.flash_map);
    std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The target directory `board`'s alias builds in (its own, so that one
/// board's image never replaces the other's: `.cargo/config.toml`).
pub fn image_dir(board: &Board) -> PathBuf {
    crate::workspace().join("target").join(board.name)
}

/// What an image takes, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Usage {
    pub flash: u64,
    pub ram: u64,
}

/// Flash: every allocated section in the map's first region (FLASH) plus
/// `.data`, whose initial values are stored there too. RAM: every section
/// in any other region.
pub fn usage(sections: &[(String, u64, u64)], regions: &[(String, u64, u64)]) -> Usage {
    let Some((_, flash_origin, flash_len)) = regions.first() else {
        return Usage::default();
    };
    let in_flash = |addr: u64| addr >= *flash_origin && addr < flash_origin + flash_len;
    let mut u = Usage::default();
    for (name, addr, size) in sections {
        if in_flash(*addr) {
            u.flash += size;
        } else {
            u.ram += size;
            if name == ".data" {
                u.flash += size;
            }
        }
    }
    u
}

/// Checks a built ELF: linked for the board's memory map, placed as the
/// board's caches and DMA need ([`crate::board_map`]), within budget.
/// Returns its usage, or every failure.
pub fn check(board: &Board, elf: &Path) -> Result<Usage, String> {
    let map_path = crate::workspace().join(board.memory_map);
    let map =
        std::fs::read_to_string(&map_path).map_err(|e| format!("{}: {e}", map_path.display()))?;
    let regions = regions(&map).map_err(|e| format!("{}: {e}", map_path.display()))?;
    let sections = sections(elf)?;
    check_memory_map(&sections, &regions).map_err(|e| format!("{}: {e}", board.name))?;
    let rules = crate::board_map::placement(board.name)
        .ok_or_else(|| format!("{}: no placement rules in board_map.rs", board.name))?;
    crate::board_map::check(rules, &crate::board_map::Image::read(elf)?)
        .map_err(|e| format!("{}: memory placement:\n  {e}", board.name))?;
    let u = usage(&sections, &regions);
    let mut over = Vec::new();
    if u.flash > board.flash_budget {
        over.push(format!(
            "flash {} B > budget {} B",
            u.flash, board.flash_budget
        ));
    }
    if u.ram > board.ram_budget {
        over.push(format!(
            "static RAM {} B > budget {} B",
            u.ram, board.ram_budget
        ));
    }
    if over.is_empty() {
        Ok(u)
    } else {
        Err(format!("{}: {}", board.name, over.join(", ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f767_map() -> Vec<(String, u64, u64)> {
        regions(&std::fs::read_to_string(crate::workspace().join("memory.x")).unwrap()).unwrap()
    }

    #[test]
    fn data_counts_in_flash_and_ram() {
        let sections = [
            (".vector_table".to_string(), 0x0808_0000, 0x1f8),
            (".text".to_string(), 0x0808_01f8, 0x1000),
            (".rodata".to_string(), 0x0808_11f8, 0x200),
            (".data".to_string(), 0x2007_0000, 0x100),
            (".bss".to_string(), 0x2007_0100, 0x800),
            (".uninit".to_string(), 0x2007_0900, 0x400),
        ];
        assert_eq!(
            usage(&sections, &f767_map()),
            Usage {
                flash: 0x1f8 + 0x1000 + 0x200 + 0x100,
                ram: 0x100 + 0x800 + 0x400
            }
        );
    }

    #[test]
    fn the_maps_put_ram_in_the_dtcm_and_the_dma_rings_where_the_dma_reaches() {
        // FLASH is the active partition of the board's flash map (issue 43).
        for (board, dma, active) in [
            (&BOARDS[0], 0x2002_0000, (0x0802_0000, 768 * KIB)),
            (&BOARDS[1], 0x2400_0000, (0x0802_0000, 768 * KIB)),
        ] {
            let map = std::fs::read_to_string(crate::workspace().join(board.memory_map)).unwrap();
            let r = regions(&map).unwrap();
            assert_eq!(r[0], ("FLASH".to_string(), active.0, active.1));
            let flash = flash_map(board).unwrap();
            let part = crate::flash_map::partitions(&flash).unwrap();
            assert!(
                part.contains(&("active", active.0 as u32, active.1 as u32)),
                "{part:?}"
            );
            assert_eq!(
                r[1],
                ("RAM".to_string(), 0x2000_0000, 128 * KIB),
                "{}",
                board.name
            );
            assert_eq!(r[2].0, "DMA_RAM");
            assert_eq!(r[2].1, dma, "{}", board.name);
            let rules = crate::board_map::placement(board.name).unwrap();
            assert_eq!(rules.dtcm.start, r[1].1);
            assert_eq!(rules.dtcm.end, r[1].1 + r[1].2);
        }
        // An image linked with the QEMU board's map (RAM from 0x2000_0000,
        // 4 MiB) is refused.
        let map = std::fs::read_to_string(crate::workspace().join(BOARDS[1].memory_map)).unwrap();
        let qemu = [
            (".vector_table".to_string(), 0x0802_0000, 0x1f8),
            (".bss".to_string(), 0x2010_0000, 0x100),
        ];
        assert!(check_memory_map(&qemu, &regions(&map).unwrap()).is_err());
    }
}
