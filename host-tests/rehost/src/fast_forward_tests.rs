//! Poll loops fast-forwarded: which instructions count as writing
//! nothing, and, on the engine's test machine, a program that programs a
//! flash word and polls FLASH_SR2: fast-forwarded or not, it leaves the
//! loop at the same cycle (read from DWT_CYCCNT) with the same registers.

use super::*;
use crate::machine::Machine;
use unicorn_engine::RegisterARM;

fn bytes(hws: &[u16]) -> Vec<u8> {
    hws.iter().flat_map(|h| h.to_le_bytes()).collect()
}

#[test]
fn loads_data_processing_and_branches_are_pure() {
    for (what, code) in [
        (
            "ldr r0,[r5,#0x10]; lsls r2,r2,#29; bne",
            &[0x6928, 0x0752, 0xD1FC][..],
        ),
        (
            "ldr.w r0,[r10,#0xc]; tst.w r0,#5",
            &[0xF8DA, 0x000C, 0xF010, 0x0F05],
        ),
        (
            "itt ne; ldrne.w; bne.w",
            &[0xBF1C, 0xF8DA, 0x000C, 0xF47F, 0xAF7F],
        ),
        (
            "and.w r0,r1,r2; mul r0,r1; nop",
            &[0xEA01, 0x0002, 0xFB00, 0xF001, 0xBF00],
        ),
        ("pop {r4,pc}; ldmia.w r0,{r1,r2}", &[0xBD10, 0xE890, 0x0006]),
        (
            "bl; b.w; cbz r0; b .",
            &[0xF000, 0xF800, 0xF000, 0xB800, 0xB100, 0xE7FE],
        ),
    ] {
        assert!(pure(&bytes(code)), "{what}");
    }
}

#[test]
fn stores_system_and_coprocessor_instructions_are_not() {
    for (what, code) in [
        ("str r0,[r6,#0x10]", &[0x6130][..]),
        ("str.w r0,[r10,#0xc]", &[0xF8CA, 0x000C]),
        ("strb r0,[r1,r2]", &[0x5488]),
        ("str r2,[sp]", &[0x9200]),
        ("push {r4-r7,lr}", &[0xB5F0]),
        ("stmdb sp!,{r4,lr}", &[0xE92D, 0x4010]),
        ("strd r0,r1,[sp]", &[0xE9CD, 0x0100]),
        ("ldrex r0,[r1]", &[0xE851, 0x0F00]),
        ("vldr s0,[pc]", &[0xED9F, 0x0A00]),
        ("msr basepri,r0", &[0xF380, 0x8811]),
        ("dsb sy", &[0xF3BF, 0x8F4F]),
        ("cpsid i", &[0xB672]),
        ("wfi", &[0xBF30]),
        ("yield", &[0xBF10]),
        ("svc 0", &[0xDF00]),
        ("bx lr", &[0x4770]),
        ("a 32-bit instruction cut off", &[0xF8DA]),
    ] {
        assert!(!pure(&bytes(code)), "{what}");
        // Anywhere in a block.
        let mut block = vec![0x6928, 0x0752];
        block.extend_from_slice(code);
        assert!(!pure(&bytes(&block)), "{what}, after pure ones");
    }
}

#[test]
fn whole_iterations_end_before_the_value_changes_and_before_the_deadline() {
    // Reads at 100 and every 3 cycles; the value changes at 110: the
    // reads at 103, 106 and 109 are skipped, the one at 112 runs.
    assert_eq!(iterations(100, 3, 110, u64::MAX), 3);
    assert_eq!(
        iterations(100, 3, 109, u64::MAX),
        2,
        "109 reads the new value"
    );
    // A deadline at 109 ends the slice after the block of the read at
    // 109: that read must run.
    assert_eq!(iterations(100, 3, u64::MAX, 109), 2);
    assert_eq!(iterations(100, 3, 103, u64::MAX), 0);
    assert_eq!(iterations(100, 3, 100, 50), 0, "both behind already");
}

const KEY1: u64 = 0x4567_0123;
const KEY2: u64 = 0xCDEF_89AB;
/// Bank 2's start, where the program writes its flash word.
const WORD: u64 = 0x0810_0000;

/// The code at 0x20: unlock bank 2, set PG, store the eight words of one
/// flash word, then `body` (the poll loop, with `ldr.w r0,[r8]` reading
/// DWT_CYCCNT after it, and `b .`).
fn program(body: &[u16]) -> Vec<u16> {
    let mut code = vec![0x6025, 0x6026, 0x6038];
    // str r6,[r1,#4k]
    code.extend((0..8).map(|k| 0x600E + 0x40 * k));
    code.extend_from_slice(body);
    code
}

/// Runs `code` for `cycles` on the H743, fast-forwarding or not: the
/// registers and virtual time at the end, and the cycles skipped.
fn run(code: &[u16], fast: bool, cycles: u64) -> ([u64; 17], u64, u64) {
    let mut m = machine(code, fast);
    let stop = m.run(cycles);
    assert!(stop.is_none(), "the program runs without a stop: {stop:?}");
    let mut regs = [0; 17];
    for (v, r) in regs
        .iter_mut()
        .zip(REGS.into_iter().chain([RegisterARM::PC]))
    {
        *v = m.uc.reg_read(r).unwrap();
    }
    let s = m.uc.get_data();
    assert_eq!(
        m.uc.mem_read_as_vec(WORD, 4).unwrap(),
        (KEY2 as u32).to_le_bytes(),
        "the word is programmed"
    );
    (regs, s.now, s.poll.skipped)
}

/// The H743 running `code` from 0x20 with the registers the program
/// expects, fast-forwarding or not, DWT_CYCCNT counting from cycle 0.
fn machine(code: &[u16], fast: bool) -> Machine {
    let mut m: Machine = crate::machine::testing::h743(&[]);
    let mut flash = crate::machine::testing::flash_with(code);
    flash[0x04..0x08].copy_from_slice(&0x0800_0021u32.to_le_bytes());
    m.set_flash(&flash).unwrap();
    for (r, v) in [
        (RegisterARM::R0, 2),
        (RegisterARM::R1, WORD),
        (RegisterARM::R3, 0x5200_2110),
        (RegisterARM::R4, 0x5200_2104),
        (RegisterARM::R5, KEY1),
        (RegisterARM::R6, KEY2),
        (RegisterARM::R7, 0x5200_210C),
        (RegisterARM::R8, 0xE000_1004),
        (RegisterARM::PC, 0x0800_0020),
    ] {
        m.uc.reg_write(r, v).unwrap();
    }
    let s = m.uc.get_data_mut();
    s.poll.enabled = fast;
    s.scs.dwt_since = Some(0);
    m
}

/// ldr r2,[r3]; lsls r2,r2,#29 (BSY, WBNE, QW); bne back; ldr.w r0,[r8]
/// (DWT_CYCCNT); b .
const PLAIN: &[u16] = &[0x681A, 0x0752, 0xD1FC, 0xF8D8, 0x0000, 0xE7FE];

/// The same loop unrolled twice, as rustc emits embassy-stm32's wait: two
/// reads from two instructions each iteration.
const UNROLLED: &[u16] = &[
    0x681A, 0x0752, 0xD002, 0x681A, 0x0752, 0xD1F9, 0xF8D8, 0x0000, 0xE7FE,
];

#[test]
fn a_poll_loop_leaves_at_the_same_cycle_fast_forwarded_or_not() {
    for (what, body) in [("plain", PLAIN), ("unrolled", UNROLLED)] {
        let code = program(body);
        let (fast, end, skipped) = run(&code, true, 200_000);
        let (slow, slow_end, none) = run(&code, false, 200_000);
        assert_eq!(none, 0, "{what}: nothing skipped with it off");
        assert!(skipped > 100, "{what}: skipped {skipped} cycles");
        assert_eq!(end, slow_end, "{what}");
        assert_eq!(fast, slow, "{what}: R0 is the cycle it left the loop at");
        assert!(fast[0] > 1000, "{what}: the program took its time");
    }
}

/// A loop that stores, or counts its iterations, changes something each
/// time round: it runs as it is.
#[test]
fn a_loop_that_stores_or_counts_runs_every_iteration() {
    for (what, body) in [
        // ldr r2,[r3]; str r2,[sp]; lsls; bne back
        (
            "stores",
            &[0x681A, 0x9200, 0x0752, 0xD1FB, 0xF8D8, 0x0000, 0xE7FE][..],
        ),
        // ldr r2,[r3]; adds r0,#1; lsls; bne back
        (
            "counts",
            &[0x681A, 0x3001, 0x0752, 0xD1FB, 0xF8D8, 0x0000, 0xE7FE],
        ),
    ] {
        let code = program(body);
        let (fast, end, skipped) = run(&code, true, 200_000);
        let (slow, slow_end, _) = run(&code, false, 200_000);
        assert_eq!(skipped, 0, "{what}");
        assert_eq!((fast, end), (slow, slow_end), "{what}");
    }
}

/// A slice that ends while the core polls: for every deadline across a
/// few iterations, the core stops after the same block with the skip as
/// without it, and leaves the loop at the same cycle.
#[test]
fn a_slice_ends_after_the_same_block_fast_forwarded_or_not() {
    let code = program(PLAIN);
    for d in 0..24 {
        let [fast, slow] = [true, false].map(|on| {
            let mut m = machine(&code, on);
            assert!(m.run(400 + d).is_none());
            let first = m.uc.get_data().now;
            assert!(m.run(200_000).is_none());
            (first, m.uc.reg_read(RegisterARM::R0).unwrap())
        });
        assert_eq!(fast, slow, "a deadline at cycle {}", 400 + d);
    }
}
