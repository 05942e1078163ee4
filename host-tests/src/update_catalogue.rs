//! `cargo demo -- --update-catalogue` (issue 43): every kind of update
//! file a device must refuse, then one it must take, pushed to the QEMU
//! board over its diagnostics port while the robot is served, and that
//! one cancelled (`DELETE /firmware`) before the robot stops, when the
//! device would restart into it; the demo's
//! verdict then says whether every robot message was still answered in
//! time. Each case checks the status code, the device's reason, and that
//! `/status.json` says the same afterwards.
//!
//! The files are made here from the image the demo booted, signed with
//! the QEMU board's demonstration key (`firmware/rri-update/demo-key/`,
//! built into QEMU images without `RRI_UPDATE_KEY`).

use crate::update_device::{self, answer};
use crate::update_file::{flat_image, image_version, read_key, sensor_version, signed_file};
use rri_update::Version;
use std::io::Write;
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::time::{Duration, Instant};

/// The board name QEMU images carry.
const BOARD: &str = "mps2-an500";

/// One case: what is sent and what must come back.
struct Case {
    what: &'static str,
    file: Vec<u8>,
    /// Bytes sent of the file (declared whole).
    sent: usize,
    force: bool,
    status: u16,
    words: &'static str,
}

/// Runs the catalogue against the device at `http`, from the image
/// `elf`: `Ok` with a line per case when every case got its answer,
/// `Err` with the same lines (`FAIL…` for each that did not) otherwise.
pub fn run(http: SocketAddr, elf: &Path) -> Result<Vec<String>, Vec<String>> {
    let cases = match cases(elf) {
        Ok(c) => c,
        Err(e) => return Err(vec![format!("FAIL update catalogue: {e}")]),
    };
    let to = format!("http://{http}/");
    let mut lines = Vec::new();
    let mut failed = false;
    let mut check = |what: &str, r: Result<String, String>| match r {
        Ok(line) => lines.push(format!("ok   {what}: {line}")),
        Err(e) => {
            failed = true;
            lines.push(format!("FAIL update {what}: {e}"));
        }
    };
    for (i, case) in cases.iter().enumerate() {
        // One at a time: a second upload while one arrives is refused,
        // and the first goes on (before the last case, which marks).
        if i + 2 == cases.len() {
            check("two at once", two_at_once(&to, http, &cases[0].file));
        }
        check(case.what, one(&to, case));
    }
    // The marked file cancelled (or the device would restart into it once
    // the robot stops), then a second cancellation finds nothing.
    check(
        "cancel the marked one",
        cancel(&to, 200, "cancelled: the marked update is not swapped in"),
    );
    check(
        "cancel with nothing marked",
        cancel(&to, 409, "no update is marked"),
    );
    if failed {
        Err(lines)
    } else {
        Ok(lines)
    }
}

/// Sends `case` and checks the answer and the status afterwards.
fn one(to: &str, case: &Case) -> Result<String, String> {
    let started = Instant::now();
    let r = update_device::upload(to, &case.file, case.sent, case.force, &mut |_| {})?;
    let took = started.elapsed();
    let said = answer(&r);
    if r.status != case.status || !said.contains(case.words) {
        return Err(format!(
            "{} {said:?}, expected {} with {:?}",
            r.status, case.status, case.words
        ));
    }
    let last = update_device::status(to)?.last;
    if last.as_deref() != Some(said.as_str()) {
        return Err(format!(
            "the answer was {said:?} but /status.json's update.last says {last:?}"
        ));
    }
    Ok(format!(
        "{} {said} ({} bytes in {:.1} s)",
        r.status,
        case.sent,
        took.as_secs_f64()
    ))
}

/// `DELETE /firmware`, its answer and the status afterwards.
fn cancel(to: &str, status: u16, words: &str) -> Result<String, String> {
    let r = update_device::cancel(to)?;
    let said = answer(&r);
    if r.status != status || !said.contains(words) {
        return Err(format!(
            "{} {said:?}, expected {status} with {words:?}",
            r.status
        ));
    }
    let last = update_device::status(to)?.last;
    if last.as_deref() != Some(said.as_str()) {
        return Err(format!(
            "the answer was {said:?} but /status.json's update.last says {last:?}"
        ));
    }
    Ok(format!("{} {said}", r.status))
}

/// A first upload that has sent half its body holds the desk: a second
/// is refused at once with 409, and the first, dropped, is abandoned.
fn two_at_once(to: &str, http: SocketAddr, file: &[u8]) -> Result<String, String> {
    let mut first = TcpStream::connect_timeout(&http, Duration::from_secs(5))
        .map_err(|e| format!("first connection: {e}"))?;
    write!(
        first,
        "PUT /firmware HTTP/1.1\r\nHost: d\r\nContent-Length: {}\r\n\r\n",
        file.len()
    )
    .and_then(|()| first.write_all(&file[..file.len() / 2]))
    .map_err(|e| format!("first upload: {e}"))?;
    // Until the device shows it receiving.
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let last = update_device::status(to)?.last;
        if last.as_deref().is_some_and(|l| l.starts_with("receiving")) {
            break;
        }
        if Instant::now() > deadline {
            return Err(format!(
                "the first upload never showed as receiving: {last:?}"
            ));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let r = update_device::upload(to, file, file.len(), false, &mut |_| {})?;
    let said = answer(&r);
    drop(first);
    if r.status != 409 || !said.contains("one at a time") {
        return Err(format!(
            "the second got {} {said:?}, expected 409",
            r.status
        ));
    }
    // The first, cut off, ends abandoned (at the latest after the
    // device's BODY_STALL).
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let last = update_device::status(to)?.last;
        if last.as_deref().is_some_and(|l| l.starts_with("abandoned")) {
            return Ok(format!(
                "409 {said}; the first, cut off: {}",
                last.unwrap_or_default()
            ));
        }
        if Instant::now() > deadline {
            return Err(format!(
                "the first upload, cut off, never showed as abandoned: {last:?}"
            ));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The catalogue's files, from the image `elf`.
fn cases(elf: &Path) -> Result<Vec<Case>, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let (origin, image) = flat_image(&bytes)?;
    let seed = read_key(&crate::workspace().join("firmware/rri-update/demo-key/update-key"))?;
    let running = match image_version(&bytes)? {
        Some(v) => v,
        None => sensor_version()?,
    };
    let running = Version::parse(&running).ok_or_else(|| format!("{running:?} is no version"))?;
    let newer = Version {
        patch: running.patch + 1,
        ..running
    };
    let older = Version {
        major: 0,
        minor: 0,
        patch: 1,
    };
    if older >= running {
        return Err(format!(
            "the running version {running:?} has no older one to try"
        ));
    }
    let sign = |image: &[u8], origin: u32, board: &str, v: Version, seed: &[u8; 32]| {
        signed_file(image, origin, board, v, seed)
    };
    let good = sign(&image, origin, BOARD, newer, &seed)?;
    let mut altered = good.clone();
    altered[1000] ^= 0x01;
    let n = good.len();
    let case = |what, file: Vec<u8>, status, words| {
        let sent = file.len();
        Case {
            what,
            file,
            sent,
            force: false,
            status,
            words,
        }
    };
    Ok(vec![
        case(
            "not ours (another key)",
            sign(&image, origin, BOARD, newer, &[9; 32])?,
            403,
            "the signature does not verify",
        ),
        case(
            "one byte altered",
            altered,
            403,
            "the signature does not verify",
        ),
        case(
            "for another board",
            sign(&image, origin, "nucleo-f767zi", newer, &seed)?,
            422,
            "an image for another board",
        ),
        case(
            "linked for another address",
            sign(&image, 0x0808_0000, BOARD, newer, &seed)?,
            422,
            "linked for another address",
        ),
        case(
            "older",
            sign(&image, origin, BOARD, older, &seed)?,
            409,
            "older than the running image",
        ),
        case(
            "not an update file",
            (0..5000u32).map(|i| i as u8).collect(),
            422,
            "not an update file",
        ),
        case("too short", vec![0xAB; 100], 422, "shorter than a trailer"),
        Case {
            sent: 0,
            ..case(
                "too large (declared 2 MiB)",
                vec![0xFF; 2 << 20],
                413,
                "larger than the update partition",
            )
        },
        case(
            "the file cut short on disk",
            good[..n - 10].to_vec(),
            422,
            "not an update file",
        ),
        Case {
            sent: n - 1,
            ..case(
                "the connection cut one byte short",
                good.clone(),
                400,
                "abandoned after",
            )
        },
        Case {
            force: true,
            ..case(
                "older, forced",
                sign(&image, origin, BOARD, older, &seed)?,
                200,
                "version 0.0.1 (FORCED: older than the running image) checked and marked",
            )
        },
        case(
            "newer, with one marked already",
            good,
            409,
            "an update is marked already",
        ),
    ])
}
