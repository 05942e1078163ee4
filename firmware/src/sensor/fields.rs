//! Field access for sensors that work with any layout (the examples in
//! [`crate::sensors`], which CI builds with several GSI configurations).
//! A sensor written for its own layout names its fields instead
//! (`robot.rob_data.feedback_pose`, `device.sens_data.application_data`).
//! Every look-up walks at most the layout's fields: bounded.

use crate::properties::{DeviceSet, RobotSet};
use crate::schema::{FieldMut, FieldRef, MAX_FIELDS};
use crate::value::{Frame, Time};

/// The first `frame` (pose) field of any robot property, in layout order
/// (the manual's `FeedbackPose`).
pub fn first_frame<R: RobotSet>(robot: &R) -> Option<Frame> {
    (0..R::WIRE_NAMES.len()).find_map(|p| {
        fields(robot, p).find_map(|f| match f {
            FieldRef::Frame(f) => Some(*f),
            _ => None,
        })
    })
}

/// The robot's feedback: the first `time` field and the first `frame`
/// field of the first robot property that has both (the manual's
/// `FeedbackTime` and `FeedbackPose`: where the robot was, and when, on
/// the controller's clock; T2).
pub fn feedback<R: RobotSet>(robot: &R) -> Option<(Time, Frame)> {
    (0..R::WIRE_NAMES.len()).find_map(|p| {
        let time = fields(robot, p).find_map(|f| match f {
            FieldRef::Time(t) => Some(t),
            _ => None,
        })?;
        let pose = fields(robot, p).find_map(|f| match f {
            FieldRef::Frame(f) => Some(*f),
            _ => None,
        })?;
        Some((time, pose))
    })
}

fn fields<R: RobotSet>(robot: &R, property: usize) -> impl Iterator<Item = FieldRef<'_>> {
    (0..MAX_FIELDS).map_while(move |i| robot.field(property, i))
}

/// Writes `values` into the first `real` array of device property
/// `property` (the manual's `AppData`), as many as fit; the rest of the
/// array keeps its values. `false` when the property has no such array.
pub fn fill_reals<D: DeviceSet>(device: &mut D, property: usize, values: &[f32]) -> bool {
    for i in 0..MAX_FIELDS {
        match device.field_mut(property, i) {
            None => break,
            Some(FieldMut::Reals(slots)) => {
                for (slot, v) in slots.iter_mut().zip(values) {
                    *slot = *v;
                }
                return true;
            }
            Some(_) => {}
        }
    }
    false
}

/// Writes `text` (cut at 80 bytes, M6) into the first `string` field of
/// device property `property` (the manual's `ErrorString`). `false` when
/// the property has none.
pub fn set_status<D: DeviceSet>(device: &mut D, property: usize, text: &str) -> bool {
    for i in 0..MAX_FIELDS {
        match device.field_mut(property, i) {
            None => break,
            Some(FieldMut::Str(s)) => {
                s.clear();
                for c in text.chars() {
                    if s.push(c).is_err() {
                        break;
                    }
                }
                return true;
            }
            Some(_) => {}
        }
    }
    false
}
