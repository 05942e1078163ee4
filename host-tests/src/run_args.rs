//! The simulator's side of a run, as `cargo demo` and `cargo hil` take it
//! on their command lines ([`RunArgs`]).

use crate::robot::args::{plot_path, Properties, ShowArgs};
use crate::robot::RobotOptions;
use crate::setup::Setup;
use std::path::PathBuf;

/// The clap id of `--fault SPEC`, so a command whose own `--fault` means
/// something else can rename it (`cargo hil` calls it `--inject`).
pub const FAULT_ARG: &str = "inject_fault";

/// The simulator's side of a run (`cargo demo` and `cargo hil` take the
/// same options).
#[derive(clap::Args, Clone, Debug)]
pub struct RunArgs {
    /// Over a TCP channel: the manual's device with Protocol="Tcp"
    /// (host-tests/gsi/anydevice-tcp) instead of the configured one.
    #[arg(long)]
    pub tcp: bool,
    /// Robot messages to send, one per 4 ms cycle.
    #[arg(long, default_value_t = 2500, value_parser = clap::value_parser!(u64).range(1..))]
    pub cycles: u64,
    /// Robot cycles sent before the counted run (their figures are
    /// printed, their timing is not judged; 0: none).
    #[arg(long, default_value_t = 250)]
    pub warm_up: u64,
    /// Write the simulator's latency plot (.svg or .png) here.
    #[arg(long, value_parser = plot_path)]
    pub plot: Option<PathBuf>,
    /// S5: after the warm-up, send the attack of "Fragments never lock the
    /// controller out" (two 9,000-byte datagrams from another port of this
    /// computer, the controller's address), then fail unless every robot
    /// message of the counted run is answered (build with a configuration
    /// whose robot messages are fragmented: host-tests/gsi/fragmented).
    #[arg(long)]
    pub oversize_attack: bool,
    #[command(flatten)]
    pub properties: Properties,
    /// `--show FIELD,…`, `--show-csv`, `--show-plot`: the reply's values
    /// as the simulator receives them (counted run only).
    #[command(flatten)]
    pub show: ShowArgs,
    /// Read the device's /status.json before and after the counted run and print its counts
    /// beside the simulator's: both sides of the wire, every disagreement named (fails when one
    /// points inside the firmware).
    #[arg(long)]
    pub device_status: bool,
    /// Inject a fault into the counted run (repeatable; `cargo robot --help` lists them), e.g.
    /// drop:1 or garbage:2. (`cargo hil` spells it `--inject`: its `--fault` is the HardFault
    /// check.)
    #[arg(long = "fault", id = FAULT_ARG, value_name = "SPEC", value_parser = crate::robot::fault::Fault::parse)]
    pub fault: Vec<crate::robot::fault::Fault>,
    /// Seed of the fault injection.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Load the device's status page in headless Chromium during and after the counted run,
    /// check the device name, state and answered count it shows against the simulator, and
    /// write a screenshot here (.png).
    #[arg(long, value_name = "FILE.png")]
    pub browser: Option<PathBuf>,
    /// Run the hostile HTTP catalogue against the device's diagnostics during the counted run;
    /// fails unless every case gets its answer and every robot message is answered.
    #[arg(long)]
    pub http_attack: bool,
    /// Push every kind of update file the device must refuse, then one it must take, to its
    /// diagnostics port (PUT /firmware) during the counted run (the QEMU board; issue 43);
    /// fails unless each gets its answer and every robot message is answered.
    #[arg(long)]
    pub update_catalogue: bool,
    /// The image the run booted (set by the tool, not a flag): the update catalogue's files
    /// are made from it.
    #[arg(skip)]
    pub image: Option<PathBuf>,
    /// After the run, keep the device running (and its status page served) until Ctrl-C.
    #[arg(long)]
    pub serve: bool,
    /// `--replay FILE` and its options: a capture's robot messages instead of the simulator's
    /// own, every reply compared with the recorded one.
    #[command(flatten)]
    pub replay: rri_robot::args::ReplayArgs,
    /// `cargo hil -- --no-probe`: read the device's own latency and stack
    /// from its `/status.json` after the run, while it still runs (the
    /// QEMU board stops with the run).
    #[arg(skip)]
    pub figures_from_status: bool,
}

impl RunArgs {
    /// Checks `--reply` and `--show` against the configured device, and
    /// that a browser is there for `--browser`, before anything is built
    /// (a bad argument exits 2 like clap's errors).
    pub fn check_show(&self) -> Result<(), String> {
        if self.browser.is_some() {
            crate::browser::find().map_err(|e| format!("--browser: {e}"))?;
        }
        if self.show.show.is_empty()
            && self.show.show_csv.is_none()
            && self.show.show_plot.is_none()
        {
            return Ok(());
        }
        let setup = Setup::new(self.tcp)?;
        let mut o = RobotOptions::new(setup.gsi.clone(), ([127, 0, 0, 1], 9).into());
        o.device = setup.device_name.clone();
        self.properties.apply(&mut o);
        self.show.apply(&mut o);
        crate::robot::check_show(&o, &setup.device)
    }
}
