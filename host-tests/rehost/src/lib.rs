//! Rehosting: the unmodified NUCLEO firmware images on unicorn's
//! Cortex-M7, with a strict register-level model of their chip. See
//! `host-tests/rehost/README.md` for what is modelled and what is not.

pub mod access;
/// The torn mix, shared with the host's flash model (whose crate holds
/// the file: see its header).
#[path = "../../src/bit_mix.rs"]
pub mod bit_mix;
pub mod bridge;
pub mod bridge_phy;
pub mod bus;
pub mod chip;
pub mod clocks;
pub mod corpus;
pub mod exceptions;
pub mod f7;
pub mod fast_forward;
pub mod fault;
pub mod flash_array;
pub mod flash_image;
pub mod gpio;
pub mod h7;
pub mod hooks;
pub mod image;
pub mod iwdg;
pub mod lan8742;
pub mod link;
pub mod machine;
pub mod memories;
pub mod mpu;
pub mod mpu_enforce;
pub mod poll_watch;
pub mod reset;
pub mod rng;
pub mod robot;
pub mod rtt;
pub mod scs;
pub mod simple;
pub mod state;
pub mod stop;
pub mod syscfg;
pub mod timer;
pub mod torn_bits;
pub mod torn_word;
pub mod wiring;
