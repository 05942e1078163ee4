//! The message codec (M1–M10): robot datagrams into typed data, typed data
//! into reply datagrams, for whatever layout the build generated.
//!
//! The generated code supplies, per message, the precomputed wire pieces
//! and a field dispatch ([`crate::schema::MessageCodec`]); this module is the
//! one generic engine behind every layout, so its no-panic, no-heap and
//! bounded-work guarantees hold for any configuration.

pub mod compiled;
pub mod decode;
pub mod encode;
mod exact;
pub mod format;
pub mod hand_over;
pub mod number;
pub mod text;
pub mod writer;

/// The unit tests' source of pseudo-random inputs: xorshift64, so a
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

/// [`xorshift64`]'s 32-bit sibling (13, 17, 5), for random `f32` bit
/// patterns.
#[cfg(test)]
fn xorshift32(seed: u32) -> impl FnMut() -> u32 {
    let mut y = seed;
    move || {
        y ^= y << 13;
        y ^= y >> 17;
        y ^= y << 5;
        y
    }
}

pub use decode::{
    decode, decode_general, DecodeError, DecodeErrorKind, Decoded, Tally, EXTRA_ITEMS,
};
pub use encode::{encode, BufferTooSmall, Encoded};
pub use hand_over::HandOver;
