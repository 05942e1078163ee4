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
    let (boot, sp, pc) = {
        let s = uc.get_data();
        let boot = u64::from(s.chip.boot);
        (
            boot,
            s.image
                .word(boot)
                .ok_or("no vector table at the boot address")?,
            s.image.word(boot + 4).ok_or("no reset vector")?,
        )
    };
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
