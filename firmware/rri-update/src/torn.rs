//! The state partition as embassy-boot and the device must read it after
//! a power cut that tore a write ([`TornAsProgrammed`]).
//!
//! A cut falls inside a flash operation, not between two: a flash word
//! half-programmed, or a sector half-erased, holds bits its ECC does not
//! agree with (the H743: 10 ECC bits per 256-bit flash word, a double
//! error detected, not corrected; RM0433's embedded flash chapter). Such a
//! word reads back as an error until its sector is erased, and can no
//! longer be programmed. In the state partition every write is one of
//! embassy-boot's marks (0.7's `set_magic`: "progress invalid", the
//! sector's erase, the magic; the swap's progress words, each written
//! after its page's copy finished) or our note after the mark. Read as
//! *programmed* (all zero bytes: no magic, a progress or validity word
//! written), a torn word leads each reader to a whole image:
//!
//! - a torn progress word: its page's copy had finished, so the swap or
//!   the rollback goes on with the next page;
//! - a torn "progress invalid" word: that is what it says (the last steps
//!   of a mark, a rollback or a confirmation: `boot::prepare` finishes
//!   them, and `set_magic` then erases the sector);
//! - a torn magic, or a sector whose erase was torn: no magic, so the
//!   image in the active partition boots (the old one if the mark was
//!   torn, the update then lost; the new one if its confirmation was),
//!   and its confirmation erases the sector;
//! - a torn note: no note (the new image does not say what it replaced).
//!
//! `host-tests/tests/update_power_cut.rs` tears each of an update's flash
//! operations against the host's flash model, which reports a torn word
//! as a read error of kind `Other`. On the H743 both images read the
//! flash carefully (`hal_board::h743_ecc`: bus faults ignored under
//! `FAULTMASK`, then `FLASH_SR`'s `DBECCERR`), which reports a torn word
//! so too, where embassy-stm32's plain loads would take a precise bus
//! fault at every start; `cargo power-cut -- --tear` checks it on the
//! rehosted chip, whose flash model has the ECC. The F767's flash has no
//! ECC: a torn word there reads as some mix of its old and new bits, with
//! no error, so this adapter passes it through as it reads; embassy-boot's
//! own readings hold for it (a progress word with a byte still erased is
//! a step not done, and is redone; a magic not whole is no magic). The
//! host's flash model (`Power::mix_bits`) and the rehosted F767 (`--tear`)
//! tear that way.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// `S` read a write unit at a time where a read fails with an error of
/// kind `Other` (the one a torn word gives), each such unit given as
/// zero bytes (programmed); alignment and range errors stay errors.
/// Writes and erases pass through.
pub struct TornAsProgrammed<S>(pub S);

impl<S: ErrorType> ErrorType for TornAsProgrammed<S> {
    type Error = S::Error;
}

impl<S: NorFlash> ReadNorFlash for TornAsProgrammed<S> {
    const READ_SIZE: usize = S::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), S::Error> {
        match self.0.read(offset, bytes) {
            Err(e) if e.kind() == NorFlashErrorKind::Other => {}
            done => return done,
        }
        // A write unit at a time: the units that do not read back are
        // given as programmed, the others as they are.
        let unit = S::WRITE_SIZE.max(1);
        let start = offset as usize;
        let mut done = 0;
        while done < bytes.len() {
            let at = start + done;
            let len = (unit - at % unit).min(bytes.len() - done);
            let Some(part) = bytes.get_mut(done..done + len) else {
                break;
            };
            match self.0.read(at as u32, part) {
                Err(e) if e.kind() == NorFlashErrorKind::Other => part.fill(0),
                other => other?,
            }
            done += len;
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl<S: NorFlash> NorFlash for TornAsProgrammed<S> {
    const WRITE_SIZE: usize = S::WRITE_SIZE;
    const ERASE_SIZE: usize = S::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), S::Error> {
        self.0.erase(from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), S::Error> {
        self.0.write(offset, bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 64 bytes in 16-byte units; `torn` units fail to read (kind
    /// `Other`).
    struct Torn {
        mem: [u8; 64],
        torn: [bool; 4],
    }

    #[derive(Debug, PartialEq)]
    struct E(NorFlashErrorKind);

    impl NorFlashError for E {
        fn kind(&self) -> NorFlashErrorKind {
            self.0
        }
    }

    impl ErrorType for Torn {
        type Error = E;
    }

    impl ReadNorFlash for Torn {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), E> {
            let start = offset as usize;
            let end = start + bytes.len();
            if end > 64 {
                return Err(E(NorFlashErrorKind::OutOfBounds));
            }
            if !bytes.is_empty() && self.torn[start / 16..=(end - 1) / 16].contains(&true) {
                return Err(E(NorFlashErrorKind::Other));
            }
            bytes.copy_from_slice(&self.mem[start..end]);
            Ok(())
        }
        fn capacity(&self) -> usize {
            64
        }
    }

    impl NorFlash for Torn {
        const WRITE_SIZE: usize = 16;
        const ERASE_SIZE: usize = 64;
        fn erase(&mut self, _: u32, _: u32) -> Result<(), E> {
            self.mem = [0xFF; 64];
            self.torn = [false; 4];
            Ok(())
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), E> {
            let start = offset as usize;
            self.mem[start..start + bytes.len()].copy_from_slice(bytes);
            Ok(())
        }
    }

    #[test]
    fn a_torn_unit_reads_as_programmed_and_its_neighbours_as_they_are() {
        let mut f = TornAsProgrammed(Torn {
            mem: [0xFF; 64],
            torn: [false, true, false, false],
        });
        f.0.mem[..16].fill(0xD0);
        let mut buf = [0x55; 40];
        // Across units 0, 1 and half of 2, from an unaligned offset.
        f.read(8, &mut buf).unwrap();
        assert_eq!(buf[..8], [0xD0; 8]);
        assert_eq!(buf[8..24], [0; 16], "the torn unit");
        assert_eq!(buf[24..], [0xFF; 16]);
        // Other errors stay errors.
        assert_eq!(
            f.read(60, &mut [0; 8]),
            Err(E(NorFlashErrorKind::OutOfBounds))
        );
        // The sector's erase mends it.
        f.erase(0, 64).unwrap();
        f.read(16, &mut buf[..16]).unwrap();
        assert_eq!(buf[..16], [0xFF; 16]);
    }
}
