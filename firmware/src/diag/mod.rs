//! The device tells its own story over the network: a status page
//! (`GET /`), the same as JSON (`GET /status.json`) and Prometheus
//! metrics (`GET /metrics`), read-only, on a TCP port of the device's own
//! address (`RRI_HTTP_PORT`, default 80; 0 compiles it out).
//!
//! A low-priority guest of the cycle. What it shows is what the cycle
//! already publishes after each turn (the [`crate::snapshot::Snapshot`])
//! and what a few cells beside it hold ([`LastBad`], the fragment
//! guard's reply latency, housekeeping's [`events::Events`]); it never
//! holds the engine and the cycle never waits for it. On a board the
//! parsing and rendering run on the background executor and only bytes
//! cross to the network stack on the urgent one ([`serve`]); the host
//! sensor serves the same responses from a thread.
//!
//! Everything here is written once for every form: [`http`] (the request
//! parser and the response head), [`json`] and [`metrics`] over the
//! [`out::Out`] sink, [`counters`] naming every counter once; the page
//! ([`page`]) is static and renders the JSON in the browser.

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
mod view;

pub use out::{Count, Out, Window};
pub use status::{Identity, Status};

use crate::codec::DecodeError;
use crate::engine::{Endpoint, Instant};
use core::cell::Cell;
use critical_section::Mutex;
use status::{BadMessage, BAD_MESSAGE_BYTES};

/// Writes the body of `route`.
pub fn body(out: &mut dyn Out, route: http::Route, id: &Identity, s: &Status) {
    match route {
        http::Route::Page => out.str(page::PAGE),
        http::Route::Json => json::write(out, id, s),
        http::Route::Metrics => metrics::write(out, id, s),
    }
}

/// Writes the whole response to `request`: the head (with the body's
/// length, from a counting pass) and, unless it is a `HEAD`, the body.
pub fn respond(out: &mut dyn Out, request: http::Request, id: &Identity, s: &Status) {
    let mut count = Count::default();
    body(&mut count, request.route, id, s);
    http::head(
        out,
        http::Status::Ok,
        request.route.content_type(),
        count.len,
    );
    if !request.head_only {
        body(out, request.route, id, s);
    }
}

/// The last robot message the decoder rejected, kept for the page: the
/// cycle writes it (a copy of its first [`BAD_MESSAGE_BYTES`] bytes, after
/// the message was dropped: never before an answer), the service reads
/// it.
pub struct LastBad {
    cell: Mutex<Cell<Option<BadMessage>>>,
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
            cell: Mutex::new(Cell::new(None)),
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
        critical_section::with(|cs| self.cell.borrow(cs).set(Some(bad)));
    }

    /// A copy of the last one.
    pub fn get(&self) -> Option<BadMessage> {
        critical_section::with(|cs| self.cell.borrow(cs).get())
    }
}
