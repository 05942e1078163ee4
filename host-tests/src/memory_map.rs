//! Linker memory maps and the sections of a linked image: where a
//! firmware image must sit on its board, checked before it boots or
//! flashes (`cargo boards`, the QEMU board).

use std::path::Path;

/// A linker script's number: decimal or `0x…`, with `K` or `M`, or a sum
/// or difference of two (`384K - 128`: a region that leaves room at its
/// end; `960K + 4K`).
pub fn number(t: &str) -> Option<u64> {
    let one = |t: &str| -> Option<u64> {
        let t = t.trim();
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
        v.checked_mul(scale)
    };
    let t = t.trim().trim_end_matches(',');
    if let Some((a, b)) = t.split_once(" - ") {
        one(a)?.checked_sub(one(b)?)
    } else if let Some((a, b)) = t.split_once(" + ") {
        one(a)?.checked_add(one(b)?)
    } else {
        one(t)
    }
}

/// `MEMORY` regions of a linker script: (name, origin, length), each
/// value a [`number`].
pub fn regions(script: &str) -> Result<Vec<(String, u64, u64)>, String> {
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
        // UPDATE (the QEMU board's update partitions) holds no section.
        let inside = regions
            .iter()
            .filter(|(r, _, _)| r != "UPDATE")
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

/// What the sensor's statics take in the firmware ELF, in bytes: its
/// sample cell (`rri_sensor::SAMPLES`, the triple buffer's three copies of
/// the history) and the sampler task (`rri_sensor::sampler`'s pool: the
/// task's state; the sampler keeps no copy of the history). `None` when neither is there.
pub fn sensor_statics(elf: &Path) -> Result<Option<u64>, String> {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    // Legacy mangling: `_ZN10rri_sensor7SAMPLES17h…E`.
    const OURS: [&str; 2] = ["10rri_sensor7SAMPLES17h", "10rri_sensor7sampler4POOL17h"];
    let sizes: Vec<u64> = file
        .symbols()
        .filter(|s| s.name().is_ok_and(|n| OURS.iter().any(|o| n.contains(o))))
        .map(|s| s.size())
        .collect();
    Ok((!sizes.is_empty()).then(|| sizes.iter().sum()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::qemu::MEMORY_MAP;

    fn map(path: &str) -> Vec<(String, u64, u64)> {
        regions(&std::fs::read_to_string(crate::workspace().join(path)).unwrap()).unwrap()
    }

    #[test]
    fn memory_maps_parse() {
        // The application in the active partition (mps2-an500-flash.x).
        assert_eq!(
            map(MEMORY_MAP),
            [
                ("FLASH".to_string(), 0x0010_0000, 960 << 10),
                ("RAM".to_string(), 0x2000_0000, (4 << 20) - 128)
            ]
        );
        assert_eq!(number("960K + 4K"), Some(964 << 10));
        assert_eq!(number("4096K - 128"), Some((4 << 20) - 128));
        assert_eq!(number("LENGTH(FLASH)"), None);
        assert_eq!(
            map("memory.x")[0],
            ("FLASH".to_string(), 0x0802_0000, 768 << 10)
        );
        // The crash record's 128 bytes after DMA_RAM.
        assert_eq!(
            map("memory.x")[2],
            ("DMA_RAM".to_string(), 0x2002_0000, (384 << 10) - 128)
        );
    }

    #[test]
    fn an_elf_linked_for_the_f767_is_not_one_for_qemu() {
        let f767 = [
            (".vector_table".to_string(), 0x0802_0000, 0x400),
            (".text".to_string(), 0x0802_0400, 0x1000),
            (".data".to_string(), 0x2000_0000, 0x100),
        ];
        assert!(check_memory_map(&f767, &map("memory.x")).is_ok());
        // One linked at the flash's start (before its bootloader, issue
        // 43) is not the F767's any more.
        let at_start = [
            (".vector_table".to_string(), 0x0800_0000, 0x400),
            (".text".to_string(), 0x0800_0400, 0x1000),
        ];
        assert!(check_memory_map(&at_start, &map("memory.x")).is_err());
        let e = check_memory_map(&f767, &map(MEMORY_MAP)).unwrap_err();
        assert!(e.contains("not at the board's FLASH origin"), "{e}");
        let qemu = [
            (".vector_table".to_string(), 0x0010_0000, 0x400),
            (".text".to_string(), 0x0010_0400, 0x1000),
            (".bss".to_string(), 0x2000_0000, 0x100),
        ];
        // One linked at 0, where the bootloader sits now, is not.
        let at_zero = [
            (".vector_table".to_string(), 0, 0x400),
            (".text".to_string(), 0x400, 0x1000),
        ];
        assert!(check_memory_map(&at_zero, &map(MEMORY_MAP))
            .unwrap_err()
            .contains("not at the board's FLASH origin"));
        assert!(check_memory_map(&qemu, &map(MEMORY_MAP)).is_ok());
        let too_big = [
            (".vector_table".to_string(), 0x0010_0000, 0x400),
            (".bss".to_string(), 0x203f_ff00, 0x200),
        ];
        assert!(check_memory_map(&too_big, &map(MEMORY_MAP))
            .unwrap_err()
            .contains(".bss"));
        // An image past its 960 KiB would run into the state partition.
        let into_update = [
            (".vector_table".to_string(), 0x0010_0000, 0x400),
            (".text".to_string(), 0x0010_0400, 960 << 10),
        ];
        assert!(check_memory_map(&into_update, &map(MEMORY_MAP))
            .unwrap_err()
            .contains(".text"));
    }
}
