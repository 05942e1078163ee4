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
//! everything after fail, until the power is restored. A cut *inside* an
//! operation (a torn erase or a half-programmed word, which on the H743
//! leaves a word whose ECC may not read back) is not modelled.

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

    /// One operation may start: `false` when the power is (now) off.
    fn tick(&self) -> bool {
        if self.off.get() {
            return false;
        }
        let n = self.ops.get();
        if self.cut_at.get() == Some(n) {
            self.off.set(true);
            return false;
        }
        self.ops.set(n + 1);
        true
    }
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
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::PowerCut => NorFlashErrorKind::Other,
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotErased => NorFlashErrorKind::Other,
        }
    }
}

/// One partition: `ERASE`-byte sectors, `WRITE`-byte words.
pub struct Flash<const ERASE: usize, const WRITE: usize> {
    mem: Vec<u8>,
    /// Which words were programmed since their sector's erase: a word
    /// written with 0xFF is programmed all the same (its ECC on the H743).
    programmed: Vec<bool>,
    power: Rc<Power>,
}

impl<const ERASE: usize, const WRITE: usize> Flash<ERASE, WRITE> {
    /// `size` bytes, erased.
    pub fn erased(size: usize, power: &Rc<Power>) -> Self {
        assert!(size.is_multiple_of(ERASE), "a partition is whole sectors");
        Flash {
            mem: vec![0xFF; size],
            programmed: vec![false; size / WRITE],
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

    /// Its bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.mem
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
            if !self.power.tick() {
                return Err(FlashError::PowerCut);
            }
            self.mem[sector..sector + ERASE].fill(0xFF);
            self.programmed[sector / WRITE..(sector + ERASE) / WRITE].fill(false);
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
            if self.programmed[at / WRITE] {
                self.power
                    .refused_writes
                    .set(self.power.refused_writes.get() + 1);
                return Err(FlashError::NotErased);
            }
            if !self.power.tick() {
                return Err(FlashError::PowerCut);
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
}
