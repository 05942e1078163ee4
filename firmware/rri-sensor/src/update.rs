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
//! `RRI_UPDATE_KEY=off` builds no key in, on any board: `PUT` is then 405
//! as any other method the service does not take.

use crate::board;
use crate::update_key::{key, KEY};
use hal_board::ram_flash::RamFlash;
use rri_update::{Device, FirmwareUpdaterConfig, Running, Version};
use static_cell::StaticCell;

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
        defmt::info!("updates: none (RRI_UPDATE_KEY=off): the diagnostics stay read-only");
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
