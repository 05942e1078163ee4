//! The key update files must be signed with (issue 43), on every board:
//! the file `RRI_UPDATE_KEY` named at build time; without it, on the QEMU
//! board alone, the demonstration key in the checkout
//! (`firmware/rri-update/demo-key/`: anyone can sign with it);
//! `RRI_UPDATE_KEY=off`, none. A board that is a product never takes the
//! demonstration key: the build fails, whether or not the board takes
//! updates yet.

use crate::board;

pub mod key {
    include!(concat!(env!("OUT_DIR"), "/update_key.rs"));
}

/// The key update files must be signed with, if any.
pub const KEY: Option<[u8; 32]> = match (key::KEY, board::update::DEMO_KEY_ALLOWED) {
    _ if key::OFF => None,
    (Some(k), _) => Some(k),
    (None, true) => Some(key::DEMO),
    (None, false) => None,
};

const _: () = {
    if let Some(k) = KEY {
        let mut same = true;
        let mut i = 0;
        while i < 32 {
            same &= k[i] == key::DEMO[i];
            i += 1;
        }
        assert!(
            board::update::DEMO_KEY_ALLOWED || !same,
            "RRI_UPDATE_KEY is the demonstration key, which anyone can sign with: build a board with your own (`cargo sign-image -- keygen`)"
        );
    }
};
