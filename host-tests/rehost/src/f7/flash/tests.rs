//! The F7 flash interface's unit tests (`flash.rs`), on the shared
//! flash bench.

use super::*;

type Bench = crate::flash_array::testing::Bench<Flash>;

fn bench() -> Bench {
    Bench::new(Flash::new(), 16_000_000)
}

fn unlock(b: &mut Bench) {
    b.unlock_at(KEYR, [KEY1, KEY2]);
}

#[test]
fn the_key_sequence_unlocks_and_a_wrong_key_is_refused() {
    let mut b = bench();
    assert_ne!(b.r(CR) & CR_LOCK, 0);
    let e = b.w(CR, CR_PG).unwrap_err();
    assert!(e.contains("while locked"), "{e}");
    unlock(&mut b);
    assert_eq!(b.r(CR) & CR_LOCK, 0);
    b.w(CR, CR_LOCK).unwrap();
    assert_ne!(b.r(CR) & CR_LOCK, 0);
    let e = b.w(KEYR, KEY2).unwrap_err();
    assert!(e.contains("bus error"), "{e}");
}

#[test]
fn a_word_is_programmed_at_x32_and_a_wrong_size_is_flagged() {
    let mut b = bench();
    unlock(&mut b);
    b.w(CR, CR_PG | (2 << 8)).unwrap();
    b.store(0x0808_0000, 4, 0x1234_5678, &[0xFF; 4]).unwrap();
    assert_eq!(
        b.shared.program,
        vec![(0x0808_0000, vec![0x78, 0x56, 0x34, 0x12])]
    );
    // Busy for the program time, and the core stalled that long.
    assert_ne!(b.r(SR) & SR_BSY, 0);
    assert_eq!(b.shared.stall, 16 * PROGRAM_US);
    b.now += 16 * PROGRAM_US;
    assert_eq!(b.r(SR) & SR_BSY, 0);
    // A half-word at x32: PGPERR, nothing written.
    b.shared.program.clear();
    b.store(0x0808_0004, 2, 0, &[0xFF; 2]).unwrap();
    assert!(b.shared.program.is_empty());
    assert_ne!(b.r(SR) & SR_PGPERR, 0);
    b.w(SR, SR_PGPERR).unwrap();
    assert_eq!(b.r(SR) & SR_PGPERR, 0);
}

#[test]
fn stores_without_pg_and_over_cleared_bits_are_refused() {
    let mut b = bench();
    let e = b.store(0x0808_0000, 4, 0, &[0xFF; 4]).unwrap_err();
    assert!(e.contains("without FLASH_CR.PG"), "{e}");
    unlock(&mut b);
    b.w(CR, CR_PG | (2 << 8)).unwrap();
    // 0x0F over 0xF0: sets bits, which only an erase does.
    let e = b
        .store(0x0808_0000, 4, 0x0F, &[0xF0, 0xFF, 0xFF, 0xFF])
        .unwrap_err();
    assert!(e.contains("only an erase sets"), "{e}");
    // Clearing more bits of a programmed word is allowed.
    b.store(0x0808_0000, 4, 0x00, &[0xF0, 0xFF, 0xFF, 0xFF])
        .unwrap();
}

#[test]
fn a_sector_erase_takes_its_time_and_leaves_all_ones() {
    let mut b = bench();
    unlock(&mut b);
    b.w(CR, CR_SER | (6 << 3)).unwrap();
    b.w(CR, CR_SER | (6 << 3) | CR_STRT).unwrap();
    assert_ne!(b.r(SR) & SR_BSY, 0);
    // 4 s for 256K, at 16 MHz.
    let len = 16 * 4_000_000;
    assert_eq!(b.shared.stall, len);
    let e = b.w(CR, 0).unwrap_err();
    assert!(e.contains("while an operation is under way"), "{e}");
    b.now += len;
    assert_eq!(b.r(SR) & SR_BSY, 0);
    assert_eq!(b.shared.program.len(), 1);
    assert_eq!(b.shared.program[0].0, 0x0808_0000);
    assert_eq!(b.shared.program[0].1.len(), 256 * 1024);
    assert!(b.shared.program[0].1.iter().all(|&x| x == 0xFF));
    // A sector single-bank mode does not have.
    b.w(CR, CR_SER | (12 << 3)).unwrap();
    let e = b.w(CR, CR_SER | (12 << 3) | CR_STRT).unwrap_err();
    assert!(e.contains("sector 12"), "{e}");
}

#[test]
fn the_sectors_are_rm0410s() {
    assert_eq!(sector(0, false), Some((0x0800_0000, 32 * 1024)));
    assert_eq!(sector(4, false), Some((0x0802_0000, 128 * 1024)));
    assert_eq!(sector(5, false), Some((0x0804_0000, 256 * 1024)));
    assert_eq!(sector(11, false), Some((0x081C_0000, 256 * 1024)));
    assert_eq!(sector(12, false), None);
    // Dual-bank mode (Table 5).
    assert_eq!(sector(3, true), Some((0x0800_C000, 16 * 1024)));
    assert_eq!(sector(4, true), Some((0x0801_0000, 64 * 1024)));
    assert_eq!(sector(5, true), Some((0x0802_0000, 128 * 1024)));
    assert_eq!(sector(11, true), Some((0x080E_0000, 128 * 1024)));
    assert_eq!(sector(12, true), None);
    assert_eq!(sector(15, true), None);
    assert_eq!(sector(16, true), Some((0x0810_0000, 16 * 1024)));
    assert_eq!(sector(20, true), Some((0x0811_0000, 64 * 1024)));
    assert_eq!(sector(27, true), Some((0x081E_0000, 128 * 1024)));
    assert_eq!(sector(28, true), None);
}

#[test]
fn dual_bank_mode_reads_back_and_erases_bank_2_without_stalling() {
    let mut b = Bench::new(Flash::dual_bank(), 16_000_000);
    assert_eq!(b.r(OPTCR) & OPTCR_NDBANK, 0);
    assert_ne!(bench().r(OPTCR) & OPTCR_NDBANK, 0);
    unlock(&mut b);
    // Bank 2's last sector (23, SNB 27): busy 4 s, no stall.
    b.w(CR, CR_SER | (27 << 3)).unwrap();
    b.w(CR, CR_SER | (27 << 3) | CR_STRT).unwrap();
    assert_ne!(b.r(SR) & SR_BSY, 0);
    assert_eq!(b.shared.stall, 0);
    b.now += 16 * 4_000_000;
    assert_eq!(b.r(SR) & SR_BSY, 0);
    assert_eq!(b.shared.program[0].0, 0x081E_0000);
    assert_eq!(b.shared.program[0].1.len(), 128 * 1024);
    // A program in bank 2 does not stall either; one in bank 1 does.
    b.w(CR, CR_PG | (2 << 8)).unwrap();
    b.store(0x081E_0000, 4, 0, &[0xFF; 4]).unwrap();
    assert_eq!(b.shared.stall, 0);
    b.now += 16 * PROGRAM_US;
    b.store(0x0802_0000, 4, 0, &[0xFF; 4]).unwrap();
    assert_eq!(b.shared.stall, 16 * PROGRAM_US);
    // SNB 12: no sector in this mode (bank 2 starts at 16).
    b.now += 16 * PROGRAM_US;
    b.w(CR, CR_SER | (12 << 3)).unwrap();
    let e = b.w(CR, CR_SER | (12 << 3) | CR_STRT).unwrap_err();
    assert!(e.contains("dual-bank mode does not have"), "{e}");
}
