//! IPv4 fragments under S5: nothing another sender does may stop the
//! controller's fragmented robot messages from being put together.
//!
//! A robot message longer than one Ethernet frame (1,472 bytes of UDP
//! payload) arrives in IPv4 fragments. smoltcp can reassemble them, but
//! on its own terms: it keeps any set, of any size, from anyone, until its
//! reassembly timeout (60 s; embassy-net offers no way to shorten it), in
//! a fixed number of buffers. Two unusable sets a minute from anyone on the
//! LAN (two 9,000-byte datagrams are enough, or two lost fragments of the
//! controller's own) then stop every robot message longer than a frame.
//!
//! So the firmware reassembles IPv4 itself, in front of the stack
//! ([`Reassembler`], run by `guard::FragmentGuard` (feature `net`), a driver wrapper
//! like smoltcp's `phy` wrappers: it sees every frame any board's driver
//! hands over), and hands smoltcp whole datagrams only; smoltcp's own
//! reassembly never sees a fragment (its buffers are the smallest its
//! features allow). The rules:
//!
//! - only UDP fragments addressed to the device and, once the first
//!   fragment shows the ports, to the channel port are kept
//!   ([`FragmentDrop::Unwanted`]);
//! - a fragment whose offset and length go past what the layout accepts
//!   (`MAX_RECEIVE_LEN` plus the UDP header) never takes a buffer and
//!   spoils its set ([`FragmentDrop::Oversize`]);
//! - an incomplete set is given up [`TIMEOUT_US`] after its first fragment
//!   (two robot cycles: fragments of one datagram arrive back to back on a
//!   LAN, and a message whose last fragment is a cycle late is late for its
//!   answer anyway);
//! - a set is one (source, destination, protocol, ID), as RFC 791 has it:
//!   a fragment of another protocol or to another address never touches
//!   a held set;
//! - an exact copy of a fragment already held is dropped alone
//!   ([`FragmentDrop::Duplicate`]); only an overlap with other bytes, or a
//!   second, different end, spoils the set ([`FragmentDrop::Malformed`]);
//! - when both buffers are taken, a set ranks by who sent it ([`Rank`]):
//!   the controller's (its address and port, from the first fragment)
//!   before one that may be the controller's (its address), before a
//!   stranger's; a newcomer takes the buffer of the lowest-ranked set at
//!   or below its own, the least recently used among equals (so nobody
//!   holds a buffer by refreshing a set every few ms against the
//!   controller's fragments, which come back to back).
//!
//! Every fragment dropped and every set given up is counted
//! ([`FragmentStats`], in the engine's `Stats` and the counter line).

mod coverage;
mod frame;
mod reassembly;
mod slot;
pub use reassembly::{Reassembler, Verdict};

#[cfg(feature = "net")]
pub mod guard;
#[cfg(feature = "net")]
pub(crate) mod probe;

pub use crate::engine::FragmentStats;
use crate::engine::{Endpoint, Pinned};

/// An incomplete set is given up this long after its first fragment
/// arrived (µs): two 4 ms robot cycles.
pub const TIMEOUT_US: u64 = 8_000;

/// Sets reassembled at once.
pub const SLOTS: usize = 2;

/// Ethernet and IPv4 headers (no options) in front of a reassembled
/// datagram, as it is handed to the stack.
pub const HEADERS: usize = 14 + 20;

/// The UDP header, part of what IPv4 reassembles.
const UDP_HEADER: usize = 8;

/// Largest IP payload a set may have: what the coverage map of a buffer
/// can record (8-byte blocks).
pub const MAX_PAYLOAD: usize = reassembly::MAP_BLOCKS * 8;

/// Bytes of one reassembly buffer for a layout whose robot messages are at
/// most `max_receive_len` bytes (`layout::MAX_RECEIVE_LEN`): the headers,
/// the UDP header and the message.
pub const fn buffer_len(max_receive_len: usize) -> usize {
    HEADERS + UDP_HEADER + max_receive_len
}

/// Where robot messages arrive: the device's address and channel port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    /// The device's IPv4 address (Description.xml's `Network Address`).
    pub device: [u8; 4],
    /// The channel's UDP port.
    pub port: u16,
}

/// Who the controller is, as far as the cycle knows: the engine's peer,
/// else a pinned controller (`RRI_CONTROLLER`), else anyone (before the
/// first robot message, any sender may become the peer, S4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Controller {
    /// Its address; `None`: any.
    pub ip: Option<[u8; 4]>,
    /// Its source port; `None`: any.
    pub port: Option<u16>,
}

impl Controller {
    /// No controller known yet: every sender may be it.
    pub const ANYONE: Controller = Controller {
        ip: None,
        port: None,
    };

    /// The engine's peer, else the pinned controller, else anyone.
    pub fn of(peer: Option<Endpoint>, pinned: Option<Pinned>) -> Self {
        match (peer, pinned) {
            (Some(p), _) => Controller {
                ip: Some(p.ip),
                port: Some(p.port),
            },
            (None, Some(p)) => Controller {
                ip: Some(p.ip),
                port: p.port,
            },
            (None, None) => Self::ANYONE,
        }
    }

    /// A datagram (or segment) from `ip`:`port` is the controller's (what
    /// is not known yet matches).
    pub fn sent(&self, ip: [u8; 4], port: u16) -> bool {
        self.from_address(ip) && self.port.is_none_or(|p| p == port)
    }

    /// A datagram from `ip` may be the controller's (the peer rule: a new
    /// port of the peer's address is a controller that reconnected, S4).
    pub fn from_address(&self, ip: [u8; 4]) -> bool {
        self.ip.is_none_or(|c| c == ip)
    }
}

/// Who a fragment set belongs to, lowest first: when buffers are short, a
/// set takes the buffer of one that ranks below it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Rank {
    /// From another address.
    #[default]
    Stranger = 0,
    /// From the controller's address: another port, or its first fragment
    /// (the one with the ports) not seen yet.
    Likely = 1,
    /// From the controller's address and port, to the channel port.
    Controller = 2,
}

/// Why a fragment was dropped on arrival (S5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FragmentDrop {
    /// Its offset and length go past what the layout accepts: its set can
    /// never be a robot message.
    Oversize,
    /// Not UDP, not addressed to the device, or (first fragment) not to
    /// the channel port.
    Unwanted,
    /// A broken header or checksum, a length that is not a multiple of 8
    /// in front of more fragments, an overlap or a second, different end.
    Malformed,
    /// Every buffer holds a set that ranks higher.
    NoBuffer,
    /// A copy of a fragment its set holds already, byte for byte (port
    /// mirroring, a layer-2 loop): dropped alone, the set goes on.
    Duplicate,
}

impl core::fmt::Display for FragmentDrop {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Oversize => "fragment past what the layout accepts (S5)",
            Self::Unwanted => "fragment not UDP to the device's channel port (S5)",
            Self::Malformed => "malformed or overlapping fragment (S5)",
            Self::NoBuffer => "no reassembly buffer: every one holds a set ranked higher (S5)",
            Self::Duplicate => "a copy of a fragment already held (S5)",
        })
    }
}

impl core::error::Error for FragmentDrop {}

/// Why a set that held a buffer was given up (S5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SetLoss {
    /// Still incomplete [`TIMEOUT_US`] after its first fragment: a
    /// fragment never came.
    TimedOut,
    /// Its buffer went to a set that ranks higher.
    Evicted,
    /// The controller's set, its buffer taken by the controller's newer
    /// set while both buffers held the controller's: a fragment of it had
    /// not come while the controller sent two more messages.
    Superseded,
    /// A later fragment showed it unusable (oversize, unwanted, malformed).
    Spoiled,
}

// The counters themselves are the engine's (`engine::stats`, beside the
// others the device reports): how fragments move them is said here.
impl FragmentStats {
    fn count_drop(&mut self, reason: FragmentDrop) {
        let c = match reason {
            FragmentDrop::Oversize => &mut self.oversize,
            FragmentDrop::Unwanted => &mut self.unwanted,
            FragmentDrop::Malformed => &mut self.malformed,
            FragmentDrop::NoBuffer => &mut self.no_buffer,
            FragmentDrop::Duplicate => &mut self.duplicate,
        };
        *c = c.saturating_add(1);
    }

    fn count_loss(&mut self, reason: SetLoss, rank: Rank) {
        let c = match reason {
            SetLoss::TimedOut => &mut self.timed_out,
            SetLoss::Evicted | SetLoss::Superseded => &mut self.evicted,
            SetLoss::Spoiled => &mut self.spoiled,
        };
        *c = c.saturating_add(1);
        if rank == Rank::Controller {
            let c = match reason {
                SetLoss::TimedOut | SetLoss::Superseded => &mut self.controller_incomplete,
                SetLoss::Evicted | SetLoss::Spoiled => &mut self.controller_dropped,
            };
            *c = c.saturating_add(1);
        }
    }
}

mod link;
pub use link::{Hold, Link, HOLD_MAX_US};

#[cfg(test)]
mod fair_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod valid_tests;
