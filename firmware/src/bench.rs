//! Cycle instrumentation for `cargo qemu-bench` (feature `bench`): per
//! robot message, the counts of
//!
//! - **compute**: the engine's work (peer check, decode, application,
//!   encode), read around `Engine::on_message`;
//! - **full**: from the moment the stack takes the frame that completes
//!   the message (its last fragment, or its only frame) from the fragment
//!   guard, to the moment the driver has taken the reply's first frame
//!   for the NIC;
//! - **where the frames in went**, per layer: for the frame that starts
//!   the full span, reading it from the NIC (before the span), then the
//!   driver's share (handing it over, taking it back), the guard's (checks,
//!   reassembly, the reassembled datagram's UDP checksum, its counters)
//!   and smoltcp's (the frame handed to the stack, up to the socket's
//!   queue); and every other frame taken in since the last message (the
//!   earlier fragments) as one figure, outside the full span. The probe's
//!   own counter reads (eight a frame) fall into these shares.
//!
//! The counter is the board's free-running cycle counter (under QEMU
//! `-icount` a fixed number of instructions per count), registered once
//! with [`count_with`]. The guard reads it through a `Probe` around each
//! frame (in other builds its probe is an empty type: nothing is read).
//! Records go through a channel to a thread-mode task that logs them:
//! nothing here waits or logs on the cycle path.

use crate::fragments::probe::{Mark, MARKS};
use core::cell::Cell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use critical_section::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

pub use crate::bench_line::Record;

/// Records waiting for the logger; when it falls behind, records are
/// counted in [`LOST`] instead of waiting.
pub static RECORDS: Channel<CriticalSectionRawMutex, Record, 64> = Channel::new();
/// Records the logger could not take in time.
pub static LOST: AtomicU32 = AtomicU32::new(0);

fn no_counter() -> u32 {
    0
}

static COUNTER: Mutex<Cell<fn() -> u32>> = Mutex::new(Cell::new(no_counter));

/// Registers the counter the bench measures with (the board's
/// `cycle_counter`); until then every count is 0.
pub fn count_with(counter: fn() -> u32) {
    critical_section::with(|cs| COUNTER.borrow(cs).set(counter));
}

fn counter() -> fn() -> u32 {
    critical_section::with(|cs| COUNTER.borrow(cs).get())
}

/// One frame's counts, per layer.
#[derive(Clone, Copy, Default)]
struct Layers {
    /// Before its token is consumed: the driver reading the frame from
    /// the NIC, smoltcp taking the token.
    read: u32,
    driver: u32,
    guard: u32,
    smoltcp: u32,
}

impl Layers {
    fn total(&self) -> u32 {
        self.read
            .wrapping_add(self.driver)
            .wrapping_add(self.guard)
            .wrapping_add(self.smoltcp)
    }
}

/// The frames taken in since the last message: the newest that handed the
/// stack a UDP datagram (with when its frame came and the datagram's
/// source port), and the sum of all the others.
#[derive(Clone, Copy, Default)]
struct FramesIn {
    frames: u32,
    datagram: Option<(Layers, u32, u16)>,
    before: u32,
}

static FRAMES_IN: Mutex<Cell<FramesIn>> = Mutex::new(Cell::new(FramesIn {
    frames: 0,
    datagram: None,
    before: 0,
}));

/// The UDP source port of a whole IPv4 datagram in an Ethernet frame.
fn udp_source_port(frame: &[u8]) -> Option<u16> {
    let be = |i: usize| -> Option<u16> {
        Some(u16::from_be_bytes([*frame.get(i)?, *frame.get(i + 1)?]))
    };
    let whole = be(12)? == 0x0800 && be(20)? & 0x3fff == 0 && *frame.get(23)? == 17;
    let ihl = usize::from(frame.get(14)? & 0x0f) * 4;
    if whole {
        be(14 + ihl)
    } else {
        None
    }
}

/// The counts around one frame the fragment guard takes in: from the
/// guard asking the driver for a frame, at each [`Mark`], and how long
/// smoltcp had it.
pub(crate) struct Probe {
    counter: fn() -> u32,
    start: u32,
    at: [u32; MARKS],
    smoltcp: u32,
    src_port: Option<u16>,
}

impl Probe {
    /// The guard asks the driver for a frame.
    pub(crate) fn start() -> Probe {
        let counter = counter();
        let start = counter();
        Probe {
            counter,
            start,
            at: [start; MARKS],
            smoltcp: 0,
            src_port: None,
        }
    }

    /// The frame has reached `at`.
    pub(crate) fn mark(&mut self, at: Mark) {
        if let Some(slot) = self.at.get_mut(at as usize) {
            *slot = (self.counter)();
        }
    }

    /// The stack takes `frame` (`f`): timed, and its UDP source port noted
    /// when it is a whole datagram.
    pub(crate) fn smoltcp<R>(&mut self, frame: &mut [u8], f: impl FnOnce(&mut [u8]) -> R) -> R {
        self.src_port = udp_source_port(frame);
        let at = (self.counter)();
        let r = f(frame);
        self.smoltcp = self.smoltcp.wrapping_add((self.counter)().wrapping_sub(at));
        r
    }

    /// When the stack consumed the frame's token: the span of a message
    /// this frame completes starts here.
    fn taken(&self) -> u32 {
        self.at
            .get(Mark::Taken as usize)
            .copied()
            .unwrap_or(self.start)
    }

    /// This frame's counts per layer, the guard done with it at `end`.
    fn layers(&self, end: u32) -> Layers {
        let at = |m: Mark| self.at.get(m as usize).copied().unwrap_or(self.start);
        let span = |from: u32, to: u32| to.wrapping_sub(from);
        Layers {
            read: span(self.start, at(Mark::Taken)),
            driver: span(at(Mark::Calling), at(Mark::Opened))
                .wrapping_add(span(at(Mark::Closed), at(Mark::After))),
            guard: span(at(Mark::Taken), at(Mark::Calling))
                .wrapping_add(span(at(Mark::Opened), at(Mark::Closed)).wrapping_sub(self.smoltcp))
                .wrapping_add(span(at(Mark::After), end)),
            smoltcp: self.smoltcp,
        }
    }

    /// The guard is done with the frame: its layers are noted for the next
    /// message's record.
    pub(crate) fn end(self) {
        let layers = self.layers((self.counter)());
        critical_section::with(|cs| {
            let cell = FRAMES_IN.borrow(cs);
            let mut seen = cell.get();
            seen.frames = seen.frames.wrapping_add(1);
            let other = match self.src_port {
                Some(port) => seen
                    .datagram
                    .replace((layers, self.taken(), port))
                    .map(|(l, _, _)| l),
                None => Some(layers),
            };
            seen.before = seen.before.wrapping_add(other.map_or(0, |l| l.total()));
            cell.set(seen);
        });
    }

    /// The driver took a frame to send; `reply`: the first frame of a reply
    /// from the channel port. Completes the pending record.
    pub(crate) fn sent(reply: bool) {
        if reply && PENDING.swap(false, Ordering::AcqRel) {
            let out = counter()();
            let (mut record, rx) = critical_section::with(|cs| PENDING_RECORD.borrow(cs).get());
            record.full = out.wrapping_sub(rx);
            record.held_in = HELD_IN.load(Ordering::Relaxed);
            record.held_out = HELD_OUT.load(Ordering::Relaxed);
            push(record);
        }
    }

    /// The guard: a robot message is in, its hold starts (the counts of
    /// what the hold turns away start again).
    pub(crate) fn hold_starts() {
        HELD_IN.store(0, Ordering::Relaxed);
        HELD_OUT.store(0, Ordering::Relaxed);
    }

    /// The guard's hold turned the runner away: from taking a frame in
    /// (`out` false), or from sending one.
    pub(crate) fn held(out: bool) {
        let count = if out { &HELD_OUT } else { &HELD_IN };
        count.fetch_add(1, Ordering::Relaxed);
    }
}

/// What the hold of the message in the works turned away: the runner's
/// ingress, its frames out ([`Record::held_in`], [`Record::held_out`]).
static HELD_IN: AtomicU32 = AtomicU32::new(0);
static HELD_OUT: AtomicU32 = AtomicU32::new(0);

/// Set when an answer is queued: the reply's first frame out completes its
/// record.
static PENDING: AtomicBool = AtomicBool::new(false);
static PENDING_RECORD: Mutex<Cell<(Record, u32)>> = Mutex::new(Cell::new((
    Record {
        bytes: 0,
        answered: false,
        compute: 0,
        full: 0,
        frames: 0,
        read: 0,
        driver: 0,
        guard: 0,
        smoltcp: 0,
        before: 0,
        held_in: 0,
        held_out: 0,
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
    let seen = critical_section::with(|cs| FRAMES_IN.borrow(cs).replace(FramesIn::default()));
    // The span starts at the datagram's frame when it came from the port
    // answered.
    let (layers, rx) = match seen.datagram {
        Some((layers, rx, port)) => (layers, (Some(port) == answered_to).then_some(rx)),
        None => (Layers::default(), None),
    };
    let record = Record {
        bytes: u32::try_from(bytes).unwrap_or(u32::MAX),
        answered: answered_to.is_some(),
        compute: counts.1.wrapping_sub(counts.0),
        full: 0,
        frames: seen.frames,
        read: layers.read,
        driver: layers.driver,
        guard: layers.guard,
        smoltcp: layers.smoltcp,
        before: seen.before,
        held_in: 0,
        held_out: 0,
    };
    match rx {
        Some(rx) => {
            critical_section::with(|cs| PENDING_RECORD.borrow(cs).set((record, rx)));
            PENDING.store(true, Ordering::Release);
        }
        None => push(record),
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

/// Bytes [`copy_cost`] copies: the longest robot message.
pub const COPY_LEN: usize = 3557;

/// Two buffers on 4-byte boundaries, a whole number of words long, so an
/// offset into either is its alignment.
#[repr(C, align(4))]
struct CopyBuffers([u8; COPY_LEN + 11], [u8; COPY_LEN + 11]);

static COPY_BUFFERS: Mutex<core::cell::RefCell<CopyBuffers>> = Mutex::new(
    core::cell::RefCell::new(CopyBuffers([0; COPY_LEN + 11], [0; COPY_LEN + 11])),
);

/// Counts of copying [`COPY_LEN`] bytes (`copy_from_slice`: the `memcpy`
/// every layer uses) from `from` bytes past a 4-byte boundary to `to`
/// bytes past one, per copy: `memcpy`'s cost depends on whether the two
/// ends are aligned alike. Start-up only: interrupts are masked
/// throughout.
pub fn copy_cost(from: usize, to: usize, counter: fn() -> u32) -> u32 {
    use core::hint::black_box;
    const ROUNDS: u32 = 8;
    critical_section::with(|cs| {
        let mut buffers = COPY_BUFFERS.borrow_ref_mut(cs);
        let CopyBuffers(src, dst) = &mut *buffers;
        let (Some(src), Some(dst)) = (
            src.get(from % 4..from % 4 + COPY_LEN),
            dst.get_mut(to % 4..to % 4 + COPY_LEN),
        ) else {
            return 0;
        };
        let start = counter();
        for _ in 0..ROUNDS {
            black_box(&mut *dst).copy_from_slice(black_box(src));
        }
        counter().wrapping_sub(start) / ROUNDS
    })
}
