//! The device's side of an upload, as a service drives it: a request
//! begins an upload, pushes its body as it arrives and finishes it (or
//! abandons it, when the client went away). [`Receive`] is what the
//! diagnostics service sees, so that it names no flash; [`Device`] is
//! the one implementation, over a board's two partitions.

use crate::image::{Running, Trailer, Version};
use crate::upload::{Refused, Upload};
use embassy_boot::FirmwareUpdaterConfig;
use embedded_storage::nor_flash::NorFlash;

/// One upload at a time, driven by the service.
pub trait Receive {
    /// Starts an upload of `declared` bytes (any earlier one is dropped:
    /// nothing it wrote is marked).
    fn begin(&mut self, declared: usize) -> Result<(), Refused>;
    /// The next bytes of the file.
    fn push(&mut self, bytes: &[u8]) -> Result<(), Refused>;
    /// Checks the file and marks it for the swap (`force`: an older
    /// version is taken too).
    fn finish(&mut self, force: bool) -> Result<Trailer, Refused>;
    /// The client went away: the upload is dropped, nothing is marked.
    fn abandon(&mut self);
    /// Cancels a marked update before its swap (`on_trial`: the running
    /// image has not confirmed itself since its own swap: refused).
    fn cancel(&mut self, on_trial: bool) -> Result<(), Refused>;
    /// Whether a bootloader swaps what is marked at the next reset (a
    /// board without one says so instead of claiming a swap).
    fn swaps(&self) -> bool;
    /// The running image's version (a marked one older than it was
    /// forced).
    fn running(&self) -> Version;
}

/// What the last upload came to, for the status page and the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// No upload since the start.
    None,
    /// An upload is arriving.
    Receiving {
        /// Bytes so far.
        received: u32,
        /// Bytes declared.
        declared: u32,
    },
    /// Checked and marked for the swap at the next reset.
    Marked {
        /// The marked image's version.
        version: Version,
        /// Older than the running image: taken only because the upload
        /// was forced (said in the answer and the log).
        older: bool,
    },
    /// Refused; nothing was marked.
    Refused(Refused),
    /// A marked update was cancelled before its swap.
    Cancelled,
    /// The client went away before the whole file came; nothing was
    /// marked.
    Abandoned {
        /// Bytes received.
        received: u32,
        /// Bytes declared.
        declared: u32,
    },
}

/// A board's update partitions and what the device checks a file against.
pub struct Device<DFU: NorFlash, STATE: NorFlash> {
    partitions: fn() -> FirmwareUpdaterConfig<DFU, STATE>,
    active: usize,
    running: Running<'static>,
    key: [u8; 32],
    swaps: bool,
    upload: Option<Upload<DFU, STATE>>,
}

impl<DFU: NorFlash, STATE: NorFlash> Device<DFU, STATE> {
    /// The version the image that marked this one noted before the swap
    /// (`None`: not swapped in by an update, or the note was lost): read
    /// at start-up, while this image is on trial (its confirmation erases
    /// the note).
    pub fn previous(&self) -> Option<Version> {
        let used = crate::upload::state_used(self.active, DFU::ERASE_SIZE, STATE::WRITE_SIZE);
        crate::upload::previous((self.partitions)().state, used)
    }

    /// The desk of a device: `partitions` gives handles on the update and
    /// state partitions (called once per upload), `active` is the active
    /// partition's size, `running` this image, `key` the public key built
    /// in; `swaps`: a bootloader reads the state partition.
    pub const fn new(
        partitions: fn() -> FirmwareUpdaterConfig<DFU, STATE>,
        active: usize,
        running: Running<'static>,
        key: [u8; 32],
        swaps: bool,
    ) -> Self {
        Device {
            partitions,
            active,
            running,
            key,
            swaps,
            upload: None,
        }
    }
}

impl<DFU: NorFlash, STATE: NorFlash> Receive for Device<DFU, STATE> {
    fn begin(&mut self, declared: usize) -> Result<(), Refused> {
        self.upload = None;
        self.upload = Some(Upload::begin((self.partitions)(), self.active, declared)?);
        Ok(())
    }

    fn push(&mut self, bytes: &[u8]) -> Result<(), Refused> {
        match self.upload.as_mut() {
            Some(up) => up.push(bytes),
            None => Err(Refused::NoUpload),
        }
    }

    fn finish(&mut self, force: bool) -> Result<Trailer, Refused> {
        let Some(up) = self.upload.take() else {
            return Err(Refused::NoUpload);
        };
        let trailer = up.finish(&self.running, &self.key, force)?;
        // Marked: the version the new image will say it replaced. Its
        // loss (no room past embassy-boot's words, a flash error) costs
        // that line of the status only.
        let used = crate::upload::state_used(self.active, DFU::ERASE_SIZE, STATE::WRITE_SIZE);
        let _ = crate::upload::note_previous((self.partitions)().state, self.running.version, used);
        Ok(trailer)
    }

    fn abandon(&mut self) {
        self.upload = None;
    }

    fn cancel(&mut self, on_trial: bool) -> Result<(), Refused> {
        self.upload = None;
        let mut word = crate::upload::Word([0; crate::WORD_MAX]);
        let w = word.0.get_mut(..STATE::WRITE_SIZE).unwrap_or(&mut []);
        crate::upload::cancel((self.partitions)().state, w, on_trial)
    }

    fn swaps(&self) -> bool {
        self.swaps
    }

    fn running(&self) -> Version {
        self.running.version
    }
}
