//! Update in the cell (issue 43), on a board with update partitions and
//! the diagnostics service (cfg `rri_update`): the device's receiver,
//! installed in the service's desk, so that `PUT /firmware` writes an
//! update file into the board's update partition, checks it against the
//! key built in and marks it for the swap (`rri_update`).
//!
//! The key: the file `RRI_UPDATE_KEY` named at build time; without it,
//! on the QEMU board alone, the demonstration key in the checkout
//! (`firmware/rri-update/demo-key/`: anyone can sign with it). A board
//! that is a product never takes that one: the build fails.

use crate::board;
use hal_board::ram_flash::RamFlash;
use rri_update::{Device, FirmwareUpdaterConfig, Running, Version};
use static_cell::StaticCell;

mod key {
    include!(concat!(env!("OUT_DIR"), "/update_key.rs"));
}

/// The key update files must be signed with, if any.
const KEY: Option<[u8; 32]> = match (key::KEY, board::update::DEMO_KEY_ALLOWED) {
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

/// This image, as update files are checked against it.
const RUNNING: Running<'static> = Running {
    board: board::update::BOARD,
    origin: board::update::ORIGIN,
    version: match Version::parse(env!("CARGO_PKG_VERSION")) {
        Some(v) => v,
        None => panic!("rri-sensor's version is major.minor.patch"),
    },
};

type Receiver = Device<RamFlash, RamFlash>;

static RECEIVER: StaticCell<Receiver> = StaticCell::new();

fn partitions() -> FirmwareUpdaterConfig<RamFlash, RamFlash> {
    let (dfu, state) = board::update::partitions();
    FirmwareUpdaterConfig { dfu, state }
}

/// Installs the receiver in the service's desk (once, before the
/// services run); without a key the service stays read-only.
pub fn install() {
    let Some(key) = KEY else {
        defmt::info!("updates: not built in (no RRI_UPDATE_KEY)");
        return;
    };
    let Some(receiver) = RECEIVER.try_init(Device::new(
        partitions,
        board::update::active(),
        RUNNING,
        key,
        board::update::SWAPS,
    )) else {
        return;
    };
    if rri_diag::tasks::DESK.install(receiver) {
        defmt::info!(
            "updates: PUT /firmware takes files signed for {=str}{=str}",
            board::update::BOARD,
            if key == key::DEMO {
                " with the demonstration key (anyone can sign with it)"
            } else {
                ""
            }
        );
    }
}
