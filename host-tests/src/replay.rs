//! The firmware's side of a replay (`cargo demo` / `cargo hil` with
//! `--replay`, `cargo qemu-bench -- --corpus`): the decoder built for this
//! GSI folder (`rri_firmware::layout`, the same `RRI_GSI_DIR` as the
//! firmware) says why a robot message is refused. The simulator itself
//! knows nothing of the firmware (it plays the controller against any
//! sensor), so this lives here.

use rri_firmware::layout;
use rri_firmware::properties::RobotSet;
use rri_robot::replay::{Outcome, ReplayReport};

/// The firmware's verdict on a robot message: `None` when its decoder
/// takes it, else the decode error and its byte offset.
pub fn refused(bytes: &[u8]) -> Option<String> {
    let mut set = Box::<layout::RobotProperties>::default();
    let mut work = Box::<layout::RobotProperties>::default();
    match set.decode(&mut work, bytes) {
        Ok(_) => None,
        Err(e) => Some(format!(
            "the firmware's decoder refuses it: {} ({:?}) at byte {}",
            e.kind.text(),
            e.kind,
            e.offset
        )),
    }
}

/// Says why each message answered in the capture and not now was not:
/// the decoder's verdict, or that it decodes (then the reason is the
/// engine's or the transport's, which the device's counters tell).
pub fn explain(report: &mut ReplayReport) {
    for row in report
        .rows
        .iter_mut()
        .filter(|r| r.outcome == Outcome::NotAnswered)
    {
        row.why = Some(refused(&row.payload).unwrap_or_else(|| {
            "the firmware's decoder takes it: not answered for another reason (the peer rule, supervision, the transport: see the device's counters)".into()
        }));
    }
}
