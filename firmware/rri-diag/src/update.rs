//! What the service says of updates (issue 43): the response to a
//! `PUT /firmware` and the status's `update` section, both from the last
//! upload's [`Outcome`]. The upload itself is `rri_update`'s; the bytes
//! reach it through the service (`serve`, feature `net`).

use crate::http;
use crate::Out;
use rri_update::{Outcome, Refused, Version};

/// The status's view of updates, where the firmware takes them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Update {
    /// A bootloader swaps a marked image in at the next reset (a board
    /// without one says so).
    pub swaps: bool,
    /// What the last upload came to.
    pub last: Outcome,
    /// Where the running image stands (on trial after a swap).
    pub image: rri_update::lifecycle::Image,
    /// The version this image replaced, when an update swapped it in
    /// (known from its start; `None` otherwise).
    pub previous: Option<Version>,
}

/// The response status for `outcome`, the answer to a `PUT /firmware`.
pub fn http_status(outcome: &Outcome) -> http::Status {
    match outcome {
        Outcome::Marked { .. } | Outcome::Cancelled => http::Status::Ok,
        Outcome::Refused(r) => match r {
            Refused::BadSignature => http::Status::Forbidden,
            Refused::TooLarge { .. } => http::Status::ContentTooLarge,
            Refused::Older | Refused::NotConfirmed | Refused::NothingMarked | Refused::OnTrial => {
                http::Status::Conflict
            }
            Refused::Flash(_) | Refused::Buffer => http::Status::InternalError,
            _ => http::Status::Unprocessable,
        },
        // The client went away, or nothing finished: it hears nothing
        // else (the response is for the log's sake).
        Outcome::None | Outcome::Receiving { .. } | Outcome::Abandoned { .. } => {
            http::Status::BadRequest
        }
    }
}

/// The outcome's one word, for `/status.json`.
pub fn name(outcome: &Outcome) -> &'static str {
    match outcome {
        Outcome::None => "none",
        Outcome::Receiving { .. } => "receiving",
        Outcome::Marked { .. } => "marked",
        Outcome::Refused(_) => "refused",
        Outcome::Cancelled => "cancelled",
        Outcome::Abandoned { .. } => "abandoned",
    }
}

/// One line: what the last upload came to.
pub fn line(out: &mut dyn Out, u: &Update) {
    match u.last {
        Outcome::None => out.str("no update since the start"),
        Outcome::Receiving { received, declared } => {
            out.str("receiving: ");
            out.u32(received);
            out.str(" of ");
            out.u32(declared);
            out.str(" bytes");
        }
        Outcome::Marked { version, older } => {
            out.str("version ");
            self::version(out, version);
            if older {
                out.str(" (FORCED: older than the running image)");
            }
            if u.swaps {
                out.str(
                    " checked and marked: the device restarts into it once its controller is not OPERATING",
                );
            } else {
                out.str(
                    " checked and marked; this board has no bootloader yet, so nothing swaps it in",
                );
            }
        }
        Outcome::Refused(r) => {
            out.str("refused: ");
            out.str(r.text());
            refusal_figures(out, &r);
            out.str("; nothing was marked");
        }
        Outcome::Cancelled => {
            out.str("cancelled: the marked update is not swapped in; the running image stays")
        }
        Outcome::Abandoned { received, declared } => {
            out.str("abandoned after ");
            out.u32(received);
            out.str(" of ");
            out.u32(declared);
            out.str(" bytes; nothing was marked");
        }
    }
}

/// The figures some refusals carry.
fn refusal_figures(out: &mut dyn Out, r: &Refused) {
    let (a, b, what) = match *r {
        Refused::TooLarge { declared, capacity } => (declared, capacity, " bytes, the most is "),
        Refused::Truncated { received, expected } => (received, expected, " bytes of "),
        Refused::LengthMismatch { file, trailer } => (file, trailer, " bytes, the trailer says "),
        _ => return,
    };
    out.str(" (");
    out.u64(a as u64);
    out.str(what);
    out.u64(b as u64);
    out.str(")");
}

/// `major.minor.patch`.
pub fn version(out: &mut dyn Out, v: Version) {
    out.u32(v.major.into());
    out.str(".");
    out.u32(v.minor.into());
    out.str(".");
    out.u32(v.patch.into());
}

/// The whole response to a `PUT /firmware` that came to `u.last`.
pub fn respond(out: &mut dyn Out, u: &Update) {
    respond_line(out, http_status(&u.last), &mut |o| line(o, u));
}

/// A `text/plain` response of one line written by `body`.
pub fn respond_line(out: &mut dyn Out, status: http::Status, body: &mut dyn FnMut(&mut dyn Out)) {
    let mut count = crate::Count::default();
    body(&mut count);
    http::head(
        out,
        status,
        http::Route::Firmware.content_type(),
        count.len + 1,
        false,
    );
    body(out);
    out.str("\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    struct S(std::string::String);
    impl Out for S {
        fn bytes(&mut self, b: &[u8]) {
            self.0.push_str(core::str::from_utf8(b).unwrap());
        }
    }

    fn said(u: Update) -> std::string::String {
        let mut s = S(std::string::String::new());
        respond(&mut s, &u);
        s.0
    }

    #[test]
    fn each_outcome_has_its_status_and_a_line_of_the_length_said() {
        let v = Version::parse("1.2.3").unwrap();
        for (last, code, words) in [
            (
                Outcome::Marked {
                    version: v,
                    older: false,
                },
                "200 OK",
                "version 1.2.3 checked and marked: the device restarts into it once its controller is not OPERATING",
            ),
            (
                Outcome::Cancelled,
                "200 OK",
                "cancelled: the marked update is not swapped in",
            ),
            (
                Outcome::Refused(Refused::NothingMarked),
                "409 Conflict",
                "no update is marked: nothing to cancel",
            ),
            (
                Outcome::Refused(Refused::OnTrial),
                "409 Conflict",
                "on trial",
            ),
            (
                Outcome::Refused(Refused::BadSignature),
                "403 Forbidden",
                "refused: the signature does not verify with this device's key; nothing was marked",
            ),
            (
                Outcome::Refused(Refused::Older),
                "409 Conflict",
                "older than the running image",
            ),
            (
                Outcome::Refused(Refused::OtherBoard),
                "422 Unprocessable Content",
                "another board",
            ),
            (
                Outcome::Refused(Refused::TooLarge {
                    declared: 9,
                    capacity: 4,
                }),
                "413 Content Too Large",
                "(9 bytes, the most is 4)",
            ),
            (
                Outcome::Refused(Refused::Truncated {
                    received: 3,
                    expected: 5,
                }),
                "422",
                "(3 bytes of 5)",
            ),
        ] {
            let text = said(Update {
                swaps: true,
                last,
                image: rri_update::lifecycle::Image::Confirmed,
                previous: None,
            });
            assert!(text.starts_with("HTTP/1.1 "), "{text}");
            assert!(text.contains(code), "{last:?}: {text}");
            assert!(text.contains(words), "{last:?}: {text}");
            let (head, body) = text.split_once("\r\n\r\n").unwrap();
            let len: usize = head
                .lines()
                .find_map(|l| l.strip_prefix("Content-Length: "))
                .unwrap()
                .parse()
                .unwrap();
            assert_eq!(len, body.len(), "{text}");
            assert!(body.ends_with('\n') && body.matches('\n').count() == 1);
        }
        let text = said(Update {
            swaps: true,
            last: Outcome::Marked {
                version: Version::parse("0.0.1").unwrap(),
                older: true,
            },
            image: rri_update::lifecycle::Image::Confirmed,
            previous: None,
        });
        assert!(
            text.contains("200 OK")
                && text.contains(
                    "version 0.0.1 (FORCED: older than the running image) checked and marked"
                ),
            "{text}"
        );
        let text = said(Update {
            swaps: false,
            last: Outcome::Marked {
                version: v,
                older: false,
            },
            image: rri_update::lifecycle::Image::Confirmed,
            previous: None,
        });
        assert!(
            text.contains("no bootloader yet, so nothing swaps it in"),
            "{text}"
        );
    }
}
