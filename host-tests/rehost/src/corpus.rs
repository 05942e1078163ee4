//! `--corpus FILE`: the bench's corpus (`cargo qemu-bench`'s realistic
//! and hostile messages, written by `cargo rehost -- --corpus`) sent to a
//! bench image in the machine's virtual time, lock-step: each message
//! `repeat` times, the next when its reply is in (every reply checked with
//! the robot simulator's `wire::check_reply`) or, for a message the decoder
//! must refuse, one 4 ms cycle later. The device's own bench record for
//! each (its DWT cycles: on the model, instructions) is kept by message,
//! for the table [`Corpus::table`] prints.

use crate::bridge::Bridge;
use crate::robot::CYCLE_NS;
use gsi_config::Device;

/// One message of the corpus: `{ID}` in its text takes the Id.
#[derive(Debug)]
pub struct Input {
    pub name: String,
    pub accepted: bool,
    pub text: String,
}

/// Reads the corpus file: per message a line with its name, a line `1`
/// (the device must answer) or `0` (it must refuse), a line with the
/// text's length in bytes, then the text and a newline.
pub fn read(path: &std::path::Path) -> Result<Vec<Input>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut at = 0;
    let line = |at: &mut usize| -> Option<String> {
        let end = bytes[*at..].iter().position(|&b| b == b'\n')? + *at;
        let s = String::from_utf8_lossy(&bytes[*at..end]).into_owned();
        *at = end + 1;
        Some(s)
    };
    let mut out = Vec::new();
    while at < bytes.len() {
        let start = at;
        let bad = || format!("{}: not a corpus file at byte {start}", path.display());
        let name = line(&mut at).ok_or_else(bad)?;
        let accepted = line(&mut at).ok_or_else(bad)? == "1";
        let len: usize = line(&mut at).and_then(|l| l.parse().ok()).ok_or_else(bad)?;
        let text = bytes.get(at..at + len).ok_or_else(bad)?;
        out.push(Input {
            name,
            accepted,
            text: String::from_utf8_lossy(text).into_owned(),
        });
        at += len + 1;
    }
    Ok(out)
}

/// One bench record of the device (`bench bytes=… compute=… …`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Record {
    pub bytes: u64,
    pub answered: bool,
    pub compute: u64,
    pub full: u64,
    pub read: u64,
    pub driver: u64,
    pub guard: u64,
    pub smoltcp: u64,
}

impl Record {
    /// A device log line's record, if it is one.
    pub fn parse(line: &str) -> Option<Record> {
        let rest = &line[line.find("bench bytes=")? + 6..];
        let mut r = Record::default();
        for kv in rest.split_whitespace() {
            let (k, v) = kv.split_once('=')?;
            let n = v.parse().unwrap_or(0);
            match k {
                "bytes" => r.bytes = n,
                "answered" => r.answered = v == "true",
                "compute" => r.compute = n,
                "full" => r.full = n,
                "read" => r.read = n,
                "driver" => r.driver = n,
                "guard" => r.guard = n,
                "smoltcp" => r.smoltcp = n,
                _ => {}
            }
        }
        Some(r)
    }
}

pub struct Corpus {
    inputs: Vec<Input>,
    device: Device,
    reply: usize,
    port: u16,
    repeat: u32,
    /// The message being sent and how many times it has been.
    current: usize,
    sent_of_current: u32,
    next_id: u32,
    /// The Id waiting for its reply and when it was sent.
    waiting: Option<(u32, u128)>,
    /// The reply is in (or the refused message's cycle over): the
    /// device's record of it is awaited until then, before the next
    /// message goes, so that every record is the current message's.
    record_due: Option<u128>,
    /// The message in flight's record is in.
    got_record: bool,
    /// Per message: replies right, replies wrong or missing, records.
    pub answered: Vec<u32>,
    pub wrong: Vec<u32>,
    pub records: Vec<Vec<Record>>,
    pub first_error: Option<String>,
}

impl Corpus {
    pub fn new(inputs: Vec<Input>, device: Device, repeat: u32) -> Result<Corpus, String> {
        let reply = crate::robot::position(&device, false)?;
        let port = device.channel.port;
        if device.channel.protocol == gsi_config::Protocol::Tcp {
            return Err("--corpus is for a UDP device (the bench's corpus is)".into());
        }
        let n = inputs.len();
        Ok(Corpus {
            inputs,
            device,
            reply,
            port,
            repeat: repeat.max(1),
            current: 0,
            sent_of_current: 0,
            next_id: 1,
            waiting: None,
            record_due: None,
            got_record: false,
            answered: vec![0; n],
            wrong: vec![0; n],
            records: vec![Vec::new(); n],
            first_error: None,
        })
    }

    /// Every message sent and its reply in or its cycle over.
    pub fn done(&self) -> bool {
        self.current >= self.inputs.len()
    }

    /// A device log line: its bench record is the message in flight's
    /// (the next goes only once it is in).
    pub fn log_line(&mut self, line: &str) {
        if let Some(r) = Record::parse(line) {
            if let Some(v) = self.records.get_mut(self.current) {
                v.push(r);
            }
            self.got_record = true;
        }
    }

    fn note(&mut self, i: usize, what: String) {
        if let Some(w) = self.wrong.get_mut(i) {
            *w += 1;
        }
        if self.first_error.is_none() {
            self.first_error = Some(what);
        }
    }

    /// The corpus's turn at virtual time `now_ns`.
    pub fn step(&mut self, bridge: &mut Bridge, now_ns: u128) {
        let replies: Vec<Vec<u8>> = bridge.replies.drain(..).collect();
        for r in replies {
            let i = self.current;
            let prop = &self.device.properties[self.reply];
            match rri_robot::wire::check_reply(&self.device, prop, &r) {
                Ok(reply) if self.waiting.map(|w| w.0) == Some(reply.id) => {
                    if self.inputs[i].accepted {
                        self.answered[i] += 1;
                    } else {
                        self.note(
                            i,
                            format!(
                                "{}: answered, but the decoder must refuse it",
                                self.inputs[i].name
                            ),
                        );
                    }
                    self.waiting = None;
                    self.record_due = (!self.got_record).then_some(now_ns + CYCLE_NS);
                }
                Ok(reply) => self.note(
                    i,
                    format!("a reply with Id {} that no message waits for", reply.id),
                ),
                Err(e) => self.note(
                    i,
                    format!("{}: a reply that fails its check: {e}", self.inputs[i].name),
                ),
            }
        }
        if let Some((id, at)) = self.waiting {
            if now_ns < at + CYCLE_NS {
                return;
            }
            // A cycle without a reply: right for a refused message.
            let i = self.current;
            if self.inputs[i].accepted {
                self.note(
                    i,
                    format!(
                        "{}: no reply to Id {id} within a cycle",
                        self.inputs[i].name
                    ),
                );
            }
            self.waiting = None;
            self.record_due = (!self.got_record).then_some(now_ns + CYCLE_NS);
        }
        if let Some(due) = self.record_due.take() {
            if !self.got_record {
                if now_ns < due {
                    self.record_due = Some(due);
                    return;
                }
                let i = self.current;
                self.note(
                    i,
                    format!(
                        "{}: no bench record from the device within a cycle",
                        self.inputs[i].name
                    ),
                );
            }
        }
        if self.sent_of_current >= self.repeat {
            self.current += 1;
            self.sent_of_current = 0;
        }
        let Some(input) = self.inputs.get(self.current) else {
            return;
        };
        let id = self.next_id;
        let msg = input.text.replace("{ID}", &format!("{id:010}"));
        bridge.send_udp(msg.as_bytes(), self.port);
        self.waiting = Some((id, now_ns));
        self.got_record = false;
        self.next_id += 1;
        self.sent_of_current += 1;
    }

    /// The table: per message its length, replies, and the device's own
    /// cycles (median and max of compute and full path) with the bench's
    /// layer fields (medians).
    pub fn table(&self, core_hz: u64) -> String {
        let med = |mut v: Vec<u64>| -> u64 {
            v.sort_unstable();
            v.get(v.len() / 2).copied().unwrap_or(0)
        };
        let mut s = format!(
            "corpus on the model ({} MHz core, one instruction a cycle: instructions, not the board's time)\n{:<32} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6} {:>6} {:>8}\n",
            core_hz / 1_000_000,
            "message", "bytes", "replies", "compute", "max", "full", "max", "read", "driver", "guard", "smoltcp"
        );
        for (i, input) in self.inputs.iter().enumerate() {
            let r = &self.records[i];
            let f = |g: fn(&Record) -> u64| med(r.iter().map(g).collect());
            let max = |g: fn(&Record) -> u64| r.iter().map(g).max().unwrap_or(0);
            s.push_str(&format!(
                "{:<32} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6} {:>6} {:>8}\n",
                input.name.chars().take(32).collect::<String>(),
                r.first().map_or(0, |x| x.bytes),
                if input.accepted {
                    format!("{}/{}", self.answered[i], self.repeat)
                } else {
                    "refused".to_string()
                },
                f(|x| x.compute),
                max(|x| x.compute),
                f(|x| x.full),
                max(|x| x.full),
                f(|x| x.read),
                f(|x| x.driver),
                f(|x| x.guard),
                f(|x| x.smoltcp),
            ));
        }
        s
    }

    /// Whether every accepted message was answered every time, nothing
    /// refused was answered, and every message has a record.
    pub fn ok(&self) -> bool {
        self.wrong.iter().all(|&w| w == 0)
            && self
                .inputs
                .iter()
                .enumerate()
                .all(|(i, inp)| !inp.accepted || self.answered[i] == self.repeat)
            && self.records.iter().all(|r| !r.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bench_line_is_a_record_and_other_lines_are_not() {
        let r = Record::parse("[1.234 INFO] bench bytes=740 answered=true compute=20766 full=29313 frames=2 read=111 driver=121 guard=414 smoltcp=2640 before=780 held_in=2 held_out=0 lost=0").unwrap();
        assert_eq!(
            (r.bytes, r.answered, r.compute, r.full, r.read, r.driver, r.guard, r.smoltcp),
            (740, true, 20766, 29313, 111, 121, 414, 2640)
        );
        assert!(Record::parse("[1.3 INFO] counters: received 1").is_none());
    }

    /// The verdict can say no: a missed reply, an answered refusal, a
    /// missing record each fail it.
    #[test]
    fn the_verdict_fails_on_a_missed_reply_an_answered_refusal_or_no_record() {
        let gsi = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../firmware/gsi/GSI");
        let device = gsi_config::load(&gsi, None).unwrap().device;
        let input = |name: &str, accepted| Input {
            name: name.into(),
            accepted,
            text: String::new(),
        };
        let mut c = Corpus::new(vec![input("a", true), input("b", false)], device, 2).unwrap();
        c.records = vec![vec![Record::default()], vec![Record::default()]];
        c.answered = vec![2, 0];
        assert!(c.ok());
        c.answered[0] = 1;
        assert!(!c.ok(), "a reply missing");
        c.answered[0] = 2;
        c.note(1, "answered, but the decoder must refuse it".into());
        assert!(!c.ok(), "a refused message answered");
        c.wrong[1] = 0;
        c.records[1].clear();
        assert!(!c.ok(), "a message without its record");
    }

    #[test]
    fn the_corpus_file_reads_back_with_newlines_inside_a_text() {
        let dir = std::env::temp_dir().join(format!("rehost-corpus-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c.txt");
        let text = "<RobData Id=\"{ID}\">\n</RobData>";
        std::fs::write(
            &path,
            format!("one\n1\n{}\n{text}\ntwo\n0\n3\nabc\n", text.len()),
        )
        .unwrap();
        let inputs = read(&path).unwrap();
        assert_eq!(inputs.len(), 2);
        assert_eq!(
            (
                inputs[0].name.as_str(),
                inputs[0].accepted,
                inputs[0].text.as_str()
            ),
            ("one", true, text)
        );
        assert_eq!(
            (
                inputs[1].name.as_str(),
                inputs[1].accepted,
                inputs[1].text.as_str()
            ),
            ("two", false, "abc")
        );
        std::fs::write(&path, "one\n1\n99\nshort\n").unwrap();
        assert!(read(&path).unwrap_err().contains("not a corpus file"));
    }
}
