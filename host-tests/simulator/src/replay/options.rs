//! What `--replay` is asked to do: the file, the conversation, the pace,
//! the comparison's rules and the outputs.

use super::compare;
use std::net::SocketAddrV4;
use std::path::PathBuf;

/// When each recorded robot message goes out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pace {
    /// At the recorded times (from the first message).
    #[default]
    Recorded,
    /// One every this many ms.
    Every(u32),
    /// Each as soon as the reply to the last is in.
    AsFast,
}

/// What `--replay` is asked to do.
#[derive(Clone, Debug, Default)]
pub struct ReplayOptions {
    pub file: PathBuf,
    /// `--conversation ADDR:PORT`: the device's end, when the file has
    /// several conversations (or one on another port).
    pub conversation: Option<SocketAddrV4>,
    pub pace: Pace,
    pub rules: compare::Rules,
    /// `--extract DIR`: write the robot messages there, one file each, and
    /// replay nothing.
    pub extract: Option<PathBuf>,
    /// `--diff FILE.csv`: every difference, one row each.
    pub diff_csv: Option<PathBuf>,
}
