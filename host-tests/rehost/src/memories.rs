//! The chip's memories as they are at power-on.

use crate::chip::Access;
use crate::image::Image;
use crate::state::State;
use unicorn_engine::unicorn_const::Prot;
use unicorn_engine::Unicorn;

/// What every byte of SRAM holds at power-on in the model.
pub const POWER_ON_RAM: u8 = 0xA5;

/// Every SRAM of the chip as at power-on, and each one's range. SRAM
/// holds no defined value then (unicorn's would be zeros): it is filled
/// with a pattern, so that an image that reads memory it never wrote does
/// not get a lucky zero. A system reset keeps it, as silicon does; a
/// power cut brings the pattern back.
pub(crate) fn fill_sram(uc: &mut Unicorn<'_, State>) -> Result<Vec<(u64, u64)>, String> {
    let chip = uc.get_data().chip;
    let mut filled = Vec::new();
    for m in chip.memories.iter().filter(|m| m.access == Access::Ram) {
        let base = u64::from(m.base);
        uc.mem_write(base, &vec![POWER_ON_RAM; m.size as usize])
            .map_err(|e| format!("unicorn: SRAM at power-on: {e:?}"))?;
        filled.push((base, base + u64::from(m.size)));
    }
    Ok(filled)
}

/// Maps the chip's memories as at power-on: the SRAM holding the
/// power-on pattern, the flash erased and then programmed with `image`
/// (as a probe leaves it), the factory data.
pub(crate) fn power_on(uc: &mut Unicorn<'static, State>, image: &Image) -> Result<(), String> {
    fn e(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
        move |err| format!("unicorn: {what}: {err:?}")
    }
    let chip = uc.get_data().chip;
    for m in chip.memories {
        let prot = match m.access {
            Access::Rom => Prot::READ | Prot::EXEC,
            Access::Ram => Prot::ALL,
        };
        uc.mem_map(u64::from(m.base), u64::from(m.size), prot)
            .map_err(e(m.name))?;
    }
    fill_sram(uc)?;
    // A chip's flash leaves the factory erased: all ones (RM0410
    // §3.3.5, RM0433 §4.3.9). A bootloader reads its state partition
    // and an image partition's vector table there before anything is
    // written.
    let erased = vec![0xFF; chip.flash.1 as usize];
    uc.mem_write(u64::from(chip.flash.0), &erased)
        .map_err(e("erased flash"))?;
    if let Some((alias, _, size)) = chip.flash_alias {
        uc.mem_write(u64::from(alias), erased.get(..size as usize).unwrap_or(&[]))
            .map_err(e("erased flash alias"))?;
    }
    for load in &image.loads {
        if chip.memory_at(load.addr).is_none() {
            return Err(format!(
                "the image loads {} bytes at {:#010x}, where {} has no memory: is it built for this board?",
                load.bytes.len(),
                load.addr,
                chip.name
            ));
        }
        uc.mem_write(load.addr, &load.bytes).map_err(e("load"))?;
        if let Some((alias, flash, size)) = chip.flash_alias {
            let (flash, size) = (u64::from(flash), u64::from(size));
            if load.addr >= flash && load.addr < flash + size {
                uc.mem_write(load.addr - flash + u64::from(alias), &load.bytes)
                    .map_err(e("flash alias"))?;
            }
        }
    }
    // The factory data: a unique ID (fixed, so runs repeat) and the
    // flash size in KiB.
    uc.mem_write(
        u64::from(chip.uid_base),
        &[
            0x31, 0x00, 0x4b, 0x00, 0x11, 0x51, 0x38, 0x30, 0x33, 0x36, 0x38, 0x37,
        ],
    )
    .map_err(e("unique ID"))?;
    uc.mem_write(u64::from(chip.flash_size_base), &2048u16.to_le_bytes())
        .map_err(e("flash size"))?;
    Ok(())
}
