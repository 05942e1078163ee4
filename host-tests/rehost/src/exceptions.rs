//! Exception entry and return, which unicorn leaves to the machine
//! (ARMv7-M Architecture Reference Manual, DDI 0403E, B1.5): the NVIC's
//! choice of the pending exception to take (B1.5.4, priorities with
//! PRIMASK, BASEPRI, FAULTMASK and the active exceptions), the stack
//! frame pushed on entry (B1.5.6: eight words, or 26 with the floating-
//! point state when CONTROL.FPCA is set, aligned to 8 bytes with xPSR bit
//! 9 saying so), EXC_RETURN in LR, and the frame popped when the handler
//! branches to EXC_RETURN (B1.5.8; unicorn raises its exception #8 then).
//! Fuzzware's `cortexm_nvic.c` was read for the shape of a software NVIC.

use crate::fault::{Fault, BUS_FAULT, FORCED, MEM_MANAGE, MSTKERR, USAGE_FAULT};
use crate::state::State;
use unicorn_engine::{RegisterARM, Unicorn};

/// Exception numbers (B1.5.2).
pub const HARD_FAULT: u32 = 3;
pub const PENDSV: u32 = 14;
pub const SYSTICK: u32 = 15;
/// The first external interrupt.
pub const IRQ0: u32 = 16;

fn r(uc: &Unicorn<State>, reg: RegisterARM) -> u32 {
    uc.reg_read(reg).unwrap_or(0) as u32
}

fn w(uc: &mut Unicorn<State>, reg: RegisterARM, v: u32) -> Result<(), String> {
    uc.reg_write(reg, u64::from(v))
        .map_err(|e| format!("unicorn: writing {reg:?}: {e:?}"))
}

fn read_word(uc: &Unicorn<State>, addr: u32) -> Result<u32, String> {
    let mut b = [0; 4];
    uc.mem_read(u64::from(addr), &mut b)
        .map_err(|_| format!("the exception frame at {addr:#010x} is not in RAM"))?;
    Ok(u32::from_le_bytes(b))
}

fn write_words(uc: &mut Unicorn<State>, addr: u32, words: &[u32]) -> Result<(), String> {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    uc.mem_write(u64::from(addr), &bytes).map_err(|_| {
        format!(
            "the exception frame at {addr:#010x}..+{} is not in RAM: the stack overflowed?",
            bytes.len()
        )
    })
}

/// The priority an exception has now (lower is more urgent).
fn priority(s: &State, exc: u32) -> i32 {
    match exc {
        2 => -2,
        HARD_FAULT => -1,
        4..=15 => i32::from(s.scs.shpr[(exc - 4) as usize]),
        _ => i32::from(s.scs.priority[(exc - IRQ0) as usize]),
    }
}

/// The group priority (PRIGROUP splits off the sub-priority, B1.5.4).
fn group(s: &State, p: i32) -> i32 {
    if p < 0 {
        return p;
    }
    let sub_bits = s.scs.aircr_prigroup + 1;
    p & !((1 << sub_bits) - 1)
}

/// The current execution priority (B1.5.4): 256 with nothing active and
/// nothing masked.
pub fn execution_priority(uc: &Unicorn<State>) -> i32 {
    let s = uc.get_data();
    let mut p = s
        .active
        .stack
        .iter()
        .map(|&(_, p)| group(s, p))
        .min()
        .unwrap_or(256);
    let basepri = r(uc, RegisterARM::BASEPRI) & 0xFF;
    if basepri != 0 {
        p = p.min(group(s, basepri as i32));
    }
    if r(uc, RegisterARM::PRIMASK) & 1 != 0 {
        p = p.min(0);
    }
    if r(uc, RegisterARM::FAULTMASK) & 1 != 0 {
        p = p.min(-1);
    }
    p
}

/// The pending exception that would be taken now, if any: the most
/// urgent by priority, the lowest number among equals.
pub fn next(uc: &Unicorn<State>) -> Option<u32> {
    let s = uc.get_data();
    let mut best: Option<(i32, u32)> = None;
    let mut consider = |exc: u32, p: i32| {
        if best.is_none_or(|(bp, be)| (p, exc) < (bp, be)) {
            best = Some((p, exc));
        }
    };
    if s.scs.pendsv {
        consider(PENDSV, priority(s, PENDSV));
    }
    if s.scs.systick_pending {
        consider(SYSTICK, priority(s, SYSTICK));
    }
    for (i, (&pending, &enabled)) in s.scs.pending.iter().zip(&s.scs.enabled).enumerate() {
        if pending && enabled {
            consider(IRQ0 + i as u32, priority(s, IRQ0 + i as u32));
        }
    }
    let (p, exc) = best?;
    (group(s, p) < execution_priority(uc)).then_some(exc)
}

/// Takes exception `exc`: pushes the frame with `return_to` as the
/// return address, and jumps to its vector.
pub fn enter(uc: &mut Unicorn<State>, exc: u32, return_to: u32) -> Result<(), String> {
    let control = r(uc, RegisterARM::CONTROL);
    let handler_mode = r(uc, RegisterARM::IPSR) & 0x1FF != 0;
    let on_psp = !handler_mode && control & 2 != 0;
    let fp = control & 4 != 0;
    let sp = r(uc, RegisterARM::SP);
    let frame_words: u32 = if fp { 26 } else { 8 };
    let mut frame_sp = sp - frame_words * 4;
    let realigned = frame_sp & 4 != 0;
    if realigned {
        frame_sp -= 4;
    }
    let mut xpsr = r(uc, RegisterARM::XPSR);
    if realigned {
        xpsr |= 1 << 9;
    } else {
        xpsr &= !(1 << 9);
    }
    let mut words = vec![
        r(uc, RegisterARM::R0),
        r(uc, RegisterARM::R1),
        r(uc, RegisterARM::R2),
        r(uc, RegisterARM::R3),
        r(uc, RegisterARM::R12),
        r(uc, RegisterARM::LR),
        return_to & !1,
        xpsr | (1 << 24),
    ];
    if fp {
        for d in 0..8 {
            let reg = RegisterARM::D0 as i32 + d;
            let v = uc.reg_read(reg).unwrap_or(0);
            words.push(v as u32);
            words.push((v >> 32) as u32);
        }
        words.push(r(uc, RegisterARM::FPSCR));
        words.push(0);
    }
    // The MPU checks the frame's writes like any other (B1.5.14): a
    // frame into a write-denied range is not written and sets MSTKERR;
    // the handler is entered all the same (the derived MemManage is taken
    // as the same handler's late arrival).
    let frame_len = u64::from(frame_words * 4 + if realigned { 4 } else { 0 });
    let mpu_applies = uc.get_data().scs.mpu_ctrl & 2 != 0 || execution_priority(uc) >= 0;
    let stacking_fault = mpu_applies
        && crate::mpu::hit(&uc.get_data().mpu_denied, u64::from(frame_sp), frame_len).is_some();
    if stacking_fault {
        uc.get_data_mut().scs.cfsr |= MSTKERR;
    } else {
        write_words(uc, frame_sp, &words)?;
    }
    let exc_return = match (handler_mode, on_psp, fp) {
        (true, _, false) => 0xFFFF_FFF1,
        (true, _, true) => 0xFFFF_FFE1,
        (false, false, false) => 0xFFFF_FFF9,
        (false, false, true) => 0xFFFF_FFE9,
        (false, true, false) => 0xFFFF_FFFD,
        (false, true, true) => 0xFFFF_FFED,
    };
    if on_psp {
        w(uc, RegisterARM::PSP, frame_sp)?;
    } else {
        w(uc, RegisterARM::MSP, frame_sp)?;
    }
    // Handlers run on the main stack, without floating-point context.
    w(uc, RegisterARM::CONTROL, control & !0b110)?;
    w(
        uc,
        RegisterARM::SP,
        if on_psp {
            r(uc, RegisterARM::MSP)
        } else {
            frame_sp
        },
    )?;
    let vtor = uc.get_data().scs.vtor;
    let vector = read_word(uc, vtor + 4 * exc)?;
    if vector & 1 == 0 {
        return Err(format!("vector {exc} ({vector:#010x}) is not a Thumb address: a UsageFault (INVSTATE) on silicon"));
    }
    {
        let s = uc.get_data_mut();
        match exc {
            PENDSV => s.scs.pendsv = false,
            SYSTICK => s.scs.systick_pending = false,
            e if e >= IRQ0 => s.scs.pending[(e - IRQ0) as usize] = false,
            _ => {}
        }
        let p = priority(s, exc);
        s.active.stack.push((exc, p));
        s.exceptions_taken += 1;
    }
    w(uc, RegisterARM::LR, exc_return)?;
    w(uc, RegisterARM::IPSR, exc)?;
    w(uc, RegisterARM::PC, vector & !1)?;
    Ok(())
}

/// Takes `f` (B1.5.14): its own handler when it is enabled in SHCSR and
/// more urgent than the execution priority, else HardFault with HFSR
/// FORCED; a fault the HardFault priority cannot take is a lock-up, which
/// ends the run.
pub fn take_fault(uc: &mut Unicorn<State>, f: Fault) -> Result<(), String> {
    let current = execution_priority(uc);
    let s = uc.get_data_mut();
    let enable_bit = match f.exc {
        MEM_MANAGE => 16,
        BUS_FAULT => 17,
        USAGE_FAULT => 18,
        _ => 0,
    };
    let enabled = enable_bit != 0 && s.scs.shcsr & (1 << enable_bit) != 0;
    let exc = if enabled && group(s, priority(s, f.exc)) < current {
        f.exc
    } else {
        HARD_FAULT
    };
    let name = match f.exc {
        MEM_MANAGE => "MemManage",
        BUS_FAULT => "BusFault",
        USAGE_FAULT => "UsageFault",
        _ => "a fault",
    };
    if exc == HARD_FAULT && current <= -1 {
        return Err(format!(
            "{} ({name}) with the core at priority {current}: the core locks up",
            f.why
        ));
    }
    s.scs.cfsr |= f.cfsr;
    if let Some(a) = f.mmfar {
        s.scs.mmfar = a;
    }
    if let Some(a) = f.bfar {
        s.scs.bfar = a;
    }
    if exc == HARD_FAULT {
        s.scs.hfsr |= FORCED;
    }
    s.scs.fault_reason = Some(format!(
        "{name}{}: {} at PC {:#010x}",
        if exc == HARD_FAULT {
            " (escalated to HardFault)"
        } else {
            ""
        },
        f.why,
        f.at
    ));
    enter(uc, exc, f.at)
}

/// Returns from the innermost exception through `exc_return` (the value
/// the handler branched to): pops its frame and restores the state.
pub fn leave(uc: &mut Unicorn<State>, exc_return: u32) -> Result<(), String> {
    let Some((exc, _)) = uc.get_data_mut().active.stack.pop() else {
        return Err(format!(
            "EXC_RETURN {exc_return:#010x} with no exception active"
        ));
    };
    let to_thread = exc_return & 0xF != 0x1;
    let on_psp = exc_return & 0xF == 0xD;
    let fp = exc_return & 0x10 == 0;
    if to_thread && !uc.get_data().active.stack.is_empty() {
        return Err(format!(
            "EXC_RETURN {exc_return:#010x} returns exception {exc} to thread mode with others still active: an INVPC UsageFault on silicon"
        ));
    }
    let sp = if on_psp {
        r(uc, RegisterARM::PSP)
    } else {
        r(uc, RegisterARM::MSP)
    };
    let count = if fp { 26 } else { 8 };
    let words: Vec<u32> = (0..count)
        .map(|i| read_word(uc, sp + 4 * i))
        .collect::<Result<_, _>>()?;
    let xpsr = words[7];
    let mut new_sp = sp + count * 4;
    if xpsr & (1 << 9) != 0 {
        new_sp += 4;
    }
    for (reg, v) in [
        (RegisterARM::R0, words[0]),
        (RegisterARM::R1, words[1]),
        (RegisterARM::R2, words[2]),
        (RegisterARM::R3, words[3]),
        (RegisterARM::R12, words[4]),
        (RegisterARM::LR, words[5]),
    ] {
        w(uc, reg, v)?;
    }
    if fp {
        for d in 0..8 {
            let v = u64::from(words[8 + 2 * d]) | (u64::from(words[9 + 2 * d]) << 32);
            uc.reg_write(RegisterARM::D0 as i32 + d as i32, v)
                .map_err(|e| format!("unicorn: D{d}: {e:?}"))?;
        }
        w(uc, RegisterARM::FPSCR, words[24])?;
    }
    if on_psp {
        w(uc, RegisterARM::PSP, new_sp)?;
    } else {
        w(uc, RegisterARM::MSP, new_sp)?;
    }
    let control = r(uc, RegisterARM::CONTROL);
    let mut c = control & !0b110;
    if fp {
        c |= 4;
    }
    if on_psp {
        c |= 2;
    }
    w(uc, RegisterARM::CONTROL, c)?;
    w(uc, RegisterARM::SP, new_sp)?;
    w(uc, RegisterARM::XPSR, xpsr & !(1 << 9))?;
    w(
        uc,
        RegisterARM::IPSR,
        if to_thread { 0 } else { xpsr & 0x1FF },
    )?;
    w(uc, RegisterARM::PC, words[6] & !1)?;
    uc.get_data_mut().event = true;
    Ok(())
}
