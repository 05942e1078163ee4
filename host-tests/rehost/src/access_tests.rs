//! The power cut as the flash array sees it (`settle`): on each chip the
//! operation the cut falls on is torn once, and nothing the core hands
//! the array after it gets there.

use super::settle;
use crate::machine::Machine;

/// A word of bank 2 (erased on the test machines), and the one after.
const AT: u32 = 0x0810_0000;
const NEXT: u32 = AT + 32;

/// The cut falls on a program of 32 zero bytes at [`AT`], torn; then,
/// before the power goes, the core hands the array another program.
fn cut_then_more(m: &mut Machine) {
    let s = m.uc.get_data_mut();
    s.shared.flash.tear = true;
    s.shared.flash.cut = true;
    s.shared.flash.kept = Some(0);
    s.shared.flash.cut_op = Some((AT, 32, false));
    s.shared.program.push((AT, vec![0; 32]));
    settle(&mut m.uc);
    m.uc.get_data_mut().shared.program.push((NEXT, vec![0; 32]));
    settle(&mut m.uc);
}

fn read(m: &Machine, at: u32) -> Vec<u8> {
    m.uc.mem_read_as_vec(u64::from(at), 32).unwrap()
}

#[test]
fn on_the_f767_a_torn_program_leaves_one_mix_and_nothing_after_it() {
    let mut m = crate::machine::testing::f767(&[]);
    cut_then_more(&mut m);
    let word = read(&m, AT);
    assert!(word != [0; 32] && word != [0xFF; 32], "a mix: {word:x?}");
    let (_, changed, of) = m.uc.get_data().shared.flash.mixed.unwrap();
    // Once: the second settle would have found the mix's bits cleared
    // already and counted none of the rest as changed.
    let cleared: u32 = word.iter().map(|b| b.count_zeros()).sum();
    assert_eq!((changed, of), (u64::from(cleared), 256));
    assert_eq!(read(&m, NEXT), [0xFF; 32], "a program after the cut");
    // The ITCM alias shows the same array.
    assert_eq!(m.uc.mem_read_as_vec(0x0030_0000, 32).unwrap(), word);
}

#[test]
fn on_the_h743_a_torn_program_tears_its_word_and_nothing_after_it() {
    let mut m = crate::machine::testing::h743(&[]);
    cut_then_more(&mut m);
    let flash = &m.uc.get_data().shared.flash;
    assert_eq!(flash.torn.iter().copied().collect::<Vec<_>>(), [AT]);
    assert_eq!(read(&m, AT), [0; 32], "the program's bytes, half-made");
    assert_eq!(read(&m, NEXT), [0xFF; 32], "a program after the cut");
}
