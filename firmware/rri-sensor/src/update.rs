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
use crate::board::update::Partition;
use crate::update_key::{key, KEY};
use core::cell::Cell;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex as Blocking;
use embedded_storage::nor_flash::NorFlash;
use rri_firmware::engine::SensorState;
use rri_firmware::snapshot::Snapshot;
use rri_update::lifecycle::{Image, Lifecycle, Seen, Step, TRIAL_MS};
use rri_update::{Device, FirmwareUpdaterConfig, Outcome, Running, State, Version};
use static_cell::StaticCell;

/// This image, as update files are checked against it.
const RUNNING: Running<'static> = Running {
    board: board::update::BOARD,
    origin: board::update::ORIGIN,
    version: match Version::parse(crate::version::VERSION) {
        Some(v) => v,
        None => panic!("the image's version is major.minor.patch (build.rs checks it)"),
    },
};

type Receiver = Device<Partition, Partition>;

static RECEIVER: StaticCell<Receiver> = StaticCell::new();

fn partitions() -> FirmwareUpdaterConfig<Partition, Partition> {
    let (dfu, state) = board::update::partitions();
    FirmwareUpdaterConfig { dfu, state }
}

/// The state partition's write unit, for embassy-boot's view of it.
type Word = [u8; <Partition as NorFlash>::WRITE_SIZE];

/// The running image's course after an update (`rri_update::lifecycle`):
/// read from the state partition at start-up, ticked by housekeeping.
pub struct Course {
    life: Lifecycle,
}

/// What [`install`] read, for housekeeping to take.
static READ: Blocking<CriticalSectionRawMutex, Cell<Option<Lifecycle>>> =
    Blocking::new(Cell::new(None));

/// Where this image stands (on trial when the bootloader just swapped it
/// in), said in the log and on the status, and the receiver installed in
/// the service's desk (once, before the services run; without a key the
/// service stays read-only). The course exists with or without a key: an
/// image swapped in must confirm itself either way ([`Course::take`]).
pub fn install() {
    let mut word: Word = [0; <Partition as NorFlash>::WRITE_SIZE];
    // A flash not set up for updates was never written by one (and
    // cannot be read through the driver): nothing can be on trial.
    let on_trial = board::update::unavailable().is_none()
        && match rri_update::state(partitions().state, &mut word) {
            Ok(state) => state == State::Swap,
            Err(e) => {
                defmt::warn!(
                    "update: the state partition cannot be read ({=str}): taken as confirmed",
                    e.text()
                );
                false
            }
        };
    let life = Lifecycle::new(on_trial, board::update::SWAPS);
    rri_diag::tasks::DESK.set_image(life.image());
    if on_trial {
        // What the image that marked this one noted: the version this
        // one replaced (the confirmation erases the note).
        let used = rri_update::state_used(
            board::update::active(),
            <Partition as NorFlash>::ERASE_SIZE,
            <Partition as NorFlash>::WRITE_SIZE,
        );
        let previous = rri_update::previous(partitions().state, used);
        rri_diag::tasks::DESK.set_previous(previous);
        match previous {
            Some(v) => defmt::warn!(
                "update: version {=str} was just swapped in, replacing version {=u16}.{=u16}.{=u16}, and is on trial: it confirms itself at OPERATING (or after {=u64} s without a controller); a reset before that brings the previous image back",
                crate::version::VERSION,
                v.major,
                v.minor,
                v.patch,
                rri_update::lifecycle::SELF_TEST_MS / 1000
            ),
            None => defmt::warn!(
                "update: version {=str} was just swapped in (what it replaced is not known) and is on trial: it confirms itself at OPERATING (or after {=u64} s without a controller); a reset before that brings the previous image back",
                crate::version::VERSION,
                rri_update::lifecycle::SELF_TEST_MS / 1000
            ),
        }
    }
    install_receiver();
    READ.lock(|c| c.set(Some(life)));
}

impl Course {
    /// The course [`install`] read (confirmed if it did not run).
    pub fn take() -> Course {
        let life = READ
            .lock(|c| c.take())
            .unwrap_or(Lifecycle::new(false, board::update::SWAPS));
        Course { life }
    }

    /// One tick of housekeeping with the cycle's latest snapshot; `false`:
    /// stop feeding the watchdog (an image on trial that gave up).
    pub fn tick(&mut self, now: &Snapshot) -> bool {
        let st = &now.stats;
        let marked = matches!(rri_diag::tasks::DESK.last(), Outcome::Marked { .. });
        let seen = Seen {
            now_ms: embassy_time::Instant::now().as_millis(),
            operating: now.state == SensorState::Operating,
            heard: st.received > 0
                || st.dropped_decode > 0
                || st.fragments.controller_datagrams > 0,
            marked,
        };
        match self.life.tick(seen) {
            Step::Wait => {}
            Step::Confirm(why) => {
                let mut word: Word = [0; <Partition as NorFlash>::WRITE_SIZE];
                match rri_update::confirm(partitions().state, &mut word) {
                    Ok(()) => defmt::info!(
                        "update: version {=str} confirmed: {=str}",
                        crate::version::VERSION,
                        why.text()
                    ),
                    Err(e) => {
                        defmt::warn!(
                            "update: the confirmation could not be written ({=str}); tried again",
                            e.text()
                        );
                        self.life.confirm_failed();
                    }
                }
            }
            Step::GiveUp => defmt::error!(
                "update: on trial, the controller was heard for {=u64} s and this image never reached OPERATING: the watchdog resets it and the bootloader brings the previous image back",
                TRIAL_MS / 1000
            ),
            Step::Restart => {
                defmt::info!(
                    "update: restarting into the bootloader's swap of the marked image (the controller is not OPERATING)"
                );
                board::restart()
            }
        }
        let image = self.life.image();
        rri_diag::tasks::DESK.set_image(image);
        // Given up: never fed again, until the watchdog's reset.
        image != Image::GaveUp
    }
}

/// Installs the receiver in the service's desk; without a key, or on a
/// board whose flash is not set up for updates (the F767 in single-bank
/// mode), the service stays read-only.
fn install_receiver() {
    if let Some(why) = board::update::unavailable() {
        defmt::error!("updates: none: {=str}; the diagnostics stay read-only", why);
        return;
    }
    let Some(key) = KEY else {
        if key::OFF {
            defmt::info!("updates: none (RRI_UPDATE_KEY=off): the diagnostics stay read-only");
        } else {
            defmt::info!(
                "updates: none (no RRI_UPDATE_KEY at build time; this board takes no demonstration key): the diagnostics stay read-only"
            );
        }
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
