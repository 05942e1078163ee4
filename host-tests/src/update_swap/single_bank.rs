//! The F767 left in the factory's single-bank mode (option byte nDBANK =
//! 1): its image, built with the upload's path, must start, serve the
//! robot, say in its log why it takes no update, and answer an upload
//! with 405, its flash untouched. The course itself needs the dual-bank
//! mode its README has the user set.

use super::{robot, Images, Step};
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
        let file = std::fs::read(&images.b_file).map_err(|e| e.to_string())?;
        let sent = crate::update_device::upload(
            &format!("http://{http}/"),
            &file,
            file.len(),
            false,
            &mut |_| {},
        )?;
        let (answered, of) = robot(setup, to, 300, 1)?;
        if sent.status == 405 && answered == of && of > 0 {
            Ok(format!(
                "in the factory's single-bank mode A starts, says why it takes no update, answers B's upload {} and {answered} of {of} robot messages",
                sent.status
            ))
        } else {
            Err(format!(
                "in single-bank mode: B's upload answered {} ({}), {answered} of {of} robot messages answered",
                sent.status,
                crate::update_device::answer(&sent)
            ))
        }
    })();
    let log = d.stop();
    result.map_err(|e: String| {
        let last: Vec<&String> = log.iter().rev().take(20).collect();
        format!(
            "{e}\n  {}",
            last.into_iter()
                .rev()
                .cloned()
                .collect::<Vec<_>>()
                .join("\n  ")
        )
    })
}
