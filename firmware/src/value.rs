//! RRI value types (G5) as the firmware holds them.

/// Longest RRI string (G5, M6). RAPID strings are 80 bytes on the
/// controller (one byte per character there); the firmware holds UTF-8, so a
/// longer text is cut at the last character boundary within 80 bytes.
pub use rri_vocabulary::MAX_STRING_LEN;

/// An RRI `string`: at most 80 bytes of UTF-8, in a fixed buffer.
pub type RriString = heapless::String<MAX_STRING_LEN>;

/// An RRI `time`: seconds, held as exact integer microseconds.
///
/// Not `f32`: a controller that has been up for a day sends
/// `Ts="86400.123"`, and `f32` has only 24 bits of mantissa, so it would be
/// off by several milliseconds. Microseconds in an `i64` hold ±292,000
/// years exactly and cover the 6 decimals real controllers write
/// (`765.315969`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Time {
    micros: i64,
}

impl Time {
    /// 0 s.
    pub const ZERO: Time = Time { micros: 0 };

    /// `micros` microseconds.
    pub const fn from_micros(micros: i64) -> Time {
        Time { micros }
    }

    /// `millis` milliseconds (saturating).
    pub const fn from_millis(millis: i64) -> Time {
        Time {
            micros: millis.saturating_mul(1000),
        }
    }

    /// Exact, in microseconds.
    pub const fn as_micros(self) -> i64 {
        self.micros
    }

    /// Whole milliseconds, rounded towards negative infinity.
    pub const fn as_millis(self) -> i64 {
        self.micros.div_euclid(1000)
    }
}

/// An RRI `frame` (`pose`): position in mm, orientation as Euler angles
/// roll-pitch-yaw in degrees. Travels as attributes `X Y Z Rx Ry Rz` (M4).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Frame {
    /// `X`, mm.
    pub x: f32,
    /// `Y`, mm.
    pub y: f32,
    /// `Z`, mm.
    pub z: f32,
    /// `Rx`, roll, degrees.
    pub rx: f32,
    /// `Ry`, pitch, degrees.
    pub ry: f32,
    /// `Rz`, yaw, degrees.
    pub rz: f32,
}

impl Frame {
    /// Origin, no rotation.
    pub const ZERO: Frame = Frame {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        rx: 0.0,
        ry: 0.0,
        rz: 0.0,
    };
}

/// An RRI `joints` (`joint`): J1..J6 in degrees, travels as attributes
/// `J1..J6` (M4).
pub type Joints = [f32; 6];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_holds_a_day_of_uptime_to_the_microsecond() {
        // The reason Time is not f32.
        let t = Time::from_micros(86_400_123_000);
        assert_eq!(t.as_millis(), 86_400_123);
        assert_ne!((86_400.123_f32 * 1000.0) as i64, 86_400_123);
    }

    #[test]
    fn millis_round_down_for_negative_times() {
        assert_eq!(Time::from_micros(-1).as_millis(), -1);
        assert_eq!(Time::from_millis(-5).as_micros(), -5000);
    }

    #[test]
    fn a_string_holds_80_bytes_and_no_more() {
        let mut s = RriString::new();
        for _ in 0..MAX_STRING_LEN {
            s.push('x').expect("fits");
        }
        assert!(s.push('x').is_err());
    }
}
