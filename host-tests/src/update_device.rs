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
        path: if force {
            "/firmware?force=1"
        } else {
            "/firmware"
        },
        body: &file[..sent.min(file.len())],
        declared: file.len(),
    };
    for _ in 0..5 {
        if let Some(r) = http_get::put(&base(to), &put, TIMEOUT, progress)? {
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

/// `/status.json`'s `update` section: the device's version and what its
/// last upload came to (`None` when the device takes no updates).
///
/// Tried up to five times, 200 ms apart: the device serves two
/// connections at once (`rri_diag::serve::SLOTS`), and while an upload
/// holds one, the other may still be closing its last exchange, when a
/// new connection is refused at once (smoltcp has no listen backlog).
pub fn status(to: &str) -> Result<(String, Option<String>), String> {
    let url = format!("{}status.json", base(to));
    let mut tries = 0;
    let r = loop {
        match http_get::get(&url, Duration::from_secs(5)) {
            Ok(r) => break r,
            Err(e) if tries >= 4 => return Err(e),
            Err(_) => {
                tries += 1;
                std::thread::sleep(Duration::from_millis(200));
            }
        }
    };
    let json: serde_json::Value =
        serde_json::from_slice(&r.body).map_err(|e| format!("{url}: {e}"))?;
    let version = json["device"]["firmware"]["version"]
        .as_str()
        .unwrap_or("?")
        .to_string();
    let last = json["update"]["last"].as_str().map(str::to_string);
    Ok((version, last))
}
