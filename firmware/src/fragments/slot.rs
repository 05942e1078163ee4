//! One set being put together: its buffer (the frame's headers, then the
//! IP payload where each fragment's offset puts it), which blocks have
//! come, and the checks a fragment passes before its bytes are kept
//! (overlaps, a second or contradicting end, a copy of one held). The
//! pool of slots, which set gets a buffer and which gives one up, is
//! the reassembler's ([`super::reassembly`]).

use super::coverage::Coverage;
use super::frame::{checksum, put16, udp_checksum_ok, Fragment, BLOCK, ETHERNET, IPV4};
use super::{Rank, HEADERS};

/// One set being put together, in a buffer of `BUF` bytes. All zeros is
/// a free slot (so a `static` of them costs no flash).
pub(super) struct Slot<const BUF: usize> {
    pub(super) busy: bool,
    pub(super) rank: Rank,
    pub(super) src: [u8; 4],
    pub(super) ident: u16,
    pub(super) started_us: u64,
    /// When its last fragment came: among sets of one rank, the least
    /// recently used gives its buffer up first.
    pub(super) last_us: u64,
    /// IP payload bytes of the whole datagram; 0 until the last fragment
    /// (the one without "more fragments") came.
    pub(super) total: usize,
    /// The furthest byte any fragment reached.
    pub(super) end: usize,
    /// Blocks received, and which.
    pub(super) blocks: usize,
    pub(super) map: Coverage,
    pub(super) fragments: u16,
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
    pub(super) const FREE: Self = Slot {
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
    pub(super) fn frame(&self) -> &[u8] {
        &self.buf.0
    }

    pub(super) fn frame_mut(&mut self) -> &mut [u8] {
        &mut self.buf.0
    }

    pub(super) fn start(&mut self, src: [u8; 4], ident: u16, rank: Rank, now_us: u64) {
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

    pub(super) fn holds(&self, src: [u8; 4], ident: u16) -> bool {
        self.busy && self.src == src && self.ident == ident
    }

    /// Adds fragment `f` (of `frame`) at `now_us`. [`Add::Conflict`] when
    /// it overlaps what is there with other bytes, or contradicts the
    /// datagram's end (the caller spoils the set); [`Add::Duplicate`]
    /// when every byte of it is there already, the same (a copy of a
    /// frame: port mirroring, a layer-2 loop), which changes nothing.
    pub(super) fn add(&mut self, f: &Fragment<'_>, frame: &[u8], now_us: u64) -> Add {
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
    pub(super) fn same(&self, f: &Fragment<'_>, end: usize) -> bool {
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

    pub(super) fn complete(&self) -> bool {
        self.total != 0 && self.blocks == self.total.div_ceil(BLOCK)
    }

    /// Writes the whole datagram's IPv4 header (no options, not a
    /// fragment, its length, a fresh checksum); its length with headers.
    pub(super) fn finish(&mut self) -> usize {
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
    pub(super) fn udp_checked(&mut self) -> bool {
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
pub(super) enum Add {
    Added,
    /// Every byte of it was there already, the same.
    Duplicate,
    /// It overlaps other bytes, or contradicts the datagram's end.
    Conflict,
}
