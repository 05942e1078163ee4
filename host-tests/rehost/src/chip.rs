//! The chips' memory maps, one screen of data each: every memory the
//! chip has, with its size and what may be done there. An address in no
//! row (and claimed by no peripheral model, `crate::periph`) stops the run.
//!
//! Sources: RM0410 rev 5 §2.2.2 "Memory map and register boundary
//! addresses" and the STM32F767ZI datasheet (DS11532) for the F767;
//! RM0433 rev 8 §2.3.2 "Memory map and register boundary addresses" for
//! the H743; ST's CMSIS device headers (`stm32f767xx.h`, `stm32h743xx.h`)
//! for `UID_BASE` and `FLASHSIZE_BASE`. Renode's `stm32f746.repl` and
//! `stm32h743.repl` were read for the layout of such a table.

/// What the core may do in a memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read and execute; a write stops the run (the flash is written only
    /// through its controller's programming sequence).
    Rom,
    /// Read, write and execute.
    Ram,
}

/// One memory of the chip.
#[derive(Clone, Copy, Debug)]
pub struct Memory {
    pub name: &'static str,
    pub base: u32,
    pub size: u32,
    pub access: Access,
}

/// A chip: its memories and where its flash starts (the vector table the
/// core boots from: BOOT0 low, the option bytes' boot address at reset).
#[derive(Clone, Copy, Debug)]
pub struct Chip {
    pub name: &'static str,
    pub memories: &'static [Memory],
    pub boot: u32,
    /// The factory-programmed unique ID (96 bits) and flash size (KiB).
    pub uid_base: u32,
    pub flash_size_base: u32,
    /// Memory the Ethernet DMA reaches on the bus matrix (RM0410 §2.1
    /// Figure 1; RM0433 §2.1 Figure 1: not the H743's TCMs).
    pub eth_dma_reaches: &'static [(u32, u32)],
    /// VTOR at reset: the boot address the option bytes hold (F7:
    /// BOOT_ADD0 = 0x0080, the flash through the ITCM interface at
    /// 0x0020_0000, RM0410 §2.4; H7: BOOT_ADD0 = 0x0800, RM0433 §2.6).
    pub vtor: u32,
    /// Another address range that shows the flash (F7: the ITCM
    /// interface): (its base, the flash's base, size).
    pub flash_alias: Option<(u32, u32, u32)>,
    /// The main flash (its base and size, every bank): erased (all ones)
    /// at power-on, before the images are programmed into it.
    pub flash: (u32, u32),
    /// MPU regions (MPU_TYPE.DREGION): 8 on the F7, 16 on the H7.
    pub mpu_regions: u32,
    /// The flash keeps an ECC with each word (the H743's 10 bits per
    /// 256-bit word; the F767 has none): what a torn operation leaves
    /// ([`crate::torn_word`], [`crate::torn_bits`]).
    pub flash_ecc: bool,
    /// Memory the core's caches never hold (the TCMs).
    pub tightly_coupled: &'static [(u32, u32)],
}

const fn rom(name: &'static str, base: u32, size: u32) -> Memory {
    Memory {
        name,
        base,
        size,
        access: Access::Rom,
    }
}

const fn ram(name: &'static str, base: u32, size: u32) -> Memory {
    Memory {
        name,
        base,
        size,
        access: Access::Ram,
    }
}

const K: u32 = 1024;

/// STM32F767ZI: 2 MiB of flash, 512 KiB of RAM (DTCM, SRAM1, SRAM2), the
/// ITCM, and the 4 KiB backup SRAM (a peripheral, on AHB1: claimed by the
/// peripheral map).
pub const STM32F767ZI: Chip = Chip {
    name: "STM32F767ZI",
    memories: &[
        ram("ITCM RAM", 0x0000_0000, 16 * K),
        rom("flash (ITCM interface)", 0x0020_0000, 2048 * K),
        rom("flash (AXIM interface)", 0x0800_0000, 2048 * K),
        rom("system memory", 0x1FF0_0000, 60 * K),
        // OTP (1 KiB), the unique ID and the flash size register: one
        // page, read-only, filled by `Machine::new`.
        rom("OTP and device data", 0x1FF0_F000, 4 * K),
        ram("DTCM", 0x2000_0000, 128 * K),
        ram("SRAM1", 0x2002_0000, 368 * K),
        ram("SRAM2", 0x2007_C000, 16 * K),
    ],
    boot: 0x0800_0000,
    uid_base: 0x1FF0_F420,
    flash_size_base: 0x1FF0_F442,
    // The DTCM through the core's AHBS port, SRAM1, SRAM2.
    eth_dma_reaches: &[(0x2000_0000, 0x2008_0000)],
    vtor: 0x0020_0000,
    flash: (0x0800_0000, 2048 * K),
    mpu_regions: 8,
    flash_ecc: false,
    flash_alias: Some((0x0020_0000, 0x0800_0000, 2048 * K)),
    tightly_coupled: &[(0x0000_0000, 0x0000_4000), (0x2000_0000, 0x2002_0000)],
};

/// STM32H743ZI: 2 MiB of flash in two banks, the TCMs, the AXI SRAM (D1),
/// SRAM1-3 (D2), SRAM4 and the backup SRAM (D3). 0x2002_0000-0x23FF_FFFF
/// is reserved: nothing answers there.
pub const STM32H743ZI: Chip = Chip {
    name: "STM32H743ZI",
    memories: &[
        ram("ITCM RAM", 0x0000_0000, 64 * K),
        rom("flash bank 1", 0x0800_0000, 1024 * K),
        rom("flash bank 2", 0x0810_0000, 1024 * K),
        rom("system memory", 0x1FF0_0000, 120 * K),
        // The unique ID (0x1FF1_E800) and the flash size (0x1FF1_E880).
        rom("device data", 0x1FF1_E000, 4 * K),
        ram("DTCM", 0x2000_0000, 128 * K),
        ram("AXI SRAM", 0x2400_0000, 512 * K),
        ram("SRAM1", 0x3000_0000, 128 * K),
        ram("SRAM2", 0x3002_0000, 128 * K),
        ram("SRAM3", 0x3004_0000, 32 * K),
        ram("SRAM4", 0x3800_0000, 64 * K),
        ram("backup SRAM", 0x3880_0000, 4 * K),
    ],
    boot: 0x0800_0000,
    uid_base: 0x1FF1_E800,
    flash_size_base: 0x1FF1_E880,
    // AXI SRAM (D1), SRAM1-3 (D2), SRAM4 (D3); never the TCMs.
    eth_dma_reaches: &[
        (0x2400_0000, 0x2408_0000),
        (0x3000_0000, 0x3004_8000),
        (0x3800_0000, 0x3801_0000),
    ],
    tightly_coupled: &[(0x0000_0000, 0x0001_0000), (0x2000_0000, 0x2002_0000)],
    vtor: 0x0800_0000,
    flash: (0x0800_0000, 2048 * K),
    mpu_regions: 16,
    flash_ecc: true,
    flash_alias: None,
};

impl Chip {
    /// The memory holding `addr`, if any.
    pub fn memory_at(&self, addr: u64) -> Option<&'static Memory> {
        self.memories
            .iter()
            .find(|m| addr >= u64::from(m.base) && addr < u64::from(m.base) + u64::from(m.size))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// unicorn maps whole 4 KiB pages: a memory that did not start and end
    /// on one would silently claim its neighbour's bytes.
    #[test]
    fn every_memory_is_whole_pages_and_none_overlap() {
        for chip in [STM32F767ZI, STM32H743ZI] {
            for (i, m) in chip.memories.iter().enumerate() {
                assert_eq!(m.base % 4096, 0, "{} {}", chip.name, m.name);
                assert_eq!(m.size % 4096, 0, "{} {}", chip.name, m.name);
                for n in &chip.memories[i + 1..] {
                    let disjoint = m.base + m.size <= n.base || n.base + n.size <= m.base;
                    assert!(disjoint, "{}: {} overlaps {}", chip.name, m.name, n.name);
                }
            }
        }
    }

    /// RM0433: the DTCM ends at 0x2001_FFFF and the AXI SRAM starts at
    /// 0x2400_0000; the H743's reserved hole in between is in no row.
    #[test]
    fn the_h743_hole_after_the_dtcm_is_unclaimed() {
        assert!(STM32H743ZI.memory_at(0x2002_0000).is_none());
        assert!(STM32H743ZI.memory_at(0x23FF_FFFC).is_none());
        assert_eq!(
            STM32H743ZI.memory_at(0x2001_FFFC).map(|m| m.name),
            Some("DTCM")
        );
        // On the F767 SRAM1 follows the DTCM directly.
        assert_eq!(
            STM32F767ZI.memory_at(0x2002_0000).map(|m| m.name),
            Some("SRAM1")
        );
    }
}
