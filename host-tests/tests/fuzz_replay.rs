//! The fuzz targets without a fuzzer: every target over its seeds (built
//! from ../shared/rri) and its committed corpus (host-tests/fuzz/corpus,
//! grown and minimised by `cargo fuzz`), so what the fuzzer once found stays
//! checked in every `cargo test`. The invariants are in host_tests::fuzzing.

use host_tests::fuzzing::{seeds, TARGETS};
use std::path::PathBuf;

fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("corpus entry").path())
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p.display().to_string(), bytes)
        })
        .collect()
}

fn replay(target: &str) {
    let (_, body) = TARGETS
        .iter()
        .find(|(name, _)| *name == target)
        .expect("a target of host_tests::fuzzing");
    let seeds = seeds(target);
    assert!(!seeds.is_empty());
    for (i, s) in seeds.iter().enumerate() {
        body(s);
        // `RRI_FUZZ_WRITE_SEEDS=1 cargo test --test fuzz_replay` starts the
        // corpora (the fuzzer then grows them).
        if std::env::var_os("RRI_FUZZ_WRITE_SEEDS").is_some() {
            let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("fuzz/corpus")
                .join(target);
            std::fs::create_dir_all(&dir).expect("corpus folder");
            std::fs::write(dir.join(format!("seed-{i}")), s).expect("write seed");
        }
    }
    let files = corpus(target);
    assert!(!files.is_empty(), "the corpus of {target} is committed");
    for (name, bytes) in &files {
        let run = std::panic::catch_unwind(|| body(bytes));
        assert!(
            run.is_ok(),
            "{target}: {name} fails (replay it with cargo fuzz run)"
        );
    }
    println!(
        "{target}: {} seeds, {} corpus inputs",
        seeds.len(),
        files.len()
    );
}

#[test]
fn decode_manual_corpus() {
    replay("decode_manual");
}

#[test]
fn decode_every_type_corpus() {
    replay("decode_every_type");
}

#[test]
fn tcp_framer_corpus() {
    replay("tcp_framer");
}

#[test]
fn cycle_corpus() {
    replay("cycle");
}

#[test]
fn gsi_corpus() {
    replay("gsi");
}

#[test]
fn decode_paths_corpus() {
    replay("decode_paths");
}

/// Every target of host-tests/fuzz is replayed here (a new target without
/// a replay would go unchecked in CI).
#[test]
fn every_fuzz_target_is_replayed() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/fuzz_targets");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("host-tests/fuzz/fuzz_targets")
        .map(|e| {
            let p = e.expect("entry").path();
            p.file_stem()
                .expect("a file")
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    on_disk.sort();
    let mut known: Vec<String> = TARGETS.iter().map(|(n, _)| n.to_string()).collect();
    known.sort();
    assert_eq!(on_disk, known);
}
