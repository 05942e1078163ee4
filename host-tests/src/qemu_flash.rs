//! What QEMU loads into the QEMU board's flash (issue 43): the bootloader
//! (`firmware/rri-boot`) at 0, as its ELF, and the application as the
//! factory image, a raw blob in the FACTORY region, which the bootloader
//! copies into the active partition once (`hal-board/memory/
//! mps2-an500-flash.x` says why the application is not loaded into the
//! active partition itself: QEMU's reset would undo every swap).
//!
//! The regions are read from that memory map, the one both images link
//! with, so that this side cannot drift from it.

use crate::mcu_target::{target_dir, PROFILE, TARGET};

/// The features that pick the QEMU board.
pub const BOARD_FEATURES: &str = "board,hal-board/mps2-an500";
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The board's partitions, as its memory map states them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Regions {
    /// Where QEMU loads the factory image.
    pub factory: u32,
    /// The most it may hold.
    pub factory_len: u32,
    /// Where the application is linked.
    pub active: u32,
}

/// The memory map both images link with.
pub fn map_path() -> PathBuf {
    crate::workspace().join("hal-board/memory/mps2-an500-flash.x")
}

use crate::flash_map::value;

/// Reads `__factory`, `__factory_len` and `__update_active` from the map's
/// text.
pub fn regions(map: &str) -> Result<Regions, String> {
    Ok(Regions {
        factory: value(map, "__factory")?,
        factory_len: value(map, "__factory_len")?,
        active: value(map, "__update_active")?,
    })
}

/// The partition table with what the bootloader `boot` and the
/// application `app` (ELFs) take of theirs, one line each.
pub fn table(boot: &Path, app: &Path) -> Result<Vec<String>, String> {
    let map = std::fs::read_to_string(map_path())
        .map_err(|e| format!("{}: {e}", map_path().display()))?;
    crate::flash_map::table(&map, boot, app)
}

/// The factory image of the application `elf`: its flash bytes, which
/// must be linked at the active partition and fit the factory region.
pub fn factory_image(elf: &[u8], regions: &Regions) -> Result<Vec<u8>, String> {
    let (origin, image) = crate::update_file::flat_image(elf)?;
    if origin != regions.active {
        return Err(format!(
            "the image is linked at {origin:#010x}, not at the QEMU board's active partition ({:#010x}): built before the board had a bootloader? rebuild it",
            regions.active
        ));
    }
    if image.len() > regions.factory_len as usize {
        return Err(format!(
            "the image has {} bytes; the QEMU board's factory region holds {}",
            image.len(),
            regions.factory_len
        ));
    }
    Ok(image)
}

/// QEMU's arguments that put the bootloader and `elf` (the application)
/// in the board's flash: `-kernel` the bootloader, `-device loader` the
/// factory image, written beside `elf` as `<elf>.factory.bin`.
pub fn load_args(elf: &Path) -> Result<Vec<String>, String> {
    let map = std::fs::read_to_string(map_path())
        .map_err(|e| format!("{}: {e}", map_path().display()))?;
    let regions = regions(&map)?;
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let image = factory_image(&bytes, &regions).map_err(|e| format!("{}: {e}", elf.display()))?;
    let blob = elf.with_extension("factory.bin");
    std::fs::write(&blob, image).map_err(|e| format!("{}: {e}", blob.display()))?;
    let boot = bootloader()?;
    Ok(vec![
        "-kernel".into(),
        boot.display().to_string(),
        "-device".into(),
        format!(
            "loader,file={},addr={:#x},force-raw=on",
            blob.display(),
            regions.factory
        ),
    ])
}

/// The bootloader's ELF, `target/qemu/rri-boot.elf`: built once per
/// process (`cargo build-qemu-boot`; cargo's own check when it is up to
/// date).
pub fn bootloader() -> Result<PathBuf, String> {
    static BUILT: Mutex<Option<PathBuf>> = Mutex::new(None);
    let mut built = BUILT
        .lock()
        .map_err(|_| "the bootloader's build lock is poisoned")?;
    if let Some(elf) = built.as_ref() {
        return Ok(elf.clone());
    }
    crate::mcu_target::ensure()?;
    crate::cargo(
        &[
            "build",
            "-p",
            "rri-boot",
            "--bin",
            "rri-boot",
            "--profile",
            PROFILE,
            "--target",
            TARGET,
            "--features",
            BOARD_FEATURES,
        ],
        "the bootloader's build",
    )?;
    let from = target_dir().join(TARGET).join(PROFILE).join("rri-boot");
    let dir = target_dir().join("qemu");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let elf = dir.join("rri-boot.elf");
    std::fs::copy(&from, &elf)
        .map_err(|e| format!("{} → {}: {e}", from.display(), elf.display()))?;
    *built = Some(elf.clone());
    Ok(elf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_regions_are_read_from_the_map_both_images_link_with() {
        let map = std::fs::read_to_string(map_path()).unwrap();
        let r = regions(&map).unwrap();
        assert_eq!(r.factory, 0x0001_0000);
        assert_eq!(r.factory_len, 960 * 1024);
        assert_eq!(r.active, 0x0010_0000);
    }

    #[test]
    fn the_partitions_are_listed_in_flash_order_apart() {
        let map = std::fs::read_to_string(map_path()).unwrap();
        let p = crate::flash_map::partitions(&map).unwrap();
        assert_eq!(p.len(), 5);
        for pair in p.windows(2) {
            assert!(pair[0].1 + pair[0].2 <= pair[1].1, "{pair:?}");
        }
        assert_eq!(p[0], ("bootloader", 0, 64 * 1024));
    }

    #[test]
    fn a_map_without_a_region_or_with_an_expression_it_cannot_read_is_refused() {
        assert!(regions("__factory = 0x10000;\n__factory_len = 960K;\n")
            .unwrap_err()
            .contains("__update_active"));
        let e =
            regions("__factory = 0x10000;\n__factory_len = LENGTH(FLASH);\n__update_active = 0;\n")
                .unwrap_err();
        assert!(e.contains("LENGTH(FLASH)"), "{e}");
        let r = regions("__factory = 1K + 0x10;\n__factory_len = 4K;\n__update_active = 0x100;\n")
            .unwrap();
        assert_eq!((r.factory, r.factory_len, r.active), (1040, 4096, 0x100));
        // `__factory_len` is not read as `__factory`.
        assert!(regions("__factory_len = 4K;\n__update_active = 0;\n")
            .unwrap_err()
            .contains("`__factory = …;`"));
    }

    /// A 32-bit ELF with one loaded segment of `len` bytes at `at`.
    fn elf(at: u32, len: usize) -> Vec<u8> {
        let mut e = vec![0u8; 52 + 32];
        e[..4].copy_from_slice(b"\x7fELF");
        e[4] = 1; // 32-bit
        e[5] = 1; // little-endian
        e[6] = 1;
        e[16..18].copy_from_slice(&2u16.to_le_bytes()); // executable
        e[18..20].copy_from_slice(&40u16.to_le_bytes()); // Arm
        e[20..24].copy_from_slice(&1u32.to_le_bytes());
        e[28..32].copy_from_slice(&52u32.to_le_bytes()); // program headers
        e[40..42].copy_from_slice(&52u16.to_le_bytes());
        e[42..44].copy_from_slice(&32u16.to_le_bytes());
        e[44..46].copy_from_slice(&1u16.to_le_bytes());
        let ph = &mut e[52..84];
        ph[0..4].copy_from_slice(&1u32.to_le_bytes()); // PT_LOAD
        ph[4..8].copy_from_slice(&84u32.to_le_bytes()); // offset
        ph[8..12].copy_from_slice(&at.to_le_bytes());
        ph[12..16].copy_from_slice(&at.to_le_bytes());
        ph[16..20].copy_from_slice(&(len as u32).to_le_bytes());
        ph[20..24].copy_from_slice(&(len as u32).to_le_bytes());
        e.extend(std::iter::repeat_n(0xA5, len));
        e
    }

    #[test]
    fn the_factory_image_must_be_linked_at_the_active_partition_and_fit() {
        let r = Regions {
            factory: 0x1_0000,
            factory_len: 4096,
            active: 0x10_0000,
        };
        assert_eq!(
            factory_image(&elf(0x10_0000, 64), &r).unwrap(),
            vec![0xA5; 64]
        );
        let e = factory_image(&elf(0, 64), &r).unwrap_err();
        assert!(
            e.contains("not at the QEMU board's active partition"),
            "{e}"
        );
        let e = factory_image(&elf(0x10_0000, 4097), &r).unwrap_err();
        assert!(e.contains("holds 4096"), "{e}");
    }
}
