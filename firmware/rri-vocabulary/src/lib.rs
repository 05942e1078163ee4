//! # rri-vocabulary: the words and limits of the Robot Reference Interface
//!
//! One home for each protocol fact that more than one crate needs: the GSI
//! compiler (`gsi-config`, `gsi-codegen`, std, at build time), the sensor
//! firmware (`no_std`, every cycle) and the host tools. Before this crate
//! each of them wrote the facts down again and they could drift apart; now a
//! limit changes in one place and every side follows. `embassy-net-driver`
//! is the model: a small leaf crate with no dependencies that everyone above
//! it agrees on.
//!
//! Rules cited are those of the team's `PROTOCOL.md` digest.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod address;
mod values;
mod words;

pub use address::parse_ipv4;
pub use values::{parse_bool, Format, FALSE, MAX_DECIMALS, TRUE};
pub use words::{is_keyword, ControllerPort, Direction, Protocol};

/// Longest RAPID symbol the controller accepts, in characters (G4): names
/// of enums, records, fields and properties.
pub const MAX_NAME_LEN: usize = 16;

/// Longest RAPID string in bytes (G5, M6). The firmware keeps strings in
/// buffers of this size and cuts longer text at a character boundary; the
/// GSI compiler refuses longer enum aliases, since an alias travels as a
/// string value.
pub const MAX_STRING_LEN: usize = 80;

/// Most fields a record may have (G3; the GSI compiler refuses more). The
/// decoder's duplicate check keeps one bit per field in a `u64`.
pub const MAX_FIELDS: usize = 64;

/// Most properties per direction a configuration may have: the firmware's
/// per-property tables (last `Id`, last good value) are this long. Our
/// limit, not the manual's; the GSI compiler refuses more.
pub const MAX_PROPERTIES: usize = 16;
