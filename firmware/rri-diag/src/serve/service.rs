//! The service half of a connection slot, on the background executor:
//! reads and parses the request from the slot's inbound pipe, renders the
//! response window by window into its outbound pipe ([`super`] has the
//! slot, the socket half and the bounds).

use super::{Cs, Renderer, ServiceHalf, Slot, PIECE, REQUEST_TIMEOUT, STALL_TIMEOUT};
use crate::http::{self, Parsed, Parser};
use crate::{Identity, Status, Window};
use embassy_futures::select::{select, Either};
use embassy_sync::mutex::Mutex;
use embassy_time::with_timeout;

/// The service half of a slot, forever: waits for a connection, reads and
/// parses its request within [`REQUEST_TIMEOUT`], renders the response
/// into the outbound pipe. Runs on the background executor.
pub async fn service(
    slot: &Slot,
    half: &mut ServiceHalf,
    renderer: &Mutex<Cs, Renderer>,
    id: &Identity,
    status: fn(&mut Option<Status>),
) -> ! {
    let ServiceHalf { parser, buf } = half;
    loop {
        slot.opened.wait().await;
        let request = async {
            *parser = Parser::new();
            loop {
                let n = slot.inbound.read(buf.as_mut_slice()).await;
                match parser.feed(buf.get(..n).unwrap_or(&[])) {
                    Parsed::More => continue,
                    done => return done,
                }
            }
        };
        let verdict = match select(with_timeout(REQUEST_TIMEOUT, request), slot.gone.wait()).await {
            Either::First(Ok(v)) => Some(v),
            Either::First(Err(_)) => Some(Parsed::Refused(http::Status::RequestTimeout)),
            Either::Second(()) => None,
        };
        slot.heard
            .store(true, core::sync::atomic::Ordering::Relaxed);
        if let Some(verdict) = verdict {
            let respond = respond(slot, renderer, id, status, verdict);
            let _ = select(respond, slot.gone.wait()).await;
        }
        slot.finished.signal(());
    }
}

/// Renders the response to `verdict` window by window into the slot's
/// outbound pipe.
async fn respond(
    slot: &Slot,
    renderer: &Mutex<Cs, Renderer>,
    id: &Identity,
    status: fn(&mut Option<Status>),
    verdict: Parsed,
) {
    let mut r = renderer.lock().await;
    let Renderer {
        status: copy,
        window,
    } = &mut *r;
    status(copy);
    let Some(s) = copy.as_ref() else { return };
    let mut sent = 0usize;
    loop {
        let mut w = Window::new(window.as_mut_slice(), sent);
        match verdict {
            Parsed::Request(req) => crate::respond(&mut w, req, id, s),
            Parsed::Refused(st) => http::error(&mut w, st),
            Parsed::More => return,
        }
        let (kept, total) = (w.kept().len(), w.total());
        let mut bytes = window.get(..kept).unwrap_or(&[]);
        while !bytes.is_empty() {
            // A pipe copies under a critical section: in small pieces, so
            // that the cycle's interrupt never waits long behind one.
            let piece = bytes.get(..PIECE).unwrap_or(bytes);
            let Ok(n) = with_timeout(STALL_TIMEOUT, slot.outbound.write(piece)).await else {
                slot.abandoned
                    .store(true, core::sync::atomic::Ordering::Relaxed);
                return;
            };
            bytes = bytes.get(n..).unwrap_or(&[]);
        }
        sent += kept;
        if sent >= total || kept == 0 {
            return;
        }
    }
}
