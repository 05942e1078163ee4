//! What a run is asked to do: [`RobotOptions`], the library form of
//! `cargo robot`'s command line.

use crate::fault::Fault;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Everything `cargo robot` takes.
#[derive(Clone, Debug)]
pub struct RobotOptions {
    pub gsi: PathBuf,
    pub device: Option<String>,
    pub to: SocketAddr,
    pub cycles: u64,
    /// Send period, a multiple of 4 ms.
    pub rate_ms: u32,
    /// `--send NAME=MS`: the properties to send, each every MS ms (one
    /// `SiSetCyclic` each). Empty: the first property the controller sends,
    /// every `rate_ms`.
    pub sends: Vec<(String, u32)>,
    /// `--reply NAME`: the property the device answers with (the device's
    /// `RRI_REPLY`); `None`: the first property the device sends.
    pub reply: Option<String>,
    /// `false`: send the next message as soon as the last one is answered
    /// (tests); latencies still count as late beyond one `rate_ms` cycle.
    pub pacing: bool,
    pub tcp: bool,
    pub csv: Option<PathBuf>,
    pub plot: Option<PathBuf>,
    pub pcap: Option<PathBuf>,
    pub json: Option<PathBuf>,
    /// `--show FIELD,…`: reply fields to show (see [`crate::show`]);
    /// empty: replies are checked, their values not kept.
    pub show: Vec<String>,
    /// `--show-csv FILE`: the shown values, one row per reply.
    pub show_csv: Option<PathBuf>,
    /// `--show-plot FILE`: the shown values over time (.svg or .png).
    pub show_plot: Option<PathBuf>,
    /// `--show-every-ms`: at most one live line per this many ms (0: every
    /// reply).
    pub show_every_ms: u64,
    pub faults: Vec<Fault>,
    pub seed: u64,
    /// Id of the first message (to test the u32 wrap, S3).
    pub first_id: u32,
    pub progress: bool,
    /// Lines of the device's own log (e.g. the QEMU board's defmt output),
    /// printed above the progress bar as they come (`cargo demo`).
    pub device_log: Option<Arc<Mutex<Vec<String>>>>,
    /// `--device-status URL`: read the device's `/status.json` before and
    /// after the run and put its counts beside the simulator's
    /// ([`crate::device_status`]).
    pub device_status: Option<String>,
    /// `--replay FILE`: replay a capture's robot messages instead of
    /// making them ([`crate::replay`]).
    pub replay: Option<crate::replay::ReplayOptions>,
    /// Sends each UDP robot message instead of the socket (from the
    /// socket's own address, so replies still come back to it): how a
    /// test puts the controller's datagrams on the wire its own way
    /// (`cargo flood -- --fragments --tail-attack` crafts them as IP
    /// fragments, the last one first). `None`: the socket sends.
    pub udp_send: Option<UdpSend>,
}

/// What a [`UdpSend`] calls: `(from, to, datagram)`.
pub type SendFn = dyn Fn(SocketAddr, SocketAddr, &[u8]) -> std::io::Result<()> + Send + Sync;

/// A replacement for the UDP socket's send.
#[derive(Clone)]
pub struct UdpSend(pub Arc<SendFn>);

impl std::fmt::Debug for UdpSend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("UdpSend(..)")
    }
}

impl RobotOptions {
    /// The defaults of `cargo robot` (1,000 cycles every 4 ms over UDP,
    /// paced, no outputs) for the layout in `gsi`, sent to `to`.
    pub fn new(gsi: PathBuf, to: SocketAddr) -> Self {
        RobotOptions {
            gsi,
            device: None,
            to,
            cycles: 1000,
            rate_ms: 4,
            sends: Vec::new(),
            reply: None,
            pacing: true,
            tcp: false,
            csv: None,
            plot: None,
            pcap: None,
            json: None,
            show: Vec::new(),
            show_csv: None,
            show_plot: None,
            show_every_ms: 100,
            faults: Vec::new(),
            seed: 1,
            first_id: 1,
            progress: false,
            device_log: None,
            device_status: None,
            replay: None,
            udp_send: None,
        }
    }
}
