//! The service's half of an upload (issue 43: `PUT /firmware`) on the
//! in-memory network (`service`'s harness): the body whole into the
//! receiver, a stall and a close, one upload at a time, a refusal before
//! the body, and a service without a receiver read-only; in mock time.

mod memnet;
mod service;

use embassy_net::tcp::TcpSocket;
use embassy_time::{Duration, Timer};
use rri_diag::serve::{self, Desk};
use service::{device, exchange, status_of, timed_exchange, with_desk, with_service};

/// A receiver that keeps what it is given (no flash, no signature): the
/// service's half of an upload alone. A file is "good" when its bytes
/// are `0, 1, 2, …` (mod 251) and at most [`SINK_CAPACITY`] long.
struct Sink {
    got: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
    declared: usize,
}

const SINK_CAPACITY: usize = 64 * 1024;

fn pattern(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i % 251) as u8).collect()
}

impl rri_update::Receive for Sink {
    fn begin(&mut self, declared: usize) -> Result<(), rri_update::Refused> {
        if declared > SINK_CAPACITY {
            return Err(rri_update::Refused::TooLarge {
                declared,
                capacity: SINK_CAPACITY,
            });
        }
        self.declared = declared;
        self.got.lock().unwrap().clear();
        Ok(())
    }
    fn push(&mut self, bytes: &[u8]) -> Result<(), rri_update::Refused> {
        self.got.lock().unwrap().extend_from_slice(bytes);
        Ok(())
    }
    fn finish(&mut self, _force: bool) -> Result<rri_update::Trailer, rri_update::Refused> {
        let got = self.got.lock().unwrap();
        if *got != pattern(self.declared) {
            return Err(rri_update::Refused::BadSignature);
        }
        Ok(rri_update::Trailer::new(
            "memnet",
            rri_update::Version::parse("1.2.3").unwrap(),
            got.len() as u32,
            0,
        )
        .unwrap())
    }
    fn abandon(&mut self) {}
    fn cancel(&mut self, on_trial: bool) -> Result<(), rri_update::Refused> {
        // A marked sink is one whose last file was whole.
        if on_trial {
            return Err(rri_update::Refused::OnTrial);
        }
        let mut got = self.got.lock().unwrap();
        if got.is_empty() {
            return Err(rri_update::Refused::NothingMarked);
        }
        got.clear();
        Ok(())
    }
    fn swaps(&self) -> bool {
        true
    }
    fn running(&self) -> rri_update::Version {
        rri_update::Version::parse("1.0.0").unwrap()
    }
}

/// A desk with a [`Sink`] installed, and what the sink got.
fn desk_with_sink() -> (&'static Desk, std::sync::Arc<std::sync::Mutex<Vec<u8>>>) {
    let desk: &'static Desk = Box::leak(Box::new(Desk::new()));
    let got = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let sink = Box::leak(Box::new(Sink {
        got: got.clone(),
        declared: 0,
    }));
    assert!(desk.install(sink));
    (desk, got)
}

fn put_head(len: usize) -> Vec<u8> {
    format!("PUT /firmware HTTP/1.1\r\nHost: x\r\nContent-Length: {len}\r\n\r\n").into_bytes()
}

fn body_of(response: &[u8]) -> String {
    let text = String::from_utf8_lossy(response);
    text.split_once("\r\n\r\n")
        .map_or(String::new(), |(_, b)| b.trim_end().to_string())
}

#[test]
fn an_upload_reaches_the_receiver_whole_and_its_outcome_is_the_answer() {
    // Issue 43: the body's first bytes come in the head's last read; all
    // of it, and nothing past its Content-Length, reaches the receiver.
    let (desk, got) = desk_with_sink();
    let file = pattern(20_000);
    let mut request = put_head(file.len());
    request.extend_from_slice(&file);
    request.extend_from_slice(b"GET / HTTP/1.1\r\n\r\n");
    let (out, [accepted, responses, aborted]) = with_desk(
        desk,
        move |stack| async move { exchange(stack, &request, false).await },
        30_000,
    );
    let response = out.expect("finished").expect("answered");
    assert_eq!(status_of(&response), Some(200), "{}", body_of(&response));
    assert_eq!(
        body_of(&response),
        "version 1.2.3 checked and marked: the device restarts into it once its controller is not OPERATING"
    );
    assert_eq!(*got.lock().unwrap(), file);
    assert_eq!((accepted, responses, aborted), (1, 1, 0));
    // The status says the same.
    let u = desk.update().expect("updates taken");
    assert!(
        matches!(u.last, rri_update::Outcome::Marked { .. }),
        "{u:?}"
    );
}

#[test]
fn a_stalled_upload_is_abandoned_after_the_body_stall_and_a_closed_one_at_once() {
    for close in [false, true] {
        let (desk, got) = desk_with_sink();
        let mut request = put_head(10_000);
        request.extend_from_slice(&pattern(4_000));
        let (out, _) = with_desk(
            desk,
            move |stack| async move { timed_exchange(stack, &request, close).await },
            30_000,
        );
        let (response, after) = out.expect("finished");
        let response = response.expect("answered");
        assert_eq!(status_of(&response), Some(400));
        assert_eq!(
            body_of(&response),
            "abandoned after 4000 of 10000 bytes; nothing was marked"
        );
        assert_eq!(got.lock().unwrap().len(), 4_000);
        if close {
            // The client's close: no more can come, so no wait.
            assert!(after < Duration::from_millis(500), "{after:?}");
        } else {
            assert!(
                after >= serve::BODY_STALL && after < serve::BODY_STALL + Duration::from_secs(1),
                "{after:?}"
            );
        }
    }
}

#[test]
fn a_second_upload_while_one_arrives_is_refused_and_a_refusal_is_answered_at_once() {
    let (desk, _) = desk_with_sink();
    let (out, _) = with_desk(
        desk,
        |stack| async move {
            // The first sends half its body and waits; the second is
            // refused with 409 meanwhile; the first then completes.
            let mut rx = [0u8; 1024];
            let mut tx = [0u8; 8192];
            let mut first = TcpSocket::new(stack, &mut rx, &mut tx);
            first.connect(device()).await.expect("connects");
            let file = pattern(8_000);
            let mut head = put_head(file.len());
            head.extend_from_slice(&file[..4_000]);
            let mut rest: &[u8] = &head;
            while !rest.is_empty() {
                let n = first.write(rest).await.expect("writes");
                rest = &rest[n..];
            }
            Timer::after(Duration::from_millis(500)).await;
            let second = exchange(stack, &put_head(100), false).await;
            let mut rest: &[u8] = &file[4_000..];
            while !rest.is_empty() {
                let n = first.write(rest).await.expect("writes");
                rest = &rest[n..];
            }
            let mut got = Vec::new();
            let mut buf = [0u8; 256];
            while let Ok(n) = first.read(&mut buf).await {
                if n == 0 {
                    break;
                }
                got.extend_from_slice(&buf[..n]);
            }
            // Too large: refused before a byte of its body is read.
            let large = exchange(stack, &put_head(SINK_CAPACITY + 1), false).await;
            (second, got, large)
        },
        30_000,
    );
    let (second, first, large) = out.expect("finished");
    let second = second.expect("answered");
    assert_eq!(status_of(&second), Some(409));
    assert_eq!(
        body_of(&second),
        "another upload is arriving: one at a time"
    );
    assert_eq!(status_of(&first), Some(200), "{}", body_of(&first));
    let large = large.expect("answered");
    assert_eq!(status_of(&large), Some(413));
    assert!(
        body_of(&large).contains("(65537 bytes, the most is 65536)"),
        "{}",
        body_of(&large)
    );
}

#[test]
fn without_a_receiver_the_service_stays_read_only() {
    let (out, _) = with_service(
        |stack| async move { exchange(stack, &put_head(10), false).await },
        30_000,
    );
    let response = out.expect("finished").expect("answered");
    assert_eq!(status_of(&response), Some(405));
    let text = String::from_utf8_lossy(&response);
    assert!(text.contains("Allow: GET, HEAD"), "{text}");
}
