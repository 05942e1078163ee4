//! A machine for the engine's own unit tests: a tiny image on the H743
//! (or the F767).

use super::Machine;
use crate::image::{Image, Load};

/// A whole H743 flash holding a vector table (the stack at
/// 0x2000_1000, reset to a `b .` at 0x40) and `code`'s half-words from
/// offset 0x20, erased elsewhere.
pub(crate) fn flash_with(code: &[u16]) -> Vec<u8> {
    let mut f = vec![0xFF; 2048 * 1024];
    f[0..4].copy_from_slice(&0x2000_1000u32.to_le_bytes());
    f[4..8].copy_from_slice(&0x0800_0041u32.to_le_bytes());
    f[0x40..0x42].copy_from_slice(&0xE7FEu16.to_le_bytes());
    for (i, hw) in code.iter().enumerate() {
        f[0x20 + 2 * i..0x22 + 2 * i].copy_from_slice(&hw.to_le_bytes());
    }
    f
}

/// The H743 with [`flash_with`]'s first 256 bytes as its image.
pub(crate) fn h743(code: &[u16]) -> Machine {
    tiny(crate::chip::STM32H743ZI, crate::h7::bus, code)
}

/// The F767 (its flash in dual-bank mode) with [`flash_with`]'s first
/// 256 bytes as its image.
pub(crate) fn f767(code: &[u16]) -> Machine {
    tiny(crate::chip::STM32F767ZI, crate::f7::bus_dual_bank, code)
}

fn tiny(
    chip: crate::chip::Chip,
    bus: fn() -> (crate::bus::Bus, crate::clocks::Clocks),
    code: &[u16],
) -> Machine {
    let mut image = Image::default();
    image.loads.push(Load {
        addr: 0x0800_0000,
        bytes: flash_with(code)[..0x100].to_vec(),
    });
    let (b, clocks) = bus();
    let mut m = Machine::new(chip, image, b, clocks).unwrap();
    m.rebuild = Some(bus);
    m
}
