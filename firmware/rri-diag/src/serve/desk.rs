//! The update desk (issue 43): the device's one [`Receive`], shared by the
//! connection slots so that one upload at a time reaches the flash, and
//! what the last upload came to, for every response's status.

use super::Cs;
use crate::update::Update;
use core::cell::Cell;
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use embassy_sync::blocking_mutex::Mutex as Blocking;
use embassy_sync::mutex::Mutex;
use rri_update::lifecycle::Image;
use rri_update::{Outcome, Receive, Version};

/// Where uploads go. Without a receiver installed (a firmware built
/// without an update key, or a board without update partitions) the
/// service stays read-only: `PUT` is 405.
pub struct Desk {
    receiver: Mutex<Cs, Option<&'static mut (dyn Receive + Send)>>,
    installed: AtomicBool,
    swaps: AtomicBool,
    last: Blocking<Cs, Cell<Outcome>>,
    image: AtomicU8,
    previous: Blocking<Cs, Cell<Option<Version>>>,
}

impl Default for Desk {
    fn default() -> Self {
        Self::new()
    }
}

impl Desk {
    /// No receiver yet (`const`, for a `static`).
    pub const fn new() -> Self {
        Desk {
            receiver: Mutex::new(None),
            installed: AtomicBool::new(false),
            swaps: AtomicBool::new(false),
            last: Blocking::new(Cell::new(Outcome::None)),
            image: AtomicU8::new(Image::Confirmed.code()),
            previous: Blocking::new(Cell::new(None)),
        }
    }

    /// Takes the device's receiver (once, at start-up, before the service
    /// runs); `false` if one is there already.
    pub fn install(&self, receiver: &'static mut (dyn Receive + Send)) -> bool {
        let Ok(mut slot) = self.receiver.try_lock() else {
            return false;
        };
        if slot.is_some() {
            return false;
        }
        self.swaps.store(receiver.swaps(), Ordering::Relaxed);
        *slot = Some(receiver);
        self.installed.store(true, Ordering::Release);
        true
    }

    /// Whether uploads are taken.
    pub fn takes_updates(&self) -> bool {
        self.installed.load(Ordering::Acquire)
    }

    /// The receiver, unless another upload holds it.
    #[cfg(rri_update)]
    pub(super) fn try_take(
        &self,
    ) -> Option<embassy_sync::mutex::MutexGuard<'_, Cs, Option<&'static mut (dyn Receive + Send)>>>
    {
        self.receiver.try_lock().ok()
    }

    /// Records what the upload has come to.
    pub fn set(&self, outcome: Outcome) {
        self.last.lock(|c| c.set(outcome));
    }

    /// Where the running image stands (the board's housekeeping says it:
    /// on trial after a swap until it confirms itself).
    pub fn set_image(&self, image: Image) {
        self.image.store(image.code(), Ordering::Relaxed);
    }

    /// The version this image replaced (the board reads it at start-up,
    /// after a swap).
    pub fn set_previous(&self, previous: Option<Version>) {
        self.previous.lock(|c| c.set(previous));
    }

    /// Where the running image stands.
    pub fn image(&self) -> Image {
        Image::from_code(self.image.load(Ordering::Relaxed))
    }

    /// The last upload's outcome.
    pub fn last(&self) -> Outcome {
        self.last.lock(|c| c.get())
    }

    /// The status's `update` section (`None` without updates).
    pub fn update(&self) -> Option<Update> {
        self.takes_updates().then(|| Update {
            swaps: self.swaps.load(Ordering::Relaxed),
            last: self.last(),
            image: self.image(),
            previous: self.previous.lock(|c| c.get()),
        })
    }
}
