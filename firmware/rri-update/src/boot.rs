//! The bootloader's half (issue 43): embassy-boot's `prepare_boot` with
//! the one recovery a power cut makes necessary, for every board's
//! bootloader to call before it jumps to the active image. Any `NorFlash`.
//!
//! Found by the power-cut test (`host-tests/tests/update_power_cut.rs`,
//! embassy-boot 0.7.0): the last steps of a rollback, and an image's
//! confirmation, are "invalidate the progress" (one word written), "erase
//! the state partition", "write the magic". Cut after the first and
//! before the last, the state still says *swap* with its progress marked
//! invalid. embassy-boot's next start then writes that progress word a
//! second time, which a flash refuses (the H743's ECC words are
//! programmed once between erases) and `prepare_boot` fails. In both
//! interrupted cases the active image is whole (the rollback's copies
//! were done; a confirming image was running), so [`prepare`] finishes
//! the step first: the state marked *boot*, the active image kept. Every
//! other error is the caller's to treat as a halt: with a flash fault in
//! the middle of a swap the active partition may hold parts of both.

use crate::torn::TornAsProgrammed;
use crate::upload::WORD_MAX;
use embassy_boot::{BlockingFirmwareState, BootError, BootLoader, BootLoaderConfig, State};
use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};

/// How the start went.
#[derive(Debug, PartialEq, Eq)]
pub struct Started {
    /// embassy-boot's state (`Swap`: an image was swapped in, or rolled
    /// back, this start).
    pub state: State,
    /// A rollback's or a confirmation's last steps were finished first
    /// (a power cut had interrupted them).
    pub recovered: bool,
}

/// Why a start halts: the bootloader says [`Halt::why`] and stops.
#[derive(Debug, PartialEq, Eq)]
pub enum Halt {
    /// The swap's state could not be read, or its swap finished.
    Flash(BootError),
    /// The active partition holds no image, and the board could not put
    /// its first one there: the board's reason (how the first image goes
    /// on).
    NoImage(&'static str),
}

impl Halt {
    /// The sentence the bootloader halts with.
    pub fn why(&self) -> &'static str {
        match self {
            Halt::Flash(_) => "the swap's state could not be read or finished (flash error)",
            Halt::NoImage(why) => why,
        }
    }
}

/// Every start of every board's bootloader, in the order a power cut
/// requires: first the swap or rollback a reset interrupted, finished
/// ([`prepare`]), because the swap's last step erases the active
/// partition's first page and copies it again, so a cut there leaves no
/// vector table until this has run; only then `image`, the board's check
/// that the active partition holds an image (or its putting the first one
/// there): `Err` says why not. The other order halted the rehosted H743 at
/// "no image" after a cut at the swap's last page (`cargo power-cut --
/// --all`), and would write the QEMU board's factory image over a
/// half-swapped partition. On `Ok` the active image is the one to jump to.
pub fn start<A: NorFlash, D: NorFlash, S: NorFlash>(
    active: &mut A,
    dfu: D,
    state: S,
    page: &mut [u8],
    image: impl FnOnce(&mut A) -> Result<(), &'static str>,
) -> Result<Started, Halt> {
    let config = BootLoaderConfig {
        active: &mut *active,
        dfu,
        state,
    };
    let started = prepare(config, page).map_err(Halt::Flash)?;
    image(active).map_err(Halt::NoImage)?;
    Ok(started)
}

/// The state partition's word buffer, aligned as flash drivers want.
#[repr(C, align(32))]
struct Word([u8; WORD_MAX]);

/// Prepares the start: the interrupted last steps finished (see the
/// module), then embassy-boot's swap or rollback. `page`: embassy-boot's
/// buffer (a divisor of the page size, a multiple of every partition's
/// write size). The active image is then the one to jump to.
pub fn prepare<A: NorFlash, D: NorFlash, S: NorFlash>(
    config: BootLoaderConfig<A, D, S>,
    page: &mut [u8],
) -> Result<Started, BootError> {
    const {
        assert!(
            S::WRITE_SIZE <= WORD_MAX,
            "the state partition's write size is at most WORD_MAX"
        );
    }
    let BootLoaderConfig { active, dfu, state } = config;
    // A word a cut tore reads as programmed (see `torn`).
    let mut state = TornAsProgrammed(state);
    let mut word = Word([0; WORD_MAX]);
    let w = word.0.get_mut(..S::WRITE_SIZE).unwrap_or(&mut []);
    let recovered = finish_interrupted(&mut state, w)?;
    let state = BootLoader::new(BootLoaderConfig {
        active,
        dfu,
        state: &mut state,
    })
    .prepare_boot(page)?;
    Ok(Started { state, recovered })
}

/// When the state says swap and its progress is marked invalid (only the
/// last steps of a rollback or a confirmation do that): marks it boot, as
/// those steps would have. Whether it did.
fn finish_interrupted<S: NorFlash>(state: &mut S, w: &mut [u8]) -> Result<bool, BootError> {
    let swap = BlockingFirmwareState::new(&mut *state, &mut *w)
        .get_state()
        .map_err(flash)?
        == State::Swap;
    if !swap {
        return Ok(false);
    }
    // The word after the magic: erased while the progress is valid.
    let at = u32::try_from(S::WRITE_SIZE).map_err(|_| BootError::BadMagic)?;
    state.read(at, w).map_err(|e| BootError::Flash(e.kind()))?;
    if w.iter().all(|&b| b == 0xFF) {
        return Ok(false);
    }
    BlockingFirmwareState::new(&mut *state, &mut *w)
        .mark_booted()
        .map_err(flash)?;
    Ok(true)
}

fn flash(e: embassy_boot::FirmwareUpdaterError) -> BootError {
    match e {
        embassy_boot::FirmwareUpdaterError::Flash(kind) => BootError::Flash(kind),
        _ => BootError::Flash(NorFlashErrorKind::Other),
    }
}
