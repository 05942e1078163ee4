//! A NOR flash whose power is cut at its N-th operation: the model that
//! update and swap are checked against (issue 43; `tests/update_power_cut.rs`).
//!
//! What it holds to, and where that comes from (not from the code it
//! checks): embedded-storage's `NorFlash` contract (erase and write
//! aligned to their sizes, inside the capacity); the STM32 reference
//! manuals (RM0410 for the F767, RM0433 for the H743): a sector erase sets
//! every byte to 0xFF, and a word (F7: the 16 bytes embassy-stm32 writes
//! at once; H7: the 32-byte flash word its ECC covers) is programmed once
//! between erases (whatever it was written with: 0xFF too). A write to a
//! word programmed since its erase is refused
//! ([`FlashError::NotErased`]: on the H743 a second program of a flash
//! word breaks its ECC) and counted ([`Power::refused_writes`]), so a test
//! sees both the caller's attempt and what it does with the refusal.
//!
//! The power: every sector erased and every word written is one
//! operation, counted across every partition sharing one [`Power`]. At
//! the cut, the operation that would be number N does not happen, it and
//! everything after fail, until the power is restored.
//!
//! A cut *inside* the operation ([`Power::tear`]): the power goes as
//! operation N runs, which is what a real cut does. A half-programmed
//! flash word of the H743 holds bits and ECC that disagree (RM0433, the
//! flash's ECC: 10 ECC bits per 256-bit flash word, a double error
//! detected, not corrected); a torn erase leaves every word of its sector
//! so. Such a word reads back as [`FlashError::Torn`] until its sector is
//! erased, and cannot be programmed. That is kinder than silicon, where a
//! CPU read of it is a precise bus fault (PX4-Autopilot #27642, Zephyr
//! #33140 and embassy #4777 met it): a caller that sees the error here
//! faults there.
//!
//! A flash without ECC ([`Power::mix_bits`], the F767: RM0410 has no ECC
//! for its main flash) tells nobody: a torn operation leaves each bit it
//! was changing changed or not (the engine's mix, `bit_mix.rs`, shared
//! with the rehosted F767), read back as it is, and a word may be
//! programmed again where that only clears bits (RM0410 §3.3.7).

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use std::cell::Cell;
use std::rc::Rc;

/// The supply shared by the partitions of one chip.
#[derive(Debug, Default)]
pub struct Power {
    ops: Cell<u64>,
    cut_at: Cell<Option<u64>>,
    /// The cut tears the operation it falls on rather than stopping it
    /// before it starts.
    tear: Cell<bool>,
    /// No ECC: the seed of a torn operation's mix of bits.
    mix: Cell<Option<u64>>,
    off: Cell<bool>,
    refused_writes: Cell<u64>,
}

impl Power {
    /// Power on, no cut planned.
    pub fn new() -> Rc<Power> {
        Rc::new(Power::default())
    }

    /// Cut the power when operation number `n` (from 0, counted from now
    /// on) would start; `None`: no cut.
    pub fn cut_at(&self, n: Option<u64>) {
        self.ops.set(0);
        self.cut_at.set(n);
    }

    /// Whether a cut tears the operation it falls on ([`FlashError::Torn`]
    /// words) rather than stopping it before it starts (the default).
    pub fn tear(&self, tear: bool) {
        self.tear.set(tear);
    }

    /// The flash has no ECC (the F767): a torn operation leaves a mix
    /// of the bits it was changing, seeded by `seed` (a program's seed is
    /// `seed` plus its offset in the partition, so two tears differ),
    /// and a word may be programmed again where that only clears bits.
    pub fn mix_bits(&self, seed: u64) {
        self.mix.set(Some(seed));
    }

    /// Power back on (a reset), no cut planned.
    pub fn restore(&self) {
        self.off.set(false);
        self.cut_at.set(None);
    }

    /// Whether the power went off.
    pub fn is_off(&self) -> bool {
        self.off.get()
    }

    /// Operations done since the last [`Power::cut_at`].
    pub fn ops(&self) -> u64 {
        self.ops.get()
    }

    /// Writes refused because their word was not erased.
    pub fn refused_writes(&self) -> u64 {
        self.refused_writes.get()
    }

    /// One operation may start: `Go`, or not at all (the power is off),
    /// or torn (the cut falls on it and tears it).
    fn tick(&self) -> Tick {
        if self.off.get() {
            return Tick::Off;
        }
        let n = self.ops.get();
        if self.cut_at.get() == Some(n) {
            self.off.set(true);
            return if self.tear.get() {
                Tick::Torn
            } else {
                Tick::Off
            };
        }
        self.ops.set(n + 1);
        Tick::Go
    }
}

/// What becomes of an operation ([`Power::tick`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Tick {
    Go,
    Off,
    Torn,
}

/// Why the model refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// The power is off.
    PowerCut,
    /// Not aligned to the write or erase size.
    NotAligned,
    /// Past the capacity.
    OutOfBounds,
    /// A write to a word that is not erased.
    NotErased,
    /// A read of a word a cut tore (on the H743: a double ECC error, a
    /// bus fault on silicon).
    Torn,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::PowerCut => NorFlashErrorKind::Other,
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotErased | FlashError::Torn => NorFlashErrorKind::Other,
        }
    }
}

/// One partition: `ERASE`-byte sectors, `WRITE`-byte words.
pub struct Flash<const ERASE: usize, const WRITE: usize> {
    mem: Vec<u8>,
    /// Which words were programmed since their sector's erase: a word
    /// written with 0xFF is programmed all the same (its ECC on the H743).
    programmed: Vec<bool>,
    /// Which words a cut tore (read back as [`FlashError::Torn`]).
    torn: Vec<bool>,
    power: Rc<Power>,
}

impl<const ERASE: usize, const WRITE: usize> Flash<ERASE, WRITE> {
    /// `size` bytes, erased.
    pub fn erased(size: usize, power: &Rc<Power>) -> Self {
        assert!(size.is_multiple_of(ERASE), "a partition is whole sectors");
        Flash {
            mem: vec![0xFF; size],
            programmed: vec![false; size / WRITE],
            torn: vec![false; size / WRITE],
            power: power.clone(),
        }
    }

    /// `size` bytes holding `bytes` at the start (as a probe would have
    /// flashed them), the rest erased.
    pub fn holding(bytes: &[u8], size: usize, power: &Rc<Power>) -> Self {
        let mut f = Self::erased(size, power);
        f.mem[..bytes.len()].copy_from_slice(bytes);
        f.programmed[..bytes.len().div_ceil(WRITE)].fill(true);
        f
    }

    /// Its bytes (a torn word's as they were before the cut).
    pub fn bytes(&self) -> &[u8] {
        &self.mem
    }

    /// Whether a word a cut tore is in it (and not erased since).
    pub fn has_torn(&self) -> bool {
        self.torn.iter().any(|&t| t)
    }

    /// A torn operation on a flash without ECC: the bytes at `at` a mix
    /// of what they were and `target`.
    fn mix(&mut self, at: usize, target: &[u8], seed: u64) {
        let span = at..at + target.len();
        let (bytes, _, _) = crate::bit_mix::mix(&self.mem[span.clone()], target, seed);
        self.mem[span].copy_from_slice(&bytes);
    }

    fn check(&self, offset: u32, len: usize, align: usize) -> Result<usize, FlashError> {
        let start = offset as usize;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(FlashError::NotAligned);
        }
        if start + len > self.mem.len() {
            return Err(FlashError::OutOfBounds);
        }
        Ok(start)
    }
}

impl<const ERASE: usize, const WRITE: usize> ErrorType for Flash<ERASE, WRITE> {
    type Error = FlashError;
}

impl<const ERASE: usize, const WRITE: usize> ReadNorFlash for Flash<ERASE, WRITE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        if self.power.is_off() {
            return Err(FlashError::PowerCut);
        }
        let start = self.check(offset, bytes.len(), 1)?;
        if !bytes.is_empty()
            && self.torn[start / WRITE..=(start + bytes.len() - 1) / WRITE].contains(&true)
        {
            return Err(FlashError::Torn);
        }
        bytes.copy_from_slice(&self.mem[start..start + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const ERASE: usize, const WRITE: usize> NorFlash for Flash<ERASE, WRITE> {
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if to < from {
            return Err(FlashError::OutOfBounds);
        }
        let start = self.check(from, (to - from) as usize, ERASE)?;
        for sector in (start..to as usize).step_by(ERASE) {
            let words = sector / WRITE..(sector + ERASE) / WRITE;
            match self.power.tick() {
                Tick::Off => return Err(FlashError::PowerCut),
                Tick::Torn => {
                    match self.power.mix.get() {
                        Some(seed) => self.mix(sector, &[0xFF; ERASE], seed),
                        None => self.torn[words.clone()].fill(true),
                    }
                    self.programmed[words].fill(true);
                    return Err(FlashError::PowerCut);
                }
                Tick::Go => {}
            }
            self.mem[sector..sector + ERASE].fill(0xFF);
            self.programmed[words.clone()].fill(false);
            self.torn[words].fill(false);
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let start = self.check(offset, bytes.len(), WRITE)?;
        for (i, word) in bytes.chunks(WRITE).enumerate() {
            let at = start + i * WRITE;
            if self.power.is_off() {
                return Err(FlashError::PowerCut);
            }
            let again = match self.power.mix.get() {
                // RM0410 §3.3.7: a program may only clear bits.
                Some(_) => self.mem[at..at + WRITE]
                    .iter()
                    .zip(word)
                    .any(|(old, new)| new & !old != 0),
                None => self.programmed[at / WRITE],
            };
            if again {
                self.power
                    .refused_writes
                    .set(self.power.refused_writes.get() + 1);
                return Err(FlashError::NotErased);
            }
            match self.power.tick() {
                Tick::Off => return Err(FlashError::PowerCut),
                Tick::Torn => {
                    match self.power.mix.get() {
                        Some(seed) => self.mix(at, word, seed.wrapping_add(at as u64)),
                        None => self.torn[at / WRITE] = true,
                    }
                    self.programmed[at / WRITE] = true;
                    return Err(FlashError::PowerCut);
                }
                Tick::Go => {}
            }
            self.mem[at..at + WRITE].copy_from_slice(word);
            self.programmed[at / WRITE] = true;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type F = Flash<256, 16>;

    /// Each check of the model, and the broken use it stops.
    #[test]
    fn the_model_refuses_what_the_chip_refuses() {
        let power = Power::new();
        let mut f = F::erased(1024, &power);
        assert_eq!(f.write(8, &[0; 16]), Err(FlashError::NotAligned));
        assert_eq!(f.write(0, &[0; 8]), Err(FlashError::NotAligned));
        assert_eq!(f.write(1024, &[0; 16]), Err(FlashError::OutOfBounds));
        assert_eq!(f.erase(128, 384), Err(FlashError::NotAligned));
        assert_eq!(f.erase(0, 2048), Err(FlashError::OutOfBounds));
        assert_eq!(f.write(16, &[0x5A; 16]), Ok(()));
        assert_eq!(f.erase(0, 256), Ok(()));
        assert!(f.bytes()[..256].iter().all(|&b| b == 0xFF));
    }

    #[test]
    fn a_word_programmed_twice_is_refused_and_counted() {
        let power = Power::new();
        let mut f = F::erased(1024, &power);
        f.write(0, &[0x00; 16]).unwrap();
        assert_eq!(f.write(0, &[0x00; 16]), Err(FlashError::NotErased));
        // Programmed with the erased value is programmed all the same.
        f.write(16, &[0xFF; 16]).unwrap();
        assert_eq!(f.write(16, &[0x00; 16]), Err(FlashError::NotErased));
        assert_eq!(power.refused_writes(), 2);
        f.erase(0, 256).unwrap();
        assert_eq!(f.write(0, &[0x00; 16]), Ok(()));
    }

    /// The cut: operation N does not happen, nor anything after it,
    /// until the power is back; reads fail while it is off.
    #[test]
    fn the_cut_stops_operation_n_and_everything_after() {
        let power = Power::new();
        let mut f = F::erased(1024, &power);
        power.cut_at(Some(2));
        assert_eq!(f.write(0, &[0; 32]), Ok(())); // operations 0 and 1
        assert_eq!(f.write(32, &[0; 32]), Err(FlashError::PowerCut));
        assert!(
            f.bytes()[32..64].iter().all(|&b| b == 0xFF),
            "operation 2 did not happen"
        );
        assert_eq!(f.read(0, &mut [0; 4]), Err(FlashError::PowerCut));
        assert_eq!(f.erase(0, 256), Err(FlashError::PowerCut));
        power.restore();
        assert_eq!(f.erase(0, 256), Ok(()));
        assert_eq!(power.ops(), 3);
    }

    /// A torn program leaves its word unreadable and unprogrammable; a
    /// torn erase, every word of its sector; an erase mends both.
    #[test]
    fn a_torn_operation_leaves_words_that_do_not_read_back_until_erased() {
        let power = Power::new();
        let mut f = F::erased(1024, &power);
        power.tear(true);
        power.cut_at(Some(1));
        assert_eq!(f.write(0, &[0; 32]), Err(FlashError::PowerCut));
        power.restore();
        assert_eq!(f.read(0, &mut [0; 16]), Ok(()), "the word before the cut");
        assert_eq!(f.read(16, &mut [0; 1]), Err(FlashError::Torn));
        assert_eq!(
            f.read(8, &mut [0; 16]),
            Err(FlashError::Torn),
            "a read across it"
        );
        assert_eq!(f.read(32, &mut [0; 16]), Ok(()));
        assert_eq!(f.write(16, &[0; 16]), Err(FlashError::NotErased));
        assert!(f.has_torn());
        power.cut_at(Some(0));
        assert_eq!(f.erase(256, 512), Err(FlashError::PowerCut));
        power.restore();
        assert_eq!(f.read(300, &mut [0; 1]), Err(FlashError::Torn));
        f.erase(0, 512).unwrap();
        assert!(!f.has_torn());
        assert_eq!(f.read(0, &mut [0; 512]), Ok(()));
        // Without tearing, the cut stops the operation whole.
        power.tear(false);
        power.cut_at(Some(0));
        assert_eq!(f.write(0, &[0; 16]), Err(FlashError::PowerCut));
        power.restore();
        assert!(!f.has_torn());
    }

    /// Without ECC (the F767) a torn program leaves some of the bits it
    /// was clearing cleared, a torn erase some of those it was setting
    /// set; both read back with no error, and a word takes a second
    /// program only where it clears bits.
    #[test]
    fn without_ecc_a_torn_operation_leaves_a_mix_that_reads_back() {
        let power = Power::new();
        power.mix_bits(5);
        power.tear(true);
        let mut f = F::erased(1024, &power);
        power.cut_at(Some(0));
        assert_eq!(f.write(16, &[0; 16]), Err(FlashError::PowerCut));
        power.restore();
        let mut word = [0; 16];
        f.read(16, &mut word).unwrap();
        assert!(word != [0; 16] && word != [0xFF; 16], "{word:x?}");
        assert!(!f.has_torn());
        // Cleared the rest of the way, as a redone write does.
        assert_eq!(f.write(16, &[0; 16]), Ok(()));
        assert_eq!(f.write(16, &[1; 16]), Err(FlashError::NotErased));
        power.cut_at(Some(0));
        assert_eq!(f.erase(0, 256), Err(FlashError::PowerCut));
        power.restore();
        let mut sector = [0; 256];
        f.read(0, &mut sector).unwrap();
        let erased = |b: &[u8]| b.iter().all(|&x| x == 0xFF);
        assert!(erased(&sector[..16]), "erased before: it stays so");
        assert!(!erased(&sector[16..32]) && sector[16..32] != [0; 16]);
    }
}
