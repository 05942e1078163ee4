//! The chip the update tests run on (`update_power_cut.rs`): its three
//! partitions on the host's flash model, its power, the device's and the
//! bootloader's steps on it, and the update files it is offered.

use embassy_boot::{FirmwareUpdaterConfig, State};
use embedded_storage::nor_flash::ReadNorFlash;
use host_tests::flash_model::{Flash, Power};
use rri_update::boot::Halt;
use rri_update::{sign, Refused, Running, Trailer, Upload, Version};
use std::rc::Rc;

mod runs;
pub use runs::*;

pub const SECTOR: usize = 2048;
pub const WORD: usize = 32;
pub type F = Flash<SECTOR, WORD>;

/// ACTIVE 2 sectors, DFU one more (embassy-boot's rule), STATE one.
pub const ACTIVE: usize = 2 * SECTOR;
pub const DFU: usize = ACTIVE + SECTOR;
pub const STATE: usize = SECTOR;

pub const BOARD: &str = "nucleo-h743zi";
/// Where the active partition starts (what the images are linked for).
pub const ORIGIN: u32 = 0x0804_0000;
pub const SEED: [u8; 32] = [7; 32];
pub const OTHER_SEED: [u8; 32] = [9; 32];

pub fn v(text: &str) -> Version {
    Version::parse(text).unwrap()
}

pub const RUNNING: Running<'static> = Running {
    board: BOARD,
    origin: ORIGIN,
    version: match Version::parse("0.2.0") {
        Some(v) => v,
        None => panic!("a version"),
    },
};

/// An update file: `len` bytes of image (a pattern of `fill`), its
/// trailer, its signature by `seed`.
pub fn file(fill: u8, len: usize, board: &str, version: &str, seed: &[u8; 32]) -> Vec<u8> {
    file_at(fill, len, board, version, seed, ORIGIN)
}

/// [`file`] for an image linked at `origin`.
pub fn file_at(
    fill: u8,
    len: usize,
    board: &str,
    version: &str,
    seed: &[u8; 32],
    origin: u32,
) -> Vec<u8> {
    let image: Vec<u8> = (0..len).map(|i| fill ^ (i as u8)).collect();
    let trailer = Trailer::new(board, v(version), len as u32, origin)
        .unwrap()
        .encode();
    let signature = sign::signature(&image, &trailer, seed);
    [image, trailer.to_vec(), signature.to_vec()].concat()
}

/// The host's stand-in for a board's vector-table check
/// (`hal_board::boot::looks_like_image`): this model's images are
/// patterns, not programs, so an image is there when the partition's first
/// word reads and is not erased. The word the swap's last step erases
/// first, and copies last.
fn holds_image(active: &mut F) -> Result<(), &'static str> {
    let mut first = [0u8; WORD];
    match active.read(0, &mut first) {
        Ok(()) if first.iter().any(|&b| b != 0xFF) => Ok(()),
        _ => Err("no image in the active partition"),
    }
}

/// One chip: its three partitions and its power.
pub struct Chip {
    pub power: Rc<Power>,
    pub active: F,
    pub dfu: F,
    pub state: F,
    /// Starts that finished an interrupted rollback or confirmation.
    pub recovered: u32,
}

impl Chip {
    /// The running image `a` flashed by a probe, nothing else.
    pub fn with(a: &[u8]) -> Chip {
        let power = Power::new();
        Chip {
            active: F::holding(a, ACTIVE, &power),
            dfu: F::erased(DFU, &power),
            state: F::erased(STATE, &power),
            power,
            recovered: 0,
        }
    }

    /// A start, as our bootloader makes it (`rri_update::boot::start`,
    /// the order `rri-boot` runs): the interrupted swap, rollback or
    /// confirmation finished, then the active partition checked for an
    /// image, which halts the start when it holds none (a NUCLEO's
    /// bootloader has no first image to put there). Counts the starts that
    /// finished an interrupted rollback or confirmation.
    pub fn boot(&mut self) -> Result<State, Halt> {
        let mut buf = [0; 512];
        let started = rri_update::boot::start(
            &mut self.active,
            &mut self.dfu,
            &mut self.state,
            &mut buf,
            holds_image,
        )?;
        self.recovered += u32::from(started.recovered);
        Ok(started.state)
    }

    /// Uploads `bytes` in pieces of 1,000 and finishes.
    pub fn upload(&mut self, bytes: &[u8], force: bool) -> Result<Trailer, Refused> {
        self.upload_declared(bytes, bytes.len(), force)
    }

    /// Uploads `bytes`, declared as `declared` bytes long.
    pub fn upload_declared(
        &mut self,
        bytes: &[u8],
        declared: usize,
        force: bool,
    ) -> Result<Trailer, Refused> {
        let config = FirmwareUpdaterConfig {
            dfu: &mut self.dfu,
            state: &mut self.state,
        };
        let mut up = Upload::begin(config, ACTIVE, declared)?;
        for piece in bytes.chunks(1000) {
            up.push(piece)?;
        }
        let trailer = up.finish(&RUNNING, &sign::public_key(&SEED), force)?;
        // As the device does after the mark: the running version noted
        // for the new image (one more flash operation, cut like the rest;
        // its loss costs the note only).
        let used = rri_update::state_used(ACTIVE, SECTOR, WORD);
        let _ = rri_update::note_previous(&mut self.state, RUNNING.version, used);
        Ok(trailer)
    }

    pub fn state(&mut self) -> Result<State, Refused> {
        rri_update::state(&mut self.state, &mut [0; WORD])
    }

    pub fn confirm(&mut self) -> Result<(), Refused> {
        rri_update::confirm(&mut self.state, &mut [0; WORD])
    }

    /// Which of `a` and `b` the whole ACTIVE partition holds: the file
    /// and, after it, erased bytes (what the probe left, and what the
    /// swap brings from the update partition's sectors, each erased as
    /// the upload began it).
    pub fn running(&self, a: &[u8], b: &[u8]) -> Option<char> {
        let act = self.active.bytes();
        let whole = |f: &[u8]| act.starts_with(f) && act[f.len()..].iter().all(|&x| x == 0xFF);
        if whole(a) {
            Some('A')
        } else if whole(b) {
            Some('B')
        } else {
            None
        }
    }
}

/// A refused file changes nothing the bootloader reads: not a byte of
/// the state partition, and the next reset boots the running image.
pub fn assert_refused(a: &[u8], offered: &[u8], force: bool, want: Refused) {
    let mut chip = Chip::with(a);
    let state = chip.state.bytes().to_vec();
    assert_eq!(chip.upload(offered, force), Err(want));
    assert_unmarked(&mut chip, a, &state);
}

/// Not a byte of the state partition changed, and the next reset boots
/// the running image, whole.
pub fn assert_unmarked(chip: &mut Chip, a: &[u8], state_before: &[u8]) {
    assert_eq!(
        chip.state.bytes(),
        state_before,
        "the state partition changed"
    );
    assert_eq!(chip.boot(), Ok(State::Boot));
    assert_eq!(
        chip.running(a, &[]),
        Some('A'),
        "the running image is untouched"
    );
    assert_eq!(chip.power.refused_writes(), 0);
}
