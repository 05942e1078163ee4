//! The configuration a run (`cargo demo`, `cargo hil`, `cargo rehost`)
//! builds the firmware for and drives: the GSI folder and its device.

use std::net::SocketAddr;
use std::path::PathBuf;

/// The configuration a run builds and drives.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The GSI folder the simulator reads.
    pub gsi: PathBuf,
    /// `RRI_DEVICE`, when the folder has several devices.
    pub device_name: Option<String>,
    /// The GSI folder to build the firmware from, when not the caller's
    /// environment (`--tcp`).
    pub build_gsi: Option<PathBuf>,
    /// The device the firmware is built for.
    pub device: gsi_config::Device,
}

impl Setup {
    /// The configured device (`RRI_GSI_DIR` / `RRI_DEVICE`), or with
    /// `tcp` the manual's device over TCP.
    pub fn new(tcp: bool) -> Result<Setup, String> {
        let (gsi, device_name, build_gsi) = if tcp {
            let dir = crate::workspace().join("host-tests/gsi/anydevice-tcp/GSI");
            (dir.clone(), None, Some(dir))
        } else {
            let (dir, name) = crate::built_gsi();
            (dir, name, None)
        };
        let device = gsi_config::load(&gsi, device_name.as_deref())
            .map_err(|f| f.to_string())?
            .device;
        Ok(Setup {
            gsi,
            device_name,
            build_gsi,
            device,
        })
    }

    /// The device's channel on its own network.
    pub fn channel(&self) -> Result<SocketAddr, String> {
        let ip: std::net::Ipv4Addr = self.device.network.address.parse().map_err(|_| {
            format!(
                "Description.xml's Network Address {} is not an IPv4 address",
                self.device.network.address
            )
        })?;
        Ok((ip, self.device.channel.port).into())
    }
}
