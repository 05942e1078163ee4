//! The reassembler: frames in, whole datagrams out, every byte checked
//! before it is trusted (the header and its checksum, lengths in 8-byte
//! units, overlaps), work bounded by the frame's length, buffers fixed at
//! build time.

use super::coverage;
use super::frame::{be16, classify, udp_ports, Frame, BLOCK, UDP};
use super::slot::{Add, Slot};
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
