//! The flash operations of an update, as the engine's `--flash-census`
//! lists them, cut into runs (one kind, one partition, one program), and
//! the operations `cargo power-cut` cuts the power at.

/// One flash operation of a census.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Op {
    pub n: u64,
    pub erase: bool,
    pub addr: u32,
    pub len: u32,
    /// The PC of the access that started it.
    pub pc: u32,
}

/// Reads the engine's `--flash-census` file: `N erase|program ADDR LEN PC`
/// a line.
pub fn parse_census(text: &str) -> Result<Vec<Op>, String> {
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let bad = || format!("census line {}: {line:?}", i + 1);
            let f: Vec<&str> = line.split_whitespace().collect();
            let [n, kind, addr, len, pc] = f[..] else {
                return Err(bad());
            };
            let hex =
                |s: &str| u32::from_str_radix(s.trim_start_matches("0x"), 16).map_err(|_| bad());
            Ok(Op {
                n: n.parse().map_err(|_| bad())?,
                erase: match kind {
                    "erase" => true,
                    "program" => false,
                    _ => return Err(bad()),
                },
                addr: hex(addr)?,
                len: len.parse().map_err(|_| bad())?,
                pc: hex(pc)?,
            })
        })
        .collect()
}

/// Where a cut falls, by what the board is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The running image takes B (the upload's census).
    Upload,
    /// The bootloader swaps B in.
    Swap,
    /// B, on trial, confirms itself at OPERATING.
    Confirm,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Upload => "upload",
            Phase::Swap => "swap",
            Phase::Confirm => "confirmation",
        }
    }
}

/// Operations of one kind in one partition by one program (the
/// bootloader or the image), one after another.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Run {
    pub first: u64,
    pub last: u64,
    pub erase: bool,
    pub partition: &'static str,
    /// The bootloader started them (else the image).
    pub by_bootloader: bool,
}

impl Run {
    pub fn what(&self) -> String {
        let kind = if self.erase { "erase" } else { "program" };
        format!("{kind} {}", self.partition)
    }
}

/// The partition of `partitions` (name, start, length) holding `addr`.
fn partition_of(partitions: &[(&'static str, u32, u32)], addr: u32) -> &'static str {
    partitions
        .iter()
        .find(|(_, start, len)| addr >= *start && addr - start < *len)
        .map(|p| p.0)
        .unwrap_or("outside every partition")
}

/// The census cut into runs.
pub fn runs(ops: &[Op], partitions: &[(&'static str, u32, u32)]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for op in ops {
        let partition = partition_of(partitions, op.addr);
        let by_bootloader = partition_of(partitions, op.pc) == "bootloader";
        match runs.last_mut() {
            Some(r)
                if r.erase == op.erase
                    && r.partition == partition
                    && r.by_bootloader == by_bootloader =>
            {
                r.last = op.n
            }
            _ => runs.push(Run {
                first: op.n,
                last: op.n,
                erase: op.erase,
                partition,
                by_bootloader,
            }),
        }
    }
    runs
}

/// Where to cut in `phase` (in the upload's census for `Upload`, the
/// swap's for the others): every run's first and last operation (`all`),
/// else a few chosen by what they do. Each with what it is.
pub fn points(runs: &[Run], phase: Phase, all: bool) -> Vec<(u64, String)> {
    let mine: Vec<&Run> = runs
        .iter()
        .filter(|r| r.by_bootloader == (phase == Phase::Swap))
        .collect();
    let is = |r: &&&Run, erase: bool, partition: &str| r.erase == erase && r.partition == partition;
    let first = |erase, partition| mine.iter().find(|r| is(r, erase, partition)).copied();
    let last = |erase, partition| mine.iter().rev().find(|r| is(r, erase, partition)).copied();
    let mut at: Vec<(u64, String)> = Vec::new();
    if all {
        for r in &mine {
            at.push((r.first, format!("the first {}", r.what())));
            if r.last != r.first {
                at.push((r.last, format!("the last {}", r.what())));
            }
        }
    } else {
        match phase {
            Phase::Upload => {
                // Marking: the state partition erased, the mark not yet
                // written.
                if let Some(r) = first(true, "state") {
                    at.push((r.first, "the state partition's erase as B is marked".into()));
                }
            }
            Phase::Swap => {
                if let Some(r) = first(true, "active") {
                    at.push((r.first, "the first erase of the active partition".into()));
                }
                // The swap's last step erases the active partition's
                // first page and copies it again: until it is finished
                // there is no vector table to start. A bootloader that
                // looked for an image before finishing the swap halted
                // here (`--all` found it at the H743's operation 45,080).
                if let Some(r) = last(false, "active") {
                    at.push((
                        r.first,
                        "the first program of the swap's last active page, which holds the vector table".into(),
                    ));
                }
                if let Some(r) = last(false, "state") {
                    at.push((r.last, "the swap's last mark in the state partition".into()));
                }
            }
            Phase::Confirm => {
                if let Some(r) = mine.first() {
                    at.push((
                        r.first,
                        format!("the confirmation's first operation, {}", r.what()),
                    ));
                }
                if let Some(r) = first(true, "state") {
                    at.push((
                        r.first,
                        "the confirmation's erase of the state partition".into(),
                    ));
                }
            }
        }
    }
    at.sort_by_key(|p| p.0);
    at.dedup_by_key(|p| p.0);
    at
}

/// The cut the default set tears (`power_cut::CutKind::Tearing`): the
/// swap's last progress mark in the state partition, the bootloader's
/// last write before it starts the new image. Torn, the word reads as a
/// double ECC error on the H743: a plain read there faults at every start
/// (the board bricked); the careful one (`hal_board::h743_ecc`) reads it
/// as programmed, and the bootloader rolls the unconfirmed swap back.
pub fn torn_point(runs: &[Run]) -> Option<(u64, String)> {
    runs.iter()
        .rev()
        .find(|r| r.by_bootloader && !r.erase && r.partition == "state")
        .map(|r| {
            (
                r.last,
                "the swap's last mark in the state partition, torn".into(),
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARTS: [(&str, u32, u32); 4] = [
        ("bootloader", 0x0800_0000, 0x2_0000),
        ("active", 0x0802_0000, 0xC_0000),
        ("update", 0x0810_0000, 0xE_0000),
        ("state", 0x081E_0000, 0x2_0000),
    ];

    /// A census of `(kind, address, by the image?)`, numbered from 1.
    fn census(ops: &[(&str, u32, bool)]) -> Vec<Op> {
        let text: String = ops
            .iter()
            .enumerate()
            .map(|(i, (kind, addr, image))| {
                let pc = if *image { 0x0803_0000 } else { 0x0800_1000 };
                format!("{} {kind} {addr:#x} 32 {pc:#x}\n", i + 1)
            })
            .collect();
        parse_census(&text).unwrap()
    }

    #[test]
    fn a_census_is_read_and_a_bad_line_named() {
        let ops = parse_census("1 erase 0x08100000 131072 0x0802a000\n").unwrap();
        assert_eq!(
            ops[0],
            Op {
                n: 1,
                erase: true,
                addr: 0x0810_0000,
                len: 131_072,
                pc: 0x0802_a000
            }
        );
        let e = parse_census("1 erase 0x08100000 131072 0x0\n2 write 0x0 32 0x0\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        assert!(parse_census("1 erase 0x08100000 131072\n").is_err());
    }

    #[test]
    fn operations_are_cut_into_runs_by_kind_partition_and_program() {
        let ops = census(&[
            ("erase", 0x0810_0000, true),
            ("program", 0x0810_0000, true),
            ("program", 0x0810_0020, true),
            ("program", 0x081E_0020, true),
            ("erase", 0x081E_0000, true),
            ("program", 0x081F_FFE0, true),
            ("program", 0x081F_FFC0, false),
        ]);
        let r = runs(&ops, &PARTS);
        let summary: Vec<(u64, u64, String, bool)> = r
            .iter()
            .map(|r| (r.first, r.last, r.what(), r.by_bootloader))
            .collect();
        assert_eq!(
            summary,
            [
                (1, 1, "erase update".to_string(), false),
                (2, 3, "program update".to_string(), false),
                (4, 4, "program state".to_string(), false),
                (5, 5, "erase state".to_string(), false),
                (6, 6, "program state".to_string(), false),
                (7, 7, "program state".to_string(), true),
            ]
        );
        let at = |phase, all| {
            points(&r, phase, all)
                .iter()
                .map(|p| p.0)
                .collect::<Vec<_>>()
        };
        // The upload's default cut: the state partition's erase.
        assert_eq!(at(Phase::Upload, false), [5]);
        // Every run's first and last, the image's only.
        assert_eq!(at(Phase::Upload, true), [1, 2, 3, 4, 5, 6]);
        assert_eq!(at(Phase::Swap, true), [7]);
    }

    #[test]
    fn the_swap_and_the_confirmation_are_cut_where_they_are_fragile() {
        // Two pages, as embassy-boot swaps them: the second page of the
        // active partition first, its first page last.
        let ops = census(&[
            ("erase", 0x0810_0000, false),
            ("program", 0x0810_0000, false),
            ("program", 0x081E_0000, false),
            ("erase", 0x0804_0000, false),
            ("program", 0x0804_0000, false),
            ("program", 0x0804_0020, false),
            ("program", 0x0804_0040, false),
            ("program", 0x081E_0020, false),
            ("erase", 0x0802_0000, false),
            ("program", 0x0802_0000, false),
            ("program", 0x0802_0020, false),
            ("program", 0x081E_0040, false),
            ("program", 0x081E_0060, false),
            ("program", 0x081E_0080, true),
            ("erase", 0x081E_0000, true),
            ("program", 0x081E_0000, true),
        ]);
        let r = runs(&ops, &PARTS);
        let at = |phase| {
            points(&r, phase, false)
                .iter()
                .map(|p| p.0)
                .collect::<Vec<_>>()
        };
        // The first erase of the active partition, the first program of
        // its last page, the swap's last mark; that mark again, torn.
        assert_eq!(at(Phase::Swap), [4, 10, 13]);
        assert_eq!(at(Phase::Confirm), [14, 15]);
        assert_eq!(torn_point(&r).map(|p| p.0), Some(13));
    }
}
