//! Cycle instrumentation for `cargo qemu-bench` (feature `bench`): per
//! robot message, the counts of
//!
//! - **compute**: the engine's work (peer check, decode, application,
//!   encode), read around `Engine::on_message`;
//! - **full**: from the driver handing the last frame before the message to
//!   the stack, to the driver taking the reply's first frame for the NIC.
//!
//! The counter is the board's free-running cycle counter (under QEMU
//! `-icount` a fixed number of instructions per count). Records go through
//! a channel to a thread-mode task that logs them: nothing here waits or
//! logs on the cycle path.
//!
//! [`Tap`] wraps any `embassy-net-driver` driver to see the frames (as
//! smoltcp's `phy` wrappers do); it only reads the counter.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Context;
use embassy_net_driver::{Capabilities, Driver, HardwareAddress, LinkState};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

/// One robot message as the bench sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Record {
    /// Datagram (or TCP message) length.
    pub bytes: u32,
    /// Answered (`true`) or dropped.
    pub answered: bool,
    /// Counts of the engine's work.
    pub compute: u32,
    /// Counts from frame in to reply frame out; 0 when not answered.
    pub full: u32,
}

/// Records waiting for the logger; when it falls behind, records are
/// counted in [`LOST`] instead of waiting.
pub static RECORDS: Channel<CriticalSectionRawMutex, Record, 64> = Channel::new();
/// Records the logger could not take in time.
pub static LOST: AtomicU32 = AtomicU32::new(0);

static LAST_RX: AtomicU32 = AtomicU32::new(0);
/// Set when an answer is queued: the next frame out completes its record.
static PENDING: AtomicBool = AtomicBool::new(false);
static PENDING_RECORD: critical_section::Mutex<core::cell::Cell<Record>> =
    critical_section::Mutex::new(core::cell::Cell::new(Record {
        bytes: 0,
        answered: false,
        compute: 0,
        full: 0,
    }));

fn push(record: Record) {
    if RECORDS.try_send(record).is_err() {
        LOST.fetch_add(1, Ordering::Relaxed);
    }
}

/// Called by the cycle's monitor after the engine handled a message.
pub fn message(bytes: usize, answered: bool, counts: (u32, u32)) {
    let record = Record {
        bytes: u32::try_from(bytes).unwrap_or(u32::MAX),
        answered,
        compute: counts.1.wrapping_sub(counts.0),
        full: 0,
    };
    if answered {
        critical_section::with(|cs| PENDING_RECORD.borrow(cs).set(record));
        PENDING.store(true, Ordering::Release);
    } else {
        push(record);
    }
}

/// A driver that notes when frames pass, reading `counter`.
pub struct Tap<D> {
    inner: D,
    counter: fn() -> u32,
}

impl<D> Tap<D> {
    pub fn new(inner: D, counter: fn() -> u32) -> Self {
        Tap { inner, counter }
    }
}

pub struct TapRx<T> {
    inner: T,
    counter: fn() -> u32,
}

pub struct TapTx<T> {
    inner: T,
    counter: fn() -> u32,
}

impl<T: embassy_net_driver::RxToken> embassy_net_driver::RxToken for TapRx<T> {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, f: F) -> R {
        LAST_RX.store((self.counter)(), Ordering::Relaxed);
        self.inner.consume(f)
    }
}

impl<T: embassy_net_driver::TxToken> embassy_net_driver::TxToken for TapTx<T> {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, len: usize, f: F) -> R {
        let counter = self.counter;
        let r = self.inner.consume(len, f);
        if PENDING.swap(false, Ordering::AcqRel) {
            let out = counter();
            let mut record = critical_section::with(|cs| PENDING_RECORD.borrow(cs).get());
            record.full = out.wrapping_sub(LAST_RX.load(Ordering::Relaxed));
            push(record);
        }
        r
    }
}

impl<D: Driver> Driver for Tap<D> {
    type RxToken<'a>
        = TapRx<D::RxToken<'a>>
    where
        Self: 'a;
    type TxToken<'a>
        = TapTx<D::TxToken<'a>>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        let counter = self.counter;
        self.inner
            .receive(cx)
            .map(|(rx, tx)| (TapRx { inner: rx, counter }, TapTx { inner: tx, counter }))
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        let counter = self.counter;
        self.inner
            .transmit(cx)
            .map(|inner| TapTx { inner, counter })
    }

    fn link_state(&mut self, cx: &mut Context) -> LinkState {
        self.inner.link_state(cx)
    }

    fn capabilities(&self) -> Capabilities {
        self.inner.capabilities()
    }

    fn hardware_address(&self) -> HardwareAddress {
        self.inner.hardware_address()
    }
}
