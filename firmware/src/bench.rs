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

/// The last frames the driver handed to the stack: when, the IPv4
/// identification, and the UDP source port (0 for a non-first fragment or
/// anything not UDP). A message's "frame in" is the newest frame of the
/// newest datagram from its sender: its last fragment.
#[derive(Clone, Copy, Default)]
struct Seen {
    tick: u32,
    ident: u16,
    src_port: u16,
}

const SEEN: usize = 16;
static RX_SEEN: critical_section::Mutex<core::cell::RefCell<([Seen; SEEN], usize)>> =
    critical_section::Mutex::new(core::cell::RefCell::new((
        [Seen {
            tick: 0,
            ident: 0,
            src_port: 0,
        }; SEEN],
        0,
    )));

/// IPv4 identification and UDP source port of an Ethernet frame.
fn ipv4_udp(frame: &[u8]) -> Option<(u16, u16)> {
    let be = |i: usize| -> Option<u16> {
        Some(u16::from_be_bytes([*frame.get(i)?, *frame.get(i + 1)?]))
    };
    if be(12)? != 0x0800 {
        return None;
    }
    let ihl = usize::from(frame.get(14)? & 0x0f) * 4;
    let ident = be(18)?;
    let first_fragment = be(20)? & 0x1fff == 0;
    let udp = *frame.get(23)? == 17;
    let src_port = if udp && first_fragment {
        be(14 + ihl)?
    } else {
        0
    };
    Some((ident, src_port))
}

fn note_rx(frame: &[u8], tick: u32) {
    let Some((ident, src_port)) = ipv4_udp(frame) else {
        return;
    };
    critical_section::with(|cs| {
        let mut seen = RX_SEEN.borrow_ref_mut(cs);
        let (ring, next) = &mut *seen;
        if let Some(slot) = ring.get_mut(*next % SEEN) {
            *slot = Seen {
                tick,
                ident,
                src_port,
            };
        }
        *next = next.wrapping_add(1);
    });
}

/// When the last frame of the newest datagram from `src_port` came in.
fn rx_tick_of(src_port: u16) -> Option<u32> {
    critical_section::with(|cs| {
        let seen = RX_SEEN.borrow_ref(cs);
        let (ring, next) = &*seen;
        let newest = |f: &dyn Fn(&Seen) -> bool| {
            (1..=SEEN)
                .filter_map(|back| ring.get(next.wrapping_sub(back) % SEEN))
                .find(|s| f(s))
                .copied()
        };
        let first = newest(&|s| s.src_port == src_port)?;
        newest(&|s| s.ident == first.ident).map(|s| s.tick)
    })
}

/// Set when an answer is queued: the next frame out completes its record.
static PENDING: AtomicBool = AtomicBool::new(false);
static PENDING_RECORD: critical_section::Mutex<core::cell::Cell<(Record, u32)>> =
    critical_section::Mutex::new(core::cell::Cell::new((
        Record {
            bytes: 0,
            answered: false,
            compute: 0,
            full: 0,
        },
        0,
    )));

fn push(record: Record) {
    if RECORDS.try_send(record).is_err() {
        LOST.fetch_add(1, Ordering::Relaxed);
    }
}

/// Called by the cycle's monitor after the engine handled a message;
/// `answered_to`: the port the reply goes to.
pub fn message(bytes: usize, answered_to: Option<u16>, counts: (u32, u32)) {
    let record = Record {
        bytes: u32::try_from(bytes).unwrap_or(u32::MAX),
        answered: answered_to.is_some(),
        compute: counts.1.wrapping_sub(counts.0),
        full: 0,
    };
    match answered_to.and_then(rx_tick_of) {
        Some(rx) => {
            critical_section::with(|cs| PENDING_RECORD.borrow(cs).set((record, rx)));
            PENDING.store(true, Ordering::Release);
        }
        None => push(record),
    }
}

/// A driver that notes when frames pass, reading `counter`.
pub struct Tap<D> {
    inner: D,
    counter: fn() -> u32,
}

impl<D> Tap<D> {
    /// Wraps the board's driver `inner`; `counter` reads the instruction
    /// counter the bench measures with.
    pub fn new(inner: D, counter: fn() -> u32) -> Self {
        Tap { inner, counter }
    }
}

/// A received frame's token that notes the counter when the stack
/// consumes it (the start of a cycle's measured span).
pub struct TapRx<T> {
    inner: T,
    counter: fn() -> u32,
}

/// A frame to send whose token notes the counter when the reply leaves
/// (the end of a cycle's measured span).
pub struct TapTx<T> {
    inner: T,
    counter: fn() -> u32,
}

impl<T: embassy_net_driver::RxToken> embassy_net_driver::RxToken for TapRx<T> {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, f: F) -> R {
        let tick = (self.counter)();
        self.inner.consume(|frame| {
            note_rx(frame, tick);
            f(frame)
        })
    }
}

impl<T: embassy_net_driver::TxToken> embassy_net_driver::TxToken for TapTx<T> {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, len: usize, f: F) -> R {
        let counter = self.counter;
        let r = self.inner.consume(len, f);
        if PENDING.swap(false, Ordering::AcqRel) {
            let out = counter();
            let (mut record, rx) = critical_section::with(|cs| PENDING_RECORD.borrow(cs).get());
            record.full = out.wrapping_sub(rx);
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

/// The manual's robot message (whitespace between elements removed) and the
/// maximum-value message: the corpus of the in-guest codec comparison.
pub const CODEC_CORPUS: [(&str, &[u8]); 2] = [
    (
        "manual",
        include_bytes!("../../host-tests/bench/RobData-compact.xml"),
    ),
    (
        "max",
        include_bytes!("../../host-tests/bench/RobData-max.xml"),
    ),
];

/// One message's counts in the codec comparison, per message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct Comparison {
    /// Our decode + encode (0 when the layout cannot decode the message).
    pub ours: u32,
    /// xmlparser tokenizing the message and nothing else.
    pub tokenizer: u32,
    /// The naive baseline (xmlparser + `core::fmt`), 0 when it fails.
    pub baseline: u32,
}

/// Runs our codec, the tokenizer alone and the naive baseline `rounds`
/// times over `message` with interrupts masked, and returns the counts per
/// message. Start-up only: this holds a critical section for milliseconds.
pub fn compare_codecs(message: &[u8], rounds: u32, counter: fn() -> u32) -> Comparison {
    use crate::codec::{decode, encode};
    use crate::layout;
    use crate::value::Time;
    use core::hint::black_box;
    let rounds = rounds.max(1);
    let measure = |f: &mut dyn FnMut() -> bool| -> u32 {
        critical_section::with(|_| {
            let start = counter();
            for _ in 0..rounds {
                if !f() {
                    return 0;
                }
            }
            counter().wrapping_sub(start) / rounds
        })
    };
    let mut robot = <layout::RobotMessage as crate::schema::Message>::Data::default();
    let reply = <layout::ReplyMessage as crate::schema::Message>::Data::default();
    let mut buf = [0u8; layout::MAX_SEND_LEN];
    let ours = measure(&mut || {
        let Ok(d) = decode::<layout::RobotMessage>(black_box(message), &mut robot) else {
            return false;
        };
        let ts = d.ts.unwrap_or(Time::ZERO);
        encode::<layout::ReplyMessage>(&reply, d.id, ts, layout::FORMAT, &mut buf)
            .map(|e| black_box(e.len))
            .is_ok()
    });
    let text = core::str::from_utf8(message).unwrap_or("");
    let tokenizer = measure(&mut || crate::baseline::tokenize(black_box(text)).is_some());
    let mut naive = crate::baseline::Naive::default();
    let mut out = heapless::String::<2048>::new();
    let baseline =
        measure(&mut || crate::baseline::cycle(black_box(text), &mut naive, &mut out).is_some());
    Comparison {
        ours,
        tokenizer,
        baseline,
    }
}
