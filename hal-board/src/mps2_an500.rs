//! QEMU's `mps2-an500` (ARM MPS2 FPGA image AN500: Cortex-M7 with FPU,
//! 25 MHz), the board every machine has. What the firmware gets from it:
//!
//! - network: the SMSC LAN9118 at `0xA000_0000`, IRQ 13 ([`crate::lan9118`]);
//! - time: a CMSDK APB timer as a free-running 25 MHz counter (extended to
//!   64 bits) for `embassy-time` at 1 MHz, and SysTick every 250 µs to run
//!   the timer queue; [`cycle_counter`] reads the raw 25 MHz count (under
//!   `-icount shift=N` one count is `40 / 2^N` instructions: QEMU has no
//!   working DWT cycle counter);
//! - the urgent executor on spare IRQ 30 (network and cycle run there) and
//!   the background executor on spare IRQ 31, with thread mode idling in
//!   `wfi` (see [`run_background`]);
//! - LEDs: the FPGA's two user LEDs; no ADC is modelled, so the sensor's
//!   inputs are [`crate::io::Simulated`] and the firmware asks the sensor to
//!   simulate its samples;
//! - watchdog: the CMSDK watchdog (NMI, then reset);
//! - defmt over semihosting (QEMU's stdout), semihosting exit codes, a
//!   panic handler that logs and exits with status 101, and the HardFault
//!   handler every board has ([`crate::fault`]: log, then reset).
//!
//! Interrupt priorities (lower is more urgent): SysTick 0 (it must never be
//! starved for a whole period: the 64-bit time depends on it), NIC 0x40,
//! urgent executor 0x80, background executor 0xC0; the idle loop in thread
//! mode below all.
#![allow(unsafe_code)]

use crate::lan9118::{self, Lan9118, Registers};
use core::cell::{Cell, RefCell};
use core::ptr;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::interrupt::{InterruptNumber, Mutex};
use cortex_m::peripheral::scb::SystemHandler;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::exception;
use defmt_semihosting as _;
use embassy_executor::{InterruptExecutor, SendSpawner};
use embassy_time_queue_utils::Queue;

/// The board's name, for the logs.
pub const NAME: &str = "QEMU mps2-an500";
/// The core clock: SysTick, the APB timers and the watchdog all count it.
pub const SYSCLK_HZ: u32 = 25_000_000;
/// A locally administered address (bit 1 of the first byte set): QEMU's
/// NIC takes whatever the driver programs.
const MAC: [u8; 6] = [0x02, 0x00, 0x52, 0x52, 0x49, 0x01];

const LAN9118_BASE: usize = 0xa000_0000;
const TIMER0_BASE: usize = 0x4000_0000;
const WATCHDOG_BASE: usize = 0x4000_8000;
const FPGAIO_LED: usize = 0x4002_8000;

#[derive(Clone, Copy)]
struct Irq(u16);

// SAFETY: both numbers are below the machine's 32 external interrupts.
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self.0
    }
}

const LAN9118_IRQ: Irq = Irq(13);
/// Not wired to any device on the AN500: free for the urgent executor.
const URGENT_IRQ: Irq = Irq(30);
/// Not wired either: the background executor's.
const BACKGROUND_IRQ: Irq = Irq(31);
const PRIO_SYSTICK: u8 = 0x00;
const PRIO_NIC: u8 = 0x40;
const PRIO_URGENT: u8 = 0x80;
const PRIO_BACKGROUND: u8 = 0xc0;

fn read32(addr: usize) -> u32 {
    // SAFETY: only called with the addresses of this board's registers.
    unsafe { ptr::read_volatile(addr as *const u32) }
}

fn write32(addr: usize, value: u32) {
    // SAFETY: only called with the addresses of this board's registers.
    unsafe { ptr::write_volatile(addr as *mut u32, value) }
}

/// The LAN9118's registers, memory-mapped.
#[derive(Clone, Copy)]
pub struct Mmio;

impl Registers for Mmio {
    fn read(&self, offset: usize) -> u32 {
        read32(LAN9118_BASE + offset)
    }
    fn write(&self, offset: usize, value: u32) {
        write32(LAN9118_BASE + offset, value)
    }
}

/// The board's network driver.
pub type Net = Lan9118<Mmio>;

/// Everything the firmware takes from the board.
pub struct Board {
    pub net: Net,
    pub leds: Leds,
    /// What the sensor samples: nothing real here (simulated).
    pub inputs: Inputs,
    pub watchdog: Watchdog,
    /// Seed for the network stack (TCP sequence numbers, ports). QEMU has no
    /// RNG; a constant keeps runs (and the bench) repeatable.
    pub seed: u64,
    /// Why the board started (QEMU has no reset flags: the crash record
    /// alone tells, [`crate::reset`]).
    pub reset: crate::reset::Report,
}

/// Why the board could not start.
pub type InitError = lan9118::InitError;

/// Starts the clocks and the NIC. Call once, first.
pub fn init() -> Result<Board, InitError> {
    let reset = crate::reset::ram::start(crate::reset::Flags::None);
    crate::sections::zero_diag_ram();
    // SAFETY: called once at start-up, before any task exists; nothing
    // else owns the core peripherals.
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    crate::stack_guard::arm(&mut cp);
    time::start(&mut cp.SYST);
    // SAFETY: priorities are set before the interrupts are unmasked.
    unsafe {
        cp.SCB.set_priority(SystemHandler::SysTick, PRIO_SYSTICK);
        cp.NVIC.set_priority(LAN9118_IRQ, PRIO_NIC);
        cp.NVIC.set_priority(URGENT_IRQ, PRIO_URGENT);
        cp.NVIC.set_priority(BACKGROUND_IRQ, PRIO_BACKGROUND);
    }
    let net = Lan9118::new(Mmio, MAC)?;
    NVIC::unpend(LAN9118_IRQ);
    // SAFETY: the handler (below) is ready and the NIC's line is active-high.
    unsafe { NVIC::unmask(LAN9118_IRQ) };
    if cfg!(feature = "fault-selftest") {
        crate::fault::selftest(&reset);
    }
    Ok(Board {
        net,
        leds: Leds { bits: 0 },
        inputs: crate::io::Simulated,
        watchdog: Watchdog,
        seed: 0x5252_4900_0000_0001,
        reset,
    })
}

static URGENT: InterruptExecutor = InterruptExecutor::new();

/// Starts the interrupt executor the network stack and the cycle run on:
/// nothing in thread mode can delay them.
pub fn start_urgent_executor() -> SendSpawner {
    URGENT.start(URGENT_IRQ)
}

static BACKGROUND: InterruptExecutor = InterruptExecutor::new();

/// Runs the background tasks (the sensor's sampler, housekeeping) on an interrupt
/// executor below the urgent one, and idles thread mode in `wfi`.
///
/// Why not embassy's thread-mode executor, as on the NUCLEO boards: it
/// sleeps in `wfe`, which QEMU (7.2) implements as a yield, not a halt, so
/// the emulator's vCPU thread would spin a whole host core while the
/// firmware idles. On a two-core machine that core is taken from the robot
/// simulator and from QEMU's own network thread, and replies arrive
/// milliseconds late. `wfi` halts the vCPU until the next interrupt; every
/// wake-up of a task here is an interrupt (its executor's pend), so nothing
/// can be missed between a poll and the `wfi`.
pub fn run_background(init: impl FnOnce(SendSpawner)) -> ! {
    init(BACKGROUND.start(BACKGROUND_IRQ));
    loop {
        cortex_m::asm::wfi();
    }
}

/// Interrupts that fired with no handler (the firmware reports them).
pub static SPURIOUS_IRQS: AtomicU32 = AtomicU32::new(0);

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    match irqn {
        13 => lan9118::on_interrupt(&Mmio),
        // SAFETY: IRQ 30 is the urgent executor's and nothing else's, and
        // the executor was started before the IRQ was unmasked.
        30 => unsafe { URGENT.on_interrupt() },
        // SAFETY: likewise IRQ 31 and the background executor.
        31 => unsafe { BACKGROUND.on_interrupt() },
        // NMI: the watchdog ran out. Reset now rather than at its second
        // timeout, and say so to the next start.
        -14 => {
            crate::reset::ram::note(&mut |r| r.watchdog());
            cortex_m::peripheral::SCB::sys_reset()
        }
        _ => {
            SPURIOUS_IRQS.fetch_add(1, Ordering::Relaxed);
        }
    }
}

#[exception]
fn SysTick() {
    time::on_tick();
}

/// The raw 25 MHz count, for measuring: see the module doc.
pub fn cycle_counter() -> u32 {
    time::raw32()
}

/// Update in the cell (issue 43): the partitions and what an update file
/// for this board says.
pub mod update {
    use crate::ram_flash::RamFlash;

    /// One partition of the board's flash (RAM with a NOR flash's rules).
    pub type Partition = RamFlash;

    /// The board an update file must name (`cargo sign-image -- sign
    /// --board qemu`).
    pub const BOARD: &str = "mps2-an500";
    /// Where the image is linked: the active partition's start
    /// (`memory/mps2-an500-flash.x`; an update file linked elsewhere is
    /// refused, so a value that disagreed with the map would refuse every
    /// file, which CI's update runs would show).
    pub const ORIGIN: u32 = 0x0010_0000;
    /// The bootloader (firmware/rri-boot) swaps a marked image in at the
    /// next reset, and this image restarts into it once its controller is
    /// not OPERATING (`rri_update::lifecycle`).
    pub const SWAPS: bool = true;
    /// The demonstration key, which anyone can sign with, may be built
    /// into this board's image (it is no product).
    pub const DEMO_KEY_ALLOWED: bool = true;

    /// The active partition's bytes: the most an image may have.
    pub fn active() -> usize {
        crate::mps2_flash::active_len()
    }

    /// Why the board takes no update (never: its flash model has no
    /// set-up to get wrong).
    pub fn unavailable() -> Option<&'static str> {
        None
    }

    /// The update and state partitions (`memory/mps2-an500-flash.x`, RAM
    /// that QEMU's reset leaves alone). Every call makes new handles on
    /// the same bytes: the caller uses one pair at a time (the update
    /// desk's mutex).
    pub fn partitions() -> (RamFlash, RamFlash) {
        // SAFETY: the desk's mutex holds one pair at a time; the
        // bootloader is not running.
        unsafe { crate::mps2_flash::dfu_and_state() }
    }
}

/// The LAN9118's receive counters (see [`lan9118::nic_counters`]; QEMU's
/// model never counts a dropped frame: its `RX_DROP` reads 0).
pub fn nic_counters() -> Option<crate::NicCounters> {
    Some(lan9118::nic_counters(&Mmio))
}

/// The link as the LAN9118's driver last read it (QEMU's PHY has no
/// speed or duplex to read).
pub fn link() -> crate::LinkInfo {
    lan9118::link()
}

/// `embassy-time` over TIMER0 (free-running) and SysTick (queue ticks).
mod time {
    use super::*;

    const CTRL: usize = TIMER0_BASE;
    const VALUE: usize = TIMER0_BASE + 0x04;
    const RELOAD: usize = TIMER0_BASE + 0x08;
    /// 25 MHz counts per `embassy-time` tick (1 MHz).
    const PER_TICK: u64 = SYSCLK_HZ as u64 / embassy_time_driver::TICK_HZ;
    /// SysTick period: 250 µs (the queue is run this often).
    const SYSTICK_RELOAD: u32 = SYSCLK_HZ / 4_000 - 1;

    struct Driver {
        /// Last raw 32-bit count and the wraps seen so far.
        extend: Mutex<Cell<(u32, u32)>>,
        /// The extended count when the timer started: time is counted
        /// from there, so the uptime starts at zero (issue 42 #8: QEMU's
        /// timer reads 0 before its first reload, which the extension took
        /// for a wrap, and every clock started at 171.8 s).
        epoch: Mutex<Cell<u64>>,
        queue: Mutex<RefCell<Queue>>,
    }

    embassy_time_driver::time_driver_impl!(static DRIVER: Driver = Driver {
        extend: Mutex::new(Cell::new((0, 0))),
        epoch: Mutex::new(Cell::new(NOT_STARTED)),
        queue: Mutex::new(RefCell::new(Queue::new())),
    });

    pub(super) fn start(syst: &mut cortex_m::peripheral::SYST) {
        write32(RELOAD, u32::MAX);
        write32(VALUE, u32::MAX);
        write32(CTRL, 1);
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYSTICK_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        let epoch = raw64();
        cortex_m::interrupt::free(|cs| DRIVER.epoch.borrow(cs).set(epoch));
    }

    /// The epoch before [`start`]: time reads 0 (a log line before the
    /// timer runs is stamped 0, not with whatever the timer reads).
    const NOT_STARTED: u64 = u64::MAX;

    /// Timer counts since [`start`].
    fn since_start() -> u64 {
        let epoch = cortex_m::interrupt::free(|cs| DRIVER.epoch.borrow(cs).get());
        if epoch == NOT_STARTED {
            return 0;
        }
        raw64().wrapping_sub(epoch)
    }

    /// Counts up from 0 (the timer counts down from `u32::MAX`).
    pub(super) fn raw32() -> u32 {
        !read32(VALUE)
    }

    fn raw64() -> u64 {
        cortex_m::interrupt::free(|cs| {
            let cell = DRIVER.extend.borrow(cs);
            let (last, mut wraps) = cell.get();
            let now = raw32();
            if now < last {
                wraps = wraps.wrapping_add(1);
            }
            cell.set((now, wraps));
            u64::from(wraps) << 32 | u64::from(now)
        })
    }

    pub(super) fn on_tick() {
        // Also keeps the 64-bit extension fresh: the 32-bit count wraps
        // every 171 s, SysTick comes every 250 µs.
        let now = since_start() / PER_TICK;
        cortex_m::interrupt::free(|cs| {
            DRIVER.queue.borrow(cs).borrow_mut().next_expiration(now);
        });
    }

    impl embassy_time_driver::Driver for Driver {
        fn now(&self) -> u64 {
            since_start() / PER_TICK
        }

        fn schedule_wake(&self, at: u64, waker: &core::task::Waker) {
            cortex_m::interrupt::free(|cs| {
                // The queue runs every SysTick, so no alarm to re-arm.
                self.queue.borrow(cs).borrow_mut().schedule_wake(at, waker);
            });
        }
    }
}

/// The FPGA's two user LEDs: 0 shows the sensor state, 1 the cycles.
pub struct Leds {
    bits: u32,
}

impl Leds {
    pub fn set(&mut self, led: usize, on: bool) {
        let mask = 1u32 << (led & 1);
        self.bits = if on {
            self.bits | mask
        } else {
            self.bits & !mask
        };
        write32(FPGAIO_LED, self.bits);
    }
}

/// The sensor's inputs. QEMU models no ADC: every sample is simulated
/// (the sensor's `simulate`).
pub type Inputs = crate::io::Simulated;

/// The CMSDK watchdog: not fed for `timeout_ms`, it raises NMI, which
/// resets the board.
pub struct Watchdog;

impl Watchdog {
    const LOAD: usize = WATCHDOG_BASE;
    const CONTROL: usize = WATCHDOG_BASE + 0x08;
    const INTCLR: usize = WATCHDOG_BASE + 0x0c;
    const LOCK: usize = WATCHDOG_BASE + 0xc00;
    const UNLOCK: u32 = 0x1acc_e551;

    pub fn start(&mut self, timeout_ms: u32) {
        write32(Self::LOCK, Self::UNLOCK);
        write32(Self::LOAD, timeout_ms.saturating_mul(SYSCLK_HZ / 1000));
        write32(Self::CONTROL, 0b11); // interrupt (NMI) and reset
        write32(Self::LOCK, 0);
    }

    pub fn feed(&mut self) {
        write32(Self::LOCK, Self::UNLOCK);
        write32(Self::INTCLR, 1); // also reloads the counter
        write32(Self::LOCK, 0);
    }
}

/// Ends the QEMU run with `code` (semihosting `SYS_EXIT_EXTENDED`).
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// After a fault ([`crate::fault`]): a system reset, as on the NUCLEO
/// boards. QEMU restarts the firmware from its image (or exits, with
/// `-no-reboot`); semihosting has already written the log.
pub(crate) fn reset() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Restarts the board on purpose (into the bootloader's swap of an
/// update). The crash record holds no crash, so the next start reports a
/// software reset ([`crate::reset`]).
pub fn restart() -> ! {
    reset()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // A panic while a fault or panic is handled (the logger's own, when
    // that handler logs with the logger held): keep the first record,
    // log nothing, reset (`crate::fault`, `crate::reset::claim`).
    if !crate::reset::claim() {
        reset()
    }
    if let Some(at) = info.location() {
        crate::reset::ram::note(&mut |r| r.panic(at.file(), at.line()));
    }
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(101)
}
