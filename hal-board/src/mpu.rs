//! The Cortex-M7 (ARMv7-M PMSA) memory protection unit's encoding of one
//! region: normal memory, not cacheable, shareable, never executed. The
//! STM32 boards use it for the window that holds the Ethernet DMA rings,
//! so that the data cache can be on for everything else (see
//! `nucleo::memory`). Plain arithmetic, checked on the host.

/// Why a window cannot be one MPU region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RegionError {
    /// The size is not a power of two from 32 bytes to 4 GiB.
    Size,
    /// The base is not aligned to the size.
    Alignment,
    /// Region numbers are 0..=15 (the M7 has 8 or 16).
    Number,
}

/// `MPU_RBAR` and `MPU_RASR` for region `number` over `[base, base +
/// size)`: TEX = 001, C = 0, B = 0 (normal, non-cacheable), S = 1, full
/// access at any privilege, execute never.
pub fn non_cacheable(number: u32, base: u32, size: u32) -> Result<(u32, u32), RegionError> {
    region(number, base, size, AP_FULL)
}

/// `MPU_RBAR` and `MPU_RASR` for a stack guard: region `number` over
/// `[base, base + size)`, attributes as [`non_cacheable`] but read-only at
/// any privilege. A write into it is a MemManage fault (DACCVIOL, or
/// MSTKERR when the core stacks an exception frame into it); reads stay
/// allowed so a fault handler may look at what is there.
pub fn read_only(number: u32, base: u32, size: u32) -> Result<(u32, u32), RegionError> {
    region(number, base, size, AP_READ_ONLY)
}

/// Access permissions (RASR.AP, bits 26..24): read/write, and read-only,
/// at both privileges.
const AP_FULL: u32 = 0b011 << 24;
const AP_READ_ONLY: u32 = 0b110 << 24;

fn region(number: u32, base: u32, size: u32, access: u32) -> Result<(u32, u32), RegionError> {
    if !size.is_power_of_two() || size < 32 {
        return Err(RegionError::Size);
    }
    if base & (size - 1) != 0 {
        return Err(RegionError::Alignment);
    }
    if number > 15 {
        return Err(RegionError::Number);
    }
    const VALID: u32 = 1 << 4;
    const XN: u32 = 1 << 28;
    const TEX_001: u32 = 0b001 << 19;
    const SHAREABLE: u32 = 1 << 18;
    const ENABLE: u32 = 1;
    // SIZE field: the region is 2^(SIZE + 1) bytes.
    let size_field = size.trailing_zeros() - 1;
    Ok((
        base | VALID | number,
        XN | access | TEX_001 | SHAREABLE | (size_field << 1) | ENABLE,
    ))
}

/// `MPU_CTRL`: on, with the default memory map for everything no region
/// covers (PRIVDEFENA). HFNMIENA is clear: the HardFault and NMI handlers
/// run on the default map, which they only need for registers and the log.
pub const CTRL_ENABLE_WITH_DEFAULT_MAP: u32 = 0b101;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_the_boards_windows() {
        // F767: 512 KiB from 0x2000_0000 (DTCM, SRAM1, SRAM2).
        assert_eq!(
            non_cacheable(0, 0x2000_0000, 512 * 1024),
            Ok((0x2000_0010, 0x130c_0025))
        );
        // H743: the 512 KiB AXI SRAM.
        let (rbar, rasr) = non_cacheable(0, 0x2400_0000, 512 * 1024).unwrap();
        assert_eq!(rbar, 0x2400_0010);
        // SIZE = 18: 2^19 bytes.
        assert_eq!((rasr >> 1) & 0x1f, 18);
        // TEX 001, S 1, C 0, B 0 (bits 21..16): normal non-cacheable,
        // shareable.
        assert_eq!((rasr >> 16) & 0x3f, 0b00_1100);
        assert_eq!(rasr & 1, 1);
        assert_eq!(non_cacheable(7, 0, 32).map(|r| r.0), Ok(0x17));
    }

    #[test]
    fn refuses_what_one_region_cannot_cover() {
        assert_eq!(
            non_cacheable(0, 0x2002_0000, 384 * 1024),
            Err(RegionError::Size)
        );
        assert_eq!(non_cacheable(0, 0, 16), Err(RegionError::Size));
        assert_eq!(
            non_cacheable(0, 0x2002_0000, 256 * 1024),
            Err(RegionError::Alignment)
        );
        assert_eq!(non_cacheable(16, 0, 1024), Err(RegionError::Number));
    }

    #[test]
    fn a_guard_is_read_only_and_otherwise_the_same() {
        let (rbar, rasr) = read_only(7, 0x2000_0100, 256).unwrap();
        assert_eq!(rbar, 0x2000_0117);
        assert_eq!(
            (rasr >> 24) & 0b111,
            0b110,
            "AP: read-only at any privilege"
        );
        assert_eq!((rasr >> 1) & 0x1f, 7, "SIZE 7: 2^8 bytes");
        let (_, full) = non_cacheable(7, 0x2000_0100, 256).unwrap();
        assert_eq!(rasr & !(0b111 << 24), full & !(0b111 << 24));
        assert_eq!(read_only(7, 0x2000_0080, 256), Err(RegionError::Alignment));
    }
}
