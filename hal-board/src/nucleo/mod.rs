//! The STM32 NUCLEO-144 Ethernet boards (NUCLEO-F767ZI, NUCLEO-H743ZI2) on
//! embassy-stm32. Both share the board layout, so everything but the chip's
//! clocks and peripheral names lives here; [`chip`] is the one file that
//! differs (`f767zi.rs`, `h743zi.rs`).
//!
//! What the firmware gets:
//! - network: the MAC's RMII to the on-board LAN8742A PHY, pins as wired
//!   on every NUCLEO-144 (PA1 REF_CLK, PA2 MDIO, PA7 CRS_DV, PB13 TXD1,
//!   PC1 MDC, PC4/PC5 RXD0/1, PG11 TX_EN, PG13 TXD0); the PHY read over
//!   MDIO by a background task, never on the cycle's path ([`phy`]); a
//!   locally administered MAC derived from the chip's unique ID
//!   ([`crate::mac`]); the DMA rings sized for every layout
//!   ([`crate::rx_ring`]) in their own memory ([`memory`]);
//! - clocks from the ST-LINK's 8 MHz output, or the internal HSI when it is
//!   missing ([`clock`]);
//! - memory: stack and statics in the DTCM, the instruction and data
//!   caches on ([`memory`]);
//! - time: embassy-stm32's time driver on a general-purpose timer;
//!   [`cycle_counter`] is the DWT cycle counter (real core cycles);
//! - the urgent executor on UART4's interrupt (the UART is unused);
//! - LEDs: LD1 (green, PB0) shows the sensor state, LD2 the answered
//!   cycles (PB7 on the F767ZI, PE1 on the H743ZI2);
//! - the sensor's inputs ([`Inputs`]): ADC1 on the Arduino header's A0
//!   (PA3), 0–3.3 V read as 0.0–1.0 of full scale (what it measures is the
//!   sensor's business: `rri_firmware::sensors`);
//! - watchdog: the independent watchdog (its own 32 kHz oscillator; a
//!   timeout resets the chip);
//! - defmt over RTT (read by `probe-rs run`), a panic handler and a
//!   HardFault handler ([`crate::fault`]) that log and reset, and a seed for
//!   the network stack from the hardware RNG.
//!
//! Interrupt priorities (lower is more urgent): the Ethernet interrupt and
//! the time driver's timer at embassy-stm32's default P0, the urgent
//! executor at P6; thread mode (the background tasks and the PHY monitor)
//! below all.
//!
//! Nothing here has run on a real board yet: it builds, links inside the
//! board's memory map and its sizes and placement are checked in CI.
#![allow(unsafe_code)]

mod broken;
#[cfg(feature = "nucleo-f767zi")]
#[path = "f767zi.rs"]
mod chip;
#[cfg(feature = "nucleo-h743zi")]
#[path = "h743zi.rs"]
mod chip;
pub mod clock;
pub mod memory;
pub mod phy;

pub mod update;

use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, SendSpawner, Spawner};
use embassy_stm32::adc::{Adc, SampleTime};
use embassy_stm32::eth::{Ethernet, Sma};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{ADC1, ETH, PA3};
use embassy_stm32::rng::Rng;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;

pub use chip::{NAME, SYSCLK_HZ};

embassy_stm32::bind_interrupts!(struct Irqs {
    ETH => embassy_stm32::eth::InterruptHandler;
    RNG => embassy_stm32::rng::InterruptHandler<embassy_stm32::peripherals::RNG>;
});

/// Ethernet transmit frames: a reply in up to three fragments (any reply
/// the IP stack can fragment: 4,096 bytes) and an ARP answer. A full ring
/// only makes the stack wait; nothing is lost.
const TX_FRAMES: usize = 4;
/// Ethernet receive frames: whatever may arrive while the cycle computes
/// (see [`crate::rx_ring`]): two datagrams in reassembly at smoltcp's
/// limit, or a burst of one datagram per robot property, plus ARP and a
/// margin. 18 with the firmware's smoltcp settings.
pub const RX_FRAMES: usize = crate::rx_ring::rx_frames(
    smoltcp::config::REASSEMBLY_BUFFER_SIZE,
    smoltcp::config::REASSEMBLY_BUFFER_COUNT,
    rri_vocabulary::MAX_PROPERTIES,
);

/// The board's network driver.
pub type Net = Ethernet<'static, ETH, phy::CachedLink>;

/// Everything the firmware takes from the board.
pub struct Board {
    pub net: Net,
    pub leds: Leds,
    /// What the sensor samples (its `sample` reads them on the
    /// background executor).
    pub inputs: Inputs,
    pub watchdog: Watchdog,
    /// Seed for the network stack (TCP sequence numbers, ports): from the
    /// hardware RNG.
    pub seed: u64,
    /// Why the board started: the RCC's reset flags and the crash record
    /// ([`crate::reset`]).
    pub reset: crate::reset::Report,
}

/// Why the board could not start. Nothing in start-up waits forever
/// unguarded: a missing ST-LINK clock falls back to the HSI ([`clock`]), a
/// PHY that does not answer is logged and retried ([`phy`]), and the one
/// wait without a bound, embassy-stm32's for the MAC's DMA to leave its
/// software reset (it needs the PHY's 50 MHz reference clock), runs with
/// the watchdog already started: a PHY that gives no clock resets the
/// board after [`crate::WATCHDOG_MS`] (`cargo rehost -- --board f767
/// --no-ref-clock` shows it).
#[derive(Clone, Copy, Debug, defmt::Format)]
pub enum InitError {
    /// `init` was called twice (the DMA rings are handed out once).
    AlreadyStarted,
}

/// Starts the caches, the clocks, the cycle counter and the Ethernet MAC.
/// Call once, first.
pub fn init() -> Result<Board, InitError> {
    // First: the flags are the chip's, embassy's init leaves them, and
    // the record must be read before anything could write it.
    let reset = crate::reset::ram::start(crate::reset::Flags::Chip(chip::reset_flags()));
    crate::sections::zero_diag_ram();
    // SAFETY: called once at start-up, before any task exists; embassy-stm32
    // does not use these core peripherals.
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    // Before anything is cached (the MPU window first).
    let caches = memory::enable_caches(&mut cp);
    let source = clock::probe(chip::RESET_HSI_HZ);
    broken::before_clocks();
    let p = embassy_stm32::init(chip::config(source));
    broken::after_clocks();
    update::start(p.FLASH);
    if update::ORIGIN != crate::nucleo_flash::active_origin() {
        defmt::error!(
            "update: this image says it is linked at {=u32:#010x}, the flash map's active partition is at {=u32:#010x}: every update file would be refused",
            update::ORIGIN,
            crate::nucleo_flash::active_origin()
        );
    }
    match source {
        clock::Source::Hse => defmt::info!(
            "clock: {=u32} MHz from the ST-LINK's 8 MHz (HSE bypass)",
            SYSCLK_HZ / 1_000_000
        ),
        clock::Source::Hsi => defmt::warn!(
            "clock: no 8 MHz from the ST-LINK on OSC_IN within {=u32} ms: {=u32} MHz from the internal HSI (about 1 % accurate: the time base and the timestamps drift)",
            clock::HSE_WAIT_MS,
            SYSCLK_HZ / 1_000_000
        ),
    }
    match caches {
        Ok(c) => defmt::info!(
            "caches: instruction on, data {=str}; {=u32:#010x}+{=u32:#x} not cacheable (Ethernet DMA)",
            if c.data_cache { "on" } else { "off (dcache-off)" },
            c.uncached_start,
            c.uncached_size
        ),
        Err(e) => {
            // The memory map is wrong (its linker script asserts this
            // cannot link): run uncached rather than risk the DMA.
            cp.SCB.enable_icache();
            defmt::error!("MPU: the uncached window is not one region ({}): data cache off", e);
        }
    }
    crate::stack_guard::arm(&mut cp);
    cp.DCB.enable_trace();
    // The STM32F7 locks the DWT after a power cycle (cortex-m's
    // `DWT::unlock`): without this every cycle count would read 0.
    cortex_m::peripheral::DWT::unlock();
    cp.DWT.enable_cycle_counter();

    let mut rng = Rng::new(p.RNG, Irqs);
    let mut seed = [0; 8];
    rng.fill_bytes(&mut seed);

    let uid = embassy_stm32::uid::uid();
    let mac = crate::mac::from_unique_id(&uid);
    defmt::info!("MAC {=[u8]:02x} from unique ID {=[u8]:02x}", mac, uid);
    let packets = memory::packet_queue().ok_or(InitError::AlreadyStarted)?;
    // The watchdog before the Ethernet bring-up (issue 42 #14):
    // embassy-stm32 waits without a bound for the MAC's DMA to leave its
    // software reset, which ends only once the PHY's 50 MHz reference
    // clock runs. A PHY that gives none would leave a dark board for
    // ever; with the watchdog running it resets, and the next start says
    // so ("last reset: watchdog").
    let watchdog = Watchdog::started(chip::iwdg!(p), crate::WATCHDOG_MS);
    let net = Ethernet::new_with_phy(
        packets,
        p.ETH,
        Irqs,
        p.PA1,
        p.PA7,
        p.PC4,
        p.PC5,
        p.PG13,
        p.PB13,
        p.PG11,
        mac,
        phy::CachedLink,
    );
    // After the MAC's reset (in `new_with_phy`): MDIO goes through it.
    let monitor = phy::Monitor::start(Sma::new(p.ETH_SMA, p.PA2, p.PC1));
    LINK_MONITOR.lock(|m| m.set(Some(monitor)));
    broken::after_ethernet();
    if cfg!(feature = "fault-selftest") {
        crate::fault::selftest(&reset);
    }
    Ok(Board {
        net,
        leds: Leds {
            pins: [
                Output::new(p.PB0, Level::Low, Speed::Low),
                Output::new(chip::ld2!(p), Level::Low, Speed::Low),
            ],
        },
        inputs: Inputs {
            adc: Adc::new(p.ADC1),
            a0: p.PA3,
        },
        watchdog,
        seed: u64::from_le_bytes(seed),
        reset,
    })
}

static URGENT: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn UART4() {
    // SAFETY: UART4's interrupt is the urgent executor's and nothing
    // else's (the UART itself is never enabled).
    unsafe { URGENT.on_interrupt() }
}

/// Starts the interrupt executor the network stack and the cycle run on:
/// nothing in thread mode can delay them.
pub fn start_urgent_executor() -> SendSpawner {
    interrupt::UART4.set_priority(Priority::P6);
    URGENT.start(interrupt::UART4)
}

/// The PHY monitor, from [`init`] to [`run_background`].
static LINK_MONITOR: embassy_sync::blocking_mutex::Mutex<
    embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex,
    core::cell::Cell<Option<phy::Monitor>>,
> = embassy_sync::blocking_mutex::Mutex::new(core::cell::Cell::new(None));

/// Runs the background tasks (the sensor's sampler, housekeeping) and the board's PHY
/// monitor on embassy's thread-mode executor, which sleeps in `wfe`
/// between polls (on silicon a real sleep; the QEMU board idles in `wfi`
/// instead, see its `run_background`).
pub fn run_background(init: impl FnOnce(Spawner)) -> ! {
    static THREAD: static_cell::StaticCell<Executor> = static_cell::StaticCell::new();
    THREAD.init(Executor::new()).run(|spawner| {
        if let Some(monitor) = LINK_MONITOR.lock(|m| m.take()) {
            match phy::monitor(monitor) {
                Ok(task) => spawner.spawn(task),
                Err(_) => defmt::error!("the PHY monitor could not start: the link stays down"),
            }
        }
        init(spawner)
    })
}

/// Core clock cycles (DWT): wraps every 2^32 / [`SYSCLK_HZ`] seconds.
pub fn cycle_counter() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// The Ethernet receive path's own missed-frame counters (the chip's
/// registers, which clear when read: summed here, under a critical
/// section, so any number of callers may ask). embassy-stm32's driver
/// counts nothing itself, so only `rx_dropped` is a reading. Not yet
/// checked on silicon: the register reads are from the reference manuals
/// and stm32-metapac.
/// Housekeeping reads them ten times a second (its tick), so a counter
/// that overflows between reads takes a flood of 2,048 frames in 100 ms;
/// when one does, its overflow flag makes the sum a lower bound
/// (`rx_dropped_at_least`, kept from then on).
pub fn nic_counters() -> Option<crate::NicCounters> {
    static DROPPED: embassy_sync::blocking_mutex::Mutex<
        embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex,
        core::cell::Cell<(u32, bool)>,
    > = embassy_sync::blocking_mutex::Mutex::new(core::cell::Cell::new((0, false)));
    let (rx_dropped, rx_dropped_at_least) = DROPPED.lock(|d| {
        let (sum, lower) = d.get();
        let (n, overflowed) = chip::missed_frames();
        d.set((sum.saturating_add(n), lower || overflowed));
        d.get()
    });
    Some(crate::NicCounters {
        rx_dropped,
        rx_dropped_at_least,
        ..crate::NicCounters::default()
    })
}

/// The link as the PHY monitor last read it.
pub fn link() -> crate::LinkInfo {
    phy::link()
}

/// LD1 (state) and LD2 (cycles).
pub struct Leds {
    pins: [Output<'static>; 2],
}

impl Leds {
    pub fn set(&mut self, led: usize, on: bool) {
        if let Some(pin) = self.pins.get_mut(led) {
            pin.set_level(if on { Level::High } else { Level::Low });
        }
    }
}

/// The sensor's inputs: ADC1 on the Arduino header's A0 (PA3).
pub struct Inputs {
    adc: Adc<'static, ADC1>,
    a0: Peri<'static, PA3>,
}

impl crate::io::Inputs for Inputs {
    /// Channel 0 (A0): one conversion (a few microseconds) as a fraction
    /// of the ADC's full scale (3.3 V).
    fn analog(&mut self, channel: usize) -> Option<f32> {
        if channel != 0 {
            return None;
        }
        let sample_time: SampleTime = chip::SAMPLE_TIME;
        let raw = self.adc.blocking_read(&mut self.a0, sample_time);
        Some(f32::from(raw) / chip::ADC_FULL_SCALE)
    }
}

/// The independent watchdog: once started it cannot be stopped; not fed
/// for its timeout, it resets the chip. It runs from `init`, before the
/// Ethernet bring-up, with [`crate::WATCHDOG_MS`].
pub struct Watchdog {
    running: IndependentWatchdog<'static, chip::Iwdg>,
}

impl Watchdog {
    fn started(p: Peri<'static, chip::Iwdg>, timeout_ms: u32) -> Watchdog {
        let mut running = IndependentWatchdog::new(p, timeout_ms.saturating_mul(1000));
        running.unleash();
        Watchdog { running }
    }

    /// Running since `init` with [`crate::WATCHDOG_MS`] (the same on
    /// every board; `timeout_ms` is the firmware's, which is that):
    /// feeds it.
    pub fn start(&mut self, timeout_ms: u32) {
        let _ = timeout_ms;
        self.running.pet();
    }

    pub fn feed(&mut self) {
        self.running.pet();
    }
}

/// Resets the board (there is nowhere to exit to).
pub fn exit(code: i32) -> ! {
    defmt::info!("exit {}: resetting", code);
    reset_after_logs()
}

/// Restarts the board on purpose (into the bootloader's swap of an
/// update), after the log's last lines. The crash record holds no crash,
/// so the next start reports a software reset ([`crate::reset`]).
pub fn restart() -> ! {
    reset_after_logs()
}

/// After a fault: the log's last lines, then a reset ([`crate::fault`]).
pub(crate) fn reset() -> ! {
    reset_after_logs()
}

/// Gives the debug probe time to read the last log lines out of the RTT
/// buffer (about 100 ms), then resets.
fn reset_after_logs() -> ! {
    cortex_m::asm::delay(SYSCLK_HZ / 10);
    cortex_m::peripheral::SCB::sys_reset()
}

/// Logs where the panic happened and resets. The message itself is not
/// formatted: that would link `core::fmt` (several KiB of flash) for a
/// path the cycle never takes; `defmt::panic!` logs its message before
/// it gets here.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // A panic while a fault or panic is handled (the logger's own, when
    // that handler logs with the logger held): keep the first record,
    // log nothing, reset (`crate::fault`, `crate::reset::claim`).
    if !crate::reset::claim() {
        reset_after_logs()
    }
    if let Some(at) = info.location() {
        crate::reset::ram::note(&mut |r| r.panic(at.file(), at.line()));
    }
    match info.location() {
        Some(at) => defmt::error!(
            "panic at {=str}:{=u32}:{=u32}",
            at.file(),
            at.line(),
            at.column()
        ),
        None => defmt::error!("panic"),
    }
    reset_after_logs()
}
