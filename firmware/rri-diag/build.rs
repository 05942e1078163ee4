//! Compresses the status page (`src/page.html`) with gzip for the flash
//! (`$OUT_DIR/page.html.gz`): every browser takes it so, and it costs
//! about a third of the plain page. Leading indentation goes first (the
//! page has no text that spans lines).
//!
//! Before that, the page's `const MEANS={}` is filled with what each
//! counter counts, read from `src/counters.rs` (each `c("key", "means",
//! …)` under its family's `key: "…"`), so the page and `/metrics`
//! explain every counter, and name it as the JSON does, from one table. The same text is
//! written to `$OUT_DIR/means.js`, which a unit test compares with the
//! table itself: a change of the file's form that this reader misses
//! fails that test, not the page.

// A build script may stop the build when its own input or cargo's
// promises fail (the page, OUT_DIR): the workspace's no-panic lints are
// for the code the boards run.
#![allow(clippy::expect_used)]

use std::io::Write;

/// The string literal at the start of `s` (after blanks), and the rest.
fn literal(s: &str) -> Option<(&str, &str)> {
    let s = s.trim_start().strip_prefix('"')?;
    let end = s.find('"')?;
    Some((&s[..end], &s[end + 1..]))
}

/// `const MEANS={"family.key":"means",…};` from the counters' table.
fn means(table: &str) -> String {
    let mut js = String::from("const MEANS={");
    let mut family = "";
    let mut first = true;
    // Members may be split over lines by rustfmt: the whole text is
    // scanned, each `c(` taking the family whose `key: "…"` came last.
    let mut rest = table;
    let mut families = table.match_indices("key: \"").map(|(i, _)| i).peekable();
    while let Some(at) = rest.find("c(") {
        let abs = table.len() - rest.len() + at;
        while families.peek().is_some_and(|&f| f < abs) {
            let f = families.next().expect("peeked");
            family = literal(&table[f + 4..]).expect("a family's key").0;
        }
        rest = &rest[at + 2..];
        let Some((key, after)) = literal(rest) else {
            continue;
        };
        let Some(after) = after.trim_start().strip_prefix(',') else {
            continue;
        };
        let Some((text, _)) = literal(after) else {
            continue;
        };
        if !first {
            js.push(',');
        }
        first = false;
        js.push_str(&format!("\"{family}.{key}\":\"{text}\""));
    }
    js.push_str("};");
    js
}

fn main() {
    // Update in the cell (issue 43): the upload's path in the service
    // (cfg `rri_update`) where the board has update partitions, and on
    // the host (its tests); a board without them carries none of it.
    println!("cargo::rustc-check-cfg=cfg(rri_update)");
    if board_takes_updates() {
        println!("cargo:rustc-cfg=rri_update");
    }
    let src = std::path::Path::new("src/page.html");
    println!("cargo:rerun-if-changed={}", src.display());
    println!("cargo:rerun-if-changed=src/counters.rs");
    let page = std::fs::read_to_string(src).expect("src/page.html is readable");
    let table = std::fs::read_to_string("src/counters.rs").expect("src/counters.rs is readable");
    let means = means(&table);
    assert!(
        page.contains("const MEANS={};"),
        "src/page.html must hold `const MEANS={{}};` for the counters' meanings"
    );
    let page = page.replace("const MEANS={};", &means);
    let compact: String = page
        .lines()
        .map(|l| l.trim_start())
        .collect::<Vec<_>>()
        .join("\n");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(compact.as_bytes()).expect("gzip into memory");
    let bytes = gz.finish().expect("gzip into memory");
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("page.html.gz"), bytes).expect("OUT_DIR is writable");
    std::fs::write(out.join("means.js"), means).expect("OUT_DIR is writable");
}

include!("../update_cfg.rs");
