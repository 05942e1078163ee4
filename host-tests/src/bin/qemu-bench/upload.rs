//! The upload run's client (issue 43): an update file pushed to the
//! device's `PUT /firmware` again and again while the cycle is measured.
//! The file is the bench image itself, signed with a key the device does
//! not hold: every upload writes the whole update partition, reads it
//! back through SHA-512 and checks the ed25519 signature, all the work of
//! a real update but the mark (a marked one would refuse every later
//! upload), and is refused at the signature. Counts what it got.

use host_tests::update_device;
use host_tests::update_file::{flat_image, sensor_version, signed_file};
use rri_update::Version;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// What the uploader got.
#[derive(Debug, Default)]
pub struct Uploaded {
    /// Uploads refused at the signature, as meant (the whole file written
    /// and checked).
    pub checked: AtomicU64,
    /// Bytes of those.
    pub bytes: AtomicU64,
    /// Anything else: another answer, or no answer.
    pub other: Mutex<Vec<String>>,
}

impl Uploaded {
    pub fn line(&self) -> String {
        let other = self.other.lock().map(|o| o.clone()).unwrap_or_default();
        format!(
            "{} uploads of {} KB written, hashed and refused at the signature as meant{}",
            self.checked.load(Ordering::Relaxed),
            self.bytes.load(Ordering::Relaxed) / 1000,
            if other.is_empty() {
                String::new()
            } else {
                format!("; {} others: {}", other.len(), other.join("; "))
            }
        )
    }
}

/// The uploader's thread.
pub struct Uploader {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<()>,
    pub got: Arc<Uploaded>,
}

/// The bench image as an update file the device writes and then refuses:
/// for its board and address, newer, signed with a key it does not hold.
pub fn file(elf: &Path) -> Result<Vec<u8>, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let (origin, image) = flat_image(&bytes)?;
    let v = sensor_version()?;
    let v = Version::parse(&v).ok_or_else(|| format!("{v:?} is no version"))?;
    let newer = Version {
        patch: v.patch + 1,
        ..v
    };
    signed_file(&image, origin, "mps2-an500", newer, &[9; 32])
}

impl Uploader {
    /// Starts uploading `file` to the diagnostics at `to`, one upload
    /// after another.
    pub fn start(to: SocketAddr, file: Vec<u8>) -> Uploader {
        let stop = Arc::new(AtomicBool::new(false));
        let got = Arc::new(Uploaded::default());
        let (s, g) = (stop.clone(), got.clone());
        let thread = std::thread::spawn(move || {
            let url = format!("http://{to}/");
            while !s.load(Ordering::Relaxed) {
                match update_device::upload(&url, &file, file.len(), false, &mut |_| {}) {
                    Ok(r) if r.status == 403 => {
                        g.checked.fetch_add(1, Ordering::Relaxed);
                        g.bytes.fetch_add(file.len() as u64, Ordering::Relaxed);
                    }
                    Ok(r) => push(&g, format!("{} {}", r.status, update_device::answer(&r))),
                    Err(e) => push(&g, e),
                }
            }
        });
        Uploader { stop, thread, got }
    }

    /// Stops after the upload under way; what it got.
    pub fn stop(self) -> Arc<Uploaded> {
        self.stop.store(true, Ordering::Relaxed);
        let _ = self.thread.join();
        self.got
    }
}

fn push(g: &Uploaded, what: String) {
    if let Ok(mut o) = g.other.lock() {
        o.push(what);
    }
}
