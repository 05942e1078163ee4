//! The engine's command line: what `rri-rehost --help` lists.

use clap::Parser;
use std::path::PathBuf;

#[derive(Parser)]
#[command(about = "Boot a NUCLEO firmware image on a strict model of its chip")]
pub struct Args {
    /// The board: f767 (NUCLEO-F767ZI) or h743 (NUCLEO-H743ZI2).
    #[arg(long)]
    pub board: String,
    /// The image (default: the one `cargo build-f767` / `build-h743` writes).
    #[arg(long)]
    pub elf: Option<PathBuf>,
    /// The bootloader the chip starts, which starts the image (default:
    /// the one `cargo build-f767-boot` / `build-h743-boot` writes). Every
    /// NUCLEO image is linked into the active partition (issue 43), so
    /// both are programmed, as a board holds them.
    #[arg(long)]
    pub boot: Option<PathBuf>,
    /// Read the device's log as this image writes it (its RTT block, its
    /// defmt table): an update's ELF, to read the log after it is
    /// swapped in (default: `--elf`'s).
    #[arg(long)]
    pub log_elf: Option<PathBuf>,
    /// Program the bootloader alone, as on a board whose probe flashed
    /// only that: the bootloader must say it found no image and stop
    /// (with `--expect-stop`, CI's check of its failure path).
    #[arg(long)]
    pub no_image: bool,
    /// Stop after this many core cycles of virtual time (default: without
    /// `--device`, 2,000,000,000; with it, until the robot's run is over
    /// or Ctrl-C).
    #[arg(long)]
    pub cycles: Option<u64>,
    /// End the run when the core reaches this function (its mangled or
    /// plain symbol name, e.g. `main`).
    #[arg(long)]
    pub until: Option<String>,
    /// The run must be stopped by the model with a message containing
    /// this text (a broken variant's check).
    #[arg(long)]
    pub expect_stop: Option<String>,
    /// The device's address and channel port, as its GSI folder's
    /// Description.xml says (`cargo rehost` passes it): with it the
    /// robot's channel is forwarded from `--listen`.
    #[arg(long)]
    pub device: Option<std::net::SocketAddrV4>,
    /// The channel is TCP (the image was built for a TCP device).
    #[arg(long)]
    pub tcp: bool,
    /// Where the robot's channel is forwarded from.
    #[arg(long, default_value = "127.0.0.1:0")]
    pub listen: std::net::SocketAddr,
    /// Where the device's status page (TCP port 80) is forwarded from.
    #[arg(long, default_value = "127.0.0.1:0")]
    pub http: std::net::SocketAddr,
    /// Deterministic: no wall clock at all (virtual time runs as fast as
    /// the host can emulate). The default with `--device` is paced to the
    /// wall clock, so that outside clients see the device's own timing.
    #[arg(long)]
    pub deterministic: bool,
    /// Paced to the wall clock from the start and through every reset.
    /// By default a paced run lets virtual time run free from each reset
    /// until the image turns its MAC's receiver on (MACCR.RE: before it
    /// no frame can reach the chip; a bootloader's swap, a start-up), and
    /// notes where pacing starts, at what time of the chip's.
    #[arg(long, conflicts_with_all = ["deterministic", "robot"])]
    pub pace_always: bool,
    /// Drive the device with this many robot messages in virtual time
    /// (deterministic: implies `--deterministic`), from the GSI folder
    /// `--gsi`; the run ends when the last cycle is over. After a power
    /// cut (`--power-cut`) the robot starts again at the next link up, as
    /// a controller reconnects: the run is judged by that robot.
    #[arg(long)]
    pub robot: Option<u64>,
    /// The GSI folder the image was built from (for `--robot`).
    #[arg(long)]
    pub gsi: Option<PathBuf>,
    /// What each line of the device's log starts with.
    #[arg(long, default_value = "device: ")]
    pub log_prefix: String,
    /// System resets (SYSRESETREQ, the watchdog) the chip may go through,
    /// each restarting the core and the peripherals with the RAM kept;
    /// the next one stops the run. 0 (the default): the first reset stops
    /// it, naming its cause.
    #[arg(long, default_value_t = 0)]
    pub resets: u32,
    /// The bench's corpus (a file `cargo rehost -- --corpus` writes) sent
    /// lock-step to a bench image in virtual time, each message
    /// `--repeat` times; prints the device's own cycles per message.
    #[arg(long)]
    pub corpus: Option<PathBuf>,
    /// How many times `--corpus` sends each message.
    #[arg(long, default_value_t = 20)]
    pub repeat: u32,
    /// The PHY gives no 50 MHz reference clock (a dead or unstrapped
    /// LAN8742A): the MAC's DMA never leaves its software reset, so the
    /// image must not wait for it unguarded (issue 42 #14).
    #[arg(long)]
    pub no_ref_clock: bool,
    /// Start from this flash content (the whole flash, every bank, as
    /// `--flash-out` wrote it) instead of an erased chip programmed with
    /// the images: a board's state after an earlier run, such as an
    /// update marked and not yet swapped in.
    #[arg(long)]
    pub flash_in: Option<PathBuf>,
    /// Write the whole flash to this file when the run ends (a reset that
    /// stops it included), as a probe would read it back.
    #[arg(long)]
    pub flash_out: Option<PathBuf>,
    /// Cut the power as the Nth flash operation (a program or an erase,
    /// counted from the start of this run, 1-based) starts: nothing of it
    /// reaches the array; the chip powers up again with its SRAM lost and
    /// its flash kept, and the run goes on (issue 43's power cuts).
    #[arg(long)]
    pub power_cut: Option<u64>,
    /// The power cut tears the operation it falls on. On the H743 its
    /// flash words are left with a bad ECC until their sector's erase
    /// (`torn_word`: a read of one is a double ECC error); on the F767,
    /// whose flash has no ECC, each bit it was changing changed or not
    /// (`torn_bits`: read back as that mix, with no error).
    #[arg(long, requires = "power_cut")]
    pub tear: bool,
    /// The seed of the F767's torn mix (default: the operation's number;
    /// the H743's torn words take none).
    #[arg(long, requires = "tear")]
    pub tear_seed: Option<u64>,
    /// Write every flash operation of the run to this file, one a line:
    /// its number, `erase` or `program`, its address, its length and the
    /// PC that started it (where to aim `--power-cut`).
    #[arg(long)]
    pub flash_census: Option<PathBuf>,
    /// The F767's flash in dual-bank mode (option byte nDBANK = 0, as the
    /// README has the user set it once with the probe) instead of the
    /// factory's single bank: the mode its updates need.
    #[arg(long)]
    pub dual_bank: bool,
    /// Run every iteration of the poll loops the engine would otherwise
    /// fast-forward (`fast_forward`): slower, and the same run to the
    /// cycle; the engine's tests compare the two.
    #[arg(long)]
    pub no_fast_forward: bool,
    /// Print the device's log (defmt over RTT) as `device:` lines.
    #[arg(long, default_value_t = true)]
    pub log: bool,
}
