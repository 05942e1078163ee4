//! Signing an update file: for the host's `cargo sign-image` and the
//! tests, never in a firmware image (the `sign` feature). The device's
//! check ([`crate::Upload::finish`]) and this are the same scheme by
//! construction: ed25519 (salty) over the SHA-512 of the image and its
//! trailer.

use crate::image::{SIGNATURE_LEN, TRAILER_LEN};

/// The public key of the secret key whose seed is `seed`.
pub fn public_key(seed: &[u8; 32]) -> [u8; 32] {
    salty::Keypair::from(seed).public.to_bytes()
}

/// The signature of `image` followed by `trailer`.
pub fn signature(
    image: &[u8],
    trailer: &[u8; TRAILER_LEN],
    seed: &[u8; 32],
) -> [u8; SIGNATURE_LEN] {
    let digest = salty::Sha512::new()
        .updated(image)
        .updated(trailer)
        .finalize();
    salty::Keypair::from(seed).sign(&digest).to_bytes()
}
