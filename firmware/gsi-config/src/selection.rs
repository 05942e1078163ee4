//! Which GSI folder and device a firmware build compiles, from the build
//! settings `RRI_GSI_DIR` and `RRI_DEVICE`. The firmware's build script
//! and the host tools that must read the configuration the firmware was
//! built from (the robot simulator, the QEMU bench) resolve them here, so
//! they cannot disagree about a relative path or a blank value.

use std::path::{Path, PathBuf};

/// The GSI folder when `RRI_GSI_DIR` is unset: the manual's example,
/// relative to the workspace root.
pub const DEFAULT_GSI_DIR: &str = "firmware/gsi/GSI";

/// A GSI folder and the device chosen in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Selection {
    /// The GSI folder (`Settings.xml` and one folder per device).
    pub dir: PathBuf,
    /// The CDP client of `Settings.xml`; `None` takes the only one.
    pub device: Option<String>,
}

impl Selection {
    /// The selection of this process's environment: `RRI_GSI_DIR` (a
    /// relative path is taken from `workspace`, the workspace root; unset
    /// or blank: [`DEFAULT_GSI_DIR`]) and `RRI_DEVICE` (unset or blank:
    /// none).
    pub fn from_env(workspace: &Path) -> Selection {
        Selection::from_settings(workspace, setting("RRI_GSI_DIR"), setting("RRI_DEVICE"))
    }

    /// [`Selection::from_env`] with the two settings given.
    pub fn from_settings(
        workspace: &Path,
        gsi_dir: Option<String>,
        device: Option<String>,
    ) -> Selection {
        let dir = match gsi_dir {
            Some(d) if Path::new(&d).is_absolute() => PathBuf::from(d),
            Some(d) => workspace.join(d),
            None => workspace.join(DEFAULT_GSI_DIR),
        };
        Selection { dir, device }
    }
}

/// Every setting the firmware's build reads from the environment (the
/// GSI folder and device, the number formats, the controller, the reply
/// and periodic properties, the network, the diagnostics' port); the
/// sensor (`RRI_SENSOR`) is `rri-active-sensor`'s. The build script
/// tracks each, and `cargo sensor-check` clears them where a step builds
/// the manual's configuration.
pub const BUILD_SETTINGS: [&str; 11] = [
    "RRI_GSI_DIR",
    "RRI_DEVICE",
    "RRI_REAL_DECIMALS",
    "RRI_TIME_DECIMALS",
    "RRI_CONTROLLER",
    "RRI_SEND_PERIOD_MS",
    "RRI_REPLY",
    "RRI_PERIODIC",
    "RRI_NETMASK",
    "RRI_GATEWAY",
    "RRI_HTTP_PORT",
];

/// A build setting from the environment: `None` when unset or blank, so
/// `RRI_X=` means the default everywhere (the build script reads every
/// `RRI_*` setting through this).
pub fn setting(name: &str) -> Option<String> {
    std::env::var(name).ok().filter(|v| !v.trim().is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_folders_are_taken_from_the_workspace() {
        let ws = Path::new("/ws");
        let s = |dir: Option<&str>| Selection::from_settings(ws, dir.map(String::from), None).dir;
        assert_eq!(s(None), Path::new("/ws/firmware/gsi/GSI"));
        assert_eq!(s(Some("my/GSI")), Path::new("/ws/my/GSI"));
        assert_eq!(s(Some("/abs/GSI")), Path::new("/abs/GSI"));
    }
}
