//! The device's receiver (`rri_update::Device`, what the diagnostics
//! service feeds an upload into) over the QEMU board's partitions
//! (`hal_board::ram_flash`: a NOR flash's rules over RAM), driven as the
//! service drives it: out-of-order calls refused with a type, a second
//! `begin` dropping the first, a whole file checked and marked, the next
//! upload refused until the marked one is dealt with, and a marked one
//! cancelled (but not an image's own trial).

use hal_board::ram_flash::{RamFlash, SECTOR};
use rri_update::{
    sign, Device, FirmwareUpdaterConfig, Receive, Refused, Running, State, Trailer, Version,
    SIGNATURE_LEN, TRAILER_LEN,
};
use std::ptr::addr_of_mut;

const ACTIVE: usize = 2 * SECTOR;
const DFU_LEN: usize = ACTIVE + SECTOR;
static mut DFU: [u8; DFU_LEN] = [0; DFU_LEN];
static mut STATE: [u8; SECTOR] = [0; SECTOR];
const SEED: [u8; 32] = [7; 32];

fn partitions() -> FirmwareUpdaterConfig<RamFlash, RamFlash> {
    // SAFETY: this test's own statics, and one test uses them (one
    // `#[test]` in this file), through one handle pair at a time.
    unsafe {
        FirmwareUpdaterConfig {
            dfu: RamFlash::new(addr_of_mut!(DFU).cast(), DFU_LEN),
            state: RamFlash::new(addr_of_mut!(STATE).cast(), SECTOR),
        }
    }
}

const RUNNING: Running<'static> = Running {
    board: "test-board",
    origin: 0,
    version: Version {
        major: 1,
        minor: 0,
        patch: 0,
    },
};

fn file(len: usize, version: &str) -> Vec<u8> {
    let image: Vec<u8> = (0..len).map(|i| (i % 253) as u8).collect();
    let v = Version::parse(version).unwrap();
    let trailer = Trailer::new("test-board", v, len as u32, 0)
        .unwrap()
        .encode();
    let mut f = image.clone();
    f.extend_from_slice(&trailer);
    f.extend_from_slice(&sign::signature(&image, &trailer, &SEED));
    f
}

#[test]
fn the_receiver_takes_one_upload_at_a_time_and_marks_only_a_checked_file() {
    let mut d = Device::new(partitions, ACTIVE, RUNNING, sign::public_key(&SEED), false);
    assert!(!d.swaps());
    // Nothing begun: pieces and a finish are refused, not a panic.
    assert_eq!(d.push(b"x"), Err(Refused::NoUpload));
    assert_eq!(d.finish(false), Err(Refused::NoUpload));
    // Too large for the active partition (the update partition's last
    // sector is the swap's scratch).
    assert_eq!(
        d.begin(ACTIVE + 1),
        Err(Refused::TooLarge {
            declared: ACTIVE + 1,
            capacity: ACTIVE
        })
    );
    // An upload dropped half-way by a second begin leaves nothing behind.
    let f = file(5000, "1.0.1");
    d.begin(f.len()).unwrap();
    d.push(&f[..3000]).unwrap();
    d.begin(f.len()).unwrap();
    for piece in f.chunks(777) {
        d.push(piece).unwrap();
    }
    let t = d.finish(false).unwrap();
    assert_eq!(t.version, Version::parse("1.0.1").unwrap());
    // Finished: the receiver holds no upload any more.
    assert_eq!(d.push(b"x"), Err(Refused::NoUpload));
    // Marked: the bootloader's state says swap, and a second upload is
    // refused until it is dealt with (a reset swaps it in).
    let FirmwareUpdaterConfig { mut state, .. } = partitions();
    assert_eq!(rri_update::state(&mut state, &mut [0; 4]), Ok(State::Swap));
    // The running version noted past embassy-boot's words, for the new
    // image to say what it replaced.
    assert_eq!(d.previous(), Some(RUNNING.version));
    assert_eq!(
        d.begin(f.len()),
        Err(Refused::NotConfirmed),
        "one marked already"
    );
    d.abandon();
    // On trial (as the running image would be after its own swap, whose
    // state also says swap), the mark is not cancelled: only the image's
    // confirmation or its rollback ends that.
    assert_eq!(d.cancel(true), Err(Refused::OnTrial));
    assert_eq!(rri_update::state(&mut state, &mut [0; 4]), Ok(State::Swap));
    // Cancelled before its swap: the state says boot, and a new upload is
    // taken again.
    assert_eq!(d.cancel(false), Ok(()));
    assert_eq!(rri_update::state(&mut state, &mut [0; 4]), Ok(State::Boot));
    assert_eq!(
        d.previous(),
        None,
        "the cancellation's erase takes the note"
    );
    // No room past embassy-boot's words: no note, and nothing written.
    let FirmwareUpdaterConfig { state: full, .. } = partitions();
    assert_eq!(
        rri_update::note_previous(full, RUNNING.version, SECTOR - 4),
        Err(Refused::Buffer)
    );
    let FirmwareUpdaterConfig { state: s2, .. } = partitions();
    assert_eq!(rri_update::previous(s2, 0), None);
    assert_eq!(d.cancel(false), Err(Refused::NothingMarked));
    d.begin(f.len()).unwrap();
    for piece in f.chunks(4096) {
        d.push(piece).unwrap();
    }
    assert!(d.finish(false).is_ok(), "marked again after the cancel");
    assert_eq!(rri_update::state(&mut state, &mut [0; 4]), Ok(State::Swap));
    assert_eq!(
        f.len(),
        5000 + TRAILER_LEN + SIGNATURE_LEN,
        "the file is image, trailer, signature"
    );
}
