//! What a board hands a sensor's sampling half: its inputs, behind one
//! chip-free trait. The board module implements it over its peripherals
//! (the NUCLEO boards: ADC1 on the Arduino header's A0); the sensor
//! (`rri_firmware::sensor::Sensor::sample`) reads through it and never
//! names a chip, so the same sensor builds for every board and runs on the
//! host. Every method has a default (nothing there), so a board without an
//! input still builds and a sensor that needs it gets `None`.
//!
//! A device on another peripheral (SPI, I²C, a second ADC channel, a GPIO
//! trigger): give this trait a method for it with a `None` default,
//! implement it on the board that has it (chip code stays in that board's
//! module), and read it from the sensor's `sample`.

/// A board's inputs as a sensor reads them.
pub trait Inputs {
    /// Analog input `channel` as a fraction of its full scale, 0.0..=1.0
    /// (0 is the Arduino header's A0); `None` where the board has no such
    /// input. May wait for the conversion (a few µs): it runs on the
    /// background executor.
    fn analog(&mut self, channel: usize) -> Option<f32> {
        let _ = channel;
        None
    }

    /// `true` where nothing real can be read (the QEMU board, the host's
    /// simulated source): the firmware then asks the sensor to simulate a
    /// sample instead of reading one.
    fn simulated(&self) -> bool {
        false
    }
}

/// A board with no inputs to read: every sample is simulated.
#[derive(Clone, Copy, Debug, Default)]
pub struct Simulated;

impl Inputs for Simulated {
    fn simulated(&self) -> bool {
        true
    }
}

/// Inputs that read nothing and are not simulated: a sensor sees `None`
/// everywhere (tests of how a sensor copes with a missing input).
#[derive(Clone, Copy, Debug, Default)]
pub struct Absent;

impl Inputs for Absent {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_read_nothing() {
        assert_eq!(Absent.analog(0), None);
        assert!(!Absent.simulated());
        assert!(Simulated.simulated());
        assert_eq!(Simulated.analog(0), None);
    }
}
