//! # rri-diag: the device tells its own story over the network
//!
//! A status page
//! (`GET /`), the same as JSON (`GET /status.json`) and Prometheus
//! metrics (`GET /metrics`), read-only, on a TCP port of the device's own
//! address (`RRI_HTTP_PORT`, default 80; 0 compiles it out).
//!
//! A low-priority guest of the cycle. What it shows is what the cycle
//! already publishes after each turn (the [`rri_firmware::snapshot::Snapshot`])
//! and what a few cells beside it hold ([`LastBad`], the fragment
//! guard's reply latency, housekeeping's [`events::Events`]); it never
//! holds the engine and the cycle never waits for it. On a board the
//! parsing and rendering run on the background executor and only bytes
//! cross to the network stack on the urgent one (`serve`, feature `net`); the host
//! sensor serves the same responses from a thread.
//!
//! A crate of its own so that it can be optimised for size (the root
//! `Cargo.toml`'s `firmware` profile builds it at `opt-level = "z"`): none
//! of it is on the cycle's path, and at the cycle's `opt-level = 3` its
//! writers were inlined into every caller (tens of KiB of flash for the
//! same bytes). The board's tasks (`tasks`, feature `board`) are
//! defined here for the same reason.
//!
//! Everything here is written once for every form: [`http`] (the request
//! parser and the response head), [`json`] and [`metrics`] over the
//! [`out::Out`] sink, [`counters`] naming every counter once; the page
//! ([`page`]) is static and renders the JSON in the browser.

#![cfg_attr(not(test), no_std)]
// No unsafe code, and no panic outside the tests: the workspace lints
// (Cargo.toml).
#![warn(missing_docs)]

pub mod counters;
pub mod events;
pub mod http;
pub mod json;
pub mod metrics;
pub mod out;
pub mod page;
#[cfg(feature = "net")]
pub mod serve;
pub mod status;
#[cfg(feature = "board")]
pub mod tasks;
pub mod update;
mod view;

pub use out::{Count, Out, Window};
pub use status::{Identity, Status};

use core::cell::Cell;
use critical_section::Mutex;
use rri_firmware::codec::DecodeError;
use rri_firmware::engine::{Endpoint, Instant};
use status::{BadMessage, BAD_MESSAGE_BYTES};

/// Writes the body of `request` (the page compressed when the client
/// takes gzip).
pub fn body(out: &mut dyn Out, request: http::Request, id: &Identity, s: &Status) {
    match request.route {
        http::Route::Page if request.gzip => out.bytes(page::PAGE_GZ),
        http::Route::Page => out.str(page::NO_GZIP),
        http::Route::Json => json::write(out, id, s),
        http::Route::Metrics => metrics::write(out, id, s),
        // Its response is the upload's ([`respond`]); as a body, the line.
        #[cfg(rri_update)]
        http::Route::Firmware => match &s.update {
            Some(u) => update::line(out, u),
            None => out.str("this firmware takes no updates"),
        },
        #[cfg(not(rri_update))]
        http::Route::Firmware => out.str("this firmware takes no updates"),
    }
}

/// Writes the whole response to `request`: the head (with the body's
/// length, from a counting pass) and, unless it is a `HEAD`, the body.
pub fn respond(out: &mut dyn Out, request: http::Request, id: &Identity, s: &Status) {
    if request.route == http::Route::Firmware {
        match &s.update {
            #[cfg(rri_update)]
            Some(u) => update::respond(out, u),
            _ => http::error(out, http::Status::MethodNotAllowed),
        }
        return;
    }
    let mut count = Count::default();
    body(&mut count, request, id, s);
    let gzip = request.gzip && request.route == http::Route::Page;
    http::head(
        out,
        http::Status::Ok,
        request.route.content_type(),
        count.len,
        gzip,
    );
    if !request.head_only {
        body(out, request, id, s);
    }
}

/// The last robot message the decoder rejected, kept for the page: the
/// cycle writes it (a copy of its first [`BAD_MESSAGE_BYTES`] bytes, after
/// the message was dropped: never before an answer), the service reads
/// it.
pub struct LastBad {
    /// Whether one was kept, and the last one (`(false, ` all zero
    /// bytes`)` at first rather than `None`: so that the `static` starts
    /// in `.bss` and costs no flash).
    cell: Mutex<Cell<(bool, BadMessage)>>,
}

impl Default for LastBad {
    fn default() -> Self {
        Self::new()
    }
}

impl LastBad {
    /// None yet (`const`, for a `static`).
    pub const fn new() -> Self {
        LastBad {
            cell: Mutex::new(Cell::new((false, BadMessage::ZERO))),
        }
    }

    /// Keeps `message` (its first bytes), rejected with `error`.
    pub fn record(&self, at: Instant, from: Endpoint, error: DecodeError, message: &[u8]) {
        let mut head = [0u8; BAD_MESSAGE_BYTES];
        for (d, s) in head.iter_mut().zip(message) {
            *d = *s;
        }
        let bad = BadMessage {
            at,
            from,
            kind: error.kind,
            offset: u32::try_from(error.offset).unwrap_or(u32::MAX),
            len: u32::try_from(message.len()).unwrap_or(u32::MAX),
            head,
        };
        critical_section::with(|cs| self.cell.borrow(cs).set((true, bad)));
    }

    /// A copy of the last one.
    pub fn get(&self) -> Option<BadMessage> {
        let (kept, bad) = critical_section::with(|cs| self.cell.borrow(cs).get());
        kept.then_some(bad)
    }
}

#[cfg(test)]
mod tests;
