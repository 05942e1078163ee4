//! One math for a sensor file, the same on the host and the MCU: `core`
//! has no `sin`, `sqrt` or `exp` for `f32` (they need a libm), and on the
//! host `x.sin()` silently takes `std`'s, whose results differ from the
//! MCU's in the last bits. These call `micromath` (a firmware dependency)
//! on both, so `cargo sensor-host`, the QEMU board and the NUCLEOs compute
//! the same values from the same samples, and a sensor file needs no
//! `#[cfg]` and no import of its own:
//!
//! ```
//! use rri_firmware::sensor::prelude::*;
//! let y = math::sin(0.5) * math::sqrt(2.0);
//! # let _ = y;
//! ```
//!
//! micromath trades accuracy for speed (its documentation gives each
//! function's error: `sin`/`cos` within 0.002, `exp`/`ln` within about
//! 0.1 %); `sqrt` here is refined to full `f32` precision, since
//! micromath's own is only about 5 % right. A sensor that needs more
//! brings its own.

use micromath::F32Ext;

/// Sine (radians).
pub fn sin(x: f32) -> f32 {
    F32Ext::sin(x)
}

/// Cosine (radians).
pub fn cos(x: f32) -> f32 {
    F32Ext::cos(x)
}

/// Sine and cosine at once (radians).
pub fn sin_cos(x: f32) -> (f32, f32) {
    F32Ext::sin_cos(x)
}

/// Tangent (radians).
pub fn tan(x: f32) -> f32 {
    F32Ext::tan(x)
}

/// The angle of the point (`x`, `y`), in radians, −π to π.
pub fn atan2(y: f32, x: f32) -> f32 {
    F32Ext::atan2(y, x)
}

/// Square root of a normal number, to within an ulp or two: micromath's estimate (about 5 %
/// off) refined by three Newton steps, plain `f32` arithmetic that gives
/// the same bits on the host and the MCU. NaN for a negative `x`.
pub fn sqrt(x: f32) -> f32 {
    if x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 || !x.is_finite() {
        // ±0, ∞ and NaN are their own roots.
        return x;
    }
    let mut y = F32Ext::sqrt(x);
    for _ in 0..3 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// e to the power of `x`.
pub fn exp(x: f32) -> f32 {
    F32Ext::exp(x)
}

/// Natural logarithm.
pub fn ln(x: f32) -> f32 {
    F32Ext::ln(x)
}

/// `x` to the power of `n`.
pub fn powf(x: f32, n: f32) -> f32 {
    F32Ext::powf(x, n)
}

/// Absolute value.
pub fn abs(x: f32) -> f32 {
    F32Ext::abs(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Close to the exact values within micromath's stated errors, on the
    /// host as on the MCU (the same code runs on both).
    #[test]
    fn close_to_the_exact_values() {
        let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol * b.abs().max(1.0);
        assert!(close(sin(0.5), 0.479_425_5, 1e-3));
        assert!(close(cos(0.5), 0.877_582_6, 1e-3));
        for x in [2.0f32, 1e-6, 0.25, 3.0, 12_345.0, 1e30] {
            let exact = (x as f64).sqrt();
            assert!(
                ((sqrt(x) as f64 - exact) / exact).abs() < 2.5e-7,
                "sqrt({x}) = {}",
                sqrt(x)
            );
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert!(sqrt(-1.0).is_nan());
        assert!(close(exp(1.0), core::f32::consts::E, 1e-2));
        assert!(close(ln(core::f32::consts::E), 1.0, 1e-2));
        assert!(close(atan2(1.0, 1.0), core::f32::consts::FRAC_PI_4, 1e-2));
        assert!(close(powf(2.0, 10.0), 1024.0, 1e-2));
        assert_eq!(abs(-3.0), 3.0);
    }

    /// Not `std`'s: the host gets micromath's approximation too (std's
    /// `sin(0.5)` is 0.47942555, micromath's differs in its last digits),
    /// so a sensor computes on the host what it computes on the MCU.
    #[test]
    fn the_same_function_as_on_the_mcu() {
        assert_eq!(sin(0.5), micromath::F32Ext::sin(0.5f32));
        assert_eq!(cos(0.5), micromath::F32Ext::cos(0.5f32));
    }
}
