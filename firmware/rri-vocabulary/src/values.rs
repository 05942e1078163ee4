//! How values are written: the number format of sent messages (M5) and the
//! boolean words (M7), for the encoder that writes them, the decoder that
//! reads them and the GSI compiler that sizes buffers for them.

/// Most decimals the firmware's fixed-point writers support: time is held
/// in microseconds, so a seventh decimal would be invented. Build settings
/// asking for more are refused; the encoder clamps as a second line.
pub const MAX_DECIMALS: u8 = 6;

/// How numbers are written in sent messages (M5): fixed decimals, never an
/// exponent. Chosen at build time (`RRI_REAL_DECIMALS`,
/// `RRI_TIME_DECIMALS`); the GSI compiler sizes the send buffers from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Format {
    /// Decimals of `real` values (lengths in mm, angles in deg); at most
    /// [`MAX_DECIMALS`].
    pub real_decimals: u8,
    /// Decimals of `time` values (seconds, 1 ms resolution in the manual);
    /// at most [`MAX_DECIMALS`].
    pub time_decimals: u8,
}

impl Format {
    /// A format with both counts clamped to [`MAX_DECIMALS`].
    pub const fn new(real_decimals: u8, time_decimals: u8) -> Format {
        const fn clamp(n: u8) -> u8 {
            if n > MAX_DECIMALS {
                MAX_DECIMALS
            } else {
                n
            }
        }
        Format {
            real_decimals: clamp(real_decimals),
            time_decimals: clamp(time_decimals),
        }
    }
}

/// `true` as the device sends it (M7: RAPID's literal).
pub const TRUE: &[u8] = b"TRUE";
/// `false` as the device sends it (M7: RAPID's literal).
pub const FALSE: &[u8] = b"FALSE";

/// A boolean word (M7, and `DryRun` etc. in the GSI files): `true`/`false`
/// in any case, or `1`/`0`. `text` is already trimmed of whitespace: the
/// decoder trims XML whitespace, the GSI reader any whitespace.
#[inline]
pub fn parse_bool(text: &[u8]) -> Option<bool> {
    if text.eq_ignore_ascii_case(b"true") || text == b"1" {
        Some(true)
    } else if text.eq_ignore_ascii_case(b"false") || text == b"0" {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m7_words_in_any_case_and_digits() {
        for t in [&b"true"[..], b"TRUE", b"True", b"1"] {
            assert_eq!(parse_bool(t), Some(true));
        }
        for t in [&b"false"[..], b"FALSE", b"fAlSe", b"0"] {
            assert_eq!(parse_bool(t), Some(false));
        }
        for t in [&b"yes"[..], b"", b"01", b" true", b"truee"] {
            assert_eq!(parse_bool(t), None);
        }
        assert_eq!(parse_bool(TRUE), Some(true));
        assert_eq!(parse_bool(FALSE), Some(false));
    }

    #[test]
    fn m5_decimals_clamp_at_the_microsecond() {
        assert_eq!(
            Format::new(3, 9),
            Format {
                real_decimals: 3,
                time_decimals: 6
            }
        );
    }
}
