//! The H743 flash interface's unit tests (`flash.rs`), on the shared
//! flash bench.

use super::*;

type Bench = crate::flash_array::testing::Bench<Flash>;

fn bench() -> Bench {
    Bench::new(Flash::new(), 64_000_000)
}

fn unlock(b: &mut Bench, bank: u32) {
    b.unlock_at(KEYR + 0x100 * bank, [KEY1, KEY2]);
}

/// A word stored into erased flash.
fn store(b: &mut Bench, addr: u32, value: u32) -> Result<(), Refusal> {
    b.store(addr, 4, u64::from(value), &[0xFF; 4])
}

const SR2: u32 = SR + 0x100;
const CR2: u32 = CR + 0x100;

#[test]
fn eight_words_fill_the_buffer_and_program_one_flash_word() {
    let mut b = bench();
    unlock(&mut b, 1);
    b.w(CR2, CR_PG | (2 << 4)).unwrap();
    for i in 0..7 {
        store(&mut b, 0x0810_0000 + 4 * i, i).unwrap();
    }
    assert!(b.shared.program.is_empty());
    assert_eq!(b.r(SR2) & (SR_WBNE | SR_QW | SR_BSY), SR_WBNE);
    store(&mut b, 0x0810_001C, 7).unwrap();
    assert_eq!(b.shared.program.len(), 1);
    assert_eq!(b.shared.program[0].0, 0x0810_0000);
    assert_eq!(&b.shared.program[0].1[..8], &[0, 0, 0, 0, 1, 0, 0, 0]);
    assert_eq!(b.r(SR2) & (SR_WBNE | SR_QW | SR_BSY), SR_QW | SR_BSY);
    // Bank 2: the core, in bank 1, does not wait.
    assert_eq!(b.shared.stall, 0);
    b.now += 64 * program_us(2);
    assert_eq!(b.r(SR2) & (SR_QW | SR_BSY | SR_EOP), SR_EOP);
    b.w(CCR + 0x100, SR_EOP).unwrap();
    assert_eq!(b.r(SR2) & SR_EOP, 0);
}

#[test]
fn another_flash_word_before_the_buffer_is_full_is_an_inconsistency() {
    let mut b = bench();
    unlock(&mut b, 1);
    b.w(CR2, CR_PG).unwrap();
    store(&mut b, 0x0810_0000, 1).unwrap();
    store(&mut b, 0x0810_0020, 2).unwrap();
    assert_ne!(b.r(SR2) & SR_INCERR, 0);
    assert!(b.shared.program.is_empty());
}

#[test]
fn locked_banks_unerased_words_and_stores_without_pg_are_refused() {
    let mut b = bench();
    let e = b.w(CR, CR_PG).unwrap_err();
    assert!(e.contains("while locked"), "{e}");
    unlock(&mut b, 0);
    // Bank 2 is still locked.
    let e = store(&mut b, 0x0810_0000, 0).unwrap_err();
    assert!(e.contains("bank 2") && e.contains("locked"), "{e}");
    let e = store(&mut b, 0x0804_0000, 0).unwrap_err();
    assert!(e.contains("without FLASH_CR1.PG"), "{e}");
    b.w(CR, CR_PG).unwrap();
    let mut cx = b.shared.cx(0, crate::bus::no_dma());
    let e = b
        .flash
        .store(0x0804_0000, 4, 0, &[0xFF, 0xFF, 0x00, 0xFF], &mut cx)
        .unwrap()
        .unwrap_err();
    assert!(e.contains("programmed once after an erase"), "{e}");
    let e = b.w(KEYR, KEY1).unwrap_err();
    assert!(e.contains("bus error"), "{e}");
}

#[test]
fn a_sector_erase_in_bank_1_stalls_the_core_and_in_bank_2_does_not() {
    let mut b = bench();
    unlock(&mut b, 0);
    unlock(&mut b, 1);
    b.w(CR2, CR_SER | (3 << 8)).unwrap();
    b.w(CR2, CR_SER | (3 << 8) | CR_START).unwrap();
    assert_eq!(b.shared.stall, 0);
    let e = b.w(CR2, 0).unwrap_err();
    assert!(e.contains("busy"), "{e}");
    b.w(CR, CR_SER | (1 << 8) | CR_EOPIE | CR_START).unwrap();
    let len = 64 * erase_us(0);
    assert_eq!(b.shared.stall, len);
    b.now += len;
    assert_eq!(b.r(SR) & SR_BSY, 0);
    assert_eq!(b.r(SR2) & SR_BSY, 0);
    // Bank 1's erase had EOPIE: the flash interrupt, once.
    assert_eq!(b.shared.raised, vec![FLASH_IRQ]);
    let erased: Vec<u32> = b.shared.program.iter().map(|p| p.0).collect();
    assert_eq!(erased, vec![0x0802_0000, 0x0816_0000]);
    assert!(b.shared.program.iter().all(|p| p.1.len() == 128 * 1024));
}

const CCR2: u32 = CCR + 0x100;
const ECC_FA2: u32 = ECC_FA + 0x100;

/// A read of a torn word ([`crate::torn_word`]) flags DBECCERR and the
/// failing word in its bank; CLR_DBECCERR clears both; with DBECCERRIE
/// the flash's interrupt is raised.
#[test]
fn a_double_ecc_error_is_flagged_in_its_bank_and_cleared_through_ccr() {
    let mut b = bench();
    b.shared.flash.ecc_errors.push(0x081E_0020);
    assert_eq!(b.r(SR2) & SR_DBECCERR, SR_DBECCERR);
    assert_eq!(b.r(SR) & SR_DBECCERR, 0, "bank 1 saw no error");
    assert_eq!(b.r(ECC_FA2), 0xE_0020 / 32);
    assert!(b.shared.raised.is_empty(), "DBECCERRIE is clear");
    b.w(CCR2, SR_DBECCERR).unwrap();
    assert_eq!(b.r(SR2) & SR_DBECCERR, 0);
    assert_eq!(b.r(ECC_FA2), 0);
    unlock(&mut b, 1);
    b.w(CR2, SR_DBECCERR).unwrap();
    b.shared.flash.ecc_errors.push(0x0810_0000);
    assert_eq!(b.r(ECC_FA2), 0);
    assert_eq!(b.shared.raised, vec![FLASH_IRQ]);
}

/// A torn word is refused to a program until its sector's erase mends
/// it (and every torn word of that sector with it, none of another).
#[test]
fn a_torn_word_is_programmed_again_only_after_its_sectors_erase() {
    let mut b = bench();
    b.shared
        .flash
        .torn
        .extend([0x0810_0000, 0x0810_0020, 0x0812_0000]);
    unlock(&mut b, 1);
    b.w(CR2, CR_PG).unwrap();
    let e = store(&mut b, 0x0810_0004, 0).unwrap_err();
    assert!(e.contains("a power cut tore"), "{e}");
    b.w(CR2, 0).unwrap();
    b.w(CR2, CR_SER).unwrap();
    b.w(CR2, CR_SER | CR_START).unwrap();
    b.now += 64 * erase_us(0);
    assert_eq!(b.r(SR2) & SR_BSY, 0);
    assert_eq!(
        b.shared.flash.torn.iter().copied().collect::<Vec<_>>(),
        [0x0812_0000],
        "sector 1's torn word stays"
    );
    b.w(CR2, CR_PG).unwrap();
    store(&mut b, 0x0810_0004, 0).unwrap();
}
