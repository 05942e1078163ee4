//! The body of a `PUT /firmware` (issue 43), on the background executor
//! like the rest of the service half: its bytes from the slot's inbound
//! pipe into the desk's receiver, bounded, and the outcome recorded. Only
//! where the upload's path is built (cfg `rri_update`).

use super::{Desk, Slot, BODY_STALL};
use crate::http::Body;
use core::sync::atomic::Ordering;
use embassy_futures::select::{select3, Either3};
use embassy_time::with_timeout;
use rri_update::Outcome;

/// Takes a `PUT /firmware`'s body (`first`: the bytes that came with the
/// head) into the desk's receiver and records the outcome; `false` when
/// another upload holds the receiver (one at a time). Bounded: the body's
/// `Content-Length`, [`BODY_STALL`] without a byte (abandoned), and the
/// network half's [`super::UPLOAD_TIMEOUT`] for the whole connection.
pub(super) async fn receive(
    slot: &Slot,
    desk: &Desk,
    body: Body,
    first: &[u8],
    buf: &mut [u8; 64],
) -> bool {
    let Some(mut guard) = desk.try_take() else {
        return false;
    };
    let Some(receiver) = guard.as_mut() else {
        return false;
    };
    slot.long.store(true, Ordering::Relaxed);
    let declared = body.length;
    let mut received = 0u32;
    let outcome = 'upload: {
        if let Err(e) = receiver.begin(declared as usize) {
            break 'upload Outcome::Refused(e);
        }
        let mut piece = first;
        loop {
            // Bytes past the Content-Length would be another request's:
            // one request per connection, so they are not read.
            let room = (declared - received) as usize;
            let take = piece.get(..room.min(piece.len())).unwrap_or(&[]);
            if let Err(e) = receiver.push(take) {
                receiver.abandon();
                break 'upload Outcome::Refused(e);
            }
            received += take.len() as u32;
            desk.set(Outcome::Receiving { received, declared });
            if received == declared {
                break;
            }
            // The client's close ends the wait as soon as the pipe is
            // empty (its bytes came before its close).
            if let Ok(n) = slot.inbound.try_read(buf.as_mut_slice()) {
                piece = buf.get(..n).unwrap_or(&[]);
                // The other tasks of this executor run between two pieces,
                // housekeeping (the watchdog's feeding) among them: the
                // network half refills the pipe from another executor,
                // so a pipe that never empties would otherwise keep this
                // loop from ever awaiting. The rehosted F767, whose flash
                // programs a word in up to 100 us, was reset by its
                // watchdog in the middle of an upload before this.
                embassy_futures::yield_now().await;
                continue;
            }
            let read = select3(
                with_timeout(BODY_STALL, slot.inbound.read(buf.as_mut_slice())),
                slot.gone.wait(),
                slot.ended.wait(),
            )
            .await;
            match read {
                Either3::First(Ok(n)) => piece = buf.get(..n).unwrap_or(&[]),
                Either3::Third(()) if !slot.inbound.is_empty() => {
                    // Read what is left before the close counts.
                    slot.ended.signal(());
                    piece = &[];
                }
                Either3::First(Err(_)) | Either3::Second(()) | Either3::Third(()) => {
                    receiver.abandon();
                    break 'upload Outcome::Abandoned { received, declared };
                }
            }
        }
        match receiver.finish(body.force) {
            Ok(trailer) => Outcome::Marked {
                version: trailer.version,
                older: trailer.version < receiver.running(),
            },
            Err(e) => Outcome::Refused(e),
        }
    };
    desk.set(outcome);
    #[cfg(feature = "board")]
    log(&outcome);
    true
}

/// A `DELETE /firmware`: the marked update cancelled before its swap
/// (refused while the running image is on trial, or with nothing marked),
/// and the outcome recorded; `false` when an upload holds the receiver.
pub(super) fn cancel(desk: &Desk) -> bool {
    let Some(mut guard) = desk.try_take() else {
        return false;
    };
    let Some(receiver) = guard.as_mut() else {
        return false;
    };
    let on_trial = desk.image() != rri_update::lifecycle::Image::Confirmed;
    let outcome = match receiver.cancel(on_trial) {
        Ok(()) => Outcome::Cancelled,
        Err(e) => Outcome::Refused(e),
    };
    desk.set(outcome);
    #[cfg(feature = "board")]
    log(&outcome);
    true
}

/// The outcome in the device's log.
#[cfg(feature = "board")]
fn log(outcome: &Outcome) {
    match outcome {
                Outcome::Marked {
            version,
            older: false,
        } => defmt::info!(
            "update: version {}.{}.{} checked and marked for the swap",
            version.major,
            version.minor,
            version.patch
        ),
        Outcome::Marked {
            version,
            older: true,
        } => defmt::warn!(
            "update: FORCED: version {}.{}.{}, older than the running image, checked and marked for the swap",
            version.major,
            version.minor,
            version.patch
        ),
        Outcome::Refused(r) => defmt::warn!("update refused: {=str}", r.text()),
        Outcome::Cancelled => {
            defmt::info!("update: the marked update was cancelled; this image stays")
        }
        Outcome::Abandoned { received, declared } => defmt::warn!(
            "update abandoned after {} of {} bytes: nothing marked",
            received,
            declared
        ),
        Outcome::None | Outcome::Receiving { .. } => {}
    }
}
