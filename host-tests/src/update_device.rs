//! `cargo update-device` (issue 43): an update file to a running device
//! over its diagnostics port (`PUT /firmware`), with the device's answer,
//! then what `/status.json` says of it.

use crate::robot::http_get::{self, Put, Response};
use std::time::Duration;

/// How long a whole upload may take: the device's own limit
/// (`rri_diag::serve::UPLOAD_TIMEOUT`, 64 s) and a little more.
pub const TIMEOUT: Duration = Duration::from_secs(70);

/// What the file says of itself (its trailer), without any check of the
/// signature: that is the device's.
pub fn describe(file: &[u8]) -> Result<String, String> {
    let t = crate::update_file::trailer_of(file)?;
    let v = t.version;
    Ok(format!(
        "{} {}.{}.{}, an image of {} bytes linked at {:#010x}",
        t.board_name(),
        v.major,
        v.minor,
        v.patch,
        t.image_len,
        t.origin
    ))
}

/// `http://host[:port]/` as given, with a trailing slash.
pub fn base(to: &str) -> String {
    format!("{}/", to.trim_end_matches('/'))
}

/// PUTs `file` (its first `sent` bytes, declared whole: a test's cut
/// connection) to the device at `to`; `progress` hears the bytes sent.
/// A connection the device ends without a byte of answer (every slot
/// busy) is tried again, up to five times, 300 ms apart.
pub fn upload(
    to: &str,
    file: &[u8],
    sent: usize,
    force: bool,
    progress: &mut dyn FnMut(usize),
) -> Result<Response, String> {
    let put = Put {
        method: "PUT",
        path: if force {
            "/firmware?force=1"
        } else {
            "/firmware"
        },
        body: &file[..sent.min(file.len())],
        declared: file.len(),
    };
    send(to, &put, progress)
}

/// `DELETE /firmware`: cancels the device's marked update before its
/// swap (refused when nothing is marked, or while its image is on trial).
pub fn cancel(to: &str) -> Result<Response, String> {
    let delete = Put {
        method: "DELETE",
        path: "/firmware",
        body: &[],
        declared: 0,
    };
    send(to, &delete, &mut |_| {})
}

/// Sends `put`, tried again when the device ends the connection without
/// a byte of answer (every slot busy), up to five times, 300 ms apart.
fn send(to: &str, put: &Put<'_>, progress: &mut dyn FnMut(usize)) -> Result<Response, String> {
    for _ in 0..5 {
        if let Some(r) = http_get::put(&base(to), put, TIMEOUT, progress)? {
            return Ok(r);
        }
        std::thread::sleep(Duration::from_millis(300));
    }
    Err(format!(
        "{}: the device ended every connection without an answer (its connection slots busy?)",
        base(to)
    ))
}

/// The device's one-line answer.
pub fn answer(r: &Response) -> String {
    String::from_utf8_lossy(&r.body).trim_end().to_string()
}

/// What a device's `/status.json` says of its image and updates.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Status {
    /// The running image's version.
    pub version: String,
    /// What its last upload came to (`None`: it takes no updates).
    pub last: Option<String>,
    /// Where its image stands: `confirmed`, `on trial`, `gave up`.
    pub image: Option<String>,
    /// Why it last started (`software`: the restart into a swap).
    pub last_reset: Option<String>,
    /// The version its image replaced, when an update swapped it in.
    pub previous: Option<String>,
}

/// `/status.json`, read once.
fn status_once(url: &str, timeout: Duration) -> Result<Status, String> {
    let r = http_get::get(url, timeout)?;
    let json: serde_json::Value =
        serde_json::from_slice(&r.body).map_err(|e| format!("{url}: {e}"))?;
    let text = |v: &serde_json::Value| v.as_str().map(str::to_string);
    Ok(Status {
        version: text(&json["device"]["firmware"]["version"]).unwrap_or_else(|| "?".into()),
        last: text(&json["update"]["last"]),
        image: text(&json["update"]["image"]),
        last_reset: text(&json["device"]["reset"]["cause"]),
        previous: text(&json["update"]["previous"]),
    })
}

/// `/status.json`'s version and `update` section.
///
/// Tried up to five times, 200 ms apart: the device serves two
/// connections at once (`rri_diag::serve::SLOTS`), and while an upload
/// holds one, the other may still be closing its last exchange, when a
/// new connection is refused at once (smoltcp has no listen backlog).
pub fn status(to: &str) -> Result<Status, String> {
    let url = format!("{}status.json", base(to));
    let mut tries = 0;
    loop {
        match status_once(&url, Duration::from_secs(5)) {
            Ok(s) => return Ok(s),
            Err(e) if tries >= 4 => return Err(e),
            Err(_) => {
                tries += 1;
                std::thread::sleep(Duration::from_millis(200));
            }
        }
    }
}

/// Waits up to `wait` for the device to run `version`: it restarts into
/// the bootloader's swap once its controller is not OPERATING, and is
/// unreachable meanwhile. Asked once a second; `tick` is told each time
/// (seconds waited, what the device said or why it did not answer).
pub fn wait_for(
    to: &str,
    version: &str,
    wait: Duration,
    tick: &mut dyn FnMut(u64, Result<&Status, &str>),
) -> Result<Status, Option<Status>> {
    let url = format!("{}status.json", base(to));
    let start = std::time::Instant::now();
    let mut last = None;
    loop {
        let asked = std::time::Instant::now();
        match status_once(&url, Duration::from_secs(2)) {
            Ok(s) if s.version == version => return Ok(s),
            Ok(s) => {
                tick(start.elapsed().as_secs(), Ok(&s));
                last = Some(s);
            }
            Err(e) => tick(start.elapsed().as_secs(), Err(&e)),
        }
        if start.elapsed() >= wait {
            return Err(last);
        }
        std::thread::sleep(Duration::from_secs(1).saturating_sub(asked.elapsed()));
    }
}
