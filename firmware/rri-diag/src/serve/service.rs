//! The service half of a connection slot, on the background executor:
//! reads and parses the request from the slot's inbound pipe, renders the
//! response window by window into its outbound pipe ([`super`] has the
//! slot, the socket half and the bounds).

#[cfg(rri_update)]
use super::upload::{cancel, receive};
use super::{Cs, Desk, Renderer, ServiceHalf, Slot, PIECE, REQUEST_TIMEOUT, STALL_TIMEOUT};
use crate::http::{self, Parsed, Parser};
use crate::{Identity, Status, Window};
use core::sync::atomic::Ordering;
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
    desk: Option<&Desk>,
) -> ! {
    let ServiceHalf { parser, buf } = half;
    loop {
        slot.opened.wait().await;
        let request = async {
            *parser = if cfg!(rri_update) && desk.is_some_and(Desk::takes_updates) {
                Parser::with_updates()
            } else {
                Parser::new()
            };
            loop {
                let n = slot.inbound.read(buf.as_mut_slice()).await;
                match parser.feed(buf.get(..n).unwrap_or(&[])) {
                    Parsed::More => continue,
                    done => return (done, n),
                }
            }
        };
        let verdict = match select(with_timeout(REQUEST_TIMEOUT, request), slot.gone.wait()).await {
            Either::First(Ok((v, n))) => Some((v, n)),
            Either::First(Err(_)) => Some((Parsed::Refused(http::Status::RequestTimeout), 0)),
            Either::Second(()) => None,
        };
        #[cfg_attr(not(rri_update), allow(unused_mut))]
        let mut reply = verdict.map(|(v, _)| Reply::Verdict(v));
        #[cfg(rri_update)]
        if let (
            Some(desk),
            Some((
                Parsed::Request(http::Request {
                    body: Some(body), ..
                }),
                n,
            )),
        ) = (desk, verdict)
        {
            // The head's last read may hold the body's first bytes.
            let mut first = [0u8; 64];
            let rest = buf.get(parser.body_start()..n).unwrap_or(&[]);
            let len = rest.len().min(first.len());
            if let (Some(to), Some(from)) = (first.get_mut(..len), rest.get(..len)) {
                to.copy_from_slice(from);
            }
            if !receive(slot, desk, body, first.get(..len).unwrap_or(&[]), buf).await {
                reply = Some(Reply::Busy);
            }
        }
        #[cfg(rri_update)]
        if let (Some(desk), Some((Parsed::Request(http::Request { cancel: true, .. }), _))) =
            (desk, verdict)
        {
            if !cancel(desk) {
                reply = Some(Reply::Busy);
            }
        }
        slot.heard.store(true, Ordering::Relaxed);
        if let Some(reply) = reply {
            let respond = respond(slot, renderer, id, status, desk, reply);
            let _ = select(respond, slot.gone.wait()).await;
        }
        slot.finished.signal(());
    }
}

/// What the service answers.
#[derive(Clone, Copy)]
enum Reply {
    /// The parser's verdict (for an upload, its outcome is the desk's).
    Verdict(Parsed),
    /// Another upload holds the desk.
    #[cfg(rri_update)]
    Busy,
}

/// Renders the response to `verdict` window by window into the slot's
/// outbound pipe.
async fn respond(
    slot: &Slot,
    renderer: &Mutex<Cs, Renderer>,
    id: &Identity,
    status: fn(&mut Option<Status>),
    desk: Option<&Desk>,
    reply: Reply,
) {
    let mut r = renderer.lock().await;
    let Renderer {
        status: copy,
        window,
    } = &mut *r;
    status(copy);
    if let Some(s) = copy.as_mut() {
        s.update = desk.and_then(Desk::update);
    }
    let Some(s) = copy.as_ref() else { return };
    let mut sent = 0usize;
    loop {
        let mut w = Window::new(window.as_mut_slice(), sent);
        match reply {
            Reply::Verdict(Parsed::Request(req)) => crate::respond(&mut w, req, id, s),
            Reply::Verdict(Parsed::Refused(st)) => http::error(&mut w, st),
            Reply::Verdict(Parsed::More) => return,
            #[cfg(rri_update)]
            Reply::Busy => crate::update::respond_line(&mut w, http::Status::Conflict, &mut |o| {
                o.str("another upload is arriving: one at a time")
            }),
        }
        let (kept, total) = (w.kept().len(), w.total());
        let mut bytes = window.get(..kept).unwrap_or(&[]);
        while !bytes.is_empty() {
            // A pipe copies under a critical section: in small pieces, so
            // that the cycle's interrupt never waits long behind one.
            let piece = bytes.get(..PIECE).unwrap_or(bytes);
            let Ok(n) = with_timeout(STALL_TIMEOUT, slot.outbound.write(piece)).await else {
                slot.abandoned.store(true, Ordering::Relaxed);
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
