//! A flash operation torn by a power cut on a flash without ECC (`--tear`
//! on the F767).
//!
//! The F767's flash has no ECC (RM0410 §3: no ECC section, no ECC flag in
//! FLASH_SR; the H743's is [`crate::torn_word`]), so nothing tells a
//! reader that an operation was cut short: a word a program did not
//! finish, or a sector an erase did not, reads back as it is. Neither the
//! reference manual nor the datasheet says which bits an interrupted
//! operation reaches: a program only clears bits and an erase only sets
//! them (§3.3.7), and each cell gets there on its own. ST's EEPROM
//! emulation (AN3969, AN4894) therefore treats an interrupted erase as
//! leaving a page of unknown content, to be erased again.
//!
//! The model: of the bits the operation was changing (a program's cleared
//! bits, an erase's set ones) each either changed or not, chosen by a
//! seeded generator (SplitMix64: about half of them, in no order a
//! reader could rely on); every other bit is as it was. Reads then return
//! that mix, stable, with no error: a reader learns of the cut only from
//! what the bits say. The seed is the operation's number unless
//! `--tear-seed` gives one, so each cut is one reproducible mix.

use crate::bit_mix::mix;
use crate::state::State;
use unicorn_engine::Unicorn;

/// At a torn cut on a flash without ECC: what the operation the cut fell
/// on leaves in the array, as a write to make (`own`: a program's bytes;
/// an erase was making its sector all ones). Noted in
/// [`crate::bus::FlashOps::mixed`].
pub fn tear(uc: &mut Unicorn<State>, own: Option<Vec<u8>>) -> Option<(u32, Vec<u8>)> {
    let flash = &uc.get_data().shared.flash;
    let (addr, len, erase) = flash.cut_op?;
    let seed = flash.tear_seed.unwrap_or(flash.started);
    let target = if erase {
        vec![0xFF; len as usize]
    } else {
        own?
    };
    let old = uc.mem_read_as_vec(u64::from(addr), target.len()).ok()?;
    let (bytes, changed, differing) = mix(&old, &target, seed);
    uc.get_data_mut().shared.flash.mixed = Some((addr, changed, differing));
    Some((addr, bytes))
}
