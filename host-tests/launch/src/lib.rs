//! What `cargo demo`'s launcher (`src/main.rs`) and the host tools agree
//! on: which runs build the plain QEMU image, how, and where.

use std::ffi::OsString;

/// Whether the demo will build the default QEMU image.
pub fn the_plain_demo(args: &[OsString]) -> bool {
    let mut board_is_qemu = true;
    let mut next_is_board = false;
    for a in args.iter().map(|a| a.to_string_lossy()) {
        if next_is_board {
            board_is_qemu = a == "qemu";
            next_is_board = false;
            continue;
        }
        match a.as_ref() {
            "--tcp" | "-h" | "--help" | "-V" | "--version" => return false,
            "--board" => next_is_board = true,
            s if s.starts_with("--board=") => board_is_qemu = s == "--board=qemu",
            _ => {}
        }
    }
    board_is_qemu
}

/// The QEMU board's target directory, under cargo's.
pub const QEMU_TARGET_DIR: &str = "mps2-an500";

/// The plain QEMU image's build.
pub const FIRMWARE_BUILD: &[&str] = &[
    "build",
    "-p",
    "rri-sensor",
    "--bin",
    "rri-sensor",
    "--profile",
    "firmware",
    "--target",
    "thumbv7em-none-eabihf",
    "--features",
    "board,hal-board/mps2-an500",
];

#[cfg(test)]
mod tests {
    use super::*;

    fn os(v: &[&str]) -> Vec<OsString> {
        v.iter().map(OsString::from).collect()
    }

    #[test]
    fn only_the_plain_qemu_demo_is_built_ahead() {
        for plain in [
            &[][..],
            &["--cycles", "500"],
            &["--board", "qemu"],
            &["--board=qemu", "--device-status"],
            &["--replay", "x.pcap", "--ignore", "AppData"],
        ] {
            assert!(the_plain_demo(&os(plain)), "{plain:?}");
        }
        for not in [
            &["--tcp"][..],
            &["--board", "h743"],
            &["--board=f767"],
            &["--help"],
            &["--cycles", "5", "--tcp"],
        ] {
            assert!(!the_plain_demo(&os(not)), "{not:?}");
        }
    }
}
