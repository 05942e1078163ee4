//! A system reset of the chip: SYSRESETREQ or the independent watchdog.
//! The core restarts from the vector table; every peripheral is built
//! anew at its reset values, the external PHY too (its nRST is the MCU's
//! NRST on the NUCLEO-144, UM1974); the RAM keeps what it held (the crash
//! record lives there) and RCC keeps its reset flags with the cause's
//! added (RM0410 §5.1.2 and §5.3.21, RM0433 §8.4.2 and §8.7.37). The wire
//! and the host's side of it stay: a cable does not notice a reset.

use crate::bus::{Bus, ResetCause};
use crate::clocks::Clocks;
use crate::scs::Scs;
use crate::state::Active;
use crate::state::State;
use crate::wiring::Wiring;
use unicorn_engine::{RegisterARM, Unicorn};

/// The core as it leaves reset: the main stack pointer and the PC from
/// the vector table at the boot address, thread mode, privileged, nothing
/// masked, no floating-point context (B1.5.5, "Reset behavior").
pub fn reset_core(uc: &mut Unicorn<State>) -> Result<(), String> {
    // Read from the memory, not the image loaded at power-on: what the
    // boot address holds now.
    let boot = u64::from(uc.get_data().chip.boot);
    let word = |uc: &Unicorn<State>, at: u64, what: &str| -> Result<u32, String> {
        let b = uc
            .mem_read_as_vec(at, 4)
            .map_err(|e| format!("{what} at {at:#010x}: {e:?}"))?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let sp = word(uc, boot, "no vector table")?;
    let pc = word(uc, boot + 4, "no reset vector")?;
    if pc & 1 == 0 {
        return Err(format!(
            "the reset vector at {:#010x} ({pc:#010x}) is not a Thumb address: the core locks up",
            boot + 4
        ));
    }
    for (reg, v) in [
        (RegisterARM::CONTROL, 0),
        (RegisterARM::PRIMASK, 0),
        (RegisterARM::BASEPRI, 0),
        (RegisterARM::FAULTMASK, 0),
        (RegisterARM::IPSR, 0),
        (RegisterARM::LR, 0xFFFF_FFFF),
        (RegisterARM::MSP, sp),
        (RegisterARM::SP, sp),
        (RegisterARM::PC, pc & !1),
    ] {
        uc.reg_write(reg, u64::from(v))
            .map_err(|e| format!("unicorn: writing {reg:?}: {e:?}"))?;
    }
    Ok(())
}

/// The power fails and comes back (`--power-cut N`): the chip starts as
/// at power-on, every peripheral at its reset values (RCC's flags as
/// after a power-on reset), the SRAM holding no trace of before (the
/// power-on pattern again), the flash kept: it is what survives.
pub fn power_cycle(uc: &mut Unicorn<State>, fresh: (Bus, Clocks)) -> Result<(), String> {
    for (base, end) in crate::memories::fill_sram(uc)? {
        // No code translated from before the cut runs from it again.
        uc.ctl_remove_cache(base, end)
            .map_err(|e| format!("unicorn: dropping translated code: {e:?}"))?;
        uc.get_data_mut()
            .block_sizes
            .retain(|a, _| *a < base || *a >= end);
    }
    let s = uc.get_data_mut();
    s.shared.flash.cut = false;
    s.shared.flash.kept = None;
    s.shared.program.clear();
    s.shared.stall = 0;
    // No reset flags kept: the fresh RCC's are power-on's.
    s.bus = Bus::default();
    system_reset(uc, ResetCause::Software, fresh)
}

/// Restarts the chip for `cause` with the peripherals `fresh` (the chip's
/// models at their reset values).
pub fn system_reset(
    uc: &mut Unicorn<State>,
    cause: ResetCause,
    fresh: (Bus, Clocks),
) -> Result<(), String> {
    let s = uc.get_data_mut();
    let (mut bus, clocks) = fresh;
    if let Some(kept) = s.bus.blocks.iter().find_map(|b| b.model.reset_flags()) {
        for b in &mut bus.blocks {
            b.model.keep_reset_flags(kept, cause);
        }
    }
    s.bus = bus;
    s.shared.clocks = clocks;
    s.shared.raised.clear();
    s.shared.wiring = Wiring::default();
    s.shared.reset = None;
    let mut scs = Scs::new();
    (scs.vtor, scs.mpu_regions) = (s.chip.vtor, s.chip.mpu_regions);
    s.scs = scs;
    s.active = Active::default();
    s.fault = None;
    s.exception_return = None;
    s.sleeping = None;
    s.event = false;
    // The MPU is off: every page it had protected writable again.
    crate::mpu_enforce::sync(uc)?;
    reset_core(uc)
}

#[cfg(test)]
mod tests {
    use unicorn_engine::RegisterARM;

    #[test]
    fn a_power_cut_loses_the_sram_and_keeps_the_flash() {
        let mut m = crate::machine::testing::h743(&[]);
        m.uc.mem_write(0x2000_0000, &[1, 2, 3, 4]).unwrap();
        m.uc.mem_write(0x2400_0000, &[5; 4]).unwrap();
        let mut flash = crate::machine::testing::flash_with(&[0xBF00]);
        flash[0x10_0000..0x10_0004].copy_from_slice(&[0x12, 0x34, 0x56, 0x78]);
        m.set_flash(&flash).unwrap();
        m.uc.reg_write(RegisterARM::PC, 0x0800_0020).unwrap();
        m.uc.get_data_mut().shared.flash.cut = true;
        super::power_cycle(&mut m.uc, crate::h7::bus()).unwrap();
        let p = crate::memories::POWER_ON_RAM;
        assert_eq!(m.uc.mem_read_as_vec(0x2000_0000, 4).unwrap(), [p; 4]);
        assert_eq!(m.uc.mem_read_as_vec(0x2400_0000, 4).unwrap(), [p; 4]);
        assert_eq!(
            m.uc.mem_read_as_vec(0x0810_0000, 4).unwrap(),
            [0x12, 0x34, 0x56, 0x78]
        );
        // The core starts again from the vector table the flash holds.
        assert_eq!(m.uc.reg_read(RegisterARM::PC).unwrap(), 0x0800_0040);
        assert_eq!(m.uc.reg_read(RegisterARM::MSP).unwrap(), 0x2000_1000);
        assert!(!m.uc.get_data().shared.flash.cut);
    }
}
