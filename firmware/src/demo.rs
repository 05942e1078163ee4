//! What the example sensors ([`crate::sensors`]) are made of, for any
//! sensor to use: a low-pass filter, the tool's axis from a pose, a point
//! projected along it, and a simulated distance for where no sensor is
//! attached (the QEMU board, `cargo sensor-host`).

use crate::engine::Instant;
use crate::value::Frame;
use micromath::F32Ext;

/// First-order low-pass over the distance readings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowPass {
    /// Weight of a new reading, 0..=1.
    pub alpha: f32,
    state: Option<f32>,
}

impl LowPass {
    /// No reading yet; each new one weighs `alpha` (0..=1).
    pub const fn new(alpha: f32) -> Self {
        LowPass { alpha, state: None }
    }

    /// Feeds reading `x`, returns the filtered value (the first reading
    /// passes unchanged).
    pub fn update(&mut self, x: f32) -> f32 {
        let y = match self.state {
            None => x,
            Some(y) => y + self.alpha * (x - y),
        };
        self.state = Some(y);
        y
    }

    /// The filtered value so far; `None` before the first reading.
    pub fn value(&self) -> Option<f32> {
        self.state
    }
}

/// The tool's z axis in robot coordinates, from a frame's Euler angles
/// (roll-pitch-yaw in degrees, R = Rz(rz)·Ry(ry)·Rx(rx)): the third column
/// of R. Trigonometry is micromath's (called explicitly: `core`'s float
/// functions would need a libm on the MCU).
pub fn tool_z_axis(pose: &Frame) -> [f32; 3] {
    let rad = core::f32::consts::PI / 180.0;
    let (sx, cx) = F32Ext::sin_cos(pose.rx * rad);
    let (sy, cy) = F32Ext::sin_cos(pose.ry * rad);
    let (sz, cz) = F32Ext::sin_cos(pose.rz * rad);
    [cz * sy * cx + sz * sx, sz * sy * cx - cz * sx, cy * cx]
}

/// `pose` moved `distance` mm along its tool z axis.
pub fn project(pose: &Frame, distance: f32) -> [f32; 3] {
    let z = tool_z_axis(pose);
    [
        pose.x + distance * z[0],
        pose.y + distance * z[1],
        pose.z + distance * z[2],
    ]
}

/// A simulated distance: 150 mm with a slow 20 mm sine and a little
/// deterministic ripple, as a laser distance sensor over a wavy surface.
pub fn simulated_distance(t: Instant) -> f32 {
    let s = t.as_micros() as f32 / 1_000_000.0;
    150.0 + 20.0 * F32Ext::sin(0.5 * s) + 0.3 * F32Ext::sin(37.0 * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-3
    }

    #[test]
    fn tool_axis_of_the_identity_pose_is_z() {
        let z = tool_z_axis(&Frame::ZERO);
        assert!(
            close(z[0], 0.0) && close(z[1], 0.0) && close(z[2], 1.0),
            "{z:?}"
        );
    }

    #[test]
    fn a_tool_pointing_down_projects_downwards() {
        // Rx = 180°: the tool's z axis points along -Z (the real IRC5
        // capture's pose is close to this).
        let pose = Frame {
            x: 400.0,
            y: -35.0,
            z: 300.0,
            rx: 180.0,
            ry: 0.0,
            rz: 90.0,
        };
        let p = project(&pose, 100.0);
        assert!(
            close(p[0], 400.0) && close(p[1], -35.0) && close(p[2], 200.0),
            "{p:?}"
        );
    }

    #[test]
    fn pitch_tilts_the_axis_towards_x() {
        let pose = Frame {
            ry: 90.0,
            ..Frame::ZERO
        };
        let z = tool_z_axis(&pose);
        assert!(close(z[0], 1.0) && close(z[2], 0.0), "{z:?}");
    }

    #[test]
    fn low_pass_starts_at_the_first_reading_and_converges() {
        let mut f = LowPass::new(0.5);
        assert_eq!(f.update(10.0), 10.0);
        assert_eq!(f.update(20.0), 15.0);
        assert_eq!(f.update(20.0), 17.5);
    }

    #[test]
    fn simulated_distance_stays_in_the_sensor_range() {
        for ms in (0..100_000).step_by(7) {
            let d = simulated_distance(Instant::from_millis(ms));
            assert!((129.0..=171.0).contains(&d), "{d} at {ms} ms");
        }
    }
}
