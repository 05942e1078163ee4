//! # hal-board: the only crate that names a chip
//!
//! A board supplies exactly three things to the firmware: an
//! `embassy-net` network driver, a clock, and its pins (LEDs, ADC input).
//! Everything else (protocol, codec, cycle engine) lives in `rri-firmware`
//! and never sees a register.
//!
//! No board is implemented yet: STM32 (NUCLEO-F767ZI / H743ZI) and QEMU
//! boards arrive with their issues, each as one small module behind a cargo
//! feature, with chip-only dependencies gated to `target_os = "none"` so the
//! host build never compiles them.
#![no_std]
