//! The image's defmt log, read as a debug probe reads it: the RTT control
//! block (`_SEGGER_RTT`, SEGGER's layout: a 16-byte ID, the buffer counts,
//! then 24-byte buffer descriptors: name, buffer, size, WrOff, RdOff,
//! flags) is found in RAM, up-buffer 0's new bytes are taken and RdOff
//! moved on, and the frames are decoded with the ELF's own defmt table.

use unicorn_engine::Unicorn;

pub struct Rtt {
    block: u64,
    table: &'static defmt_decoder::Table,
    decoder: Box<dyn defmt_decoder::StreamDecoder>,
}

fn word<D>(uc: &Unicorn<D>, addr: u64) -> Option<u32> {
    let mut b = [0; 4];
    uc.mem_read(addr, &mut b).ok()?;
    Some(u32::from_le_bytes(b))
}

impl Rtt {
    /// The log of the image `elf` (its bytes) whose control block is at
    /// `block`; `None` when the image has no defmt table.
    pub fn new(elf: &[u8], block: u64) -> Option<Rtt> {
        let table = defmt_decoder::Table::parse(elf).ok()??;
        let table: &'static defmt_decoder::Table = Box::leak(Box::new(table));
        Some(Rtt {
            block,
            table,
            decoder: table.new_stream_decoder(),
        })
    }

    /// Forgets any frame begun before a power cut: the image starts its
    /// log afresh.
    pub fn restart(&mut self) {
        self.decoder = self.table.new_stream_decoder();
    }

    /// The log lines written since the last call.
    pub fn lines<D>(&mut self, uc: &mut Unicorn<D>) -> Vec<String> {
        let up = self.block + 24;
        let (Some(id), Some(buf), Some(size), Some(wr), Some(rd)) = (
            word(uc, self.block),
            word(uc, up + 4),
            word(uc, up + 8),
            word(uc, up + 12),
            word(uc, up + 16),
        ) else {
            return Vec::new();
        };
        // "SEGG": the image has not set the block up yet.
        if id != u32::from_le_bytes(*b"SEGG") || size == 0 || wr >= size || rd >= size || wr == rd {
            return Vec::new();
        }
        let mut bytes = Vec::new();
        let mut at = rd;
        while at != wr {
            let end = if wr > at { wr } else { size };
            let mut chunk = vec![0; (end - at) as usize];
            if uc.mem_read(u64::from(buf + at), &mut chunk).is_err() {
                return Vec::new();
            }
            bytes.extend_from_slice(&chunk);
            at = if end == size { 0 } else { end };
        }
        let _ = uc.mem_write(up + 16, &wr.to_le_bytes());
        self.decoder.received(&bytes);
        let mut lines = Vec::new();
        loop {
            match self.decoder.decode() {
                Ok(frame) => {
                    let level = frame
                        .level()
                        .map(|l| l.as_str().to_uppercase())
                        .unwrap_or_default();
                    // probe-rs's `--log-format "[{t} {L}] {s}"`, which
                    // `cargo hil` and `cargo demo` read on a real board.
                    let t = frame
                        .display_timestamp()
                        .map(|t| t.to_string())
                        .unwrap_or_default();
                    lines.push(format!("[{t} {level}] {}", frame.display_message()));
                }
                Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
                Err(defmt_decoder::DecodeError::Malformed) => {
                    lines.push("(malformed defmt frame)".into());
                    break;
                }
            }
        }
        lines
    }
}
