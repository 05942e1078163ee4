//! Frames as the reassembler reads them, without trusting a byte: the
//! Ethernet and IPv4 headers, whether a frame is a fragment (checked:
//! header length and checksum, lengths within the frame, 8-byte units),
//! the UDP ports of a whole datagram, and a reassembled datagram's UDP
//! checksum.

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
    !ones(b)
}

/// The one's-complement sum of `b` as big-endian 16-bit words (an odd
/// last byte padded with 0), folded to 16 bits, not complemented.
///
/// Four bytes at a time, read in the machine's order into a 64-bit sum:
/// the one's-complement sum does not depend on byte order but for a swap
/// of its two bytes (RFC 1071, 2.B), which is done once at the end. Over
/// a reassembled 3.5 KB datagram the guard spent most of its time summing
/// 16-bit words one at a time.
pub(super) fn ones(b: &[u8]) -> u16 {
    let mut sum: u64 = 0;
    let mut words = b.chunks_exact(4);
    for w in &mut words {
        if let Ok(w) = <[u8; 4]>::try_from(w) {
            sum += u64::from(u32::from_le_bytes(w));
        }
    }
    // The last 1 to 3 bytes, zero-padded: an odd last byte is the high
    // byte of its big-endian word, the low byte here.
    let mut tail = [0u8; 4];
    for (t, b) in tail.iter_mut().zip(words.remainder()) {
        *t = *b;
    }
    sum += u64::from(u32::from_le_bytes(tail));
    fold(sum).swap_bytes()
}

/// `sum` folded to 16 bits with end-around carries.
fn fold(mut sum: u64) -> u16 {
    while sum > 0xffff {
        sum = (sum & 0xffff) + (sum >> 16);
    }
    sum as u16
}

/// Whether `ip`, a whole IPv4 datagram (a 20-byte header without
/// options, then UDP), carries a UDP length within its payload and a right
/// UDP checksum over it, or none (0, which IPv4 allows). A reassembled
/// datagram is checked here whatever the driver declares: no NIC can
/// check the checksum of a payload that came in fragments.
pub(super) fn udp_checksum_ok(ip: &[u8]) -> bool {
    let (Some(addresses), Some(payload)) = (ip.get(12..IPV4), ip.get(IPV4..)) else {
        return false;
    };
    let Some(udp) = be16(payload, 4).and_then(|n| payload.get(..usize::from(n))) else {
        return false;
    };
    if udp.len() < 8 {
        return false;
    }
    if be16(udp, 6) == Some(0) {
        return true;
    }
    // The pseudo-header: source, destination, zero and protocol, length.
    let length = u64::try_from(udp.len()).unwrap_or(u64::MAX);
    let sum = u64::from(ones(udp)) + u64::from(ones(addresses)) + u64::from(UDP) + length;
    !fold(sum) == 0
}

/// Whether a whole IPv4 `frame`'s header is one the stack keeps: its
/// header checksum right and its length within the frame (a controller
/// datagram is counted only once it passes this).
fn header_valid(frame: &[u8], ihl: usize) -> bool {
    let total = be16(frame, ETHERNET + 2).map_or(0, usize::from);
    total >= ihl
        && frame.len() >= ETHERNET + total
        && frame
            .get(ETHERNET..ETHERNET + ihl)
            .is_some_and(|h| checksum(h) == 0)
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

/// UDP source and destination port of a whole IPv4 datagram to `device`,
/// whose IPv4 header is valid (its checksum, its length): one the stack
/// keeps (the UDP checksum is the NIC's or the stack's to check).
pub(super) fn udp_ports(frame: &[u8], device: [u8; 4]) -> Option<([u8; 4], u16, u16)> {
    if be16(frame, 12)? != ETHERTYPE_IPV4 || *frame.get(ETHERNET + 9)? != UDP {
        return None;
    }
    if ip4(frame, ETHERNET + 16)? != device {
        return None;
    }
    let ihl = usize::from(frame.get(ETHERNET)? & 0x0f) * 4;
    if ihl < IPV4 || !header_valid(frame, ihl) {
        return None;
    }
    let udp = ETHERNET + ihl;
    Some((
        ip4(frame, ETHERNET + 12)?,
        be16(frame, udp)?,
        be16(frame, udp + 2)?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RFC 1071's own way: 16-bit big-endian words, one at a time.
    fn reference(b: &[u8]) -> u16 {
        let mut sum: u32 = 0;
        for pair in b.chunks(2) {
            let hi = u32::from(pair[0]) << 8;
            sum += hi | pair.get(1).map_or(0, |lo| u32::from(*lo));
            sum = (sum & 0xffff) + (sum >> 16);
        }
        sum as u16
    }

    #[test]
    fn rfc_1071s_example_sums_to_ddf2() {
        // RFC 1071, 3: the bytes 00 01 f2 03 f4 f5 f6 f7 sum to dd f2.
        assert_eq!(
            ones(&[0x00, 0x01, 0xf2, 0x03, 0xf4, 0xf5, 0xf6, 0xf7]),
            0xddf2
        );
    }

    #[test]
    fn the_word_sum_is_the_pairwise_sum_at_every_length_and_alignment() {
        let mut x: u32 = 12345;
        let data: Vec<u8> = (0..200)
            .map(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (x >> 16) as u8
            })
            .collect();
        for start in 0..4 {
            for len in 0..=(data.len() - start) {
                let b = &data[start..start + len];
                assert_eq!(ones(b), reference(b), "start {start} len {len}");
            }
        }
        // Carries past 16 and 32 bits: every byte 0xff.
        let ff = [0xffu8; 4099];
        for len in [0, 1, 2, 3, 4, 5, 4096, 4097, 4098, 4099] {
            assert_eq!(ones(&ff[..len]), reference(&ff[..len]), "0xff × {len}");
        }
    }
}
