//! The image's version: what the log's first line, the status page and
//! `/status.json` say, what update files for this image carry, and what
//! the device compares an update's version with.
//!
//! `RRI_IMAGE_VERSION=major.minor.patch` at build time sets it (an
//! integrator's own numbering: every image built from a changed GSI
//! folder is a new version, though the firmware's code is the same);
//! without it, rri-sensor's own version (its `Cargo.toml`). The build
//! script checks the value.

/// This image's version.
pub const VERSION: &str = env!("RRI_IMAGE_VERSION");

const LEN: usize = VERSION.len() + 1;

/// [`VERSION`] NUL-terminated, under a symbol of its own: `cargo
/// sign-image` reads it from the ELF, so that an update file says the
/// version its image reports.
#[no_mangle]
#[used]
pub static RRI_IMAGE_VERSION: [u8; LEN] = {
    let mut out = [0u8; LEN];
    let bytes = VERSION.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        out[i] = bytes[i];
        i += 1;
    }
    out
};
