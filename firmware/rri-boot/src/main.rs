//! The bootloader: the first code a board runs, from its own partition.
//!
//! 1. It finishes what embassy-boot left: an interrupted rollback or
//!    confirmation ([`rri_update::boot::prepare`]), then the swap a marked
//!    update asks for, or the swap back when the image swapped in last
//!    time did not confirm itself. Every step is power-cut safe: a cut
//!    anywhere is finished at the next start (the host's power-cut test,
//!    `host-tests/tests/update_power_cut.rs`, cuts at every flash
//!    operation). First, because a cut in the swap's last step leaves the
//!    active partition without its vector table until it is finished.
//! 2. While the active partition then holds no image, it puts the first
//!    one there where the board can (QEMU: its loader writes a factory
//!    image beside the bootloader, copied once); on a NUCLEO the probe
//!    flashes the first image (`cargo f767`, `cargo h743`), and without
//!    one the bootloader says so.
//! 3. It starts the active image.
//!
//! It says nothing when all is well; a bootloader that cannot start an
//! image says why and stops (the board's `fail`).
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod boot {
    use hal_board::board;

    /// embassy-boot's copy buffer (a divisor of its swap page).
    #[repr(C, align(32))]
    struct Buffer([u8; board::COPY_BUFFER]);

    #[cortex_m_rt::entry]
    fn main() -> ! {
        let Some(board::Flash {
            mut active,
            dfu,
            state,
        }) = board::Flash::take()
        else {
            board::fail("the partitions were taken twice")
        };
        // The swap or rollback a reset interrupted is finished before the
        // active partition is checked for an image (`rri_update::boot::
        // start` says why, and the host's power-cut test runs the same
        // order).
        let mut page = Buffer([0; board::COPY_BUFFER]);
        let started = rri_update::boot::start(&mut active, dfu, state, &mut page.0, |active| {
            if board::active_holds_image(active) {
                Ok(())
            } else {
                board::install_first_image(active)
            }
        });
        if let Err(halt) = started {
            board::fail(halt.why());
        }
        board::start_active(active)
    }
}

/// The host build (`cargo test`, clippy) has nothing to run.
#[cfg(not(target_os = "none"))]
fn main() {}
