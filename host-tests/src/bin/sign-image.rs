//! `cargo sign-image`: the update files a device takes over the network
//! (issue 43). Once: `cargo sign-image -- keygen` makes the key pair
//! (kept in `~/.config/rri-sensor`, or `$RRI_UPDATE_KEY_DIR`: never in the
//! checkout). Each release: `cargo sign-image -- sign --board f767 --elf
//! target/nucleo-f767zi/thumbv7em-none-eabihf/firmware/rri-sensor --out
//! rri-sensor-f767.update` flattens the image, appends its trailer (board,
//! version, length) and signs both. `check` says what a file is and
//! whether a public key verifies it, as the device would.
//!
//! Not done yet: the devices do not take these files (no upload service,
//! no bootloader image): see the README's "Update in the cell".

use clap::{Parser, Subcommand, ValueEnum};
use host_tests::flash_model::{Flash, Power};
use host_tests::update_file::{self, key_dir, read_key, PUBLIC, SECRET};
use rri_update::{Running, Upload, Version};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Make the update key, sign a firmware image, check an update file")]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum Board {
    F767,
    H743,
    Qemu,
}

impl Board {
    /// The name the trailer carries (and the firmware compares with its own).
    fn name(self) -> &'static str {
        match self {
            Board::F767 => "nucleo-f767zi",
            Board::H743 => "nucleo-h743zi",
            Board::Qemu => "mps2-an500",
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Make the key pair, once (refuses to replace one).
    Keygen {
        /// The key's directory (default: $RRI_UPDATE_KEY_DIR, else ~/.config/rri-sensor).
        #[arg(long)]
        dir: Option<PathBuf>,
    },
    /// Sign a firmware image for a board.
    Sign {
        #[arg(long, value_enum)]
        board: Board,
        /// The firmware ELF a board build wrote.
        #[arg(long)]
        elf: PathBuf,
        /// The version the file says it is: the one the image reports (its
        /// `RRI_IMAGE_VERSION`), which this must equal if given; for an ELF
        /// that reports none, default rri-sensor's, from its Cargo.toml.
        #[arg(long)]
        version: Option<String>,
        /// The secret key (default: the key directory's update-key).
        #[arg(long)]
        key: Option<PathBuf>,
        /// Where to write the update file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Say what an update file is and whether a public key verifies it.
    Check {
        file: PathBuf,
        /// The public key (default: the key directory's update-key.pub).
        #[arg(long)]
        public: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<(), String> {
    match args.command {
        Command::Keygen { dir } => {
            let dir = match dir {
                Some(d) => d,
                None => key_dir()?,
            };
            let (secret, public) = update_file::keygen(&dir)?;
            println!(
                "secret key: {} (keep it; it signs every image)",
                secret.display()
            );
            println!(
                "public key: {} (the firmware builds it in)",
                public.display()
            );
            Ok(())
        }
        Command::Sign {
            board,
            elf,
            version,
            key,
            out,
        } => {
            let elf_bytes = std::fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
            // The file carries the version its image reports: a device
            // compares it with the running one, and after the swap the
            // image says its own.
            let version = match (version, update_file::image_version(&elf_bytes)?) {
                (Some(asked), Some(own)) if asked != own => {
                    return Err(format!(
                        "{}: the image reports version {own}, not {asked}: build it with RRI_IMAGE_VERSION={asked} (or leave --version out)",
                        elf.display()
                    ))
                }
                (_, Some(own)) => own,
                (Some(asked), None) => asked,
                (None, None) => update_file::sensor_version()?,
            };
            let parsed = Version::parse(&version)
                .ok_or_else(|| format!("{version:?} is not a version (major.minor.patch)"))?;
            let seed = match key {
                Some(k) => read_key(&k)?,
                None => read_key(&key_dir()?.join(SECRET))?,
            };
            let (origin, image) = update_file::flat_image(&elf_bytes)?;
            let file = update_file::signed_file(&image, origin, board.name(), parsed, &seed)?;
            std::fs::write(&out, &file).map_err(|e| format!("{}: {e}", out.display()))?;
            println!(
                "{}: {} bytes of image from {origin:#010x} for {} version {version}, signed ({} bytes)",
                out.display(),
                image.len(),
                board.name(),
                file.len()
            );
            Ok(())
        }
        Command::Check { file, public } => {
            let bytes = std::fs::read(&file).map_err(|e| format!("{}: {e}", file.display()))?;
            let key = match public {
                Some(p) => read_key(&p)?,
                None => read_key(&key_dir()?.join(PUBLIC))?,
            };
            let n = bytes.len();
            let t = update_file::trailer_of(&bytes)?;
            println!(
                "{}: for {} version {}.{}.{}, {} bytes of image linked at {:#010x}",
                file.display(),
                t.board_name(),
                t.version.major,
                t.version.minor,
                t.version.patch,
                t.image_len,
                t.origin
            );
            // The device's own check of the file's form and signature, on
            // the flash model. What only a device knows is not checked
            // here: its board, its partitions' sizes and its version (the
            // file is taken as for the board and address it names, by a
            // device at version 0.0.0).
            let power = Power::new();
            let size = n.div_ceil(2048) * 2048;
            let mut dfu = Flash::<2048, 32>::erased(size + 2048, &power);
            let mut state = Flash::<2048, 32>::erased(2048, &power);
            let config = rri_update::FirmwareUpdaterConfig {
                dfu: &mut dfu,
                state: &mut state,
            };
            let running = Running {
                board: t.board_name(),
                origin: t.origin,
                version: Version {
                    major: 0,
                    minor: 0,
                    patch: 0,
                },
            };
            let mut up = Upload::begin(config, size, n).map_err(|e| e.text().to_string())?;
            up.push(&bytes).map_err(|e| e.text().to_string())?;
            up.finish(&running, &key, false)
                .map_err(|e| format!("the device would refuse it: {}", e.text()))?;
            println!("signature: verifies with the public key (board, version and size are the device's to check)");
            Ok(())
        }
    }
}
