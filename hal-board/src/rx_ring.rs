//! How many Ethernet frames a board's receive DMA ring must hold.
//!
//! The network stack and the cycle share one executor: while the cycle
//! decodes and answers a message, nobody empties the ring, and whatever
//! arrives meanwhile must wait there. When the ring is full the MAC drops
//! frames, and one lost fragment loses its whole datagram. What may arrive
//! at once, for any layout the firmware builds:
//!
//! - datagrams in reassembly: the IP stack reassembles up to `count`
//!   datagrams of up to `size` bytes (smoltcp's reassembly buffers, which
//!   the firmware checks its layout's longest robot message against), each
//!   `fragments(size)` frames;
//! - a burst of one message per robot property: a controller sends every
//!   cyclic property due in a cycle back to back (M11), up to
//!   [`rri_vocabulary::MAX_PROPERTIES`] datagrams; the firmware's UDP
//!   socket has room for that many;
//! - an ARP request (the controller refreshing its cache) and one frame of
//!   margin (a stray broadcast).

/// IPv4 payload bytes in one Ethernet frame: a 1,500-byte MTU less the
/// 20-byte IPv4 header (a multiple of 8, as fragment offsets require).
pub const IPV4_PAYLOAD_PER_FRAME: usize = 1480;

/// The smallest ring the boards use, whatever the arithmetic says.
pub const MIN_FRAMES: usize = 8;

/// Frames an IPv4 datagram of `ip_payload` bytes (UDP header included)
/// arrives in.
pub const fn fragments(ip_payload: usize) -> usize {
    if ip_payload == 0 {
        1
    } else {
        ip_payload.div_ceil(IPV4_PAYLOAD_PER_FRAME)
    }
}

/// The receive ring for an IP stack that reassembles `reassembly_count`
/// datagrams of up to `reassembly_size` bytes, and bursts of up to
/// `burst_datagrams` single datagrams: the larger of the two, plus an ARP
/// request and one frame of margin, and never under [`MIN_FRAMES`].
pub const fn rx_frames(
    reassembly_size: usize,
    reassembly_count: usize,
    burst_datagrams: usize,
) -> usize {
    let reassembling = reassembly_count * fragments(reassembly_size);
    let burst = if reassembling > burst_datagrams {
        reassembling
    } else {
        burst_datagrams
    };
    let frames = burst + 2;
    if frames < MIN_FRAMES {
        MIN_FRAMES
    } else {
        frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manuals_message_is_three_frames() {
        // 3,557 bytes of UDP payload (the manual layout's maximum), plus
        // the 8-byte UDP header.
        assert_eq!(fragments(3557 + 8), 3);
        assert_eq!(fragments(1472 + 8), 1);
        assert_eq!(fragments(1473 + 8), 2);
        assert_eq!(fragments(4096), 3);
        assert_eq!(fragments(0), 1);
    }

    #[test]
    fn ring_sizes() {
        // The firmware's smoltcp: two 4,096-byte reassembly buffers; up to
        // 16 robot properties in a burst.
        assert_eq!(rx_frames(4096, 2, rri_vocabulary::MAX_PROPERTIES), 18);
        // Reassembly alone: 2 x 3 frames, ARP, margin.
        assert_eq!(rx_frames(4096, 2, 1), 8);
        // Larger reassembly buffers grow the ring.
        assert_eq!(rx_frames(9000, 4, 1), 4 * 7 + 2);
        // Never under the floor.
        assert_eq!(rx_frames(1480, 1, 1), MIN_FRAMES);
    }
}
