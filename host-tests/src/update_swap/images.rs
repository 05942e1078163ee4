//! The course's images (`cargo update-swap`): A, and the update files
//! of B (one patch newer) and C (another layout, one patch newer again),
//! built and signed for the board the course runs on.

use crate::qemu;
use crate::setup::Setup;
use crate::update_file::{flat_image, image_version, read_key, signed_file};
use rri_update::Version;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where the course runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    /// QEMU's mps2-an500.
    Qemu,
    /// The NUCLEO-H743ZI2 on the model of its chip (`cargo rehost`).
    H743,
    /// The NUCLEO-F767ZI on the model of its chip, its flash in dual-bank
    /// mode (`cargo rehost -- --dual-bank`).
    F767,
}

impl Board {
    /// The name update files carry.
    pub(crate) fn update_name(self) -> &'static str {
        match self {
            Board::Qemu => "mps2-an500",
            Board::H743 => "nucleo-h743zi",
            Board::F767 => "nucleo-f767zi",
        }
    }

    /// The engine's name for a rehosted board (`None`: QEMU's).
    pub(crate) fn rehosted(self) -> Option<&'static str> {
        match self {
            Board::Qemu => None,
            Board::H743 => Some("h743"),
            Board::F767 => Some("f767"),
        }
    }

    /// The engine's options the board always runs with: the F767's
    /// flash in the dual-bank mode its updates need.
    pub(crate) fn engine_options(self) -> &'static [&'static str] {
        match self {
            Board::F767 => &["--dual-bank"],
            Board::Qemu | Board::H743 => &[],
        }
    }

    /// Its row in `cargo boards`' table (`None`: QEMU's).
    pub(crate) fn nucleo(self) -> Option<&'static crate::boards::Board> {
        match self {
            Board::Qemu => None,
            Board::F767 => Some(&crate::boards::BOARDS[0]),
            Board::H743 => Some(&crate::boards::BOARDS[1]),
        }
    }

    /// The longest the confirmation may keep the status page away: on
    /// a NUCLEO it erases a 128K sector of the state partition, 2-4 s of
    /// the chip's time during which the background executor (the page's)
    /// polls the erase; the engine emulates that polling slower than the
    /// wall clock.
    pub(crate) fn flash_wait(self) -> Duration {
        match self {
            Board::Qemu => Duration::from_secs(10),
            Board::H743 | Board::F767 => Duration::from_secs(60),
        }
    }

    /// The longest a restart with a swap (or a rollback's) may take until
    /// the device answers again: a NUCLEO's bootloader erases and writes
    /// six 128K pages several times over at the datasheet's times.
    pub(crate) fn swap_wait(self) -> Duration {
        match self {
            Board::Qemu => Duration::from_secs(60),
            Board::H743 | Board::F767 => Duration::from_secs(360),
        }
    }
}

/// The three images and their update files.
pub struct Images {
    pub a: PathBuf,
    pub a_version: String,
    pub b_file: PathBuf,
    pub b_version: String,
    pub c_file: PathBuf,
    pub c_version: String,
    /// The GSI folder C is built from (the robot's property renamed).
    pub c_gsi: PathBuf,
}

/// `version` with its patch number raised by `by`.
fn newer(version: &str, by: u16) -> Result<String, String> {
    let v = Version::parse(version).ok_or_else(|| format!("{version:?} is no version"))?;
    Ok(format!("{}.{}.{}", v.major, v.minor, v.patch + by))
}

/// `gsi` copied to `to` with the robot's property renamed (`RobData` to
/// `RobOther`): an image built from it takes none of the robot's messages
/// as its own (the decoder skips an unknown field, but not an unknown
/// property).
fn other_layout(gsi: &Path, to: &Path) -> Result<(), String> {
    let copy = |from: &Path, to: &Path| -> Result<(), String> {
        std::fs::create_dir_all(to).map_err(|e| format!("{}: {e}", to.display()))?;
        for entry in std::fs::read_dir(from).map_err(|e| format!("{}: {e}", from.display()))? {
            let entry = entry.map_err(|e| e.to_string())?;
            let (src, dst) = (entry.path(), to.join(entry.file_name()));
            if src.is_file() {
                std::fs::copy(&src, &dst).map_err(|e| format!("{}: {e}", src.display()))?;
            }
        }
        Ok(())
    };
    copy(gsi, to)?;
    for dir in std::fs::read_dir(gsi).map_err(|e| format!("{}: {e}", gsi.display()))? {
        let dir = dir.map_err(|e| e.to_string())?.path();
        if dir.is_dir() {
            let name = dir.file_name().unwrap_or_default();
            copy(&dir, &to.join(name))?;
            let config = to.join(name).join("Configuration.xml");
            if let Ok(text) = std::fs::read_to_string(&config) {
                if !text.contains("\"RobData\"") {
                    return Err(format!(
                        "{}: no RobData property to rename",
                        config.display()
                    ));
                }
                std::fs::write(&config, text.replace("\"RobData\"", "\"RobOther\""))
                    .map_err(|e| format!("{}: {e}", config.display()))?;
            }
        }
    }
    Ok(())
}

/// Builds A, B and C for `board` and signs B and C: with the QEMU
/// board's demonstration key, or for a NUCLEO with a key pair made for
/// this run (`target/update-swap/<board>-key`) and built into all three.
pub fn build(setup: &Setup, board: Board) -> Result<Images, String> {
    let work = qemu::target_dir().join("update-swap");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let (secret, public) = match board {
        Board::Qemu => (
            crate::workspace().join("firmware/rri-update/demo-key/update-key"),
            None,
        ),
        Board::H743 | Board::F767 => {
            let dir = work.join(format!("{}-key", board.rehosted().unwrap_or("qemu")));
            let (secret, public) = (dir.join("update-key"), dir.join("update-key.pub"));
            if !(secret.is_file() && public.is_file()) {
                let _ = std::fs::remove_dir_all(&dir);
                crate::update_file::keygen(&dir)?;
            }
            (secret, Some(public))
        }
    };
    let seed = read_key(&secret)?;
    let key = public.as_ref().map(|p| p.display().to_string());
    let features = match board {
        Board::Qemu => qemu::BOARD_FEATURES,
        Board::H743 => "board,hal-board/nucleo-h743zi",
        Board::F767 => "board,hal-board/nucleo-f767zi",
    };
    let dir = match board {
        Board::Qemu => "qemu",
        Board::H743 => "update-swap-h743",
        Board::F767 => "update-swap-f767",
    };
    let image = |gsi: Option<&Path>, version: Option<&str>, name: &str| {
        let mut env: Vec<(&str, &str)> = Vec::new();
        if let Some(k) = &key {
            env.push(("RRI_UPDATE_KEY", k));
        }
        if let Some(v) = version {
            env.push(("RRI_IMAGE_VERSION", v));
        }
        qemu::build_board(features, &[], gsi, &env, dir, name)
    };
    let a = match board {
        Board::Qemu => qemu::build_firmware(&[], setup.build_gsi.as_deref(), "swap-a")?,
        Board::H743 | Board::F767 => image(setup.build_gsi.as_deref(), None, "swap-a")?,
    };
    let a_version = image_version(&std::fs::read(&a).map_err(|e| e.to_string())?)?
        .ok_or("image A reports no version")?;
    let b_version = newer(&a_version, 1)?;
    let c_version = newer(&a_version, 2)?;
    let gsi_c = work.join("gsi-c");
    other_layout(&setup.gsi, &gsi_c)?;
    let sign = |elf: &Path, version: &str, out: &str| -> Result<PathBuf, String> {
        let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        if image_version(&bytes)?.as_deref() != Some(version) {
            return Err(format!(
                "{} does not report version {version}",
                elf.display()
            ));
        }
        let (origin, image) = flat_image(&bytes)?;
        let v = Version::parse(version).ok_or("no version")?;
        let file = signed_file(&image, origin, board.update_name(), v, &seed)?;
        let path = work.join(out);
        std::fs::write(&path, file).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(path)
    };
    let b = image(setup.build_gsi.as_deref(), Some(&b_version), "swap-b")?;
    let b_file = sign(&b, &b_version, "b.update")?;
    let c = image(Some(&gsi_c), Some(&c_version), "swap-c")?;
    let c_file = sign(&c, &c_version, "c.update")?;
    Ok(Images {
        a,
        a_version,
        b_file,
        b_version,
        c_file,
        c_version,
        c_gsi: gsi_c,
    })
}
