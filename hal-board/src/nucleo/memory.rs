//! Where the NUCLEO boards keep their memory, for speed, and the caches
//! that this placement makes safe.
//!
//! The board's memory map (`memory.x` for the F767,
//! `memory/nucleo-h743zi.x` for the H743) puts:
//!
//! - `RAM`: the 128 KiB DTCM at `0x2000_0000`: the stack (at its bottom,
//!   under flip-link, so an overflow faults) and every static. The core
//!   reaches it in one cycle, the caches never hold it, and nothing but the
//!   core writes it;
//! - `DMA_RAM`: SRAM1 + SRAM2 (F767) or the AXI SRAM (H743): the Ethernet
//!   DMA rings and nothing else, in section `.eth_dma` (`packet_queue`).
//!   The H743's Ethernet DMA cannot reach its DTCM; the F767's could, but
//!   the rings would take DTCM from the stack;
//! - `__uncached_start` / `__uncached_size`: the window the MPU makes
//!   normal non-cacheable memory; it covers `DMA_RAM` (the script asserts
//!   it).
//!
//! With every writable byte either in the DTCM or in the non-cacheable
//! window, the data cache only ever holds flash (`.rodata`, the tables the
//! codec reads every cycle): it has nothing to clean or invalidate, and
//! the DMA and the core always agree, with no cache maintenance anywhere.
//! `cargo boards` checks the placement in each board's ELF
//! (`host-tests/src/board_map.rs`). The `dcache-off` feature leaves the
//! data cache off, to measure what it gains on a real board.
#![allow(unsafe_code)]

use super::{RX_FRAMES, TX_FRAMES};
use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};
use core::sync::atomic::{AtomicBool, Ordering};
use embassy_stm32::eth::PacketQueue;

extern "C" {
    // The board's memory map: the window the MPU makes non-cacheable (the
    // symbols' addresses are the values).
    static __uncached_start: u8;
    static __uncached_size: u8;
}

/// The Ethernet DMA descriptors and frame buffers, in `DMA_RAM` (`NOLOAD`:
/// [`packet_queue`] zeroes them at start-up).
#[link_section = ".eth_dma"]
static mut ETH_DMA_PACKETS: MaybeUninit<PacketQueue<TX_FRAMES, RX_FRAMES>> = MaybeUninit::uninit();
static TAKEN: AtomicBool = AtomicBool::new(false);

/// The DMA rings, zeroed in place (never built on the stack: 30 KB). Only
/// once; `None` after that.
pub(super) fn packet_queue() -> Option<&'static mut PacketQueue<TX_FRAMES, RX_FRAMES>> {
    if TAKEN.swap(true, Ordering::AcqRel) {
        return None;
    }
    // SAFETY: `TAKEN` hands the static out once, so this is its only
    // reference; `PacketQueue::init` zeroes it, which embassy-stm32
    // documents as a valid queue.
    unsafe {
        let queue = &mut *addr_of_mut!(ETH_DMA_PACKETS);
        PacketQueue::init(queue);
        Some(queue.assume_init_mut())
    }
}

/// The MPU window and what the caches were left as, for the log.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct Caches {
    /// The MPU's non-cacheable window: its first address and size.
    pub uncached_start: u32,
    pub uncached_size: u32,
    /// Whether the data cache is on (off with the `dcache-off` feature).
    pub data_cache: bool,
}

/// Makes the map's uncached window non-cacheable (MPU region 0), then
/// turns on the instruction cache and, unless the `dcache-off` feature is
/// on, the data cache. Call once, first: before anything is cached.
pub(super) fn enable_caches(
    cp: &mut cortex_m::Peripherals,
) -> Result<Caches, crate::mpu::RegionError> {
    let start = addr_of!(__uncached_start) as u32;
    let size = addr_of!(__uncached_size) as u32;
    let (rbar, rasr) = crate::mpu::non_cacheable(0, start, size)?;
    cortex_m::asm::dsb();
    // SAFETY: the MPU is programmed before the data cache is on and before
    // any DMA runs; the one region only takes caching away, and the
    // default map (PRIVDEFENA) keeps everything else as it was.
    unsafe {
        cp.MPU.ctrl.write(0);
        // The broken variant `rehost-broken-cacheable` (Cargo.toml) leaves
        // the DMA RAM cacheable.
        if cfg!(not(feature = "rehost-broken-cacheable")) {
            cp.MPU.rbar.write(rbar);
            cp.MPU.rasr.write(rasr);
        }
        cp.MPU.ctrl.write(crate::mpu::CTRL_ENABLE_WITH_DEFAULT_MAP);
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    cp.SCB.enable_icache();
    let data_cache = cfg!(not(feature = "dcache-off"));
    if data_cache {
        cp.SCB.enable_dcache(&mut cp.CPUID);
    }
    Ok(Caches {
        uncached_start: start,
        uncached_size: size,
        data_cache,
    })
}
