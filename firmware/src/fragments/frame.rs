//! Frames as the reassembler reads them, without trusting a byte: the
//! Ethernet and IPv4 headers, whether a frame is a fragment (checked:
//! header length and checksum, lengths within the frame, 8-byte units),
//! and the UDP ports of a whole datagram.

pub(super) const ETHERTYPE_IPV4: u16 = 0x0800;
pub(super) const ETHERNET: usize = 14;
pub(super) const IPV4: usize = 20;
pub(super) const UDP: u8 = 17;
/// IPv4 flags and fragment offset: "more fragments", the offset in 8-byte
/// units.
pub(super) const MORE_FRAGMENTS: u16 = 0x2000;
pub(super) const OFFSET_UNITS: u16 = 0x1fff;
/// Coverage is kept per 8-byte block (fragment offsets count in them).
pub(super) const BLOCK: usize = 8;

/// An IPv4 fragment, checked: header length and checksum, lengths within
/// the frame, a non-empty payload that is a multiple of 8 bytes in front
/// of more fragments.
pub(super) struct Fragment<'a> {
    pub(super) src: [u8; 4],
    pub(super) dst: [u8; 4],
    pub(super) ident: u16,
    pub(super) protocol: u8,
    pub(super) more: bool,
    /// In bytes.
    pub(super) offset: usize,
    pub(super) payload: &'a [u8],
}

/// What a frame is, read without trusting it.
pub(super) enum Frame<'a> {
    /// Not IPv4, or IPv4 that is not a fragment.
    Whole,
    Fragment(Fragment<'a>),
    /// IPv4 with the fragment bits set, but broken.
    Broken,
}

pub(super) fn be16(b: &[u8], i: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(i)?, *b.get(i + 1)?]))
}

pub(super) fn put16(b: &mut [u8], i: usize, v: u16) {
    if let Some(d) = b.get_mut(i..i + 2) {
        d.copy_from_slice(&v.to_be_bytes());
    }
}

pub(super) fn ip4(b: &[u8], i: usize) -> Option<[u8; 4]> {
    b.get(i..i + 4)?.try_into().ok()
}

/// The Internet checksum of `b` (0 over a header whose checksum is right).
pub(super) fn checksum(b: &[u8]) -> u16 {
    let mut sum: u32 = 0;
    let mut words = b.chunks_exact(2);
    for w in &mut words {
        if let [hi, lo] = w {
            sum += u32::from(u16::from_be_bytes([*hi, *lo]));
        }
    }
    if let [last] = words.remainder() {
        sum += u32::from(*last) << 8;
    }
    while sum > 0xffff {
        sum = (sum & 0xffff) + (sum >> 16);
    }
    !(sum as u16)
}

pub(super) fn classify(frame: &[u8]) -> Frame<'_> {
    if be16(frame, 12) != Some(ETHERTYPE_IPV4) {
        return Frame::Whole;
    }
    let (Some(&vihl), Some(flags)) = (frame.get(ETHERNET), be16(frame, ETHERNET + 6)) else {
        return Frame::Whole;
    };
    let more = flags & MORE_FRAGMENTS != 0;
    let offset = usize::from(flags & OFFSET_UNITS) * 8;
    if vihl >> 4 != 4 || (!more && offset == 0) {
        // Not IPv4 (the stack drops it) or not a fragment.
        return Frame::Whole;
    }
    fragment(frame, vihl, more, offset).map_or(Frame::Broken, Frame::Fragment)
}

pub(super) fn fragment(frame: &[u8], vihl: u8, more: bool, offset: usize) -> Option<Fragment<'_>> {
    let ihl = usize::from(vihl & 0x0f) * 4;
    let total = usize::from(be16(frame, ETHERNET + 2)?);
    if ihl < IPV4 || total < ihl {
        return None;
    }
    let header = frame.get(ETHERNET..ETHERNET + ihl)?;
    if checksum(header) != 0 {
        return None;
    }
    let payload = frame.get(ETHERNET + ihl..ETHERNET + total)?;
    if payload.is_empty() || (more && payload.len() % BLOCK != 0) {
        return None;
    }
    Some(Fragment {
        src: ip4(frame, ETHERNET + 12)?,
        dst: ip4(frame, ETHERNET + 16)?,
        ident: be16(frame, ETHERNET + 4)?,
        protocol: *frame.get(ETHERNET + 9)?,
        more,
        offset,
        payload,
    })
}

/// UDP source and destination port of a whole IPv4 datagram to `device`.
pub(super) fn udp_ports(frame: &[u8], device: [u8; 4]) -> Option<([u8; 4], u16, u16)> {
    if be16(frame, 12)? != ETHERTYPE_IPV4 || *frame.get(ETHERNET + 9)? != UDP {
        return None;
    }
    if ip4(frame, ETHERNET + 16)? != device {
        return None;
    }
    let ihl = usize::from(frame.get(ETHERNET)? & 0x0f) * 4;
    if ihl < IPV4 {
        return None;
    }
    let udp = ETHERNET + ihl;
    Some((
        ip4(frame, ETHERNET + 12)?,
        be16(frame, udp)?,
        be16(frame, udp + 2)?,
    ))
}
