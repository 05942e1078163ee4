//! A board's flash partitions (issue 43) as its flash map states them
//! (`hal-board/memory/<board>-flash.x`, the file both of its images link
//! with), read here so that the host's tools cannot drift from it: the
//! QEMU board's loader ([`crate::qemu_flash`]) and `cargo boards`, which
//! prints every board's table and checks that each image lies in its
//! partition.

use std::path::Path;

/// The symbol `name`'s value in the map's text (`NAME = VALUE;`, VALUE a
/// [`crate::memory_map::number`]).
pub fn value(map: &str, name: &str) -> Result<u32, String> {
    let expr = map
        .lines()
        .find_map(|l| {
            let rest = l.trim().strip_prefix(name)?.trim_start();
            rest.strip_prefix('=')
        })
        .ok_or_else(|| format!("the flash map has no `{name} = …;`"))?
        .trim()
        .trim_end_matches(';');
    crate::memory_map::number(expr)
        .and_then(|n| u32::try_from(n).ok())
        .ok_or_else(|| {
            format!("the flash map: `{name}`'s `{expr}` is not a number this reader takes")
        })
}

/// What each partition is for and the symbol it starts at (its length:
/// the same with `_len`), in flash order. The factory region only the
/// QEMU board has.
const PARTITIONS: &[(&str, &str)] = &[
    ("bootloader", "__boot"),
    ("factory image", "__factory"),
    ("state", "__update_state"),
    ("active", "__update_active"),
    ("update", "__update_dfu"),
];

/// The board's partitions in flash order: what each is for, its start and
/// its length.
pub fn partitions(map: &str) -> Result<Vec<(&'static str, u32, u32)>, String> {
    let mut found = Vec::new();
    for &(what, name) in PARTITIONS {
        if what == "factory image" && value(map, name).is_err() {
            continue;
        }
        found.push((what, value(map, name)?, value(map, &format!("{name}_len"))?));
    }
    found.sort_by_key(|p| p.1);
    Ok(found)
}

/// Where an image (`elf`'s flash bytes) starts and how long it is.
pub fn extent(elf: &Path) -> Result<(u32, usize), String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let (origin, image) =
        crate::update_file::flat_image(&bytes).map_err(|e| format!("{}: {e}", elf.display()))?;
    Ok((origin, image.len()))
}

/// Checks that the bootloader `boot` lies in the bootloader partition
/// and the application `app` in the active one, each from the partition's
/// start: where the chip starts and where the bootloader looks.
pub fn check(map: &str, boot: &Path, app: &Path) -> Result<(), String> {
    let parts = partitions(map)?;
    for (what, elf) in [("bootloader", boot), ("active", app)] {
        let (origin, len) = extent(elf)?;
        let (_, at, size) = parts
            .iter()
            .find(|p| p.0 == what)
            .ok_or_else(|| format!("the flash map has no {what} partition"))?;
        if origin != *at || len > *size as usize {
            return Err(format!(
                "{}: {len} bytes at {origin:#010x}, not inside the {what} partition ({at:#010x}, {size} bytes): is it built with the board's maps?",
                elf.display()
            ));
        }
    }
    Ok(())
}

/// The partition table with what the bootloader `boot` and the
/// application `app` (ELFs) take of theirs, one line each.
pub fn table(map: &str, boot: &Path, app: &Path) -> Result<Vec<String>, String> {
    let (boot, app) = (extent(boot)?.1, extent(app)?.1);
    // An update file: the image, its trailer and its signature, all
    // written into the update partition.
    let file = app + rri_update::image::TRAILER_LEN + rri_update::image::SIGNATURE_LEN;
    Ok(partitions(map)?
        .into_iter()
        .map(|(what, at, len)| {
            let used = match what {
                "bootloader" => Some(boot),
                "active" | "factory image" => Some(app),
                "update" => Some(file),
                _ => None,
            };
            let used = used.map_or(String::new(), |u| {
                let of = if what == "update" {
                    " (this image's update file)"
                } else {
                    ""
                };
                format!(
                    ": {u} B used{of}, {} B free",
                    (len as usize).saturating_sub(u)
                )
            });
            format!("{what:<14} {at:#010x} {:>5} KiB{used}", len / 1024)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every board's flash map, read as the tools read it: whole
    /// partitions in order, none overlapping, the update one a swap page
    /// larger than the active one (the maps' ASSERTs say the same to the
    /// linker; this reads the same text).
    #[test]
    fn every_board_map_reads_in_order() {
        for (file, page) in [
            ("hal-board/memory/mps2-an500-flash.x", 4 * 1024),
            ("hal-board/memory/nucleo-f767zi-flash.x", 128 * 1024),
            ("hal-board/memory/nucleo-h743zi-flash.x", 128 * 1024),
        ] {
            let map = std::fs::read_to_string(crate::workspace().join(file)).unwrap();
            let parts = partitions(&map).unwrap();
            assert_eq!(parts.first().map(|p| p.0), Some("bootloader"), "{file}");
            for w in parts.windows(2) {
                assert!(
                    w[0].1 + w[0].2 <= w[1].1,
                    "{file}: {:?} overlaps {:?}",
                    w[0],
                    w[1]
                );
            }
            let len = |what: &str| parts.iter().find(|p| p.0 == what).unwrap().2;
            assert!(len("update") >= len("active") + page, "{file}");
            for (what, at, size) in &parts {
                if *what != "factory image" {
                    assert_eq!((at % page, size % page), (0, 0), "{file}: {what}");
                }
            }
        }
    }

    #[test]
    fn a_missing_symbol_is_named() {
        let e = value("__boot = 0x0;\n", "__update_active").unwrap_err();
        assert!(e.contains("__update_active"), "{e}");
        assert_eq!(value("__boot = 0x08000000;\n", "__boot"), Ok(0x0800_0000));
        // `__boot_len` is not `__boot`.
        assert!(value("__boot_len = 4K;\n", "__boot").is_err());
    }
}
