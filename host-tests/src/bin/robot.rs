//! `cargo robot -- --gsi DIR [--device NAME] --to ADDR [--cycles N]
//! [--rate-ms 4] [--send NAME=MS]… [--reply NAME] [--tcp] [--csv FILE]
//! [--plot FILE.svg|.png] [--pcap FILE] [--json FILE] [--fault SPEC]…`
//!
//! Plays the robot controller against any RRI sensor. Exit status 0 if and
//! only if supervision never tripped and every reply was correct; 1 with
//! the reason on stderr otherwise; 2 for bad arguments or a bad GSI folder.

use host_tests::robot::fault::{Fault, SPECS};
use host_tests::robot::{load, run, RobotOptions};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str =
    "usage: cargo robot -- --gsi DIR [--device NAME] --to ADDR:PORT [--cycles N] [--rate-ms 4]
                    [--send NAME=MS]... [--reply NAME]
                    [--tcp] [--csv FILE] [--plot FILE.svg|FILE.png] [--pcap FILE] [--json FILE]
                    [--fault SPEC]... [--seed N] [--first-id N] [--no-pacing] [--no-progress]

--send NAME=MS: send property NAME every MS ms (one SiSetCyclic each; repeat
  for several, all in one Id sequence); default: the first property the
  controller sends, every --rate-ms. --cycles then counts cycles of the
  greatest common period.
--reply NAME: the property the device answers with (its RRI_REPLY; default
  $RRI_REPLY, else the first property the device sends).";

fn parse(args: &[String]) -> Result<RobotOptions, String> {
    let mut gsi = None;
    let mut to = None;
    let mut o = RobotOptions::new(PathBuf::new(), "127.0.0.1:3002".parse().map_err(|_| "")?);
    o.progress = std::io::stderr().is_terminal();
    o.reply = std::env::var("RRI_REPLY")
        .ok()
        .filter(|v| !v.trim().is_empty());
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        let mut value = || -> Result<String, String> {
            i += 1;
            args.get(i)
                .cloned()
                .ok_or_else(|| format!("{flag} needs a value"))
        };
        match flag {
            "--gsi" => gsi = Some(PathBuf::from(value()?)),
            "--device" => o.device = Some(value()?),
            "--to" => {
                let v = value()?;
                to =
                    Some(v.parse().map_err(|_| {
                        format!("--to {v}: expected ADDR:PORT, e.g. 127.0.0.1:3002")
                    })?);
            }
            "--cycles" => o.cycles = value()?.parse().map_err(|_| "--cycles: a whole number")?,
            "--rate-ms" => {
                let v = value()?;
                o.rate_ms = v
                    .parse()
                    .map_err(|_| format!("--rate-ms {v}: a number of milliseconds"))?;
                if o.rate_ms == 0 || !o.rate_ms.is_multiple_of(4) {
                    return Err(format!(
                        "--rate-ms {v}: must be a positive multiple of 4 (the controller's cycle)"
                    ));
                }
            }
            "--send" => {
                let v = value()?;
                let (name, ms) = v
                    .split_once('=')
                    .ok_or_else(|| format!("--send {v}: expected NAME=MS, e.g. RobData=4"))?;
                let ms = ms
                    .trim()
                    .parse()
                    .map_err(|_| format!("--send {v}: MS is a number of milliseconds"))?;
                o.sends.push((name.trim().to_string(), ms));
            }
            "--reply" => o.reply = Some(value()?),
            "--tcp" => o.tcp = true,
            "--csv" => o.csv = Some(value()?.into()),
            "--plot" => {
                let p = PathBuf::from(value()?);
                match p.extension().and_then(|e| e.to_str()) {
                    Some("svg" | "png") => o.plot = Some(p),
                    _ => {
                        return Err(format!(
                            "--plot {}: the file must end in .svg or .png",
                            p.display()
                        ))
                    }
                }
            }
            "--pcap" => o.pcap = Some(value()?.into()),
            "--json" => o.json = Some(value()?.into()),
            "--fault" => o.faults.push(Fault::parse(&value()?)?),
            "--seed" => o.seed = value()?.parse().map_err(|_| "--seed: a number")?,
            "--first-id" => o.first_id = value()?.parse().map_err(|_| "--first-id: a u32")?,
            "--no-pacing" => o.pacing = false,
            "--no-progress" => o.progress = false,
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other}")),
        }
        i += 1;
    }
    o.gsi = gsi.ok_or("--gsi DIR is required (the controller's HOME/GSI folder)")?;
    o.to = to.ok_or("--to ADDR:PORT is required (the sensor)")?;
    Ok(o)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opts = match parse(&args) {
        Ok(o) => o,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("error: {e}");
            }
            eprintln!("{USAGE}\nfaults: {SPECS}");
            return ExitCode::from(2);
        }
    };
    let device = match load(&opts) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let mut out = std::io::stdout();
    match run(&opts, &device, &mut out) {
        Ok((summary, _)) => {
            let _ = summary.print(&mut out);
            match summary.failure() {
                None => ExitCode::SUCCESS,
                Some(reason) => {
                    eprintln!("error: {reason}");
                    ExitCode::FAILURE
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
