//! Update in the cell (issue 43): a firmware image that arrives in pieces
//! over the network is written to the update partition, checked, and only
//! then marked for the bootloader's swap.
//!
//! What an update file is ([`image`]): the image's bytes as the board
//! flashes them, then a 64-byte [`Trailer`] (which board, which version,
//! how long), then a 64-byte ed25519 signature of the SHA-512 of the two
//! (the scheme embassy-boot's own `verify_and_mark_updated` uses: pure
//! ed25519 over the 64-byte digest). [`Upload`] takes the file in pieces
//! of any size, bounded by the partition, and [`Upload::finish`] refuses
//! it before anything is marked when it is short, not an image, for
//! another board, older than the running one (unless forced) or not
//! signed by the key built into the firmware; each refusal is a
//! [`Refused`] with its reason. What is marked, the bootloader swaps at
//! the next reset, and swaps back at the one after unless the new image
//! confirms itself ([`confirm`]): embassy-boot's A/B scheme, whose every
//! step is recorded in the state partition so that a power cut at any
//! point leaves the old image or the new one, whole
//! (`host-tests/tests/update_power_cut.rs` cuts it at every flash
//! operation, and tears each: [`torn`]).
//!
//! No chip is named here: the flash is any `NorFlash` (the boards' flash
//! driver, the host's model). No heap, work bounded by the bytes given,
//! no panic on any input: a bad file is a typed refusal and the running
//! image goes on.

#![no_std]

pub mod boot;
mod device;
pub mod image;
pub mod lifecycle;
pub mod torn;
mod upload;

pub use device::{Device, Outcome, Receive};
pub use embassy_boot::{FirmwareUpdaterConfig, State};
pub use image::{Running, Trailer, Version, SIGNATURE_LEN, TRAILER_LEN};
pub use upload::{
    cancel, confirm, note_previous, previous, state, state_used, Refused, Upload, PREVIOUS_LEN,
    STAGE, WORD_MAX,
};

#[cfg(feature = "sign")]
pub mod sign;
