//! The message codec (M1–M10): robot datagrams into typed data, typed data
//! into reply datagrams, for whatever layout the build generated.
//!
//! The generated code supplies, per message, the precomputed wire pieces
//! and a field dispatch ([`crate::schema::MessageCodec`]); this module is the
//! one generic engine behind every layout, so its no-panic, no-heap and
//! bounded-work guarantees hold for any configuration.

pub mod decode;
pub mod encode;
mod exact;
pub mod format;
pub mod number;
pub mod text;
pub mod writer;

/// The unit tests' one source of pseudo-random inputs: xorshift64, so a
/// failing input is the same on every run.
#[cfg(test)]
fn xorshift64(seed: u64) -> impl FnMut() -> u64 {
    let mut x = seed;
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    }
}

pub use decode::{decode, DecodeError, DecodeErrorKind, Decoded, Tally, EXTRA_ITEMS};
pub use encode::{encode, BufferTooSmall, Encoded};
