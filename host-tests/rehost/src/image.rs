//! The firmware image as the chip's flash holds it: the ELF's loadable
//! segments at their physical (load) addresses, and its function symbols
//! so that every stop names the function it happened in.

use object::{Object, ObjectSegment, ObjectSymbol, SymbolKind};
use std::path::Path;

/// One loadable piece of the image: bytes at the address the chip's
/// programmer writes them to (the segment's physical address: `.data`'s
/// initial values sit in flash, where the reset handler copies them from).
#[derive(Clone, Debug)]
pub struct Load {
    pub addr: u64,
    pub bytes: Vec<u8>,
}

/// A linked firmware image.
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub loads: Vec<Load>,
    /// Function symbols sorted by address: (address without the Thumb bit,
    /// size, demangled name).
    functions: Vec<(u64, u64, String)>,
    /// Every named symbol (linker symbols such as `__sbss` included).
    symbols: Vec<(String, u64)>,
}

impl Image {
    /// Reads an ELF written by the boards' builds.
    pub fn read(path: &Path) -> Result<Image, String> {
        let data = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Image::parse(&data).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parses an ELF held in memory.
    pub fn parse(data: &[u8]) -> Result<Image, String> {
        let file = object::File::parse(data).map_err(|e| e.to_string())?;
        if file.architecture() != object::Architecture::Arm {
            return Err(format!(
                "not an ARM image ({:?}): build it with `cargo build-f767` or `cargo build-h743`",
                file.architecture()
            ));
        }
        let mut loads = Vec::new();
        if let object::File::Elf32(elf) = &file {
            use object::read::elf::ProgramHeader;
            let endian = elf.endian();
            for header in elf.elf_program_headers() {
                if header.p_type(endian) != object::elf::PT_LOAD || header.p_filesz(endian) == 0 {
                    continue;
                }
                let bytes = header
                    .data(endian, data)
                    .map_err(|()| "a segment lies outside the file".to_string())?;
                loads.push(Load {
                    addr: u64::from(header.p_paddr(endian)),
                    bytes: bytes.to_vec(),
                });
            }
        } else {
            // Only the segments' virtual addresses: good enough when no
            // section is loaded elsewhere than it runs.
            for segment in file.segments() {
                let bytes = segment.data().map_err(|e| e.to_string())?;
                if !bytes.is_empty() {
                    loads.push(Load {
                        addr: segment.address(),
                        bytes: bytes.to_vec(),
                    });
                }
            }
        }
        let mut functions = Vec::new();
        let mut symbols = Vec::new();
        for s in file.symbols() {
            let Ok(name) = s.name() else { continue };
            if name.is_empty() {
                continue;
            }
            symbols.push((name.to_string(), s.address()));
            if s.kind() == SymbolKind::Text {
                let pretty = format!("{:#}", rustc_demangle::demangle(name));
                functions.push((s.address() & !1, s.size(), pretty));
            }
        }
        functions.sort_by_key(|f| f.0);
        Ok(Image {
            loads,
            functions,
            symbols,
        })
    }

    /// The chip's flash as a probe leaves it after programming the
    /// bootloader `boot` and this application: both images' segments,
    /// and their functions for every stop's description. This image's
    /// symbols win where both name one (the RTT block, `main`). Fails
    /// when the two overlap: the application is not linked into the
    /// board's active partition.
    pub fn with_boot(mut self, boot: Image) -> Result<Image, String> {
        for a in &self.loads {
            for b in &boot.loads {
                let (a0, a1) = (a.addr, a.addr + a.bytes.len() as u64);
                let (b0, b1) = (b.addr, b.addr + b.bytes.len() as u64);
                if a0 < b1 && b0 < a1 {
                    return Err(format!(
                        "the image ({a0:#010x}..{a1:#010x}) overlaps the bootloader ({b0:#010x}..{b1:#010x}): is it linked into the board's active partition (`cargo build-f767` / `build-h743`)?"
                    ));
                }
            }
        }
        self.loads.extend(boot.loads);
        self.functions.extend(boot.functions);
        self.functions.sort_by_key(|f| f.0);
        self.symbols.extend(boot.symbols);
        Ok(self)
    }

    /// The address of a symbol by its exact (mangled) name.
    pub fn symbol(&self, name: &str) -> Option<u64> {
        self.symbols
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, a)| *a)
    }

    /// `function+0xoffset` for a code address, or `?` outside every
    /// function the image names.
    pub fn describe(&self, pc: u64) -> String {
        let pc = pc & !1;
        let i = self.functions.partition_point(|f| f.0 <= pc);
        match i.checked_sub(1).and_then(|i| self.functions.get(i)) {
            Some((start, size, name)) if pc < start + (*size).max(1) => {
                format!("{name}+{:#x}", pc - start)
            }
            _ => "?".to_string(),
        }
    }

    /// The word at `addr` in the loaded image (the vector table's initial
    /// stack pointer and reset vector).
    pub fn word(&self, addr: u64) -> Option<u32> {
        self.loads.iter().find_map(|l| {
            let at = usize::try_from(addr.checked_sub(l.addr)?).ok()?;
            let b = l.bytes.get(at..at + 4)?;
            Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{Image, Load};

    fn image(at: u64, len: usize, symbol: &str) -> Image {
        Image {
            loads: vec![Load {
                addr: at,
                bytes: vec![0xA5; len],
            }],
            functions: vec![(at, 4, symbol.to_string())],
            symbols: vec![(symbol.to_string(), at), ("main".to_string(), at + 8)],
        }
    }

    #[test]
    fn the_bootloader_and_an_image_in_the_active_partition_load_together() {
        let both = image(0x0808_0000, 0x100, "app")
            .with_boot(image(0x0800_0000, 0x100, "boot"))
            .unwrap();
        assert_eq!(both.loads.len(), 2);
        assert_eq!(both.word(0x0800_0000), Some(0xA5A5_A5A5));
        assert_eq!(both.describe(0x0800_0002), "boot+0x2");
        assert_eq!(both.describe(0x0808_0002), "app+0x2");
        // The application's symbols win (its `main`, its RTT block).
        assert_eq!(both.symbol("main"), Some(0x0808_0008));
    }

    #[test]
    fn an_image_linked_over_the_bootloader_is_refused() {
        // An image from before issue 43, linked at the flash's start.
        let e = image(0x0800_0000, 0x1000, "app")
            .with_boot(image(0x0800_0000, 0x100, "boot"))
            .unwrap_err();
        assert!(e.contains("active partition"), "{e}");
        // One byte of overlap is enough.
        assert!(image(0x0800_00FF, 0x10, "app")
            .with_boot(image(0x0800_0000, 0x100, "boot"))
            .is_err());
        assert!(image(0x0800_0100, 0x10, "app")
            .with_boot(image(0x0800_0000, 0x100, "boot"))
            .is_ok());
    }
}
