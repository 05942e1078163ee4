//! `cargo rehost`: boot a NUCLEO image on the model of its chip.

use clap::Parser;
use rri_rehost::{bus::Bus, chip, image::Image, machine::Machine};
use std::path::PathBuf;

#[derive(Parser)]
struct Args {
    /// f767 or h743.
    #[arg(long)]
    board: String,
    /// The image (default: the one `cargo build-f767` / `build-h743` writes).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Stop after this many core cycles.
    #[arg(long, default_value_t = 2_000_000_000)]
    cycles: u64,
}

fn main() {
    let args = Args::parse();
    let ((bus, clocks), chip, dir) = match args.board.as_str() {
        "f767" => (rri_rehost::f7::bus(), chip::STM32F767ZI, "nucleo-f767zi"),
        "h743" => (
            (Bus::default(), Default::default()),
            chip::STM32H743ZI,
            "nucleo-h743zi",
        ),
        other => {
            eprintln!("error: no board {other:?} (f767 or h743)");
            std::process::exit(2);
        }
    };
    let elf = args.elf.unwrap_or_else(|| {
        PathBuf::from(format!(
            "target/{dir}/thumbv7em-none-eabihf/firmware/rri-sensor"
        ))
    });
    let image = match Image::read(&elf) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let mut m = match Machine::new(chip, image, bus, clocks) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let t = std::time::Instant::now();
    match m.run(args.cycles) {
        Some(stop) => {
            println!("rehost: stopped: {stop}");
            println!("({} instructions in {:.2?})", m.now(), t.elapsed());
            std::process::exit(1);
        }
        None => println!("rehost: ran {} cycles", m.now()),
    }
}
