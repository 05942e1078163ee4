//! The update file's trailer: what the image says about itself, signed
//! with it. Fixed layout, little-endian, 64 bytes:
//!
//! | bytes | field |
//! |---|---|
//! | 0..8 | magic `RRIIMG01` |
//! | 8..24 | board, ASCII, zero-padded (`nucleo-f767zi`, `nucleo-h743zi`, `mps2-an500`) |
//! | 24..30 | version: major, minor, patch (`u16` each) |
//! | 30..32 | zero |
//! | 32..36 | the image's length in bytes (what comes before the trailer) |
//! | 36..40 | the address the image is linked to run from (the active partition's start) |
//! | 40..64 | zero (room for what a later format needs; a non-zero byte refuses the file) |
//!
//! The signature (64 bytes) follows the trailer and covers the image and
//! the trailer: a file cannot be moved to another board or version by
//! editing its trailer.

/// Bytes of the trailer.
pub const TRAILER_LEN: usize = 64;
/// Bytes of the signature after it.
pub const SIGNATURE_LEN: usize = 64;
/// The trailer's first bytes.
pub const MAGIC: [u8; 8] = *b"RRIIMG01";
/// Longest board name the trailer holds.
pub const BOARD_LEN: usize = 16;

/// A firmware version, `major.minor.patch`, ordered as such.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Version {
    /// Major.
    pub major: u16,
    /// Minor.
    pub minor: u16,
    /// Patch.
    pub patch: u16,
}

impl Version {
    /// `"1.2.3"` (a pre-release or build suffix after `-` or `+` is not
    /// part of the order and is left out); `None` when it is not three
    /// numbers each under 65,536. `const`, so a firmware reads its own
    /// at build time (rri-sensor's `RRI_IMAGE_VERSION`).
    pub const fn parse(text: &str) -> Option<Version> {
        let mut rest = text.as_bytes();
        // The three numbers so far, the one being read, its digits.
        let mut done = [0u32; 3];
        let mut part = 0;
        let mut value = 0u32;
        let mut digits = 0;
        while let [c, tail @ ..] = rest {
            rest = tail;
            match *c {
                b'-' | b'+' => break,
                b'.' => {
                    if digits == 0 || part == 2 {
                        return None;
                    }
                    done = match part {
                        0 => [value, 0, 0],
                        _ => [done[0], value, 0],
                    };
                    part += 1;
                    value = 0;
                    digits = 0;
                }
                b'0'..=b'9' => {
                    value = value * 10 + (*c - b'0') as u32;
                    if value > u16::MAX as u32 {
                        return None;
                    }
                    digits += 1;
                }
                _ => return None,
            }
        }
        if part != 2 || digits == 0 {
            return None;
        }
        Some(Version {
            major: done[0] as u16,
            minor: done[1] as u16,
            patch: value as u16,
        })
    }
}

/// What the running firmware is: the file must be for its board and, unless
/// forced, not older.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Running<'a> {
    /// The board's name, as the trailer writes it.
    pub board: &'a str,
    /// Where its active partition starts: an image linked for another
    /// address would crash at its first instruction.
    pub origin: u32,
    /// Its version.
    pub version: Version,
}

/// What an image says about itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Trailer {
    /// The board, zero-padded.
    pub board: [u8; BOARD_LEN],
    /// Its version.
    pub version: Version,
    /// Bytes of the image before the trailer.
    pub image_len: u32,
    /// The address it is linked to run from.
    pub origin: u32,
}

/// Why a trailer is no trailer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadTrailer {
    /// Not our magic: not an update file (or not one of this format).
    Magic,
    /// A byte that must be zero is not.
    Reserved,
    /// The board name is not ASCII, or empty.
    Board,
}

impl Trailer {
    /// The trailer for `board` (at most [`BOARD_LEN`] bytes of ASCII;
    /// `None` otherwise), `version` and an image of `image_len` bytes
    /// linked at `origin`.
    pub fn new(board: &str, version: Version, image_len: u32, origin: u32) -> Option<Trailer> {
        let name = board.as_bytes();
        if name.is_empty() || name.len() > BOARD_LEN || !name.iter().all(|b| b.is_ascii_graphic()) {
            return None;
        }
        let mut padded = [0; BOARD_LEN];
        padded.get_mut(..name.len())?.copy_from_slice(name);
        Some(Trailer {
            board: padded,
            version,
            image_len,
            origin,
        })
    }

    /// Its 64 bytes.
    pub fn encode(&self) -> [u8; TRAILER_LEN] {
        let mut t = [0; TRAILER_LEN];
        let fields: [(usize, &[u8]); 7] = [
            (0, &MAGIC),
            (8, &self.board),
            (24, &self.version.major.to_le_bytes()),
            (26, &self.version.minor.to_le_bytes()),
            (28, &self.version.patch.to_le_bytes()),
            (32, &self.image_len.to_le_bytes()),
            (36, &self.origin.to_le_bytes()),
        ];
        for (at, bytes) in fields {
            if let Some(to) = t.get_mut(at..at + bytes.len()) {
                to.copy_from_slice(bytes);
            }
        }
        t
    }

    /// The trailer in `t`.
    pub fn decode(t: &[u8; TRAILER_LEN]) -> Result<Trailer, BadTrailer> {
        let (magic, rest) = t.split_at(8);
        if magic != MAGIC {
            return Err(BadTrailer::Magic);
        }
        let (board, rest) = rest.split_at(BOARD_LEN);
        let (version, rest) = rest.split_at(8);
        let (len, rest) = rest.split_at(4);
        let (origin, reserved) = rest.split_at(4);
        let u16_at = |i: usize| {
            u16::from_le_bytes([
                version.get(i).copied().unwrap_or(0),
                version.get(i + 1).copied().unwrap_or(0),
            ])
        };
        let zero_pad = version.get(6..).is_some_and(|z| z.iter().all(|&b| b == 0));
        if !zero_pad || reserved.iter().any(|&b| b != 0) {
            return Err(BadTrailer::Reserved);
        }
        let name_len = board.iter().position(|&b| b == 0).unwrap_or(BOARD_LEN);
        let (name, padding) = board.split_at(name_len);
        if name.is_empty()
            || !name.iter().all(|b| b.is_ascii_graphic())
            || padding.iter().any(|&b| b != 0)
        {
            return Err(BadTrailer::Board);
        }
        let mut padded = [0; BOARD_LEN];
        padded.copy_from_slice(board);
        let mut l = [0; 4];
        l.copy_from_slice(len);
        let mut o = [0; 4];
        o.copy_from_slice(origin);
        Ok(Trailer {
            board: padded,
            version: Version {
                major: u16_at(0),
                minor: u16_at(2),
                patch: u16_at(4),
            },
            image_len: u32::from_le_bytes(l),
            origin: u32::from_le_bytes(o),
        })
    }

    /// The board's name.
    pub fn board_name(&self) -> &str {
        let len = self.board.iter().position(|&b| b == 0).unwrap_or(BOARD_LEN);
        self.board
            .get(..len)
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or("")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const V: Version = match Version::parse("0.1.0") {
        Some(v) => v,
        None => Version {
            major: 0,
            minor: 0,
            patch: 0,
        },
    };

    #[test]
    fn versions_parse_and_order() {
        assert_eq!(
            Version::parse("1.20.3-rc.1"),
            Some(Version {
                major: 1,
                minor: 20,
                patch: 3
            })
        );
        for bad in [
            "",
            "1",
            "1.2",
            "1.2.3.4",
            "1..3",
            "a.b.c",
            "1.2.70000",
            "1.2.",
        ] {
            assert_eq!(Version::parse(bad), None, "{bad}");
        }
        assert!(Version::parse("0.10.0") > Version::parse("0.9.9"));
        assert_eq!(V.minor, 1);
    }

    #[test]
    fn a_trailer_reads_back_and_every_bad_field_is_named() {
        let t = Trailer::new("nucleo-f767zi", V, 212_000, 0x0808_0000).unwrap();
        let bytes = t.encode();
        assert_eq!(Trailer::decode(&bytes), Ok(t));
        assert_eq!(t.board_name(), "nucleo-f767zi");
        let mut b = bytes;
        b[0] ^= 1;
        assert_eq!(Trailer::decode(&b), Err(BadTrailer::Magic));
        let mut b = bytes;
        b[44] = 1;
        assert_eq!(Trailer::decode(&b), Err(BadTrailer::Reserved));
        let mut b = bytes;
        b[30] = 1;
        assert_eq!(Trailer::decode(&b), Err(BadTrailer::Reserved));
        let mut b = bytes;
        b[8] = 0;
        assert_eq!(Trailer::decode(&b), Err(BadTrailer::Board));
        let mut b = bytes;
        b[23] = b'x'; // a byte after the name's end
        assert_eq!(Trailer::decode(&b), Err(BadTrailer::Board));
        assert_eq!(Trailer::new("", V, 1, 0), None);
        assert_eq!(Trailer::new("a-board-name-too-long", V, 1, 0), None);
    }
}
