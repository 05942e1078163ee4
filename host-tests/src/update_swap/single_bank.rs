//! The F767 left in the factory's single-bank mode (option byte nDBANK =
//! 1): its image, built with the upload's path, must start, serve the
//! robot, say in its log why it takes no update, and answer an upload
//! with 405, its flash untouched. The course itself needs the dual-bank
//! mode its README has the user set.

use super::{robot, send_file, Images, Step};
use crate::device::Device;
use crate::setup::Setup;
use std::time::Duration;

/// What the image says at start-up in single-bank mode (hal-board's
/// `nucleo::update`, logged by the firmware's receiver set-up).
const SAID: &str = "updates: none: the flash is in the factory's single-bank mode";

/// Boots A on the rehosted F767 in single-bank mode and checks it: one
/// line, or why not.
pub fn check(setup: &Setup, images: &Images) -> Step {
    let (d, to, http) = crate::rehost::boot_elf("f767", setup, &images.a, &["--resets", "0"])?;
    let mut d: Box<dyn Device> = Box::new(d);
    let result = (|| {
        for (needle, within) in crate::rehost::ready() {
            d.wait_for(needle, within)?;
        }
        d.wait_for(SAID, Duration::from_secs(5))?;
        let http = http.ok_or("the board's diagnostics are not forwarded")?;
        let (status, said) = send_file(http, &images.b_file)?;
        let (answered, of) = robot(setup, to, 300, 1)?;
        if status == 405 && answered == of && of > 0 {
            Ok(format!(
                "in the factory's single-bank mode A starts, says why it takes no update, answers B's upload {status} and {answered} of {of} robot messages"
            ))
        } else {
            Err(format!(
                "in single-bank mode: B's upload answered {status} ({said}), {answered} of {of} robot messages answered"
            ))
        }
    })();
    let log = d.stop();
    result.map_err(|e: String| {
        format!(
            "{e}\n  {}",
            crate::device::tail(log.iter().map(String::as_str), 20)
        )
    })
}
