//! Torn flash words on the H743: which words a torn cut leaves, and what
//! the core meets when it reads one (tiny programs on the engine's test
//! machine).

use super::*;
use crate::machine::Machine;
use unicorn_engine::RegisterARM;

/// The torn word the programs read, in bank 2 (word 0x7000 of it).
const TORN: u32 = 0x081E_0000;
const SR2: u64 = 0x5200_2110;
const CCR2: u64 = 0x5200_2114;
const ECC_FA2: u64 = 0x5200_2160;
const DBECCERR: u64 = 1 << 26;

/// The H743 with `code` at 0x20 (Thumb half-words), `handler` as its
/// HardFault handler at 0x40, and [`TORN`] torn and watched.
fn machine(code: &[u16], handler: &[u16]) -> Machine {
    let mut flash = crate::machine::testing::flash_with(code);
    flash[0x0C..0x10].copy_from_slice(&0x0800_0041u32.to_le_bytes());
    for (i, hw) in handler.iter().enumerate() {
        flash[0x40 + 2 * i..0x42 + 2 * i].copy_from_slice(&hw.to_le_bytes());
    }
    let mut m = crate::machine::testing::h743(&[]);
    m.set_flash(&flash).unwrap();
    m.uc.get_data_mut().shared.flash.torn.insert(TORN);
    watch(&mut m.uc).unwrap();
    for (r, v) in [
        (RegisterARM::R1, u64::from(TORN) + 4),
        (RegisterARM::R4, SR2),
        (RegisterARM::R5, ECC_FA2),
        (RegisterARM::R6, DBECCERR),
        (RegisterARM::R7, CCR2),
        (RegisterARM::PC, 0x0800_0020),
    ] {
        m.uc.reg_write(r, v).unwrap();
    }
    m
}

fn reg(m: &Machine, r: RegisterARM) -> u64 {
    m.uc.reg_read(r).unwrap()
}

#[test]
fn a_torn_program_tears_its_word_and_a_torn_erase_its_whole_sector() {
    let mut f = FlashOps {
        cut_op: Some((0x081E_0040, 32, false)),
        ..FlashOps::default()
    };
    assert!(tear(&mut f), "a program's bytes reach the array");
    assert_eq!(f.torn.iter().copied().collect::<Vec<_>>(), [0x081E_0040]);
    assert_eq!(hit(&f, 0x081E_005C, 4), Some(0x081E_0040));
    assert_eq!(hit(&f, 0x081E_003C, 4), None);
    assert_eq!(hit(&f, 0x081E_003E, 4), Some(0x081E_0040), "a read across");
    let mut f = FlashOps {
        cut_op: Some((0x081E_0000, 128 * 1024, true)),
        ..FlashOps::default()
    };
    assert!(!tear(&mut f), "an erase's bytes stay as they were");
    assert_eq!(f.torn.len(), 4096);
    assert_eq!(f.torn.last(), Some(&0x081F_FFE0));
}

/// A plain load of a torn word: a precise BusFault, escalated to
/// HardFault (BusFault is not enabled), stacking the load's own address,
/// with BFAR and DBECCERR set. The handler reads FLASH_SR2 and ECC_FA2R.
#[test]
fn a_load_of_a_torn_word_is_a_precise_bus_fault() {
    // ldr r0,[r1]; b .   handler: ldr r2,[r4]; ldr r3,[r5]; b .
    let mut m = machine(&[0x6808, 0xE7FE], &[0x6822, 0x682B, 0xE7FE]);
    assert!(m.run(500).is_none());
    assert_eq!(reg(&m, RegisterARM::PC), 0x0800_0044, "in the handler");
    let s = m.uc.get_data();
    assert_eq!(s.scs.cfsr & (PRECISERR | BFARVALID), PRECISERR | BFARVALID);
    assert_eq!(s.scs.bfar, TORN + 4);
    assert_ne!(s.scs.hfsr & crate::fault::FORCED, 0);
    let sp = reg(&m, RegisterARM::MSP);
    let stacked_pc = m.uc.mem_read_as_vec(sp + 24, 4).unwrap();
    assert_eq!(stacked_pc, 0x0800_0020u32.to_le_bytes(), "the load's own");
    assert_eq!(reg(&m, RegisterARM::R2) & DBECCERR, DBECCERR);
    assert_eq!(reg(&m, RegisterARM::R3), 0xE_0000 / 32);
}

/// The careful read: under FAULTMASK with SCB.CCR.BFHFNMIGN the fault is
/// ignored and the load goes on; DBECCERR says what happened, and
/// CLR_DBECCERR clears it and the failing address.
#[test]
fn under_faultmask_with_bfhfnmign_the_fault_is_ignored_and_flagged() {
    // cpsid f; ldr r0,[r1]; cpsie f; ldr r2,[r4]; ldr r3,[r5];
    // str r6,[r7]; ldr r6,[r4]; ldr r7,[r5]; b .
    let code = [
        0xB671, 0x6808, 0xB661, 0x6822, 0x682B, 0x603E, 0x6826, 0x682F, 0xE7FE,
    ];
    let mut m = machine(&code, &[0xE7FE]);
    m.uc.get_data_mut().scs.ccr |= BFHFNMIGN;
    assert!(m.run(500).is_none());
    assert_eq!(reg(&m, RegisterARM::PC), 0x0800_0030, "ran to its end");
    assert_eq!(m.uc.get_data().exceptions_taken, 0);
    assert_eq!(reg(&m, RegisterARM::R2) & DBECCERR, DBECCERR);
    assert_eq!(reg(&m, RegisterARM::R3), 0xE_0000 / 32);
    assert_eq!(reg(&m, RegisterARM::R6) & DBECCERR, 0, "cleared");
    assert_eq!(reg(&m, RegisterARM::R7), 0, "the address with it");
}

/// Under FAULTMASK without BFHFNMIGN the bus fault cannot be taken: the
/// core locks up (B1.5.15), which ends the run.
#[test]
fn under_faultmask_without_bfhfnmign_the_core_locks_up() {
    let mut m = machine(&[0xB671, 0x6808, 0xE7FE], &[0xE7FE]);
    let stop = m.run(500).expect("a lock-up ends the run");
    assert!(format!("{stop:?}").contains("locks up"), "{stop:?}");
}

/// A word nobody tore reads as memory, inside the watched span too.
#[test]
fn the_words_beside_a_torn_one_read_as_they_are() {
    let mut m = machine(&[0x6808, 0xE7FE], &[0xE7FE]);
    // A second torn word two words on: the hook watches both, and the
    // word between them.
    m.uc.get_data_mut().shared.flash.torn.insert(TORN + 64);
    watch(&mut m.uc).unwrap();
    assert_eq!(
        m.uc.get_data().torn_hook.map(|(_, a, b)| (a, b)),
        Some((u64::from(TORN), u64::from(TORN) + 95))
    );
    m.uc.reg_write(RegisterARM::R1, u64::from(TORN) + 32)
        .unwrap();
    assert!(m.run(500).is_none());
    assert_eq!(reg(&m, RegisterARM::PC), 0x0800_0022);
    assert_eq!(reg(&m, RegisterARM::R0), 0xFFFF_FFFF);
    assert!(m.uc.get_data().fault.is_none());
}
