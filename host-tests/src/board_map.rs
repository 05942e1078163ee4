//! The STM32 boards' memory placement, checked in the linked image
//! (`cargo boards`): what `hal-board/src/nucleo/memory.rs` relies on for
//! the data cache and the Ethernet DMA to be correct, read back from the
//! ELF's sections and symbols rather than trusted.
//!
//! The rules, for each board:
//! 1. the uncached window (`__uncached_start`, `__uncached_size`, which
//!    the firmware programs into the MPU) is one MPU region: a power of two
//!    of at least 32 bytes, aligned to its size;
//! 2. the Ethernet DMA rings (the `ETH_DMA_PACKETS` static) lie in section
//!    `.eth_dma`, which lies in the uncached window and in memory the
//!    board's Ethernet DMA can reach (the H743's cannot reach its DTCM);
//! 3. the diagnostics service's buffers (section `.diag_ram`: low
//!    priority, kept out of the DTCM the stack and the cycle share) lie in
//!    the uncached window too; every other writable section, and the
//!    stack (`_stack_end` .. `_stack_start`), lies in the DTCM: memory the
//!    caches never hold and no DMA writes;
//! 4. the RTT control block (`_SEGGER_RTT`, read by the debug probe behind
//!    the core's back) is not cacheable: in the DTCM or the window;
//! 5. the stack region the statics leave in the DTCM is at least
//!    [`MIN_STACK`]: the statics share the DTCM with the stack, and a
//!    static that grew would otherwise eat the stack's margin unseen;
//! 6. what cortex-m-rt's reset handler zeroes, `__sbss..__ebss`, is
//!    `.bss` and nothing else: a section inserted after `.bss` in another
//!    region moves `__ebss` there, and the handler then zeroes everything
//!    between (on the H743 through the reserved hole after the DTCM: a
//!    bus fault before `main`; on the F767 `.uninit`, the stack and the
//!    rings), and `.uninit` and `_stack_end` lie in the DTCM.
//!
//! Together: no byte the core writes is ever in the data cache, so the
//! cache needs no maintenance and the DMA, the probe and the core always
//! agree.

use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

/// The smallest stack region the boards may be left with: the deepest
/// stack measured (start-up on the QEMU board, building embassy-net's
/// stack: 59,276 bytes at opt-level 3, 56,216 at "z") with the 25 %
/// margin `cargo qemu-bench` and `cargo hil` require, rounded up.
pub const MIN_STACK: u64 = 80 * 1024;

/// The same for a bench build (hal-board's `bench`, which the image says
/// with its symbol `__rri_bench_build`): measured, never deployed, and
/// larger by its cycle records and baseline codec. The NUCLEO images'
/// deepest stack on the model of their chip is 16,600 bytes (start-up,
/// `cargo rehost`): 64 KiB keeps that four times over.
pub const BENCH_MIN_STACK: u64 = 64 * 1024;

/// What a board's memory is, for the rules above.
#[derive(Clone, Debug)]
pub struct Placement {
    /// The board's name in [`crate::boards::BOARDS`].
    pub board: &'static str,
    /// The data TCM.
    pub dtcm: Range<u64>,
    /// Memory the Ethernet DMA can reach (the reference manual's bus
    /// matrix).
    pub dma_reachable: &'static [Range<u64>],
}

/// The boards' memories (RM0410 for the STM32F767, RM0433 for the
/// STM32H743).
pub const PLACEMENTS: [Placement; 2] = [
    Placement {
        board: "nucleo-f767zi",
        dtcm: 0x2000_0000..0x2002_0000,
        // The DTCM (through the core's AHBS port), SRAM1 and SRAM2.
        dma_reachable: &[
            0x2000_0000..0x2002_0000,
            0x2002_0000..0x2007_c000,
            0x2007_c000..0x2008_0000,
        ],
    },
    Placement {
        board: "nucleo-h743zi",
        dtcm: 0x2000_0000..0x2002_0000,
        // AXI SRAM (D1), SRAM1-3 (D2), SRAM4 (D3); never the TCMs.
        dma_reachable: &[
            0x2400_0000..0x2408_0000,
            0x3000_0000..0x3004_8000,
            0x3800_0000..0x3801_0000,
        ],
    },
];

/// The board's placement rules, by name.
pub fn placement(board: &str) -> Option<&'static Placement> {
    PLACEMENTS.iter().find(|p| p.board == board)
}

/// An allocated section of the image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Section {
    pub name: String,
    pub addr: u64,
    pub size: u64,
    pub writable: bool,
}

impl Section {
    fn range(&self) -> Range<u64> {
        self.addr..self.addr + self.size
    }
}

/// What the rules read from an image.
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub sections: Vec<Section>,
    /// Symbol name (demangled names are matched by substring) → (address,
    /// size).
    pub symbols: HashMap<String, (u64, u64)>,
}

impl Image {
    /// Reads an ELF.
    pub fn read(elf: &Path) -> Result<Image, String> {
        use object::{Object, ObjectSection, ObjectSymbol, SectionFlags};
        let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
        let sections = file
            .sections()
            .filter_map(|s| {
                let SectionFlags::Elf { sh_flags } = s.flags() else {
                    return None;
                };
                let alloc = sh_flags & u64::from(object::elf::SHF_ALLOC) != 0;
                (alloc && s.size() > 0).then(|| Section {
                    name: s.name().unwrap_or("?").to_string(),
                    addr: s.address(),
                    size: s.size(),
                    writable: sh_flags & u64::from(object::elf::SHF_WRITE) != 0,
                })
            })
            .collect();
        let symbols = file
            .symbols()
            .filter_map(|s| Some((s.name().ok()?.to_string(), (s.address(), s.size()))))
            .collect();
        Ok(Image { sections, symbols })
    }

    fn symbol(&self, name: &str) -> Result<(u64, u64), String> {
        self.symbols.get(name).copied().ok_or_else(|| {
            format!("no symbol `{name}` (is this image linked with the board's map?)")
        })
    }

    /// The one symbol whose (mangled) name contains `part`.
    fn symbol_containing(&self, part: &str) -> Result<(u64, u64), String> {
        let mut found = self.symbols.iter().filter(|(n, _)| n.contains(part));
        match (found.next(), found.next()) {
            (Some((_, v)), None) => Ok(*v),
            (None, _) => Err(format!("no symbol named like `{part}`")),
            (Some(_), Some(_)) => Err(format!("more than one symbol named like `{part}`")),
        }
    }
}

fn inside(r: &Range<u64>, outer: &Range<u64>) -> bool {
    r.start >= outer.start && r.end <= outer.end
}

fn hex(r: &Range<u64>) -> String {
    format!("{:#010x}..{:#010x}", r.start, r.end)
}

/// Checks the rules (module doc) on `image`; every broken rule, one per
/// line.
pub fn check(p: &Placement, image: &Image) -> Result<(), String> {
    let mut broken = Vec::new();
    let (start, _) = image.symbol("__uncached_start")?;
    let (size, _) = image.symbol("__uncached_size")?;
    let window = start..start + size;
    // 1. One MPU region.
    if !size.is_power_of_two() || size < 32 || start % size != 0 {
        broken.push(format!(
            "the uncached window {} is not one MPU region (a power of two, aligned to its size)",
            hex(&window)
        ));
    }
    // 2. The DMA rings.
    match image.sections.iter().find(|s| s.name == ".eth_dma") {
        None => broken.push("no .eth_dma section: where are the Ethernet DMA rings?".into()),
        Some(dma) => {
            let rings = image.symbol_containing("ETH_DMA_PACKETS")?;
            let rings = rings.0..rings.0 + rings.1;
            if rings.is_empty() || !inside(&rings, &dma.range()) {
                broken.push(format!(
                    "the Ethernet DMA rings ({}) are not in .eth_dma ({})",
                    hex(&rings),
                    hex(&dma.range())
                ));
            }
            if !inside(&dma.range(), &window) {
                broken.push(format!(
                    ".eth_dma ({}) is not inside the uncached window {}: the data cache would hold DMA buffers",
                    hex(&dma.range()),
                    hex(&window)
                ));
            }
            if !p.dma_reachable.iter().any(|r| inside(&dma.range(), r)) {
                broken.push(format!(
                    ".eth_dma ({}) is where the {} Ethernet DMA cannot reach",
                    hex(&dma.range()),
                    p.board
                ));
            }
        }
    }
    // 3. The diagnostics' buffers uncached; everything else the core
    // writes, and the stack, in the DTCM.
    if let Some(diag) = image.sections.iter().find(|s| s.name == ".diag_ram") {
        if !inside(&diag.range(), &window) {
            broken.push(format!(
                ".diag_ram ({}) is not inside the uncached window {}: the data cache would hold it",
                hex(&diag.range()),
                hex(&window)
            ));
        }
    }
    for s in image
        .sections
        .iter()
        .filter(|s| s.writable && s.name != ".eth_dma" && s.name != ".diag_ram")
    {
        if !inside(&s.range(), &p.dtcm) {
            broken.push(format!(
                "{} ({}) is writable and outside the DTCM {}",
                s.name,
                hex(&s.range()),
                hex(&p.dtcm)
            ));
        }
    }
    let (top, _) = image.symbol("_stack_start")?;
    let (bottom, _) = image.symbol("_stack_end")?;
    let stack = bottom..top;
    if stack.is_empty() || !inside(&stack, &p.dtcm) {
        broken.push(format!(
            "the stack ({}) is not inside the DTCM {}",
            hex(&stack),
            hex(&p.dtcm)
        ));
    }
    // 5. Room for it.
    let bench = image.symbol("__rri_bench_build").is_ok_and(|(v, _)| v == 1);
    let floor = if bench { BENCH_MIN_STACK } else { MIN_STACK };
    if stack.end.saturating_sub(stack.start) < floor {
        broken.push(format!(
            "the statics leave the stack {} bytes of the DTCM, under {floor}{}: move a large static out of the DTCM or make it smaller",
            stack.end.saturating_sub(stack.start),
            if bench { " (a bench build's floor)" } else { "" }
        ));
    }
    // 6. What the reset handler zeroes.
    let (sbss, _) = image.symbol("__sbss")?;
    let (ebss, _) = image.symbol("__ebss")?;
    let zeroed = sbss..ebss;
    let bss = image
        .sections
        .iter()
        .find(|s| s.name == ".bss")
        .map_or(sbss..sbss, |s| s.range());
    if !inside(&zeroed, &p.dtcm)
        || zeroed.end > bss.end.next_multiple_of(4)
        || zeroed.start < bss.start
    {
        broken.push(format!(
            "the reset handler zeroes __sbss..__ebss ({}), which is not .bss ({}) alone: a section inserted after .bss in another region moved __ebss (INSERT BEFORE .bss in the memory map)",
            hex(&zeroed),
            hex(&bss)
        ));
    }
    if let Some(uninit) = image.sections.iter().find(|s| s.name == ".uninit") {
        if !inside(&uninit.range(), &p.dtcm) {
            broken.push(format!(
                ".uninit ({}) is outside the DTCM {}",
                hex(&uninit.range()),
                hex(&p.dtcm)
            ));
        }
    }
    // 4. The probe's window into the log.
    let (rtt, rtt_size) = image.symbol("_SEGGER_RTT")?;
    let rtt = rtt..rtt + rtt_size.max(1);
    if !inside(&rtt, &p.dtcm) && !inside(&rtt, &window) {
        broken.push(format!(
            "_SEGGER_RTT ({}) is cacheable: the probe would read stale log data",
            hex(&rtt)
        ));
    }
    if broken.is_empty() {
        Ok(())
    } else {
        Err(broken.join("\n  "))
    }
}

/// The stack region's size in bytes (the linked image's), for the table.
pub fn stack_bytes(image: &Image) -> Option<u64> {
    let top = image.symbols.get("_stack_start")?.0;
    let bottom = image.symbols.get("_stack_end")?.0;
    top.checked_sub(bottom)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(name: &str, addr: u64, size: u64, writable: bool) -> Section {
        Section {
            name: name.into(),
            addr,
            size,
            writable,
        }
    }

    /// An image laid out as the H743's map does it.
    fn h743() -> Image {
        let mut symbols = HashMap::new();
        for (name, addr, size) in [
            ("__uncached_start", 0x2400_0000, 0),
            ("__uncached_size", 512 * 1024, 0),
            (
                "_ZN9hal_board6nucleo6memory15ETH_DMA_PACKETS17h0E",
                0x2400_0000,
                34_000,
            ),
            ("_stack_start", 0x2001_5000, 0),
            ("_stack_end", 0x2000_0000, 0),
            ("_SEGGER_RTT", 0x2001_6000, 48),
            ("__sbss", 0x2001_5200, 0),
            ("__ebss", 0x2001_5200 + 40_000, 0),
        ] {
            symbols.insert(name.to_string(), (addr, size));
        }
        Image {
            sections: vec![
                section(".vector_table", 0x0800_0000, 0x2a0, false),
                section(".text", 0x0800_02a0, 80_000, false),
                section(".rodata", 0x0801_4000, 18_000, false),
                section(".data", 0x2001_5000, 444, true),
                section(".bss", 0x2001_5200, 40_000, true),
                section(".uninit", 0x2001_f000, 1024, true),
                section(".eth_dma", 0x2400_0000, 34_080, true),
                section(".diag_ram", 0x2400_8520, 9_000, true),
            ],
            symbols,
        }
    }

    fn rules() -> &'static Placement {
        placement("nucleo-h743zi").unwrap()
    }

    #[test]
    fn the_boards_layout_passes() {
        assert_eq!(check(rules(), &h743()), Ok(()));
    }

    #[test]
    fn a_stack_of_70_kib_is_refused_unless_the_image_is_a_bench_build() {
        let mut image = h743();
        // The statics grown: the stack keeps 70 KiB of the DTCM.
        image.symbols.get_mut("_stack_start").unwrap().0 = 0x2000_0000 + 70 * 1024;
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("under 81920"), "{e}");
        image
            .symbols
            .insert("__rri_bench_build".to_string(), (1, 0));
        assert_eq!(check(rules(), &image), Ok(()));
        image.symbols.get_mut("_stack_start").unwrap().0 = 0x2000_0000 + 60 * 1024;
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("under 65536 (a bench build's floor)"), "{e}");
    }

    #[test]
    fn dma_rings_in_the_h743_dtcm_are_refused() {
        let mut image = h743();
        image.sections[6].addr = 0x2000_0000;
        image.symbols.insert(
            "_ZN9hal_board6nucleo6memory15ETH_DMA_PACKETS17h0E".into(),
            (0x2000_0000, 34_000),
        );
        image.symbols.insert("_stack_end".into(), (0x2000_8500, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("Ethernet DMA cannot reach"), "{e}");
        assert!(e.contains("not inside the uncached window"), "{e}");
    }

    #[test]
    fn rings_left_out_of_their_section_are_refused() {
        let mut image = h743();
        // The static without its link_section: in .bss.
        image.symbols.insert(
            "_ZN9hal_board6nucleo6memory15ETH_DMA_PACKETS17h0E".into(),
            (0x2001_5200, 34_000),
        );
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("are not in .eth_dma"), "{e}");
    }

    #[test]
    fn cacheable_statics_and_stack_are_refused() {
        let mut image = h743();
        // .bss in the AXI SRAM: uncached there, but the rule is the DTCM.
        image.sections[4].addr = 0x2401_0000;
        image
            .symbols
            .insert("_stack_start".into(), (0x2404_0000, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains(".bss"), "{e}");
        assert!(e.contains("the stack"), "{e}");
    }

    #[test]
    fn statics_that_squeeze_the_stack_are_refused() {
        let mut image = h743();
        image
            .symbols
            .insert("_stack_start".into(), (0x2001_0000, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("leave the stack 65536 bytes"), "{e}");
    }

    #[test]
    fn a_window_that_is_not_one_region_is_refused() {
        let mut image = h743();
        image
            .symbols
            .insert("__uncached_size".into(), (384 * 1024, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("not one MPU region"), "{e}");
    }

    #[test]
    fn diagnostics_buffers_outside_the_uncached_window_are_refused() {
        let mut image = h743();
        // In the H743's cacheable SRAM1 (D2).
        image.sections[7].addr = 0x3000_0000;
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains(".diag_ram (0x30000000"), "{e}");
        assert!(!e.contains("outside the DTCM"), "{e}");
    }

    #[test]
    fn a_cacheable_rtt_block_is_refused() {
        let mut image = h743();
        image
            .symbols
            .insert("_SEGGER_RTT".into(), (0x3000_0000, 48));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("_SEGGER_RTT"), "{e}");
    }

    /// Rule 6: the H743 image as linked before the fix (the DMA RAM's
    /// sections inserted after .bss): __ebss at the end of .diag_ram in
    /// the AXI SRAM, so the reset handler zeroed through 0x2002_0000.
    #[test]
    fn a_zeroed_range_that_runs_past_bss_is_refused() {
        let mut image = h743();
        image.symbols.insert("__ebss".into(), (0x2400_a180, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(
            e.contains("zeroes __sbss..__ebss (0x20015200..0x2400a180)"),
            "{e}"
        );
        // Within the DTCM but reaching into .uninit: refused too.
        image.symbols.insert("__ebss".into(), (0x2001_f400, 0));
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains("not .bss (0x20015200..0x2001ee40) alone"), "{e}");
    }

    #[test]
    fn uninit_outside_the_dtcm_is_refused() {
        let mut image = h743();
        image.sections[5].addr = 0x2407_0000;
        let e = check(rules(), &image).unwrap_err();
        assert!(e.contains(".uninit (0x24070000"), "{e}");
    }
}
