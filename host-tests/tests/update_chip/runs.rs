//! One update's run on the chip, the power cut where a test says, and
//! the starts after it (`update_power_cut.rs`).

use super::Chip;
use embassy_boot::State;

/// What one run did before its cut.
#[derive(Debug)]
pub struct Cut {
    /// Read through `Debug`, in every failure's message.
    #[allow(dead_code)]
    pub at: u64,
    /// The step the power went off in.
    pub step: &'static str,
}

/// The run of an update, the power cut at operation `cut` (`None`: no
/// cut): upload, reset (the swap), the new image runs and (if
/// `confirms`) confirms itself, reset. Returns the chip as the cut left
/// it, and where the cut fell.
pub fn run(a: &[u8], b: &[u8], cut: Option<u64>, confirms: bool) -> (Chip, Option<Cut>) {
    run_tearing(a, b, cut, confirms, Tear::No)
}

/// How a cut falls: before its operation starts, or inside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tear {
    /// Before: nothing of the operation reaches the flash.
    No,
    /// Inside, on a flash with ECC (the H743): its words read as errors.
    Ecc,
    /// Inside, on a flash without (the F767): a mix of the bits it was
    /// changing, from this seed.
    Mix(u64),
}

/// [`run`], the cut falling as `tear` says.
pub fn run_tearing(
    a: &[u8],
    b: &[u8],
    cut: Option<u64>,
    confirms: bool,
    tear: Tear,
) -> (Chip, Option<Cut>) {
    let mut chip = Chip::with(a);
    chip.power.tear(tear != Tear::No);
    if let Tear::Mix(seed) = tear {
        chip.power.mix_bits(seed);
    }
    chip.power.cut_at(cut);
    let off = |chip: &Chip, step| {
        chip.power.is_off().then(|| Cut {
            at: cut.unwrap_or(0),
            step,
        })
    };
    let up = chip.upload(b, false);
    if let Some(c) = off(&chip, "upload") {
        return (chip, Some(c));
    }
    up.expect("an upload with the power on is accepted");
    let swap = chip.boot();
    if let Some(c) = off(&chip, "swap") {
        return (chip, Some(c));
    }
    assert_eq!(swap, Ok(State::Swap));
    if confirms {
        let confirmed = chip.confirm();
        if let Some(c) = off(&chip, "confirmation") {
            return (chip, Some(c));
        }
        confirmed.unwrap();
    }
    let next = chip.boot();
    if let Some(c) = off(&chip, "rollback at the next reset") {
        return (chip, Some(c));
    }
    next.unwrap();
    (chip, None)
}

/// After a cut: the power comes back and the device starts, and goes on
/// starting until an image confirms itself. Every start must prepare
/// without an error (our bootloader halts on one) and find a whole image,
/// A or B, in ACTIVE. A runs and confirms itself (it is the image that
/// worked); B confirms itself only when `confirms`, otherwise the
/// watchdog resets it. Returns the image it settled on and how many
/// starts finished an interrupted rollback or confirmation first.
pub fn recover(chip: &mut Chip, a: &[u8], b: &[u8], confirms: bool, cut: &Cut) -> (char, u32) {
    settle(chip, a, b, confirms).unwrap_or_else(|e| panic!("{cut:?}: {e}"))
}

/// Where the starts after a cut settled: the image, and how many starts
/// finished an interrupted rollback or confirmation first; or how the
/// device failed to settle.
pub type Settled = Result<(char, u32), String>;

/// [`recover`]'s starts: `Err` says how the device failed to settle.
pub fn settle(chip: &mut Chip, a: &[u8], b: &[u8], confirms: bool) -> Settled {
    chip.power.restore();
    let before = chip.recovered;
    for _start in 0..4 {
        if let Err(e) = chip.boot() {
            return Err(format!("the bootloader reported {e:?}"));
        }
        let errors = chip.recovered - before;
        if chip.active.has_torn() {
            return Err("ACTIVE holds a torn word (the image faults where it runs)".into());
        }
        let running = chip
            .running(a, b)
            .ok_or("ACTIVE holds neither image whole")?;
        if running == 'B' && !confirms {
            continue;
        }
        chip.confirm()
            .map_err(|e| format!("{running} could not confirm itself: {e:?}"))?;
        let after = chip.boot();
        if after != Ok(State::Boot) {
            return Err(format!("the start after the confirmation: {after:?}"));
        }
        if chip.running(a, b) != Some(running) {
            return Err(format!("{running} did not stay"));
        }
        return Ok((running, errors));
    }
    Err("no image confirmed itself in four starts".into())
}
