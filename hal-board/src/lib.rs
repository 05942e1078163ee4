//! # hal-board: the only crate that names a chip
//!
//! A board supplies exactly what the firmware cannot know: its network
//! driver, its time driver, its LEDs, the inputs a sensor samples
//! ([`io::Inputs`]), a watchdog, its interrupt vector and logger. Everything else
//! (protocol, codec, cycle engine, the firmware's tasks) lives in
//! `rri-firmware` and never sees a register.
//!
//! Boards: `mps2-an500` (QEMU, [`lan9118`] over MMIO), `nucleo-f767zi` and
//! `nucleo-h743zi` (embassy-stm32; one shared `nucleo` module, one chip file
//! each). Each board is one module behind one cargo feature and exports the
//! same names (see [`board`]): `init()`, `Board`, `Net`, `Leds`, `Inputs`,
//! `Watchdog`, `start_urgent_executor()`, `run_background()`, `cycle_counter()`,
//! `nic_counters()`, `exit()`.
//! Chip-only dependencies are gated to `target_os = "none"`, so the host
//! build (`cargo test`) never compiles them; the LAN9118 and LAN8742A
//! drivers are plain logic over a register trait, and the MPU encoding and
//! the receive ring's size plain arithmetic: all unit-tested on the host.
#![cfg_attr(not(test), no_std)]

// The host tests' critical sections (embassy-sync's mutex in the drivers'
// wakers) need an implementation linked in: critical-section's `std` one.
// Without this `cargo test -p hal-board` alone failed to link
// (`_critical_section_1_0_acquire`); in the workspace another crate had
// linked it.
#[cfg(test)]
use critical_section as _;

/// The watchdog's timeout on every board: not fed for this long (the
/// cycle stopped turning, or start-up hangs), the board resets. The
/// NUCLEO boards start it in `init`, before the Ethernet bring-up.
pub const WATCHDOG_MS: u32 = 2_000;

pub mod io;
pub mod lan8742;
pub mod lan9118;
pub mod mac;
pub mod mpu;
pub mod ram_flash;
pub mod reset;
pub mod rx_ring;
pub mod stack_guard;

/// What the network chip itself counted on the receive side, for the
/// firmware's counter line and the diagnostics: frames it lost before the
/// driver could take them are invisible everywhere else. Each board's
/// `nic_counters()` returns them, or `None` where the board does not read
/// them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NicCounters {
    /// Frames the driver took from the chip and handed to the stack (the
    /// LAN9118 driver's count; 0 on the STM32 boards, whose driver is
    /// embassy's: see `fifo`).
    pub rx_frames: u32,
    /// Frames the chip dropped (its own counters; LAN9118: `RX_DROP`;
    /// STM32F7: the Ethernet DMA's `ETH_DMAMFBOCR` missed frames, by the
    /// controller and by the application; STM32H7: `DMACMFCR` and
    /// `MTLRXQMPOCR`'s missed and overflow packets).
    pub rx_dropped: u32,
    /// A counter behind `rx_dropped` overflowed between two reads (its
    /// overflow flag was set): more frames were dropped than it could
    /// count, and `rx_dropped` is a lower bound ([`missed`]).
    pub rx_dropped_at_least: bool,
    /// Times the chip reported its receive status FIFO full (LAN9118:
    /// `INT_STS.RSFF`, seen by the interrupt handler).
    pub status_full: u32,
    /// The most bytes the receive data FIFO held when the driver looked.
    pub fifo_max: u32,
    /// Whether `rx_frames`, `status_full` and `fifo_max` are read (the
    /// LAN9118's driver is ours and counts them; embassy-stm32's does
    /// not, so there only `rx_dropped` is a reading).
    pub fifo: bool,
}

/// Frames a clear-on-read missed-frame counter of `bits` bits says were
/// dropped, given its overflow flag (issue 42 #12: they were ignored, so a
/// flood between two reads came out silently low). With the flag set the
/// counter passed its end, whether it then wrapped or stuck there (the
/// manuals say only that the flag is set): at least its full count
/// (2^bits - 1), or what it reads if that is more. Returns the count and
/// whether it is a lower bound.
pub const fn missed(value: u32, bits: u32, overflow: bool) -> (u32, bool) {
    let full = (1u32 << bits) - 1;
    let value = value & full;
    if overflow {
        (if value > full { value } else { full }, true)
    } else {
        (value, false)
    }
}

/// The Ethernet link as the board sees it, for the diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkInfo {
    /// Up: the network stack may use it.
    pub up: bool,
    /// The negotiated speed in Mbit/s, where the board reads it.
    pub speed_mbps: Option<u16>,
    /// Full duplex, where the board reads it.
    pub full_duplex: Option<bool>,
}

/// Stack painting and its high-water mark (every board).
#[cfg(app_board)]
pub mod stack;

/// `.diag_ram`, zeroed at start-up (every board).
#[cfg(app_board)]
pub mod sections;

/// The HardFault handler (every board).
#[cfg(app_board)]
pub mod fault;

#[cfg(all(feature = "mps2-an500", target_os = "none"))]
pub mod mps2_flash;

#[cfg(all(app_board, feature = "mps2-an500"))]
pub mod mps2_an500;

#[cfg(all(feature = "mps2-an500", feature = "boot", target_os = "none"))]
pub mod mps2_an500_boot;

#[cfg(all(app_board, feature = "stm32"))]
pub mod nucleo;

#[cfg(all(feature = "stm32", feature = "boot", target_os = "none"))]
pub mod nucleo_boot;

#[cfg(all(feature = "stm32", target_os = "none"))]
pub mod nucleo_flash;

#[cfg(all(feature = "nucleo-f767zi", target_os = "none"))]
pub mod f7_erase;

#[cfg(all(feature = "nucleo-h743zi", target_os = "none"))]
pub mod h743_ecc;

pub mod boot;

#[cfg(all(
    target_os = "none",
    any(
        all(feature = "mps2-an500", feature = "stm32"),
        all(feature = "nucleo-f767zi", feature = "nucleo-h743zi"),
    )
))]
compile_error!("choose one board feature: mps2-an500, nucleo-f767zi or nucleo-h743zi");

#[cfg(all(
    feature = "stm32",
    not(any(feature = "nucleo-f767zi", feature = "nucleo-h743zi"))
))]
compile_error!("`stm32` is not a board: choose nucleo-f767zi or nucleo-h743zi");

/// The board this firmware is built for.
#[cfg(all(app_board, feature = "mps2-an500"))]
pub use mps2_an500 as board;
/// The board this bootloader is built for.
#[cfg(all(feature = "mps2-an500", feature = "boot", target_os = "none"))]
pub use mps2_an500_boot as board;
/// The board this firmware is built for.
#[cfg(all(app_board, feature = "stm32"))]
pub use nucleo as board;
/// The board this bootloader is built for.
#[cfg(all(feature = "stm32", feature = "boot", target_os = "none"))]
pub use nucleo_boot as board;

#[cfg(test)]
mod missed_tests {
    use super::missed;

    #[test]
    fn an_overflowed_counter_is_a_lower_bound_at_its_full_count() {
        // F767 ETH_DMAMFBOCR: MFC 16 bits (OMFC), MFA 11 bits (OFOC).
        assert_eq!(missed(12, 16, false), (12, false));
        assert_eq!(missed(3, 16, true), (65_535, true));
        assert_eq!(missed(7, 11, true), (2_047, true));
        // Bits above the field are not the counter's.
        assert_eq!(missed(1 << 11 | 5, 11, false), (5, false));
    }
}
