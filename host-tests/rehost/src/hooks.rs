//! The instructions the machine must see (WFI, WFE, SEV, the unmasking
//! ones), found in the image by their encodings, and the instruction
//! count of a translated block.

use crate::image::Image;
use crate::state::State;
use unicorn_engine::Unicorn;

/// Hooks on the instructions the model must see (ARMv7-M A7.7): WFI and
/// WFE (the core sleeps until the next event), SEV (the event register),
/// and CPSIE and MSR to PRIMASK/BASEPRI/FAULTMASK, after which a pending
/// interrupt may be taken at once.
pub(crate) fn install_instruction_hooks(
    uc: &mut Unicorn<'static, State>,
    image: &Image,
) -> Result<(), String> {
    let sleeps = image.find_code(|hw, _| hw == 0xBF30 || hw == 0xBF20);
    for addr in sleeps {
        uc.add_code_hook(addr, addr, |uc, addr, size| {
            let mut hw = [0; 2];
            let _ = uc.mem_read(addr, &mut hw);
            let wfe = u16::from_le_bytes(hw) == 0xBF20;
            uc.get_data_mut().sleeping = Some((addr as u32, size, wfe));
            let _ = uc.emu_stop();
        })
        .map_err(|e| format!("unicorn: WFI hook: {e:?}"))?;
    }
    for addr in image.find_code(|hw, _| hw == 0xBF40) {
        uc.add_code_hook(addr, addr, |uc, _, _| uc.get_data_mut().event = true)
            .map_err(|e| format!("unicorn: SEV hook: {e:?}"))?;
    }
    let unmasks = image.find_code(|hw, next| {
        hw == 0xB662
            || (hw & 0xFFF0 == 0xF380
                && next & 0xFF00 == 0x8800
                && (0x10..=0x13).contains(&(next & 0xFF)))
    });
    for addr in unmasks {
        uc.add_code_hook(addr, addr, |uc, _, _| {
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
        })
        .map_err(|e| format!("unicorn: CPSIE hook: {e:?}"))?;
    }
    Ok(())
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
