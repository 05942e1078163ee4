//! The STM32 NUCLEO-144 Ethernet boards (NUCLEO-F767ZI, NUCLEO-H743ZI) on
//! embassy-stm32. Both share the board layout, so everything but the chip's
//! clocks and peripheral names lives here; [`chip`] is the one file that
//! differs (`f767zi.rs`, `h743zi.rs`).
//!
//! What the firmware gets:
//! - network: the MAC's RMII to the on-board LAN8742 PHY (`GenericPhy` over
//!   MDIO), pins as wired on every NUCLEO-144 (PA1 REF_CLK, PA2 MDIO, PA7
//!   CRS_DV, PB13 TXD1, PC1 MDC, PC4/PC5 RXD0/1, PG11 TX_EN, PG13 TXD0); a
//!   locally administered MAC derived from the chip's unique ID
//!   ([`crate::mac`]); the DMA rings in the board's RAM (on the H743 the
//!   linker puts all RAM in AXI SRAM, which its Ethernet DMA can reach);
//! - time: embassy-stm32's time driver on a general-purpose timer;
//!   [`cycle_counter`] is the DWT cycle counter (real core cycles);
//! - the urgent executor on UART4's interrupt (the UART is unused);
//! - LEDs: LD1 (green, PB0) shows the sensor state, LD2 (blue, PB7) the
//!   answered cycles;
//! - sample source: ADC1 on the Arduino header's A0 (PA3), 0–3.3 V read as
//!   0–[`RANGE_MM`] mm;
//! - watchdog: the independent watchdog (its own 32 kHz oscillator; a
//!   timeout resets the chip);
//! - defmt over RTT (read by `probe-rs run`), a panic handler that logs and
//!   resets, and a seed for the network stack from the hardware RNG.
//!
//! Interrupt priorities (lower is more urgent): the Ethernet interrupt and
//! the time driver's timer at embassy-stm32's default P0, the urgent
//! executor at P6; thread mode below all.
//!
//! Nothing here has run on a real board yet: it builds, links inside the
//! board's memory map and its sizes are checked in CI.
#![allow(unsafe_code)]

#[cfg(feature = "nucleo-f767zi")]
#[path = "f767zi.rs"]
mod chip;
#[cfg(feature = "nucleo-h743zi")]
#[path = "h743zi.rs"]
mod chip;

use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, SendSpawner, Spawner};
use embassy_stm32::adc::{Adc, SampleTime};
use embassy_stm32::eth::{Ethernet, GenericPhy, PacketQueue, Sma};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{ADC1, ETH, ETH_SMA, PA3};
use embassy_stm32::rng::Rng;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;

pub use chip::{NAME, SYSCLK_HZ};

embassy_stm32::bind_interrupts!(struct Irqs {
    ETH => embassy_stm32::eth::InterruptHandler;
    RNG => embassy_stm32::rng::InterruptHandler<embassy_stm32::peripherals::RNG>;
});

/// The analog input's full scale, as a distance for the demo application.
pub const RANGE_MM: f32 = 300.0;
/// Ethernet DMA descriptors and buffers: frames in flight each way. The
/// cycle has one message at a time; four leave room for ARP and a burst of
/// fragments.
const TX_FRAMES: usize = 4;
const RX_FRAMES: usize = 4;

/// The board's network driver.
pub type Net = Ethernet<'static, ETH, GenericPhy<Sma<'static, ETH_SMA>>>;

/// Everything the firmware takes from the board.
pub struct Board {
    pub net: Net,
    pub leds: Leds,
    pub sampler: Sampler,
    pub watchdog: Watchdog,
    /// Seed for the network stack (TCP sequence numbers, ports): from the
    /// hardware RNG.
    pub seed: u64,
}

/// The board cannot fail to start: a clock that does not come up hangs in
/// embassy-stm32's init (the watchdog is not running yet), which is what
/// to check first on a board that stays dark.
pub type InitError = core::convert::Infallible;

/// Starts the clocks, the cycle counter and the Ethernet MAC. Call once,
/// first.
pub fn init() -> Result<Board, InitError> {
    let p = embassy_stm32::init(chip::config());
    // SAFETY: called once at start-up, before any task exists; embassy-stm32
    // does not use these core peripherals.
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    // The instruction cache is safe with DMA; the data cache is left off so
    // the Ethernet DMA and the core always agree on memory.
    cp.SCB.enable_icache();

    let mut rng = Rng::new(p.RNG, Irqs);
    let mut seed = [0; 8];
    rng.fill_bytes(&mut seed);

    let uid = embassy_stm32::uid::uid();
    let mac = crate::mac::from_unique_id(&uid);
    defmt::info!("MAC {=[u8]:02x} from unique ID {=[u8]:02x}", mac, uid);
    static PACKETS: static_cell::StaticCell<PacketQueue<TX_FRAMES, RX_FRAMES>> =
        static_cell::StaticCell::new();
    let net = Ethernet::new(
        PACKETS.init_with(PacketQueue::new),
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
        p.ETH_SMA,
        p.PA2,
        p.PC1,
    );
    Ok(Board {
        net,
        leds: Leds {
            pins: [
                Output::new(p.PB0, Level::Low, Speed::Low),
                Output::new(p.PB7, Level::Low, Speed::Low),
            ],
        },
        sampler: Sampler {
            adc: Adc::new(p.ADC1),
            pin: p.PA3,
        },
        watchdog: Watchdog {
            peripheral: Some(chip::iwdg!(p)),
            running: None,
        },
        seed: u64::from_le_bytes(seed),
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

/// Runs the background tasks (sampler, housekeeping) on embassy's
/// thread-mode executor, which sleeps in `wfe` between polls (on silicon a
/// real sleep; the QEMU board idles in `wfi` instead, see its
/// `run_background`).
pub fn run_background(init: impl FnOnce(Spawner)) -> ! {
    static THREAD: static_cell::StaticCell<Executor> = static_cell::StaticCell::new();
    THREAD.init(Executor::new()).run(init)
}

/// Core clock cycles (DWT): wraps every 2^32 / [`SYSCLK_HZ`] seconds.
pub fn cycle_counter() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Not read on the STM32 boards yet: embassy-stm32's driver does not
/// expose the Ethernet DMA's missed-frame counter, and nothing here has
/// run on a board to check a register read of our own against.
pub fn nic_counters() -> Option<crate::NicCounters> {
    None
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

/// ADC1 on A0 (PA3).
pub struct Sampler {
    adc: Adc<'static, ADC1>,
    pin: Peri<'static, PA3>,
}

impl Sampler {
    /// One conversion (a few microseconds), scaled to 0..[`RANGE_MM`].
    pub fn read(&mut self) -> Option<f32> {
        let sample_time: SampleTime = chip::SAMPLE_TIME;
        let raw = self.adc.blocking_read(&mut self.pin, sample_time);
        Some(f32::from(raw) * (RANGE_MM / chip::ADC_FULL_SCALE))
    }
}

/// The independent watchdog: once started it cannot be stopped; not fed
/// for `timeout_ms`, it resets the chip.
pub struct Watchdog {
    peripheral: Option<Peri<'static, chip::Iwdg>>,
    running: Option<IndependentWatchdog<'static, chip::Iwdg>>,
}

impl Watchdog {
    pub fn start(&mut self, timeout_ms: u32) {
        if let Some(p) = self.peripheral.take() {
            let mut wdg = IndependentWatchdog::new(p, timeout_ms.saturating_mul(1000));
            wdg.unleash();
            self.running = Some(wdg);
        }
    }

    pub fn feed(&mut self) {
        if let Some(wdg) = self.running.as_mut() {
            wdg.pet();
        }
    }
}

/// Resets the board (there is nowhere to exit to).
pub fn exit(code: i32) -> ! {
    defmt::info!("exit {}: resetting", code);
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
