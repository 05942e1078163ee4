//! The bits a torn flash operation reached, on a flash without ECC: one
//! seeded mix, shared by the host's flash model (`flash_model.rs`) and
//! the rehosting engine's F767 (`rehost/src/torn_bits.rs`, which includes
//! this file by path: the engine is GPL-2.0 for unicorn, this crate MIT
//! or Apache-2.0, so the shared file lives here), so both tear alike.

/// The bytes a torn operation leaves: each bit where `old` and `target`
/// (what the operation was making of them) differ takes `target`'s value
/// or keeps `old`'s, as `seed`'s stream says; the others are unchanged.
/// Also how many of the differing bits changed, and how many differed.
pub fn mix(old: &[u8], target: &[u8], seed: u64) -> (Vec<u8>, u64, u64) {
    let mut stream = SplitMix64(seed);
    let mut word = [0u8; 8];
    let (mut changed, mut differing) = (0, 0);
    let bytes = old
        .iter()
        .zip(target)
        .enumerate()
        .map(|(i, (&o, &t))| {
            if i % 8 == 0 {
                word = stream.next().to_le_bytes();
            }
            let d = o ^ t;
            let reached = d & word[i % 8];
            differing += u64::from(d.count_ones());
            changed += u64::from(reached.count_ones());
            o ^ reached
        })
        .collect();
    (bytes, changed, differing)
}

/// Sebastiano Vigna's SplitMix64: a small, well-mixed stream from any
/// seed (zero included), enough to scatter the bits a cut reaches.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_torn_program_only_clears_bits_it_was_clearing() {
        let old = [0xFF, 0xF0, 0x0F, 0xFF];
        let new = [0x00, 0x00, 0x0F, 0xFF];
        for seed in 0..64 {
            let (torn, changed, differing) = mix(&old, &new, seed);
            assert_eq!(differing, 12);
            for ((t, o), n) in torn.iter().zip(old).zip(new) {
                assert_eq!(t & !o, 0, "seed {seed}: a bit set");
                assert_eq!(!t & n, 0, "seed {seed}: a bit cleared the program left");
            }
            assert_eq!(
                &torn[2..],
                &old[2..],
                "seed {seed}: bytes it did not change"
            );
            let cleared: u32 = torn
                .iter()
                .zip(old)
                .map(|(t, o)| (t ^ o).count_ones())
                .sum();
            assert_eq!(u64::from(cleared), changed);
        }
    }

    #[test]
    fn a_torn_erase_only_sets_bits_and_about_half_of_them() {
        // A 128 KB sector of programmed bytes, half way erased.
        let old: Vec<u8> = (0..128 * 1024).map(|i| (i * 7 % 251) as u8).collect();
        let erased = vec![0xFF; old.len()];
        let (torn, changed, differing) = mix(&old, &erased, 43_080);
        assert!(torn.iter().zip(&old).all(|(t, o)| t & o == *o));
        assert!(torn != old && torn != erased);
        let half = differing / 2;
        assert!(
            changed.abs_diff(half) < differing / 100,
            "{changed} of {differing}"
        );
    }

    #[test]
    fn the_mix_follows_the_seed() {
        let old = [0u8; 64];
        let target = [0xFF; 64];
        assert_eq!(mix(&old, &target, 7).0, mix(&old, &target, 7).0);
        assert_ne!(mix(&old, &target, 7).0, mix(&old, &target, 8).0);
        // The generator's published first output for seed 0.
        assert_eq!(SplitMix64(0).next(), 0xE220_A839_7B1D_CDAF);
    }
}
