//! Compresses the status page (`src/page.html`) with gzip for the flash
//! (`$OUT_DIR/page.html.gz`): every browser takes it so, and it costs
//! about a third of the plain page. Leading indentation goes first (the
//! page has no text that spans lines).

// A build script may stop the build when its own input or cargo's
// promises fail (the page, OUT_DIR): the workspace's no-panic lints are
// for the code the boards run.
#![allow(clippy::expect_used)]

use std::io::Write;

fn main() {
    let src = std::path::Path::new("src/page.html");
    println!("cargo:rerun-if-changed={}", src.display());
    let page = std::fs::read_to_string(src).expect("src/page.html is readable");
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
}
