//! The instructions the machine must see (WFI, WFE, SEV, the unmasking
//! ones), found in the image by their encodings, and the instruction
//! count of a translated block.

use crate::image::Image;
use crate::state::State;
use unicorn_engine::Unicorn;

/// An instruction the model must see (ARMv7-M A7.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Seen {
    /// WFI or WFE: the core sleeps until the next event.
    Sleep,
    /// SEV: the event register.
    Sev,
    /// CPSIE (i, f or both), or MSR to PRIMASK/BASEPRI/BASEPRI_MAX/
    /// FAULTMASK: a pending interrupt may be taken at once.
    Unmask,
    /// YIELD: a NOP on the Cortex-M7, undefined to unicorn
    /// ([`step_over_yield`]).
    Yield,
}

/// What the half-word `hw` (followed by `next`) is, if it starts one of
/// the instructions the model must see. A match in data or inside a
/// 32-bit instruction is harmless: a code hook fires only where an
/// instruction starts.
pub(crate) fn seen(hw: u16, next: u16) -> Option<Seen> {
    if hw == 0xBF30 || hw == 0xBF20 {
        Some(Seen::Sleep)
    } else if hw == 0xBF40 {
        Some(Seen::Sev)
    } else if hw == 0xBF10 {
        Some(Seen::Yield)
    } else if (0xB661..=0xB663).contains(&hw)
        || (hw & 0xFFF0 == 0xF380
            && next & 0xFF00 == 0x8800
            && (0x10..=0x13).contains(&(next & 0xFF)))
    {
        Some(Seen::Unmask)
    } else {
        None
    }
}

/// Hooks on the instructions the model must see in the image as loaded.
pub(crate) fn install_instruction_hooks(
    uc: &mut Unicorn<'static, State>,
    image: &Image,
) -> Result<(), String> {
    for l in &image.loads {
        let end = l.addr + l.bytes.len() as u64;
        uc.get_data_mut().code_changed.push((l.addr, end));
    }
    follow_code(uc)
}

/// Makes the instruction hooks follow what memory now holds where it was
/// written ([`State::code_changed`]): the flash a swap rewrote holds
/// another image, whose WFI, SEV and unmasking instructions are at other
/// addresses. Hooks left at the old image's addresses would make an
/// arbitrary instruction of the new one a sleep (skipped on wake), and
/// the new image's own WFIs would run as no-ops. Also drops the
/// translated blocks and the instruction counts of the changed code.
pub(crate) fn follow_code(uc: &mut Unicorn<'static, State>) -> Result<(), String> {
    let changed = std::mem::take(&mut uc.get_data_mut().code_changed);
    for (start, end) in changed {
        // A match at `a` reads the half-words at `a` and `a + 2`.
        let mut from = start.saturating_sub(2) & !1;
        if uc.mem_read_as_vec(from, 2).is_err() {
            // The start of a memory.
            from = start & !1;
        }
        let stale: Vec<u64> = uc
            .get_data()
            .instruction_hooks
            .range(from..end)
            .map(|(a, _)| *a)
            .collect();
        for a in stale {
            if let Some(id) = uc.get_data_mut().instruction_hooks.remove(&a) {
                uc.remove_hook(id)
                    .map_err(|e| format!("unicorn: removing a hook: {e:?}"))?;
            }
        }
        let mut bytes = vec![0; (end + 2 - from) as usize];
        if uc.mem_read(from, &mut bytes).is_err() {
            // The last half-word past the end of a memory.
            bytes.truncate(bytes.len() - 2);
            uc.mem_read(from, &mut bytes)
                .map_err(|e| format!("unicorn: reading code at {from:#x}: {e:?}"))?;
        }
        let hws: Vec<u16> = bytes
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        for (i, &hw) in hws.iter().enumerate() {
            let addr = from + 2 * i as u64;
            if addr >= end {
                break;
            }
            if let Some(kind) = seen(hw, hws.get(i + 1).copied().unwrap_or(0)) {
                let id = hook(uc, addr, kind)?;
                uc.get_data_mut().instruction_hooks.insert(addr, id);
            }
        }
        uc.ctl_remove_cache(from, end)
            .map_err(|e| format!("unicorn: dropping translated code: {e:?}"))?;
        // A translated block is at most a page (1K here) long: a count
        // cached for one starting up to 4K before may cover the change.
        let low = from.saturating_sub(4096);
        uc.get_data_mut()
            .block_sizes
            .retain(|a, _| *a < low || *a >= end);
    }
    Ok(())
}

/// YIELD is a hint every ARMv7-M core may run as a NOP (A7.7.263; the
/// Cortex-M7 does), and `core::hint::spin_loop` emits it; unicorn raises
/// it as undefined (a UsageFault the image would never take). Its hook
/// stops the core before it, and it is stepped over here, outside an IT
/// block; inside one the IT state would have to advance with it, which
/// is not modelled: said.
///
/// Whether it is in an IT block is read from the code, as unicorn does
/// not keep the IT state in xPSR between a hook and the next start: an IT
/// instruction (0xBFxy, mask y not 0) in any of the four half-words
/// before it. A half-word of data or of a 32-bit instruction may look
/// like one: the engine then refuses a YIELD it could have stepped over,
/// never the other way round.
pub(crate) fn step_over_yield(uc: &mut Unicorn<'static, State>, pc: u32) -> Result<(), String> {
    use unicorn_engine::RegisterARM;
    let mut before = [0u8; 8];
    let _ = uc.mem_read(u64::from(pc.saturating_sub(8)), &mut before);
    let in_it = before
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .any(|hw| hw & 0xFF00 == 0xBF00 && hw & 0x000F != 0);
    if in_it {
        return Err(format!(
            "a YIELD inside an IT block at {pc:#010x}, which unicorn raises as undefined (silicon runs it as a NOP): not modelled"
        ));
    }
    uc.reg_write(RegisterARM::PC, u64::from(pc) + 2)
        .map_err(|e| format!("unicorn: stepping over YIELD: {e:?}"))
}

/// One instruction's hook.
fn hook(
    uc: &mut Unicorn<'static, State>,
    addr: u64,
    kind: Seen,
) -> Result<unicorn_engine::UcHookId, String> {
    let id = match kind {
        Seen::Sleep => uc.add_code_hook(addr, addr, |uc, addr, size| {
            let mut hw = [0; 2];
            let _ = uc.mem_read(addr, &mut hw);
            let wfe = u16::from_le_bytes(hw) == 0xBF20;
            uc.get_data_mut().sleeping = Some((addr as u32, size, wfe));
            let _ = uc.emu_stop();
        }),
        Seen::Sev => uc.add_code_hook(addr, addr, |uc, _, _| uc.get_data_mut().event = true),
        Seen::Yield => uc.add_code_hook(addr, addr, |uc, addr, _| {
            uc.get_data_mut().yield_at = Some(addr as u32);
            let _ = uc.emu_stop();
        }),
        Seen::Unmask => uc.add_code_hook(addr, addr, |uc, _, _| {
            let s = uc.get_data();
            let pending = s.scs.pendsv
                || s.scs.systick_pending
                || s.scs
                    .pending
                    .iter()
                    .zip(&s.scs.enabled)
                    .any(|(p, e)| *p && *e);
            if pending {
                // Not emu_stop: from a code hook it stops before the hooked
                // instruction, which would then never run. The block hook
                // stops at the next block, after the unmasking instruction
                // (which ends its block: it changes the interrupt mask).
                uc.get_data_mut().deadline = 0;
            }
        }),
    };
    id.map_err(|e| format!("unicorn: {kind:?} hook at {addr:#x}: {e:?}"))
}

/// Thumb-2 instructions in a run of code: a half-word whose top five bits
/// are 0b11101, 0b11110 or 0b11111 starts a 32-bit instruction (ARMv7-M
/// ARM A5.1), every other one is a 16-bit instruction.
pub fn thumb_instructions(code: &[u8]) -> u64 {
    let mut i = 0;
    let mut n = 0;
    while i + 1 < code.len() {
        let hw = u16::from_le_bytes([code[i], code[i + 1]]);
        i += if hw >> 11 >= 0b11101 { 4 } else { 2 };
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hooked(m: &crate::machine::Machine) -> Vec<u64> {
        m.uc.get_data().instruction_hooks.keys().copied().collect()
    }

    #[test]
    fn yield_runs_as_the_hint_it_is() {
        use unicorn_engine::RegisterARM;
        // YIELD, NOP, then `b .` at 0x24.
        let mut m = crate::machine::testing::h743(&[0xBF10, 0xBF00, 0xE7FE]);
        m.uc.reg_write(RegisterARM::PC, 0x0800_0020).unwrap();
        assert!(m.run(200).is_none());
        assert_eq!(m.uc.reg_read(RegisterARM::PC).unwrap(), 0x0800_0024);
        assert_eq!(m.uc.get_data().exceptions_taken, 0);
        // Inside an IT block it is not skipped: said, not faulted.
        let mut m = crate::machine::testing::h743(&[0x2800, 0xBF08, 0xBF10, 0xE7FE]);
        m.uc.reg_write(RegisterARM::PC, 0x0800_0020).unwrap();
        let stop = m.run(200).expect("a YIELD in an IT block is refused");
        assert!(format!("{stop:?}").contains("IT block"), "{stop:?}");
    }

    #[test]
    fn the_instruction_hooks_follow_an_image_written_over_another() {
        // The old image: a WFI at 0x20. The new one: a NOP there, then
        // CPSIE i at 0x22, MSR BASEPRI, r0 at 0x24 and SEV at 0x28.
        let mut m = crate::machine::testing::h743(&[0xBF30]);
        assert_eq!(hooked(&m), [0x0800_0020]);
        m.uc.get_data_mut().block_sizes.insert(0x0800_0020, 1);
        m.uc.get_data_mut().block_sizes.insert(0x0800_4000, 1);
        // As the flash model's program operations write it: only the
        // changed range is looked at again.
        let new: Vec<u8> = [0xBF00u16, 0xB662, 0xF380, 0x8811, 0xBF40]
            .iter()
            .flat_map(|hw| hw.to_le_bytes())
            .collect();
        m.uc.mem_write(0x0800_0020, &new).unwrap();
        m.uc.get_data_mut()
            .code_changed
            .push((0x0800_0020, 0x0800_0020 + new.len() as u64));
        follow_code(&mut m.uc).unwrap();
        assert_eq!(hooked(&m), [0x0800_0022, 0x0800_0024, 0x0800_0028]);
        // The old block's instruction count is dropped; one past the
        // change is kept.
        let sizes = &m.uc.get_data().block_sizes;
        assert!(!sizes.contains_key(&0x0800_0020));
        assert!(sizes.contains_key(&0x0800_4000));
        // A whole flash put in (`--flash-in`) is followed the same way.
        m.set_flash(&crate::machine::testing::flash_with(&[0xBF20]))
            .unwrap();
        assert_eq!(hooked(&m), [0x0800_0020]);
    }

    #[test]
    fn only_the_instructions_the_model_must_see_are_seen() {
        assert_eq!(seen(0xBF30, 0), Some(Seen::Sleep));
        assert_eq!(seen(0xBF20, 0), Some(Seen::Sleep));
        assert_eq!(seen(0xBF40, 0), Some(Seen::Sev));
        assert_eq!(seen(0xB662, 0), Some(Seen::Unmask));
        // CPSIE f and CPSIE if: FAULTMASK cleared (the H743's careful
        // flash read), a pending interrupt taken at once.
        assert_eq!(seen(0xB661, 0), Some(Seen::Unmask));
        assert_eq!(seen(0xB663, 0), Some(Seen::Unmask));
        assert_eq!(seen(0xB671, 0), None, "CPSID f masks");
        assert_eq!(seen(0xF380, 0x8810), Some(Seen::Unmask));
        // MSR to APSR (0x00) and to CONTROL (0x14) unmask nothing; CPSID.
        assert_eq!(seen(0xF380, 0x8800), None);
        assert_eq!(seen(0xF380, 0x8814), None);
        assert_eq!(seen(0xB672, 0), None);
        assert_eq!(seen(0xBF00, 0), None);
    }

    #[test]
    fn thumb_instructions_are_told_by_their_first_half_word() {
        // movs r0, #1; ldr.w r0, [r8]; bx lr
        assert_eq!(
            thumb_instructions(&[0x01, 0x20, 0xd8, 0xf8, 0x00, 0x00, 0x70, 0x47]),
            3
        );
        assert_eq!(thumb_instructions(&[]), 0);
    }
}
