//! Realistic, changing robot data: the TCP moving along a circle, joints
//! following, feedback ~8 ms old and planned values 24–60 ms ahead with
//! their own timestamps (T2), operation-mode changes now and then.

use super::wire::Value;
use gsi_config::{Device, Field, Link, SimpleType, TypeRef};
use std::f64::consts::TAU;

/// The controller's clock at the start of a run: up for a while, as a real
/// one (and past f32's millisecond precision, on purpose).
pub const UPTIME_AT_START: f64 = 86_400.0;

/// How far behind (feedback) or ahead (planned) a field's data is.
fn lead(f: &Field) -> Option<bool> {
    let n = format!("{} {}", f.name, f.alias.as_deref().unwrap_or("")).to_ascii_lowercase();
    if n.contains("plan") || n.contains("predict") || n.contains("_des") {
        Some(true)
    } else if n.contains("feedback") || n.contains("_act") {
        Some(false)
    } else {
        None
    }
}

/// Robot data at controller time `t` (s since the run started).
pub struct Motion<'d> {
    device: &'d Device,
}

impl<'d> Motion<'d> {
    pub fn new(device: &'d Device) -> Self {
        Motion { device }
    }

    /// The controller's timestamp of cycle time `t`.
    pub fn now(t: f64) -> f64 {
        UPTIME_AT_START + t
    }

    /// How far ahead planned data is: 24–60 ms, varying slowly.
    pub fn planned_ahead(t: f64) -> f64 {
        0.042 + 0.018 * (t * 0.7).sin()
    }

    /// The TCP pose at time `t`: a 100 mm circle in 8 s, tool pointing down.
    pub fn pose(t: f64) -> [f64; 6] {
        let a = TAU * t / 8.0;
        [
            400.0 + 100.0 * a.cos(),
            100.0 * a.sin(),
            300.0 + 20.0 * (2.0 * a).sin(),
            -179.995 + 0.01 * a.sin(),
            -0.000497347 * a.cos(),
            90.0 + 5.0 * a.sin(),
        ]
    }

    /// Joint values (degrees) following the path.
    pub fn joints(t: f64) -> [f64; 6] {
        let a = TAU * t / 8.0;
        [
            14.0 * a.sin(),
            28.0 + 5.0 * a.cos(),
            14.0 - 3.0 * a.sin(),
            0.0000696,
            48.0 + 2.0 * a.cos(),
            85.0 + 14.0 * a.sin(),
        ]
    }

    /// The value of field `f` in cycle `cycle` at time `t`.
    pub fn value(&self, f: &Field, cycle: u64, t: f64) -> Value {
        let at = match lead(f) {
            Some(true) => t + Self::planned_ahead(t),
            Some(false) => t - 0.008,
            None => t,
        };
        let one = |ty: TypeRef, k: usize| -> Value {
            match ty {
                TypeRef::Simple(SimpleType::Bool) => Value::Bool((cycle / 100 + k as u64) % 2 == 1),
                TypeRef::Simple(SimpleType::Real) => {
                    Value::Real(100.0 * (at + k as f64 * 0.37).sin())
                }
                TypeRef::Simple(SimpleType::Time) => Value::Time(Self::now(at)),
                TypeRef::Simple(SimpleType::String) => Value::Str(format!("cycle {cycle}")),
                TypeRef::Enum(e) => {
                    let n = self.device.enums[e].members.len().max(1) as u64;
                    // Internal (operation mode): changes every 1000 cycles.
                    let every = if f.link == Link::Intern { 1000 } else { 250 };
                    Value::Enum(((cycle / every) % n) as usize)
                }
                TypeRef::Simple(SimpleType::Frame) => Value::Six(Self::pose(at)),
                TypeRef::Simple(SimpleType::Joints) => Value::Six(Self::joints(at)),
                TypeRef::Record(_) => Value::Real(0.0),
            }
        };
        match f.size {
            Some(n) => Value::Array((0..usize::from(n)).map(|k| one(f.ty, k)).collect()),
            None => one(f.ty, 0),
        }
    }
}
