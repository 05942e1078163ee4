//! `--replay` with a file it cannot replay, as a user meets it: one line
//! saying why, exit 2, never a panic or a partial run. The files are the
//! committed fixtures (made by tcpdump and tshark: `host-tests/captures/
//! make.sh`) and copies of them spoiled on purpose. No sensor needed:
//! every case fails before the first message.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(root().join("host-tests/captures").join(name)).expect("fixture")
}

fn robot(args: &[&str]) -> (i32, String) {
    let gsi = root().join("firmware/gsi/GSI");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_robot"))
        .args(["--gsi", gsi.to_str().expect("utf-8"), "--to", "127.0.0.1:9"])
        .args(args)
        .output()
        .expect("robot runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.code().unwrap_or(-1), err)
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write");
    p.to_str().expect("utf-8").to_string()
}

/// The records of a little-endian microsecond pcap: (offset of the record
/// header, captured length).
fn records(pcap: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = 24;
    while at + 16 <= pcap.len() {
        let caplen = u32::from_le_bytes(pcap[at + 8..at + 12].try_into().unwrap()) as usize;
        out.push((at, caplen));
        at += 16 + caplen;
    }
    out
}

/// Whether a record's frame (Ethernet, IPv4) has `port` at either end and
/// a payload (UDP, or TCP with data).
fn carries(pcap: &[u8], (at, caplen): (usize, usize), port: u16) -> bool {
    let f = &pcap[at + 16..at + 16 + caplen];
    if f.len() < 38 || f[12..14] != [8, 0] {
        return false;
    }
    let ihl = usize::from(f[14] & 15) * 4;
    let l4 = 14 + ihl;
    let ports = [
        u16::from_be_bytes([f[l4], f[l4 + 1]]),
        u16::from_be_bytes([f[l4 + 2], f[l4 + 3]]),
    ];
    let total = usize::from(u16::from_be_bytes([f[16], f[17]]));
    let data = match f[23] {
        17 => total > ihl + 8,
        6 => total > ihl + usize::from(f[l4 + 12] >> 4) * 4,
        _ => false,
    };
    data && ports.contains(&port)
}

#[test]
fn files_that_cannot_be_replayed_exit_2_with_one_line_saying_why() {
    let dir = std::env::temp_dir().join(format!("rri-replay-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let udp = fixture("udp-lo.pcap");
    let tcp = fixture("tcp-lo.pcap");

    let text = write(&dir, "notes.pcap", b"these are not packets\n");
    let truncated = write(&dir, "truncated.pcap", &udp[..udp.len() / 2 + 7]);
    // A robot message cut by the snapshot length: 100 bytes of it not in
    // the file (its IPv4 header says more than was captured).
    let recs = records(&udp);
    let (first_rri, _) = recs
        .iter()
        .enumerate()
        .find(|(_, r)| carries(&udp, **r, 3002))
        .expect("an RRI packet");
    let cut = write(
        &dir,
        "cut.pcap",
        &snap(&udp, |k| (k == first_rri).then_some(100)),
    );
    // Issue 42 #2: a capture made with `-s 120`: every packet cut, no
    // whole datagram at all (was: "the file holds no UDP or TCP over IPv4
    // at all", false, and nothing named the cut).
    let s120 = write(&dir, "s120.pcap", &snap_at(&udp, 120));
    // Everything but the RRI conversation: nothing to replay.
    let mut other = udp[..24].to_vec();
    for r in recs.iter().filter(|r| !carries(&udp, **r, 3002)) {
        other.extend_from_slice(&udp[r.0..r.0 + 16 + r.1]);
    }
    let other = write(&dir, "other.pcap", &other);
    // The TCP stream with one data segment of the robot's missing.
    let trecs = records(&tcp);
    let drop = trecs
        .iter()
        .filter(|r| carries(&tcp, **r, 3002))
        .nth(20)
        .copied()
        .expect("20 TCP segments with data");
    let mut gap = tcp[..drop.0].to_vec();
    gap.extend_from_slice(&tcp[drop.0 + 16 + drop.1..]);
    let gap = write(&dir, "gap.pcap", &gap);
    let missing = dir.join("missing.pcap");

    for (args, says) in [
        (
            vec!["--replay", &text],
            "not a capture (neither pcap nor pcapng",
        ),
        (
            vec!["--replay", &truncated],
            "truncated: the file ends inside the block after packet",
        ),
        (
            vec!["--replay", &cut],
            &format!(
                "packet {} of the conversation was cut by the capture's snapshot length",
                first_rri + 1
            ),
        ),
        (
            vec!["--replay", &s120],
            "no conversation on port 3002 (the GSI folder's channel port) whole: its 200 packets were cut by the capture's snapshot length (the first: packet",
        ),
        (
            vec!["--replay", &other],
            "no conversation on port 3002 (the GSI folder's channel port)",
        ),
        (
            vec!["--replay", &udp_path(), "--conversation", "127.0.0.1:4000"],
            "no conversation with 127.0.0.1:4000",
        ),
        (vec!["--replay", &gap], "a gap in the stream"),
        (
            vec!["--replay", missing.to_str().unwrap()],
            "No such file or directory",
        ),
        (
            vec!["--replay", &udp_path(), "--tolerance", "AppData=-1"],
            "TOL a number",
        ),
        (vec!["--tolerance", "1"], "--replay"),
    ] {
        let (code, err) = robot(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: expected {says:?} in: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        // One line of ours (the listing of what a file holds aside), or
        // clap's usage error.
        let said = err
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with("For more information"))
            .count();
        let ours = said == 1 || err.contains("what the file holds");
        assert!(ours || err.contains("Usage:"), "{args:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `pcap` with `less(k)` bytes taken off the end of record `k`'s data
/// (its original length kept): what a snapshot length does.
fn snap(pcap: &[u8], less: impl Fn(usize) -> Option<usize>) -> Vec<u8> {
    let mut out = pcap[..24].to_vec();
    for (k, (at, caplen)) in records(pcap).into_iter().enumerate() {
        let keep = caplen - less(k).unwrap_or(0).min(caplen);
        let mut header = pcap[at..at + 16].to_vec();
        header[8..12].copy_from_slice(&(keep as u32).to_le_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(&pcap[at + 16..at + 16 + keep]);
    }
    out
}

/// `pcap` as captured with `-s snaplen`.
fn snap_at(pcap: &[u8], snaplen: usize) -> Vec<u8> {
    let recs = records(pcap);
    snap(pcap, |k| Some(recs[k].1.saturating_sub(snaplen)))
}

/// Issue 42 #2, the reverse: whole packets whose original length counts a
/// frame check sequence the capture did not keep (4 bytes more than the
/// file holds) are not cut: the capture is read whole.
#[test]
fn a_frame_check_sequence_not_captured_does_not_cut_a_packet() {
    let udp = fixture("udp-lo.pcap");
    let mut fcs = udp.clone();
    for (at, caplen) in records(&udp) {
        fcs[at + 12..at + 16].copy_from_slice(&(caplen as u32 + 4).to_le_bytes());
    }
    let dir = std::env::temp_dir().join(format!("rri-fcs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = write(&dir, "fcs.pcap", &fcs);
    let out = dir.join("corpus");
    let (code, err) = robot(&["--replay", &file, "--extract", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 100);
    let _ = std::fs::remove_dir_all(&dir);
}

fn udp_path() -> String {
    root()
        .join("host-tests/captures/udp-lo.pcap")
        .to_str()
        .unwrap()
        .to_string()
}

#[test]
fn extract_writes_each_robot_message_of_every_fixture() {
    for (name, messages) in [
        ("udp-lo.pcap", 100),
        ("udp-any.pcapng", 100),
        ("tcp-lo.pcap", 100),
        ("fragmented-lo.pcapng", 100),
    ] {
        let dir = std::env::temp_dir().join(format!("rri-extract-{}-{name}", std::process::id()));
        let path = root().join("host-tests/captures").join(name);
        let (code, err) = robot(&[
            "--replay",
            path.to_str().unwrap(),
            "--extract",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let files: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(files.len(), messages, "{name}");
        // Each is one whole robot message, as the controller sent it.
        for f in files {
            let text = std::fs::read_to_string(f.unwrap().path()).unwrap();
            assert!(
                text.trim_start().starts_with("<RobData")
                    && text.trim_end().ends_with("</RobData>"),
                "{name}: {text}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Issue 42 #6: `--describe` tells what a capture holds with no sensor:
/// the fixture's 100 robot messages, Ids 1 to 100 without a gap, each
/// answered.
#[test]
fn describe_tells_what_the_capture_holds_without_a_sensor() {
    for name in ["udp-lo.pcap", "tcp-lo.pcap"] {
        let path = root().join("host-tests/captures").join(name);
        let gsi = root().join("firmware/gsi/GSI");
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_robot"))
            .args(["--gsi", gsi.to_str().unwrap()])
            .args(["--replay", path.to_str().unwrap(), "--describe"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{name}: {text} {}",
            String::from_utf8_lossy(&out.stderr)
        );
        for says in [
            "the controller sent 100 messages: 100 with an Id (Ids 1 to 100), 0 without a readable Id",
            "0 gaps skipping 0 Ids, 0 repeated, 0 out of order",
            "100 answer a robot message, 0 answer none; 0 robot messages with an Id got no reply",
            "the longest pause",
        ] {
            assert!(text.contains(says), "{name}: expected {says:?} in:\n{text}");
        }
    }
}
