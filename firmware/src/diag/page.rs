//! `GET /`: one self-contained HTML page (inline CSS, inline script, an
//! SVG chart it draws itself; nothing loaded from anywhere else) that a
//! commissioning engineer reads at a glance. The page is the same bytes
//! every time (`page.html`, in flash); its script reads `/status.json`
//! every two seconds and renders it in the browser.
//!
//! Why not render the page on the device as the JSON is: the JSON already
//! carries everything the page shows, and a second renderer on the device
//! cost about 12 KiB of flash (its markup and its code) for the same
//! facts; the browser does that work instead, and the device renders one
//! form less per refresh. Every string from the device reaches the page
//! through the DOM's text (`textContent`, `append` of strings), never as
//! markup, so nothing a GSI folder or a robot message holds can become
//! markup. Elements a test or a script may look for carry ids: `device`,
//! `state`, `peer`, `received`, `answered`, `latency-chart`, `last-bad`,
//! `events`.

/// The page.
pub const PAGE: &str = include_str!("page.html");
