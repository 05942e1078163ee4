//! One upload: the file in pieces into the update partition, then the
//! checks, then the mark for the swap. Nothing is marked before every
//! check passed, so a refused, abandoned or cut-off upload leaves the
//! state partition as it was: the bootloader boots the running image.

use crate::image::{BadTrailer, Running, Trailer, Version, SIGNATURE_LEN, TRAILER_LEN};
use crate::torn::TornAsProgrammed;
use embassy_boot::{BlockingFirmwareState, FirmwareUpdaterConfig, FirmwareUpdaterError, State};
use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

/// Bytes gathered before each write to the update partition: a multiple of
/// every board's flash write size (F7: 16, H7: 32; checked at build time)
/// and a divisor of every erase size, so a file's last piece is padded
/// (with the erased value) to a whole stage and never past the partition.
pub const STAGE: usize = 256;

/// Why an update file was refused. Nothing was marked: the running image
/// goes on and boots again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// The declared length is too short to hold a trailer and a signature.
    TooShort {
        /// The length declared.
        declared: usize,
    },
    /// The declared length does not fit: more than the active partition
    /// (what the swap copies) or the update partition less its last
    /// sector (the swap's scratch).
    TooLarge {
        /// The length declared.
        declared: usize,
        /// The most a file may have.
        capacity: usize,
    },
    /// More bytes came than were declared.
    TooLong {
        /// The length declared.
        declared: usize,
    },
    /// Fewer bytes came than were declared (the upload was cut off).
    Truncated {
        /// Bytes received.
        received: usize,
        /// Bytes the file should have.
        expected: usize,
    },
    /// The trailer's image length does not match the file's.
    LengthMismatch {
        /// Bytes of the file.
        file: usize,
        /// Bytes the trailer says the file has.
        trailer: usize,
    },
    /// No trailer of ours: not an update file.
    NotAnImage(BadTrailer),
    /// An image for another board.
    OtherBoard,
    /// An image linked for another address than the active partition's.
    OtherAddress,
    /// Older than the running image (allowed only when forced).
    Older,
    /// The signature does not verify with the key built into the
    /// firmware: unsigned, signed by another key, or altered.
    BadSignature,
    /// An update is marked already (waiting for its reset), or the
    /// running image has not confirmed itself since its swap (a second
    /// update now would lose the image to roll back to).
    NotConfirmed,
    /// A cancellation with no update marked.
    NothingMarked,
    /// A cancellation while the running image is on trial: the state
    /// partition's swap is its own, which only its confirmation ends.
    OnTrial,
    /// The buffer given for the state partition is not its write size.
    Buffer,
    /// Bytes or a finish without an upload begun (or after it ended).
    NoUpload,
    /// The flash refused a read, write or erase.
    Flash(NorFlashErrorKind),
}

impl Refused {
    /// One line for the log and the status page.
    pub fn text(&self) -> &'static str {
        match self {
            Refused::TooShort { .. } => {
                "shorter than a trailer and a signature: not an update file"
            }
            Refused::TooLarge { .. } => "larger than the update partition",
            Refused::TooLong { .. } => "more bytes than the upload declared",
            Refused::Truncated { .. } => "truncated: fewer bytes than the upload declared",
            Refused::LengthMismatch { .. } => "the trailer's length does not match the file's",
            Refused::NotAnImage(BadTrailer::Magic) => "not an update file (no trailer)",
            Refused::NotAnImage(BadTrailer::Reserved) => {
                "not an update file of this format (reserved bytes set)"
            }
            Refused::NotAnImage(BadTrailer::Board) => "not an update file (no board name)",
            Refused::OtherBoard => "an image for another board",
            Refused::OtherAddress => "an image linked for another address than the active partition",
            Refused::Older => "older than the running image (force to install it)",
            Refused::BadSignature => "the signature does not verify with this device's key",
            Refused::NotConfirmed => {
                "an update is marked already, or the running image has not confirmed itself since its update"
            }
            Refused::NothingMarked => "no update is marked: nothing to cancel",
            Refused::OnTrial => {
                "the running image is on trial since its update: it confirms itself or is rolled back, nothing to cancel"
            }
            Refused::Buffer => "the state partition's buffer is not its write size",
            Refused::NoUpload => "no upload in progress",
            Refused::Flash(_) => "the flash refused an operation",
        }
    }
}

impl From<FirmwareUpdaterError> for Refused {
    fn from(e: FirmwareUpdaterError) -> Self {
        match e {
            FirmwareUpdaterError::Flash(kind) => Refused::Flash(kind),
            FirmwareUpdaterError::Signature(_) => Refused::BadSignature,
            FirmwareUpdaterError::BadState => Refused::NotConfirmed,
        }
    }
}

/// The stage, on the alignment flash drivers want of a source buffer.
#[repr(C, align(32))]
struct Stage([u8; STAGE]);

/// The state partition's write buffer, on the same alignment (sliced to
/// its write size; every board's is at most [`WORD_MAX`]).
#[repr(C, align(32))]
pub(crate) struct Word(pub(crate) [u8; WORD_MAX]);

/// The largest state-partition write size an upload takes (the H743's
/// flash word is 32 bytes).
pub const WORD_MAX: usize = 32;

/// An upload in progress. `begin`, then `push` the file's bytes in order,
/// in pieces of any size, then `finish`. It owns its two partitions (a
/// board's are handles on its flash), so it can be kept between the
/// pieces of a request without borrowing anything. Dropping it changes
/// nothing the bootloader reads. After its first refusal every later
/// call gets the same one: a stage is never written twice (a flash word
/// is programmed once between erases).
pub struct Upload<DFU: NorFlash, STATE: NorFlash> {
    dfu: DFU,
    /// Read as the bootloader reads it: a torn word as programmed.
    state: TornAsProgrammed<STATE>,
    word: Word,
    failed: Option<Refused>,
    declared: usize,
    received: usize,
    /// Bytes written to the partition (whole stages).
    written: usize,
    /// Sectors of the update partition erased so far (from its start).
    erased: usize,
    stage: Stage,
    staged: usize,
}

impl<DFU: NorFlash, STATE: NorFlash> Upload<DFU, STATE> {
    /// Starts an upload of a file of `declared` bytes into `config`'s
    /// update partition (`active`: the active partition's bytes, all the
    /// swap copies). Refused when it cannot hold a trailer and a
    /// signature, does not fit, or an update is pending.
    pub fn begin(
        config: FirmwareUpdaterConfig<DFU, STATE>,
        active: usize,
        declared: usize,
    ) -> Result<Self, Refused> {
        const {
            assert!(
                STAGE.is_multiple_of(DFU::WRITE_SIZE),
                "a stage is whole flash writes"
            );
            assert!(
                DFU::ERASE_SIZE.is_multiple_of(STAGE),
                "a sector is whole stages"
            );
            assert!(DFU::READ_SIZE == 1, "the trailer is read at any offset");
            assert!(
                STATE::WRITE_SIZE <= WORD_MAX,
                "the state partition's write size is at most WORD_MAX"
            );
        }
        // The swap copies the active partition's bytes, and the update
        // partition's last whole sector is its scratch; counting whole
        // sectors only, the last stage, padded, stays inside.
        let dfu = config.dfu.capacity();
        let whole = dfu - dfu % DFU::ERASE_SIZE;
        let capacity = active.min(whole.saturating_sub(DFU::ERASE_SIZE));
        if declared <= TRAILER_LEN + SIGNATURE_LEN {
            return Err(Refused::TooShort { declared });
        }
        if declared > capacity {
            return Err(Refused::TooLarge { declared, capacity });
        }
        let mut up = Upload {
            dfu: config.dfu,
            state: TornAsProgrammed(config.state),
            word: Word([0; WORD_MAX]),
            failed: None,
            declared,
            received: 0,
            written: 0,
            erased: 0,
            stage: Stage([0; STAGE]),
            staged: 0,
        };
        match up.state_view().get_state()? {
            State::Swap => return Err(Refused::NotConfirmed),
            State::Boot | State::Revert | State::DfuDetach => {}
        }
        Ok(up)
    }

    /// embassy-boot's view of the state partition, through this upload's
    /// word buffer.
    fn state_view(&mut self) -> BlockingFirmwareState<'_, &mut TornAsProgrammed<STATE>> {
        let word = self.word.0.get_mut(..STATE::WRITE_SIZE).unwrap_or(&mut []);
        BlockingFirmwareState::new(&mut self.state, word)
    }

    /// Bytes received so far.
    pub fn received(&self) -> usize {
        self.received
    }

    /// The next piece of the file. Work: a copy of `bytes` and a flash
    /// write (with its sector's erase, the first time) per whole stage.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), Refused> {
        let r = self.failed.map_or_else(|| self.take(bytes), Err);
        self.failed = r.err();
        r
    }

    fn take(&mut self, mut bytes: &[u8]) -> Result<(), Refused> {
        if bytes.len() > self.declared - self.received {
            return Err(Refused::TooLong {
                declared: self.declared,
            });
        }
        while !bytes.is_empty() {
            let room = STAGE - self.staged;
            let (now, later) = bytes.split_at(room.min(bytes.len()));
            if let Some(to) = self.stage.0.get_mut(self.staged..self.staged + now.len()) {
                to.copy_from_slice(now);
            }
            self.staged += now.len();
            self.received += now.len();
            bytes = later;
            if self.staged == STAGE {
                self.flush()?;
            }
        }
        Ok(())
    }

    /// Writes the stage (its unfilled end erased-value) at `written`,
    /// erasing each sector the first time a stage enters it (as
    /// embassy-boot's `write_firmware` does: its writes are these).
    fn flush(&mut self) -> Result<(), Refused> {
        if self.staged == 0 {
            return Ok(());
        }
        if let Some(rest) = self.stage.0.get_mut(self.staged..) {
            rest.fill(0xFF);
        }
        let sector = self.written / DFU::ERASE_SIZE;
        if sector >= self.erased {
            let from = sector * DFU::ERASE_SIZE;
            self.dfu
                .erase(offset(from)?, offset(from + DFU::ERASE_SIZE)?)
                .map_err(flash)?;
            self.erased = sector + 1;
        }
        self.dfu
            .write(offset(self.written)?, &self.stage.0)
            .map_err(flash)?;
        self.written += STAGE;
        self.staged = 0;
        Ok(())
    }

    /// Checks the whole file and marks it for the swap: the length, the
    /// trailer (board; version unless `force`), then the signature with
    /// `key` (the 32-byte ed25519 public key built into the firmware).
    /// On success the next reset swaps the image in; the trailer is
    /// returned for the log.
    pub fn finish(
        mut self,
        running: &Running<'_>,
        key: &[u8; 32],
        force: bool,
    ) -> Result<Trailer, Refused> {
        if let Some(refused) = self.failed {
            return Err(refused);
        }
        if self.received != self.declared {
            return Err(Refused::Truncated {
                received: self.received,
                expected: self.declared,
            });
        }
        self.flush()?;
        let signed = self.declared - SIGNATURE_LEN;
        let mut raw = [0; TRAILER_LEN];
        self.read(signed - TRAILER_LEN, &mut raw)?;
        let trailer = Trailer::decode(&raw).map_err(Refused::NotAnImage)?;
        let expected = (trailer.image_len as usize)
            .saturating_add(TRAILER_LEN)
            .saturating_add(SIGNATURE_LEN);
        if expected != self.declared {
            return Err(Refused::LengthMismatch {
                file: self.declared,
                trailer: expected,
            });
        }
        if trailer.board_name() != running.board {
            return Err(Refused::OtherBoard);
        }
        if trailer.origin != running.origin {
            return Err(Refused::OtherAddress);
        }
        if trailer.version < running.version && !force {
            return Err(Refused::Older);
        }
        let mut signature = [0; SIGNATURE_LEN];
        self.read(signed, &mut signature)?;
        let digest = self.digest(signed)?;
        let key = salty::PublicKey::try_from(key).map_err(|_| Refused::BadSignature)?;
        key.verify(&digest, &salty::Signature::from(&signature))
            .map_err(|_| Refused::BadSignature)?;
        self.state_view().mark_updated()?;
        Ok(trailer)
    }

    /// SHA-512 of the partition's first `len` bytes, a stage at a time.
    fn digest(&mut self, len: usize) -> Result<[u8; 64], Refused> {
        let mut hash = salty::Sha512::new();
        let mut at = 0;
        while at < len {
            let n = STAGE.min(len - at);
            let mut chunk = [0; STAGE];
            let part = chunk.get_mut(..n).unwrap_or(&mut []);
            self.read(at, part)?;
            hash.update(part);
            at += n;
        }
        Ok(hash.finalize())
    }

    fn read(&mut self, at: usize, buf: &mut [u8]) -> Result<(), Refused> {
        self.dfu.read(offset(at)?, buf).map_err(flash)
    }
}

/// A partition offset, as the flash traits take it.
fn offset(at: usize) -> Result<u32, Refused> {
    u32::try_from(at).map_err(|_| Refused::Flash(NorFlashErrorKind::OutOfBounds))
}

fn flash<E: NorFlashError>(e: E) -> Refused {
    Refused::Flash(e.kind())
}

/// The state the bootloader left (`Swap`: this image was just swapped in
/// and has not confirmed itself; a reset now rolls it back).
pub fn state<STATE: NorFlash>(state: STATE, aligned: &mut [u8]) -> Result<State, Refused> {
    if aligned.len() != STATE::WRITE_SIZE {
        return Err(Refused::Buffer);
    }
    BlockingFirmwareState::new(TornAsProgrammed(state), aligned)
        .get_state()
        .map_err(Refused::from)
}

/// Bytes of the note [`note_previous`] writes (a whole number of the state
/// partition's write units is taken for it).
pub const PREVIOUS_LEN: usize = 12;
const PREVIOUS_MAGIC: [u8; 4] = *b"RRIP";

/// Where the note sits: the state partition's last write units, when
/// they lie past `used` bytes (embassy-boot's magic and progress words,
/// which it writes from the partition's start).
fn previous_at<STATE: NorFlash>(state: &STATE, used: usize) -> Option<(u32, usize)> {
    let len = PREVIOUS_LEN.next_multiple_of(STATE::WRITE_SIZE.max(1));
    let at = state.capacity().checked_sub(len)?;
    (len <= WORD_MAX && at >= used && at.is_multiple_of(STATE::WRITE_SIZE))
        .then(|| u32::try_from(at).ok().map(|at| (at, len)))
        .flatten()
}

/// The check word of a note of `v`.
fn previous_check(v: Version) -> u16 {
    v.major ^ v.minor.rotate_left(5) ^ v.patch.rotate_left(10) ^ 0x5A5A
}

/// Notes the running image's `version` where the image it has just marked
/// for the swap finds it after the swap ([`previous`]): the state
/// partition's last bytes, past the `used` bytes embassy-boot writes from
/// its start. Written after the mark, whose erase would clear it; the
/// bootloader's swap leaves it; the new image's confirmation and a
/// rollback erase the partition, and with it the note. A cut before it is
/// written costs the note only (the new image then says it does not know
/// what it replaced).
pub fn note_previous<STATE: NorFlash>(
    mut state: STATE,
    version: Version,
    used: usize,
) -> Result<(), Refused> {
    let (at, len) = previous_at(&state, used).ok_or(Refused::Buffer)?;
    let mut word = Word([0xFF; WORD_MAX]);
    let [m0, m1, m2, m3] = PREVIOUS_MAGIC;
    let [a0, a1] = version.major.to_le_bytes();
    let [b0, b1] = version.minor.to_le_bytes();
    let [c0, c1] = version.patch.to_le_bytes();
    let [k0, k1] = previous_check(version).to_le_bytes();
    let note = [m0, m1, m2, m3, a0, a1, b0, b1, c0, c1, k0, k1];
    for (d, s) in word.0.iter_mut().zip(note) {
        *d = s;
    }
    let buf = word.0.get(..len).ok_or(Refused::Buffer)?;
    state.write(at, buf).map_err(flash)
}

/// The version the image that marked this one noted ([`note_previous`]):
/// what this image replaced, read at start-up while it is on trial.
pub fn previous<STATE: NorFlash>(state: STATE, used: usize) -> Option<Version> {
    let mut state = TornAsProgrammed(state);
    let (at, len) = previous_at(&state.0, used)?;
    let mut word = Word([0; WORD_MAX]);
    let buf = word.0.get_mut(..len)?;
    state.read(at, buf).ok()?;
    let [m0, m1, m2, m3, a0, a1, b0, b1, c0, c1, k0, k1, ..] = word.0;
    let v = Version {
        major: u16::from_le_bytes([a0, a1]),
        minor: u16::from_le_bytes([b0, b1]),
        patch: u16::from_le_bytes([c0, c1]),
    };
    ([m0, m1, m2, m3] == PREVIOUS_MAGIC && u16::from_le_bytes([k0, k1]) == previous_check(v))
        .then_some(v)
}

/// The bytes of the state partition embassy-boot may write (its magic and
/// progress words) for an active partition of `active` bytes swapped in
/// pages of `page` bytes: at most `2 + 2 × pages` write units (embassy-boot's
/// own bound on the partition's size).
pub fn state_used(active: usize, page: usize, write: usize) -> usize {
    (2 + 2 * active.div_ceil(page.max(1))) * write
}

/// Cancels a marked update before its swap: the state partition says
/// *boot* again, and the update partition's bytes are left for the next
/// upload to replace. `on_trial`: the running image was swapped in and
/// has not confirmed itself, when the state's *swap* is its own and is
/// not cancelled ([`Refused::OnTrial`]).
pub fn cancel<STATE: NorFlash>(
    state: STATE,
    aligned: &mut [u8],
    on_trial: bool,
) -> Result<(), Refused> {
    let mut state = TornAsProgrammed(state);
    if aligned.len() != STATE::WRITE_SIZE {
        return Err(Refused::Buffer);
    }
    if on_trial {
        return Err(Refused::OnTrial);
    }
    let marked = BlockingFirmwareState::new(&mut state, &mut *aligned)
        .get_state()
        .map_err(Refused::from)?
        == State::Swap;
    if !marked {
        return Err(Refused::NothingMarked);
    }
    BlockingFirmwareState::new(state, aligned)
        .mark_booted()
        .map_err(Refused::from)
}

/// The running image confirms itself (it reached OPERATING with its
/// controller, or passed its self-test): from now on a reset boots it,
/// and the previous image is no longer kept to roll back to.
pub fn confirm<STATE: NorFlash>(state: STATE, aligned: &mut [u8]) -> Result<(), Refused> {
    if aligned.len() != STATE::WRITE_SIZE {
        return Err(Refused::Buffer);
    }
    BlockingFirmwareState::new(TornAsProgrammed(state), aligned)
        .mark_booted()
        .map_err(Refused::from)
}
