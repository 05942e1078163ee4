//! A NOR flash over a region of RAM, for a board that has no flash of its
//! own (QEMU's mps2-an500 runs from SSRAM): the update and state
//! partitions of issue 43, with a flash's rules kept so that code written
//! for the NUCLEO boards' flash is held to them here too.
//!
//! - An erase sets a whole number of [`SECTOR`]s to `0xFF`.
//! - A write programs whole [`WORD`]s, aligned, and only words that are
//!   erased: as on the H743 (ECC words are programmed once between
//!   erases), programming a word twice is refused, not silently ANDed.
//! - Reads take any offset and length.
//!
//! Why a region of RAM survives a reset there: QEMU's reset copies the
//! ELF's segments back (the code, `.data`) and nothing else, so a region
//! no section is linked into keeps its bytes across it, as the crash
//! record does (`memory/mps2-an500.x` places the partitions). Quitting
//! QEMU is a power cut that loses them: a fresh QEMU starts with the
//! region all zero, which reads as no update pending.
#![allow(unsafe_code)]

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Erase granularity.
pub const SECTOR: usize = 4096;
/// Program granularity.
pub const WORD: usize = 4;

/// Why an operation was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// Not on a sector or word boundary.
    NotAligned,
    /// Past the region.
    OutOfBounds,
    /// A word that is not erased was to be programmed.
    NotErased,
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Error::NotAligned => NorFlashErrorKind::NotAligned,
            Error::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Error::NotErased => NorFlashErrorKind::Other,
        }
    }
}

/// A handle on one partition: `len` bytes of RAM from `base`.
pub struct RamFlash {
    base: *mut u8,
    len: usize,
}

// SAFETY: the handle is an address and a length; the memory is a region
// no Rust object owns (the memory map keeps every section out of it), and
// its users take one handle at a time (the update desk's mutex).
unsafe impl Send for RamFlash {}

impl RamFlash {
    /// A handle on `[base, base + len)`.
    ///
    /// # Safety
    /// The region is RAM no Rust object lives in, and no other handle on
    /// it is used while this one is.
    pub const unsafe fn new(base: *mut u8, len: usize) -> Self {
        RamFlash { base, len }
    }

    fn range(&self, offset: u32, len: usize) -> Result<usize, Error> {
        let from = offset as usize;
        match from.checked_add(len) {
            Some(to) if to <= self.len => Ok(from),
            _ => Err(Error::OutOfBounds),
        }
    }
}

impl ErrorType for RamFlash {
    type Error = Error;
}

impl ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        let from = self.range(offset, bytes.len())?;
        // SAFETY: inside the region (checked above), which `new`'s caller
        // promised is ours alone.
        unsafe {
            core::ptr::copy_nonoverlapping(self.base.add(from), bytes.as_mut_ptr(), bytes.len())
        };
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.len
    }
}

impl NorFlash for RamFlash {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = SECTOR;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        if from > to
            || !(from as usize).is_multiple_of(SECTOR)
            || !(to as usize).is_multiple_of(SECTOR)
        {
            return Err(Error::NotAligned);
        }
        let at = self.range(from, (to - from) as usize)?;
        // SAFETY: inside the region, as for `read`.
        unsafe { core::ptr::write_bytes(self.base.add(at), 0xFF, (to - from) as usize) };
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        if !(offset as usize).is_multiple_of(WORD) || !bytes.len().is_multiple_of(WORD) {
            return Err(Error::NotAligned);
        }
        let at = self.range(offset, bytes.len())?;
        // SAFETY: inside the region, as for `read`.
        let target = unsafe { core::slice::from_raw_parts_mut(self.base.add(at), bytes.len()) };
        if target.iter().any(|&b| b != 0xFF) {
            return Err(Error::NotErased);
        }
        target.copy_from_slice(bytes);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn region(len: usize) -> RamFlash {
        let mem: &'static mut [u8] = Vec::leak(vec![0u8; len]);
        // SAFETY: a leaked buffer nothing else uses.
        unsafe { RamFlash::new(mem.as_mut_ptr(), len) }
    }

    #[test]
    fn it_keeps_a_flash_rules() {
        let mut f = region(2 * SECTOR);
        let mut b = [0u8; 8];
        // Fresh RAM is zero: not erased, so a write is refused.
        assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(Error::NotErased));
        f.erase(0, SECTOR as u32).unwrap();
        f.read(SECTOR as u32 - 4, &mut b).unwrap();
        assert_eq!(b, [0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]);
        f.write(4, &[1, 2, 3, 4]).unwrap();
        // Programmed once between erases.
        assert_eq!(f.write(4, &[1, 2, 3, 4]), Err(Error::NotErased));
        f.read(3, &mut b[..3]).unwrap();
        assert_eq!(&b[..3], &[0xFF, 1, 2]);
        assert_eq!(f.write(2, &[0; 4]), Err(Error::NotAligned));
        assert_eq!(f.write(0, &[0; 3]), Err(Error::NotAligned));
        assert_eq!(f.erase(1, SECTOR as u32), Err(Error::NotAligned));
        assert_eq!(f.erase(0, 3 * SECTOR as u32), Err(Error::OutOfBounds));
        assert_eq!(
            f.read(2 * SECTOR as u32 - 1, &mut b[..2]),
            Err(Error::OutOfBounds)
        );
        assert_eq!(f.read(u32::MAX, &mut b[..2]), Err(Error::OutOfBounds));
        f.erase(0, SECTOR as u32).unwrap();
        f.write(4, &[9; 4]).unwrap();
    }
}
