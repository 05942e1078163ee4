//! `GET /`: one self-contained HTML page (inline CSS, inline script, an
//! SVG chart it draws itself; nothing loaded from anywhere else) that a
//! commissioning engineer reads at a glance. The page is the same bytes
//! every time (`page.html`, kept gzip-compressed in flash by the build
//! script); its script reads `/status.json` every two seconds and renders
//! it in the browser.
//!
//! Why not render the page on the device as the JSON is: the JSON already
//! carries everything the page shows, and a second renderer on the device
//! cost about 12 KiB of flash (its markup and its code) for the same
//! facts; the browser does that work instead, and the device renders one
//! form less per refresh. Why gzip: the page is 2.6 KiB of flash so, 7.4
//! KiB plain; every browser accepts it (`Accept-Encoding: gzip`), and a
//! client that does not (plain `curl`) gets [`NO_GZIP`], a few lines that
//! say where the data is.
//!
//! Every string from the device reaches the page through the DOM's text
//! (`textContent`, `append` of strings), never as markup, so nothing a
//! GSI folder or a robot message holds can become markup. Elements a test
//! or a script may look for carry ids: `device`, `state`, `peer`,
//! `received`, `answered`, `latency-chart`, `last-bad`, `events`.

/// The page, gzip-compressed.
pub const PAGE_GZ: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/page.html.gz"));

/// The page for a client that takes no gzip.
pub const NO_GZIP: &str = "<!DOCTYPE html><title>RRI sensor</title><p>This page is sent gzip-compressed: open it in a browser, or use <code>curl --compressed</code>. The data: <a href=\"/status.json\">/status.json</a>, <a href=\"/metrics\">/metrics</a>.\n";
