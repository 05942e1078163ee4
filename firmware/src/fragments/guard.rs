//! [`FragmentGuard`]: the [`Reassembler`] in front of any board's
//! `embassy-net-driver` driver, as smoltcp's `phy` wrappers sit in front
//! of a device. It sees every frame the driver hands to the stack; what it
//! hands on is every frame that is not an IPv4 fragment, as it came, and
//! each reassembled datagram as one frame (longer than the MTU: smoltcp
//! takes any length it receives). A fragment it keeps or drops reaches
//! the stack as an empty frame, which smoltcp skips. Sending is the
//! driver's own.
//!
//! What it tells the stack of the driver ([`Driver::capabilities`]) is
//! the driver's, unchanged, on purpose: the MTU is also smoltcp's
//! transmit size and the base of the TCP MSS it advertises, so reporting
//! the reassembled size would make it send frames the link cannot carry
//! and invite peers to send segments that must be reassembled; and the
//! checksum capabilities describe what the NIC checked in a frame. A
//! reassembled datagram is neither: the reassembler checks its UDP
//! checksum itself whatever the driver declares (no NIC can check a
//! payload that came in fragments) and zeroes it, so the stack, which
//! takes 0 as "no checksum", never trusts a check nobody made.
//!
//! It keeps other traffic from between a robot message and its reply
//! ([`super::Hold`]): while the cycle works on a message nothing is sent
//! or taken in (smoltcp would otherwise send the diagnostics' segments,
//! or anyone's, right after taking the message in and in front of the
//! reply), and once the reply is queued nothing is taken in until it has
//! left.
//!
//! It also times every reply at the driver (the diagnostics' reply
//! latency, [`super::Link::latency`]): from the moment it hands the stack
//! a robot message's last frame (a datagram for the channel port, or a
//! TCP segment with data for it) to the moment the driver takes the
//! reply's first frame (from the channel port, with data).
//!
//! In bench builds it counts each frame's instructions per layer (the
//! driver's, its own, smoltcp's: the `probe` module) for `cargo
//! qemu-bench`.
//!
//! It also ends a poll of the network runner after each datagram for the
//! channel port it hands on (and after [`FRAMES_PER_POLL`] frames).
//! smoltcp takes frames until the driver has none left, so under a flood
//! the runner kept the cycle task (on the same executor) from running
//! while the UDP socket's queue filled with flood datagrams and
//! overflowed: robot messages that had reached the device whole were lost
//! there (723 of the 1,178 lost in a `cargo flood` run at ten times the
//! cycle rate). After such a datagram the guard says "nothing now" and
//! wakes the runner again: the executor polls the cycle, which empties
//! the queue, before the runner's next turn, so the queue never holds more
//! than two datagrams for the channel (it has room for `net::QUEUE` of the
//! longest).

use super::probe::{Mark, Probe};
use super::{Channel, Link, Reassembler};
use core::future::Future;
use core::task::Context;
use embassy_net_driver::{Capabilities, Driver, HardwareAddress, LinkState};

fn now_us() -> u64 {
    embassy_time::Instant::now().as_micros()
}

/// A frame was held back ([`Link::may_receive`] / [`Link::may_transmit`]):
/// the runner (whose context `cx` is) is woken when the hold ends at the
/// latest, not only when the cycle ends its turn, which it may never do
/// for this message (see [`Link::hold_until_us`]).
fn wake_at_hold_end(link: &Link, cx: &mut Context) {
    if let Some(until) = link.hold_until_us() {
        let timer = core::pin::pin!(embassy_time::Timer::at(embassy_time::Instant::from_micros(
            until
        )));
        // Pending registers the runner's waker for `until`; Ready: the
        // bound has passed, and the next poll of the runner lifts it.
        if timer.poll(cx).is_ready() {
            cx.waker().wake_by_ref();
        }
    }
}

/// Runs the network runner `runner` (embassy-net's `Runner::run`), passing
/// over every wake-up that comes while the cycle works on a robot message
/// ([`Link::may_run`]): a frame arriving for anyone else, a socket's
/// timer, another task touching its socket. Such a pass would find the
/// guard refusing it both ways, and cost the message's full path what the
/// stack's poll costs (its egress builds any segment due before the
/// driver refuses it). The wake-up is not lost: the cycle's end of turn,
/// or [`HOLD_MAX_US`](super::HOLD_MAX_US) at the latest, wakes the runner,
/// which then does everything that came meanwhile.
pub async fn run_gated<F: Future>(link: &Link, runner: F) -> F::Output {
    let mut runner = core::pin::pin!(runner);
    core::future::poll_fn(|cx| {
        if !link.may_run(now_us, cx.waker()) {
            wake_at_hold_end(link, cx);
            return core::task::Poll::Pending;
        }
        runner.as_mut().poll(cx)
    })
    .await
}

/// Frames handed to the stack per poll of the network runner at most (a
/// poll also ends after a datagram for the channel port): bounds how long
/// a flood of other frames keeps the cycle waiting.
pub const FRAMES_PER_POLL: usize = 16;

/// What this poll of the runner has had.
#[derive(Clone, Copy, Default)]
struct Budget {
    frames: usize,
    to_channel: bool,
}

/// The driver `D` with IPv4 reassembly under S5 in front of it, buffers
/// of `BUF` bytes ([`super::buffer_len`] of the layout's
/// `MAX_RECEIVE_LEN`).
pub struct FragmentGuard<'d, D, const BUF: usize> {
    inner: D,
    parts: Parts<'d, BUF>,
}

/// What the guard adds to the driver; a received frame's token borrows it.
struct Parts<'d, const BUF: usize> {
    reassembler: &'d mut Reassembler<BUF>,
    link: &'d Link,
    channel: Channel,
    budget: Budget,
}

impl<'d, D, const BUF: usize> FragmentGuard<'d, D, BUF> {
    /// Wraps the board's driver `inner`: datagrams to `channel` are put
    /// together in `reassembler`'s buffers (a `static`: they are the
    /// largest buffers of the stack), the controller read from and the
    /// counters published to `link`.
    pub fn new(
        inner: D,
        reassembler: &'d mut Reassembler<BUF>,
        link: &'d Link,
        channel: Channel,
    ) -> Self {
        FragmentGuard {
            inner,
            parts: Parts {
                reassembler,
                link,
                channel,
                budget: Budget::default(),
            },
        }
    }
}

/// A received frame's token: the reassembler decides what the stack sees
/// when the stack consumes it.
pub struct GuardRx<'a, 'd, T, const BUF: usize> {
    inner: T,
    parts: &'a mut Parts<'d, BUF>,
    probe: Probe,
}

impl<T: embassy_net_driver::RxToken, const BUF: usize> embassy_net_driver::RxToken
    for GuardRx<'_, '_, T, BUF>
{
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, f: F) -> R {
        let GuardRx {
            inner,
            parts,
            mut probe,
        } = self;
        probe.mark(Mark::Taken);
        let Parts {
            reassembler,
            link,
            channel,
            budget,
        } = parts;
        let channel = *channel;
        let controller = link.controller();
        let now = now_us();
        let mut tcp = false;
        probe.mark(Mark::Calling);
        let r = inner.consume(|frame| {
            probe.mark(Mark::Opened);
            // A segment for the cycle: from the controller as the cycle
            // knows it, so that data for M10's standby connection (a new
            // port) holds nothing: the cycle does not read it yet.
            tcp = channel_data(frame, channel.port, Side::To)
                .is_some_and(|(ip, port)| controller.sent(ip, port));
            let r = reassembler.pass(frame, now, channel, controller, |frame| {
                probe.smoltcp(frame, f)
            });
            probe.mark(Mark::Closed);
            r
        });
        probe.mark(Mark::After);
        if reassembler.take_changed() {
            link.publish(reassembler.stats());
        }
        budget.frames += 1;
        let to_channel = reassembler.to_channel();
        budget.to_channel |= to_channel;
        if to_channel || tcp {
            link.message_in(now);
            Probe::hold_starts();
        }
        probe.end();
        r
    }
}

impl<'d, D: Driver, const BUF: usize> Driver for FragmentGuard<'d, D, BUF> {
    type RxToken<'a>
        = GuardRx<'a, 'd, D::RxToken<'a>, BUF>
    where
        Self: 'a;
    type TxToken<'a>
        = GuardTx<'a, D::TxToken<'a>>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        let FragmentGuard { inner, parts } = self;
        let link = parts.link;
        // The cycle works on a robot message, or its reply waits to leave:
        // nothing comes in meanwhile (`Link::may_receive`; the cycle wakes
        // us, the egress that sends the reply ends the wait).
        let now = now_us();
        // No timer here: every message the hold is for reaches the cycle,
        // which ends the hold when done with it (a timer per message cost
        // the hostile worst case 1,300 instructions).
        if !link.may_receive(now, cx.waker()) {
            Probe::held(false);
            return None;
        }
        // Stale sets go at every poll, not only when the next fragment
        // comes, so the counters show them.
        parts.reassembler.expire(now);
        if parts.reassembler.take_changed() {
            link.publish(parts.reassembler.stats());
        }
        let budget = &mut parts.budget;
        if budget.to_channel || budget.frames >= FRAMES_PER_POLL {
            // This poll had its share: let the cycle run, then come back.
            *budget = Budget::default();
            cx.waker().wake_by_ref();
            return None;
        }
        let mut probe = Probe::start();
        let Some((rx, tx)) = inner.receive(cx) else {
            *budget = Budget::default();
            return None;
        };
        probe.mark(Mark::Given);
        let port = parts.channel.port;
        Some((
            GuardRx {
                inner: rx,
                parts,
                probe,
            },
            GuardTx {
                inner: tx,
                link,
                port,
            },
        ))
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        let FragmentGuard { inner, parts } = self;
        let link = parts.link;
        // The cycle works on a robot message: nothing leaves in front of
        // its reply (`Link::may_transmit`; the cycle wakes us).
        if link.is_holding() && !link.may_transmit(now_us(), cx.waker()) {
            Probe::held(true);
            wake_at_hold_end(link, cx);
            return None;
        }
        Some(GuardTx {
            inner: inner.transmit(cx)?,
            link,
            port: parts.channel.port,
        })
    }

    fn link_state(&mut self, cx: &mut Context) -> LinkState {
        self.inner.link_state(cx)
    }

    /// The driver's own, unchanged (the module doc says why).
    fn capabilities(&self) -> Capabilities {
        self.inner.capabilities()
    }

    fn hardware_address(&self) -> HardwareAddress {
        self.inner.hardware_address()
    }
}

/// A frame to send: the driver's, and the reply's time when it is one.
pub struct GuardTx<'a, T> {
    inner: T,
    link: &'a Link,
    port: u16,
}

impl<T: embassy_net_driver::TxToken> embassy_net_driver::TxToken for GuardTx<'_, T> {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, len: usize, f: F) -> R {
        let GuardTx { inner, link, port } = self;
        let mut reply = false;
        let r = inner.consume(len, |frame| {
            let r = f(frame);
            reply = channel_data(frame, port, Side::From).is_some();
            if reply {
                link.reply_out(now_us());
            }
            r
        });
        Probe::sent(reply);
        r
    }
}

/// Which port of a segment is the channel's.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    /// The destination: a message coming in (TCP only: UDP datagrams are
    /// the reassembler's to tell).
    To,
    /// The source: a reply going out (UDP or TCP).
    From,
}

/// Whether an Ethernet `frame` carries channel data: IPv4, a first (or
/// only) fragment, TCP with a payload or (`Side::From`) UDP, with the
/// channel `port` on `side`; if so, the other end's address and port.
/// Reads a few header bytes, checked.
fn channel_data(frame: &[u8], port: u16, side: Side) -> Option<([u8; 4], u16)> {
    let be = |i: usize| -> Option<u16> {
        Some(u16::from_be_bytes([*frame.get(i)?, *frame.get(i + 1)?]))
    };
    // The protocol first: on the way in only TCP is ours to tell (the
    // reassembler tells UDP), and every frame in comes through here.
    let tcp = match *frame.get(23)? {
        6 => true,
        17 if side == Side::From => false,
        _ => return None,
    };
    if be(12)? != 0x0800 || be(20)? & 0x1fff != 0 {
        return None;
    }
    let ihl = usize::from(frame.get(14)? & 0x0f) * 4;
    let l4 = 14 + ihl;
    let (src, dst) = (be(l4)?, be(l4 + 2)?);
    let (ours, other, ip_at) = match side {
        Side::To => (dst, src, 26),
        Side::From => (src, dst, 30),
    };
    let data = !tcp || {
        let total = usize::from(be(16)?);
        let header = ihl + usize::from(frame.get(l4 + 12)? >> 4) * 4;
        total > header
    };
    let ip: [u8; 4] = frame.get(ip_at..ip_at + 4)?.try_into().ok()?;
    (data && ours == port).then_some((ip, other))
}
