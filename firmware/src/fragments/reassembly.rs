//! The reassembler: frames in, whole datagrams out, every byte checked
//! before it is trusted (the header and its checksum, lengths in 8-byte
//! units, overlaps), work bounded by the frame's length, buffers fixed at
//! build time.

use super::coverage::{self, Coverage};
use super::frame::{
    be16, checksum, classify, put16, udp_checksum_ok, udp_ports, Fragment, Frame, BLOCK, ETHERNET,
    IPV4, UDP,
};
use super::{
    Channel, Controller, FragmentDrop, FragmentStats, Rank, SetLoss, HEADERS, SLOTS, TIMEOUT_US,
    UDP_HEADER,
};

/// Blocks a buffer's coverage map records.
pub(super) const MAP_BLOCKS: usize = coverage::BLOCKS;

/// What [`Reassembler::accept`] made of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Not an IPv4 fragment: hand the frame on as it is.
    Pass,
    /// A fragment, kept in its set's buffer: nothing to hand on yet.
    Held,
    /// A fragment, dropped (counted).
    Dropped(FragmentDrop),
    /// The fragment completed its set: the first `len` bytes of buffer
    /// `slot` are the whole datagram, Ethernet header first
    /// ([`Reassembler::datagram`]). The buffer is free again: read it
    /// before the next frame.
    Complete {
        /// The buffer.
        slot: usize,
        /// Bytes of the datagram with its headers.
        len: usize,
    },
}

/// One set being put together, in a buffer of `BUF` bytes. All zeros is
/// a free slot (so a `static` of them costs no flash).
struct Slot<const BUF: usize> {
    busy: bool,
    rank: Rank,
    src: [u8; 4],
    ident: u16,
    started_us: u64,
    /// When its last fragment came: among sets of one rank, the least
    /// recently used gives its buffer up first.
    last_us: u64,
    /// IP payload bytes of the whole datagram; 0 until the last fragment
    /// (the one without "more fragments") came.
    total: usize,
    /// The furthest byte any fragment reached.
    end: usize,
    /// Blocks received, and which.
    blocks: usize,
    map: Coverage,
    fragments: u16,
    /// Ethernet header, IPv4 header (20 bytes), IP payload.
    buf: Aligned<BUF>,
}

/// A slot's bytes, on a 4-byte boundary as every driver's frame buffer
/// is, so each fragment's payload lands two bytes past a boundary as it
/// sat in its frame, and so does the datagram's UDP payload, where the
/// socket buffers that smoltcp copies it into start (`net::AsInFrame`).
/// `memcpy` with both ends aligned alike costs a third of a copy whose
/// ends are not (Thumb-2: 3,855 against 12,540 instructions for 3,557
/// bytes, `cargo qemu-bench`).
#[repr(C, align(4))]
struct Aligned<const N: usize>([u8; N]);

impl<const BUF: usize> Slot<BUF> {
    const FREE: Self = Slot {
        busy: false,
        rank: Rank::Stranger,
        src: [0; 4],
        ident: 0,
        started_us: 0,
        last_us: 0,
        total: 0,
        end: 0,
        blocks: 0,
        map: Coverage::EMPTY,
        fragments: 0,
        buf: Aligned([0; BUF]),
    };

    /// The frame's bytes.
    fn frame(&self) -> &[u8] {
        &self.buf.0
    }

    fn frame_mut(&mut self) -> &mut [u8] {
        &mut self.buf.0
    }

    fn start(&mut self, src: [u8; 4], ident: u16, rank: Rank, now_us: u64) {
        self.busy = true;
        self.rank = rank;
        self.src = src;
        self.ident = ident;
        self.started_us = now_us;
        self.last_us = now_us;
        self.total = 0;
        self.end = 0;
        self.blocks = 0;
        self.map = Coverage::EMPTY;
        self.fragments = 0;
    }

    fn holds(&self, src: [u8; 4], ident: u16) -> bool {
        self.busy && self.src == src && self.ident == ident
    }

    /// Adds fragment `f` (of `frame`) at `now_us`. [`Add::Conflict`] when
    /// it overlaps what is there with other bytes, or contradicts the
    /// datagram's end (the caller spoils the set); [`Add::Duplicate`]
    /// when every byte of it is there already, the same (a copy of a
    /// frame: port mirroring, a layer-2 loop), which changes nothing.
    fn add(&mut self, f: &Fragment<'_>, frame: &[u8], now_us: u64) -> Add {
        let end = f.offset + f.payload.len();
        let (first, last) = (f.offset / BLOCK, end.div_ceil(BLOCK));
        let Some(present) = self.map.held(first, last) else {
            return Add::Conflict;
        };
        if present > 0 {
            return if present == last - first && self.same(f, end) {
                Add::Duplicate
            } else {
                Add::Conflict
            };
        }
        if f.more {
            if self.total != 0 && end > self.total {
                return Add::Conflict;
            }
        } else {
            if (self.total != 0 && self.total != end) || self.end > end {
                return Add::Conflict;
            }
            self.total = end;
        }
        let Some(dst) = self.frame_mut().get_mut(HEADERS + f.offset..HEADERS + end) else {
            return Add::Conflict;
        };
        dst.copy_from_slice(f.payload);
        self.map.mark(first, last);
        self.blocks += last - first;
        self.end = self.end.max(end);
        // The headers of the first fragment to come, then of the first
        // fragment itself: the addresses are the same in every one.
        if self.fragments == 0 || f.offset == 0 {
            if let (Some(to), Some(from)) =
                (self.frame_mut().get_mut(..HEADERS), frame.get(..HEADERS))
            {
                to.copy_from_slice(from);
            }
        }
        self.fragments = self.fragments.saturating_add(1);
        self.last_us = now_us;
        Add::Added
    }

    /// Whether fragment `f`, ending at `end`, whose blocks are all there,
    /// is what is there: the same bytes and the same end of the datagram
    /// (its last fragment again, or one in front of it).
    fn same(&self, f: &Fragment<'_>, end: usize) -> bool {
        let same_end = if f.more {
            self.total == 0 || end <= self.total
        } else {
            self.total == end
        };
        same_end
            && self
                .frame()
                .get(HEADERS + f.offset..HEADERS + end)
                .is_some_and(|held| held == f.payload)
    }

    fn complete(&self) -> bool {
        self.total != 0 && self.blocks == self.total.div_ceil(BLOCK)
    }

    /// Writes the whole datagram's IPv4 header (no options, not a
    /// fragment, its length, a fresh checksum); its length with headers.
    fn finish(&mut self) -> usize {
        let len = IPV4 + self.total;
        if let Some(h) = self.frame_mut().get_mut(ETHERNET..HEADERS) {
            if let Some(v) = h.get_mut(0) {
                *v = 0x45;
            }
            put16(h, 2, u16::try_from(len).unwrap_or(u16::MAX));
            put16(h, 6, 0);
            put16(h, 10, 0);
            let sum = checksum(h);
            put16(h, 10, sum);
        }
        ETHERNET + len
    }
}

impl<const BUF: usize> Slot<BUF> {
    /// After [`Slot::finish`]: whether the whole datagram's UDP length
    /// and checksum are right (or the checksum absent). A right one is
    /// then zeroed: checked once, here, the stack need not check it again
    /// (smoltcp, as RFC 768 says, takes 0 as "no checksum"), so the
    /// guard's check costs the cycle nothing over the stack's own.
    fn udp_checked(&mut self) -> bool {
        let ok = self
            .frame()
            .get(ETHERNET..HEADERS + self.total)
            .is_some_and(udp_checksum_ok);
        if ok {
            put16(self.frame_mut(), HEADERS + 6, 0);
        }
        ok
    }
}

/// What [`Slot::add`] made of a fragment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Add {
    Added,
    /// Every byte of it was there already, the same.
    Duplicate,
    /// It overlaps other bytes, or contradicts the datagram's end.
    Conflict,
}

/// IPv4 reassembly under S5 (see the [module](super)), in [`SLOTS`]
/// buffers of `BUF` bytes each ([`super::buffer_len`] of the layout's
/// `MAX_RECEIVE_LEN`). All zeros when new, so a `static` costs no flash.
pub struct Reassembler<const BUF: usize> {
    slots: [Slot<BUF>; SLOTS],
    stats: FragmentStats,
    changed: bool,
    /// The last frame handed on was a UDP datagram to the channel port.
    to_channel: bool,
}

impl<const BUF: usize> Default for Reassembler<BUF> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const BUF: usize> Reassembler<BUF> {
    /// Every buffer free, every counter at zero. Does not compile when a
    /// buffer cannot hold the headers and a UDP header, or holds more than
    /// the coverage map can record ([`super::MAX_PAYLOAD`]).
    pub const fn new() -> Self {
        const {
            assert!(
                BUF >= HEADERS + UDP_HEADER,
                "a reassembly buffer must hold the headers"
            );
            assert!(
                BUF - HEADERS <= MAP_BLOCKS * BLOCK,
                "the layout's MAX_RECEIVE_LEN is past what a reassembly buffer can record (fragments::MAX_PAYLOAD)"
            );
        }
        Reassembler {
            slots: [const { Slot::FREE }; SLOTS],
            stats: FragmentStats::ZERO,
            changed: false,
            to_channel: false,
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> FragmentStats {
        self.stats
    }

    /// Whether the counters changed since the last call (the guard
    /// publishes them only then).
    pub fn take_changed(&mut self) -> bool {
        core::mem::take(&mut self.changed)
    }

    /// Whether the last frame [`Reassembler::accept`] took handed the
    /// stack a UDP datagram for the channel port (whole or reassembled):
    /// one the cycle will have to take from its socket.
    pub fn to_channel(&self) -> bool {
        self.to_channel
    }

    /// Sets holding a buffer now.
    pub fn held(&self) -> usize {
        self.slots.iter().filter(|s| s.busy).count()
    }

    fn lose(&mut self, slot: usize, reason: SetLoss) {
        if let Some(s) = self.slots.get_mut(slot) {
            if s.busy {
                s.busy = false;
                self.stats.count_loss(reason, s.rank);
                self.changed = true;
            }
        }
    }

    fn drop_fragment(&mut self, reason: FragmentDrop, spoils: Option<usize>) -> Verdict {
        if let Some(slot) = spoils {
            // A set shown to be oversize or for another port was never a
            // robot message: given up, not the controller's loss.
            let robot_message = matches!(reason, FragmentDrop::Malformed);
            if let (false, Some(s)) = (robot_message, self.slots.get_mut(slot)) {
                s.rank = s.rank.min(Rank::Likely);
            }
            self.lose(slot, SetLoss::Spoiled);
        }
        self.stats.count_drop(reason);
        self.changed = true;
        Verdict::Dropped(reason)
    }

    /// Gives up every set still incomplete [`TIMEOUT_US`] after its first
    /// fragment.
    pub fn expire(&mut self, now_us: u64) {
        for i in 0..SLOTS {
            let stale = self
                .slots
                .get(i)
                .is_some_and(|s| s.busy && now_us.saturating_sub(s.started_us) >= TIMEOUT_US);
            if stale {
                self.lose(i, SetLoss::TimedOut);
            }
        }
    }

    /// A buffer for a new set of rank `rank`: a free one, else that of
    /// the lowest-ranked set at or below `rank`, the least recently used
    /// among equals. So no sender holds buffers against the controller's
    /// reordered messages (their fragments come back to back: a set
    /// that a fragment refreshes every few ms is older than theirs), and
    /// the controller's newest message supersedes its own stalest set.
    fn allocate(&mut self, rank: Rank) -> Option<usize> {
        if let Some(free) = self.slots.iter().position(|s| !s.busy) {
            return Some(free);
        }
        let (victim, victim_rank) = self
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.rank <= rank)
            .min_by_key(|(_, s)| (s.rank, s.last_us))
            .map(|(i, s)| (i, s.rank))?;
        let reason = if victim_rank == Rank::Controller {
            SetLoss::Superseded
        } else {
            SetLoss::Evicted
        };
        self.lose(victim, reason);
        Some(victim)
    }

    /// Takes one frame at `now_us` (µs, any monotonic clock). Frames that
    /// are not IPv4 fragments pass (the controller's datagrams to the
    /// channel port among them are counted); fragments are checked, kept
    /// or dropped, and the one that completes its set gives the whole
    /// datagram.
    pub fn accept(
        &mut self,
        frame: &[u8],
        now_us: u64,
        channel: Channel,
        controller: Controller,
    ) -> Verdict {
        self.to_channel = false;
        let f = match classify(frame) {
            Frame::Whole => {
                if let Some((src, sport, dport)) = udp_ports(frame, channel.device) {
                    self.to_channel = dport == channel.port;
                    if self.to_channel && controller.sent(src, sport) {
                        self.stats.controller_datagrams =
                            self.stats.controller_datagrams.saturating_add(1);
                        self.changed = true;
                    }
                }
                return Verdict::Pass;
            }
            Frame::Broken => {
                self.stats.fragments = self.stats.fragments.saturating_add(1);
                return self.drop_fragment(FragmentDrop::Malformed, None);
            }
            Frame::Fragment(f) => f,
        };
        self.stats.fragments = self.stats.fragments.saturating_add(1);
        self.changed = true;
        self.expire(now_us);
        // A set is one (source, destination, protocol, ID) (RFC 791): only
        // UDP to the device is ever kept, so a fragment for another
        // protocol or address is no part of any held set, whatever its ID.
        if f.dst != channel.device || f.protocol != UDP {
            return self.drop_fragment(FragmentDrop::Unwanted, None);
        }
        let held = self.slots.iter().position(|s| s.holds(f.src, f.ident));
        if f.offset + f.payload.len() > BUF - HEADERS {
            return self.drop_fragment(FragmentDrop::Oversize, held);
        }
        let rank = if f.offset == 0 {
            // The first fragment carries the UDP header (at least 8 bytes:
            // its length is a multiple of 8 in front of more fragments).
            let (Some(sport), Some(dport)) = (be16(f.payload, 0), be16(f.payload, 2)) else {
                return self.drop_fragment(FragmentDrop::Malformed, held);
            };
            if dport != channel.port {
                return self.drop_fragment(FragmentDrop::Unwanted, held);
            }
            if controller.sent(f.src, sport) {
                Rank::Controller
            } else if controller.from_address(f.src) {
                Rank::Likely
            } else {
                Rank::Stranger
            }
        } else if controller.from_address(f.src) {
            Rank::Likely
        } else {
            Rank::Stranger
        };
        let slot = match held {
            Some(i) => {
                if let (Some(s), 0) = (self.slots.get_mut(i), f.offset) {
                    s.rank = rank;
                }
                i
            }
            None => match self.allocate(rank) {
                Some(i) => {
                    if let Some(s) = self.slots.get_mut(i) {
                        s.start(f.src, f.ident, rank, now_us);
                    }
                    i
                }
                None => {
                    if rank == Rank::Controller {
                        self.stats.controller_dropped =
                            self.stats.controller_dropped.saturating_add(1);
                    }
                    return self.drop_fragment(FragmentDrop::NoBuffer, None);
                }
            },
        };
        let Some(s) = self.slots.get_mut(slot) else {
            return self.drop_fragment(FragmentDrop::NoBuffer, None);
        };
        match s.add(&f, frame, now_us) {
            Add::Added => {}
            // A copy changes nothing: dropped alone, the set goes on.
            Add::Duplicate => return self.drop_fragment(FragmentDrop::Duplicate, None),
            Add::Conflict => return self.drop_fragment(FragmentDrop::Malformed, Some(slot)),
        }
        if !s.complete() {
            return Verdict::Held;
        }
        let len = s.finish();
        if !s.udp_checked() {
            // Whole, but its UDP checksum (or length) is wrong: no NIC
            // could have checked it, whatever the driver declares. The
            // set is spoiled: the controller's loss when it was theirs.
            return self.drop_fragment(FragmentDrop::Malformed, Some(slot));
        }
        // Free again: the datagram stays in the buffer until the next
        // fragment, and the caller hands it on before that.
        s.busy = false;
        let rank = s.rank;
        self.stats.reassembled = self.stats.reassembled.saturating_add(1);
        self.to_channel = true;
        if rank == Rank::Controller {
            self.stats.controller_datagrams = self.stats.controller_datagrams.saturating_add(1);
        }
        Verdict::Complete { slot, len }
    }

    /// [`Reassembler::accept`], then `f` gets what the stack should see:
    /// the frame itself, the whole datagram of a completed set, or nothing (an empty frame, which smoltcp
    /// skips) for a fragment kept or dropped.
    pub fn pass<R>(
        &mut self,
        frame: &mut [u8],
        now_us: u64,
        channel: Channel,
        controller: Controller,
        f: impl FnOnce(&mut [u8]) -> R,
    ) -> R {
        match self.accept(frame, now_us, channel, controller) {
            Verdict::Pass => f(frame),
            Verdict::Complete { slot, len } => {
                match self
                    .slots
                    .get_mut(slot)
                    .and_then(|s| s.frame_mut().get_mut(..len))
                {
                    Some(datagram) => f(datagram),
                    None => f(&mut []),
                }
            }
            Verdict::Held | Verdict::Dropped(_) => f(&mut []),
        }
    }

    /// The datagram a [`Verdict::Complete`] named (for callers of
    /// [`Reassembler::accept`]); valid until the next frame.
    pub fn datagram(&self, slot: usize, len: usize) -> Option<&[u8]> {
        self.slots.get(slot)?.frame().get(..len)
    }
}
