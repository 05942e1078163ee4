//! The whole flash as a probe reads and writes it: `--flash-out` at the
//! end of a run, `--flash-in` at the start of another.

use crate::machine::Machine;

impl Machine {
    /// The whole flash, every bank, as a probe would read it back.
    pub fn flash(&self) -> Result<Vec<u8>, String> {
        let (base, size) = self.uc.get_data().chip.flash;
        self.uc
            .mem_read_as_vec(u64::from(base), size as usize)
            .map_err(|e| format!("unicorn: reading the flash: {e:?}"))
    }

    /// Replaces the whole flash (and its alias) with `bytes`, which must
    /// be exactly the chip's flash size.
    pub fn set_flash(&mut self, bytes: &[u8]) -> Result<(), String> {
        let chip = self.uc.get_data().chip;
        if bytes.len() != chip.flash.1 as usize {
            return Err(format!(
                "{} bytes, but {} has {} bytes of flash",
                bytes.len(),
                chip.name,
                chip.flash.1
            ));
        }
        let e = |err| format!("unicorn: writing the flash: {err:?}");
        let (base, size) = (u64::from(chip.flash.0), u64::from(chip.flash.1));
        self.uc.mem_write(base, bytes).map_err(e)?;
        let s = self.uc.get_data_mut();
        s.code_changed.push((base, base + size));
        if let Some((alias, _, size)) = chip.flash_alias {
            self.uc
                .mem_write(u64::from(alias), bytes.get(..size as usize).unwrap_or(&[]))
                .map_err(e)?;
            let alias = u64::from(alias);
            self.uc
                .get_data_mut()
                .code_changed
                .push((alias, alias + u64::from(size)));
        }
        crate::hooks::follow_code(&mut self.uc)
    }
}
