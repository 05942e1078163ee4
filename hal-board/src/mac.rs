//! The board's Ethernet address, derived from the chip's unique ID.
//!
//! A NUCLEO board has no EUI-48 of its own. Its address must be stable (the
//! robot controller's ARP cache and any switch keep it) and must differ
//! between two boards on one network, so it is a hash of the 96-bit unique
//! ID every STM32 carries, made locally administered and unicast (IEEE 802
//! U/L bit set, I/G bit clear) so it can never collide with a vendor's
//! address.

/// FNV-1a over the unique ID, folded to the 46 free bits of a locally
/// administered unicast address.
pub fn from_unique_id(uid: &[u8; 12]) -> [u8; 6] {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in uid {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    let b = h.to_le_bytes();
    // Bits 0 (I/G: unicast) and 1 (U/L: locally administered) of the first
    // octet.
    [(b[0] & 0xfc) | 0x02, b[1], b[2], b[3], b[4], b[5]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locally_administered_unicast() {
        for seed in 0u8..=255 {
            let mac = from_unique_id(&[seed; 12]);
            assert_eq!(mac[0] & 0x03, 0x02, "{mac:02x?}");
        }
    }

    #[test]
    fn stable_per_board() {
        let uid = *b"\x33\x00\x47\x00\x0d\x51\x38\x37\x33\x39\x34\x30";
        assert_eq!(from_unique_id(&uid), from_unique_id(&uid));
    }

    /// Boards of one production lot differ in a few bits of the wafer
    /// coordinates or lot number: every single-bit change of an ID, and
    /// each of 65,536 IDs differing in their first two bytes, must give an
    /// address of its own.
    #[test]
    fn different_between_boards() {
        let base = [
            0x33, 0x00, 0x47, 0x00, 0x0d, 0x51, 0x38, 0x37, 0x33, 0x39, 0x34, 0x30,
        ];
        let mut ids = std::collections::HashSet::new();
        for byte in 0..12 {
            for bit in 0..8 {
                let mut uid = base;
                uid[byte] ^= 1 << bit;
                ids.insert(uid);
            }
        }
        for n in 0..=u16::MAX {
            let mut uid = base;
            uid[0..2].copy_from_slice(&n.to_le_bytes());
            ids.insert(uid);
        }
        let macs: std::collections::HashSet<_> = ids.iter().map(from_unique_id).collect();
        assert_eq!(macs.len(), ids.len(), "two IDs share an address");
    }
}
