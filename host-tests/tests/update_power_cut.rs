//! Update in the cell (issue 43), the device's half against a flash model:
//! every refused file leaves the running image marked and booting, and a
//! power cut at every flash operation of an upload, of the swap and of
//! the confirmation leaves a device that boots a whole, signed image, the
//! old one or the new one, and rolls an unconfirmed new one back.
//!
//! The partitions are scaled down (2 KiB sectors, 32-byte words as on the
//! H743) so that a cut can be tried at every one of the run's operations;
//! the algorithm (embassy-boot's swap) and the checks are the boards'. A
//! cut stops its operation before it starts, or tears it: as the H743's
//! ECC reports a torn word (an error), or as the F767's flash, which has
//! no ECC, leaves it (a mix of bits, read back as it is).

mod update_chip;

use embassy_boot::{FirmwareUpdaterConfig, State};
use rri_update::image::BadTrailer;
use rri_update::{Refused, Upload};
use update_chip::*;

#[test]
fn unsigned_altered_other_board_older_and_short_files_are_refused_and_nothing_is_marked() {
    let a = file(0xA0, 2000, BOARD, "0.2.0", &SEED);
    let b = file(0xB0, 3000, BOARD, "0.3.0", &SEED);
    let n = b.len();

    // Unsigned (a zero signature), signed by another key, one byte altered.
    let mut unsigned = b.clone();
    unsigned[n - 64..].fill(0);
    assert_refused(&a, &unsigned, false, Refused::BadSignature);
    let other_key = file(0xB0, 3000, BOARD, "0.3.0", &OTHER_SEED);
    assert_refused(&a, &other_key, false, Refused::BadSignature);
    let mut altered = b.clone();
    altered[100] ^= 1;
    assert_refused(&a, &altered, false, Refused::BadSignature);

    // For another board, or linked for another address, even signed by
    // our key.
    let f767 = file(0xB0, 3000, "nucleo-f767zi", "0.3.0", &SEED);
    assert_refused(&a, &f767, false, Refused::OtherBoard);
    let elsewhere = file_at(0xB0, 3000, BOARD, "0.3.0", &SEED, 0x0800_0000);
    assert_refused(&a, &elsewhere, false, Refused::OtherAddress);

    // Older: refused, unless forced.
    let older = file(0xB0, 3000, BOARD, "0.1.9", &SEED);
    assert_refused(&a, &older, false, Refused::Older);
    let mut chip = Chip::with(&a);
    assert!(
        chip.upload(&older, true).is_ok(),
        "forced, an older image is marked"
    );

    // Not an update file at all.
    let mut not_ours = b.clone();
    not_ours[n - 128] = b'X';
    assert_refused(&a, &not_ours, false, Refused::NotAnImage(BadTrailer::Magic));
    // The connection dropped one byte short of the declared length.
    let mut chip = Chip::with(&a);
    let state = chip.state.bytes().to_vec();
    assert_eq!(
        chip.upload_declared(&b[..n - 1], n, false),
        Err(Refused::Truncated {
            received: n - 1,
            expected: n
        })
    );
    assert_unmarked(&mut chip, &a, &state);
    // A file cut short on disk (declared as what it holds): its trailer
    // is not where the length says.
    assert_refused(
        &a,
        &b[..n - 1],
        false,
        Refused::NotAnImage(BadTrailer::Magic),
    );
    // A trailer that says another length than the file has.
    let mut longer = b.clone();
    longer.splice(0..0, [0u8; 32]);
    assert_refused(
        &a,
        &longer,
        false,
        Refused::LengthMismatch {
            file: n + 32,
            trailer: n,
        },
    );
    assert_refused(&a, &[0; 100], false, Refused::TooShort { declared: 100 });
    // Larger than ACTIVE, though it fits the update partition: the swap
    // would copy only ACTIVE's bytes of it.
    let huge = vec![0; ACTIVE + 1];
    assert!(huge.len() <= DFU);
    assert_refused(
        &a,
        &huge,
        false,
        Refused::TooLarge {
            declared: ACTIVE + 1,
            capacity: ACTIVE,
        },
    );

    // An upload that stops half-way (the connection dropped) and is
    // never finished; more bytes than declared; after a refusal, every
    // call gets it, so nothing is written twice.
    let mut chip = Chip::with(&a);
    let state = chip.state.bytes().to_vec();
    {
        let config = FirmwareUpdaterConfig {
            dfu: &mut chip.dfu,
            state: &mut chip.state,
        };
        let mut up = Upload::begin(config, ACTIVE, n).unwrap();
        up.push(&b[..1500]).unwrap();
        let too_long = Err(Refused::TooLong { declared: n });
        assert_eq!(up.push(&vec![0; n]), too_long);
        assert_eq!(up.push(&b[1500..1600]), too_long);
    }
    assert_unmarked(&mut chip, &a, &state);
    // A buffer of the wrong size for the state partition is refused, not
    // a panic inside embassy-boot.
    assert_eq!(
        rri_update::state(&mut chip.state, &mut [0; 8]),
        Err(Refused::Buffer)
    );
    assert_eq!(
        rri_update::confirm(&mut chip.state, &mut [0; 8]),
        Err(Refused::Buffer)
    );
}

/// The whole way, no cut: upload, swap, the new image confirms itself;
/// and the same without the confirmation, rolled back at the next reset.
#[test]
fn a_signed_image_swaps_in_and_an_unconfirmed_one_is_rolled_back() {
    let a = file(0xA0, 2000, BOARD, "0.2.0", &SEED);
    let b = file(0xB0, 3000, BOARD, "0.3.0", &SEED);

    let mut chip = Chip::with(&a);
    let t = chip.upload(&b, false).unwrap();
    assert_eq!((t.board_name(), t.version), (BOARD, v("0.3.0")));
    assert_eq!(chip.boot(), Ok(State::Swap));
    assert_eq!(chip.running(&a, &b), Some('B'));
    assert_eq!(
        chip.state(),
        Ok(State::Swap),
        "the new image sees it is on trial"
    );
    // A second upload before the confirmation would lose the image to
    // roll back to.
    assert_eq!(chip.upload(&b, false), Err(Refused::NotConfirmed));
    chip.confirm().unwrap();
    assert_eq!(chip.boot(), Ok(State::Boot));
    assert_eq!(chip.running(&a, &b), Some('B'));

    let mut chip = Chip::with(&a);
    chip.upload(&b, false).unwrap();
    assert_eq!(chip.boot(), Ok(State::Swap));
    assert_eq!(chip.running(&a, &b), Some('B'));
    // It never reached OPERATING: no confirmation; the watchdog resets.
    assert_eq!(
        chip.boot(),
        Ok(State::Swap),
        "embassy-boot reports the revert as a swap"
    );
    assert_eq!(chip.running(&a, &b), Some('A'), "rolled back");
    assert_eq!(chip.state(), Ok(State::Revert));
    chip.confirm().unwrap();
    assert_eq!(chip.boot(), Ok(State::Boot));
    assert_eq!(chip.running(&a, &b), Some('A'));
}

fn every_cut(confirms: bool) -> (u64, Vec<(&'static str, char, u32)>) {
    let a = file(0xA0, 2000, BOARD, "0.2.0", &SEED);
    let b = file(0xB0, 3000, BOARD, "0.3.0", &SEED);
    let (chip, cut) = run(&a, &b, None, confirms);
    assert!(cut.is_none());
    let total = chip.power.ops();
    assert!(total > 200, "the run is {total} operations");
    let mut outcomes = Vec::new();
    for n in 0..total {
        let (mut chip, cut) = run(&a, &b, Some(n), confirms);
        let cut = cut.unwrap_or_else(|| panic!("a cut at {n} of {total} fell in no step"));
        let (settled, recovered) = recover(&mut chip, &a, &b, confirms, &cut);
        assert!(
            recovered <= 1,
            "{cut:?}: {recovered} starts finished an interrupted step"
        );
        outcomes.push((cut.step, settled, recovered));
    }
    (total, outcomes)
}

/// A power cut at every flash operation of an update that confirms
/// itself: the device always comes back with a whole image; cut in the
/// upload, the old one (but after the mark, at the version note, the new
/// one); once the swap has begun, the new one.
#[test]
fn a_power_cut_at_every_operation_of_a_confirmed_update_leaves_a_bootable_device() {
    let (total, outcomes) = every_cut(true);
    report(total, &outcomes);
    // The figures the README states, as measured.
    assert_eq!(total, 377);
    // The upload's last operation is the note after the mark: cut there,
    // the update is marked already and goes on to the new image.
    assert_eq!(tally(&outcomes, "upload"), (109, 1, 0));
    assert_eq!(tally(&outcomes, "swap"), (0, 264, 0));
    assert_eq!(tally(&outcomes, "confirmation"), (1, 2, 1));
}

/// The same for an update that never confirms itself (it never reached
/// OPERATING): wherever the power was cut, the device ends on A.
#[test]
fn a_power_cut_at_every_operation_of_an_unconfirmed_update_ends_on_the_old_image() {
    let (total, outcomes) = every_cut(false);
    report(total, &outcomes);
    assert!(
        outcomes.iter().all(|o| o.1 == 'A'),
        "of {total} cuts: {:?}",
        outcomes.iter().filter(|o| o.1 == 'B').collect::<Vec<_>>()
    );
    assert_eq!(total, 641);
    assert_eq!(tally(&outcomes, "upload"), (110, 0, 0));
    assert_eq!(tally(&outcomes, "swap"), (264, 0, 0));
    assert_eq!(tally(&outcomes, "rollback at the next reset"), (267, 0, 1));
}

/// One torn run's outcomes: (step, partition torn, what the device did).
type TornOutcome = (&'static str, &'static str, Settled);

/// Every operation of an update (confirmed or not) torn in turn, once
/// for each of `tears`; the tally printed under `title`. Each outcome:
/// the step, the partition an ECC tear left torn words in (none for a
/// mix, which leaves no mark), what the device did.
fn every_tear(confirms: bool, tears: &[Tear], title: &str) -> (u64, Vec<TornOutcome>) {
    let a = file(0xA0, 2000, BOARD, "0.2.0", &SEED);
    let b = file(0xB0, 3000, BOARD, "0.3.0", &SEED);
    let total = run(&a, &b, None, confirms).0.power.ops();
    let mut outcomes = Vec::new();
    for n in 0..total {
        for &tear in tears {
            let (mut chip, cut) = run_tearing(&a, &b, Some(n), confirms, tear);
            let cut = cut.unwrap_or_else(|| panic!("a torn cut at {n} fell in no step"));
            let partition = if tear != Tear::Ecc {
                ""
            } else if chip.state.has_torn() {
                "state"
            } else if chip.dfu.has_torn() {
                "update"
            } else {
                "active"
            };
            let outcome = settle(&mut chip, &a, &b, confirms)
                .map_err(|e| format!("operation {n}, {tear:?}: {e}"));
            outcomes.push((cut.step, partition, outcome));
        }
    }
    print_tally(
        &format!("{total} flash operations, {title}:"),
        outcomes
            .iter()
            .map(|(step, partition, o)| match *partition {
                "" => (format!("in the {step}"), o),
                p => (format!("in the {step}, {p} partition torn"), o),
            }),
    );
    (total, outcomes)
}

/// [`every_tear`] as the H743's ECC reports a torn word.
fn every_torn_cut(confirms: bool) -> (u64, Vec<TornOutcome>) {
    every_tear(confirms, &[Tear::Ecc], "each torn by the cut")
}

/// A cut *inside* every flash operation of a confirmed update: the
/// operation torn, its word (or its sector, an erase) left unreadable as
/// a half-programmed H743 flash word is (`flash_model`'s `Power::tear`).
/// What the device does after each, tallied by step and by outcome.
///
/// A tear in the update or the active partition ends as a clean cut does
/// (the swap copies a torn page again from its source; the upload's
/// erase mends its own). A tear in the state partition is read as a
/// programmed word (`rri_update::torn`): before that, all 10 left
/// embassy-boot reporting a flash error, which the bootloader halts on.
/// One of them ends on A where a clean cut ends on B: the swap's last
/// progress mark torn reads as the swap finished, which is also what a
/// new image that never confirmed itself leaves, so the next start rolls
/// it back: the old image, whole, and the update to be sent again.
#[test]
fn a_torn_operation_at_every_cut_of_a_confirmed_update() {
    let (total, outcomes) = every_torn_cut(true);
    assert_eq!(total, 377);
    assert_eq!(
        ended_on(&outcomes),
        [(109, 1), (1, 263), (0, 3)],
        "A and B after the upload, the swap, the confirmation"
    );
}

/// Torn runs that ended on A and on B, after a cut in the upload, the
/// swap and the confirmation; none may have failed.
fn ended_on(outcomes: &[TornOutcome]) -> [(usize, usize); 3] {
    let failed: Vec<_> = outcomes.iter().filter(|o| o.2.is_err()).collect();
    assert!(
        failed.is_empty(),
        "{} of {} tears failed: {failed:?}",
        failed.len(),
        outcomes.len()
    );
    let ended = |step: &str, image: char| {
        outcomes
            .iter()
            .filter(|o| o.0 == step && matches!(o.2, Ok((i, _)) if i == image))
            .count()
    };
    ["upload", "swap", "confirmation"].map(|step| (ended(step, 'A'), ended(step, 'B')))
}

/// Of the cuts in `step`: how many ended on A, on B, and the starts that
/// finished an interrupted rollback or confirmation first.
fn tally(outcomes: &[(&'static str, char, u32)], step: &str) -> (usize, usize, u32) {
    let of = |r: char| outcomes.iter().filter(|o| o.0 == step && o.1 == r).count();
    let errors = outcomes.iter().filter(|o| o.0 == step).map(|o| o.2).sum();
    (of('A'), of('B'), errors)
}

/// Where the cuts fell, what the device settled on, and the starts that
/// finished an interrupted rollback or confirmation first (without that,
/// embassy-boot reports an error there: a second write of a flash word).
fn report(total: u64, outcomes: &[(&'static str, char, u32)]) {
    let mut steps: Vec<&str> = outcomes.iter().map(|o| o.0).collect();
    steps.dedup();
    println!("{total} flash operations, the power cut at each:");
    for step in steps {
        let (a, b, errors) = tally(outcomes, step);
        println!("  in the {step}: {a} ended on A, {b} on B; {errors} starts finished an interrupted step first");
    }
}

/// The same for an update that never confirms itself: every torn cut,
/// the rollback's own marks included, ends on A.
#[test]
fn a_torn_operation_at_every_cut_of_an_unconfirmed_update_ends_on_the_old_image() {
    let (total, outcomes) = every_torn_cut(false);
    assert_eq!(total, 641);
    let not_a: Vec<_> = outcomes
        .iter()
        .filter(|o| !matches!(o.2, Ok(('A', _))))
        .collect();
    assert!(not_a.is_empty(), "of {total}: {not_a:?}");
}

/// Torn runs' outcomes counted by where the cut fell and how the device
/// ended, printed under `title`.
fn print_tally<'a>(title: &str, outcomes: impl Iterator<Item = (String, &'a Settled)>) {
    let mut tally: std::collections::BTreeMap<String, u64> = Default::default();
    for (place, outcome) in outcomes {
        let what = match outcome {
            Ok((image, _)) => format!("ended on {image}"),
            Err(e) => format!("FAILED: {e}"),
        };
        *tally.entry(format!("{place}: {what}")).or_default() += 1;
    }
    println!("{title}");
    for (what, n) in &tally {
        println!("  {what}: {n}");
    }
}

/// Mixes of each operation [`every_mixed_cut`] tries.
const MIXES: u64 = 8;

/// Every operation of an update torn on a flash without ECC (the F767),
/// [`MIXES`] times, each with another mix of the bits it was changing.
fn every_mixed_cut(confirms: bool) -> (u64, Vec<TornOutcome>) {
    let tears: Vec<Tear> = (0..MIXES).map(Tear::Mix).collect();
    every_tear(
        confirms,
        &tears,
        &format!("each torn {MIXES} ways (no ECC)"),
    )
}

/// The F767's flash has no ECC: a cut inside an operation leaves a mix
/// of the bits it was changing, which a reader cannot tell from data. In
/// the state partition that mix is read as it is: a progress word with a
/// byte still erased is a step not done (redone: its page copied again,
/// the word then programmed the rest of the way, which only clears
/// bits); a magic that is not whole is no magic (the active image
/// boots). Every operation of a confirmed update, eight mixes each.
#[test]
fn a_mixed_tear_at_every_cut_of_a_confirmed_update() {
    let (total, outcomes) = every_mixed_cut(true);
    assert_eq!(total, 377);
    // A as after a clean cut in the upload (B once the mark is whole);
    // in the swap, A where the last progress mark's mix has no byte left
    // erased (a finished swap never confirmed: rolled back), as after the
    // H743's torn mark.
    assert_eq!(
        ended_on(&outcomes),
        [(872, 8), (5, 2107), (0, 24)],
        "A and B after the upload, the swap, the confirmation"
    );
}

/// The same for an update that never confirms itself: every mixed tear
/// ends on the old image.
#[test]
fn a_mixed_tear_at_every_cut_of_an_unconfirmed_update_ends_on_the_old_image() {
    let (total, outcomes) = every_mixed_cut(false);
    assert_eq!(total, 641);
    let not_a: Vec<_> = outcomes
        .iter()
        .filter(|o| !matches!(o.2, Ok(('A', _))))
        .collect();
    assert!(
        not_a.is_empty(),
        "{} of {}: {not_a:?}",
        not_a.len(),
        outcomes.len()
    );
    let in_step = |step: &str| outcomes.iter().filter(|o| o.0 == step).count();
    assert_eq!(
        ["upload", "swap", "rollback at the next reset"].map(in_step),
        [880, 2112, 2136]
    );
}

/// The limit no model above reaches (rri-update's README, "What no mix
/// here reaches"): the confirmation's erase torn *word by word*, so that
/// the swap magic keeps every zero bit while "progress invalid" and the
/// progress marks from `kept` on are erased. embassy-boot then reads a
/// swap in progress and swaps again: with 0 or 1 of the 4 marks kept,
/// ACTIVE ends holding neither image. Asserted as it is so that the
/// README's account stays true: a change that survives this state fails
/// here, and the README changes with it.
#[test]
fn an_erase_torn_word_by_word_is_read_as_a_swap_to_do_again() {
    use embedded_storage::nor_flash::NorFlash;
    let a = file(0xA0, 2000, BOARD, "0.2.0", &SEED);
    let b = file(0xB0, 3000, BOARD, "0.3.0", &SEED);
    let marks = 2 * ACTIVE / SECTOR;
    let settled: Vec<Option<char>> = (0..marks)
        .map(|kept| {
            let mut chip = Chip::with(&a);
            chip.upload(&b, false).unwrap();
            assert_eq!(chip.boot(), Ok(State::Swap));
            assert_eq!(chip.running(&a, &b), Some('B'));
            // What the torn erase leaves: the magic (32 bytes of 0xF0)
            // whole, the marks before `kept`, nothing else.
            chip.state.erase(0, STATE as u32).unwrap();
            chip.state.write(0, &[0xF0; WORD]).unwrap();
            for i in 0..kept {
                chip.state
                    .write(((2 + i) * WORD) as u32, &[0; WORD])
                    .unwrap();
            }
            settle(&mut chip, &a, &b, true).ok().map(|(image, _)| image)
        })
        .collect();
    assert_eq!(settled, [None, None, Some('B'), Some('B')]);
}
