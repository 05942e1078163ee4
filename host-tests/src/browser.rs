//! A real browser on the device's status page (`cargo demo -- --browser
//! FILE.png`): headless Chromium, from the distribution's packages, loads
//! the page as a commissioning engineer's browser would (its script
//! fetches `/status.json` and renders it), and the rendered DOM is read
//! back: the device's name, its state and its answered count are checked
//! against what the robot simulator saw. A screenshot is written.
//!
//! Chromium runs with the flags this workplace's closed network needs
//! (no background networking, no component updates: otherwise it tries
//! Google's hosts at every start) and a fresh profile per run.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// The browser's executable: `CHROMIUM`, else the first of the usual
/// names on `PATH`.
pub fn find() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return Ok(PathBuf::from(p));
    }
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        let found = std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(name))
                .find(|p| p.is_file())
        });
        if let Some(p) = found {
            return Ok(p);
        }
    }
    Err("no Chromium found (install it: Debian/Ubuntu `apt-get install --no-install-recommends chromium`, or set CHROMIUM=/path/to/chrome)".into())
}

fn headless(browser: &Path, profile: &Path) -> Command {
    let mut c = Command::new(browser);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        // The page's script fetches /status.json at once and every 2 s:
        // let its first fetch and render happen before the dump.
        "--virtual-time-budget=4000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    c
}

/// What the rendered page shows.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Rendered {
    pub device: String,
    pub state: String,
    pub answered: Option<u64>,
    pub received: Option<u64>,
    /// The whole DOM, for a failure's message.
    pub dom: String,
}

/// The text of the element with `id` (its first text, tags stripped).
fn by_id(dom: &str, id: &str) -> Option<String> {
    let at = dom.find(&format!("id=\"{id}\""))?;
    let rest = &dom[at..];
    let open_end = rest.find('>')? + 1;
    let close = rest[open_end..].find("</")?;
    let mut text = String::new();
    let mut in_tag = false;
    for c in rest[open_end..open_end + close].chars() {
        match c {
            '<' => in_tag = true,
            '>' => in_tag = false,
            c if !in_tag => text.push(c),
            _ => {}
        }
    }
    Some(text.trim().to_string())
}

impl Rendered {
    pub fn parse(dom: &str) -> Rendered {
        Rendered {
            device: by_id(dom, "device").unwrap_or_default(),
            state: by_id(dom, "state").unwrap_or_default(),
            answered: by_id(dom, "answered").and_then(|t| t.parse().ok()),
            received: by_id(dom, "received").and_then(|t| t.parse().ok()),
            dom: dom.to_string(),
        }
    }
}

/// Loads `url` and returns the rendered DOM.
pub fn dump_dom(browser: &Path, url: &str) -> Result<Rendered, String> {
    let profile = tempdir("dom")?;
    let out = headless(browser, &profile)
        .arg("--dump-dom")
        .arg(url)
        .output()
        .map_err(|e| format!("{}: {e}", browser.display()))?;
    let _ = std::fs::remove_dir_all(&profile);
    if !out.status.success() {
        return Err(format!(
            "{} --dump-dom {url} failed ({}): {}",
            browser.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ));
    }
    Ok(Rendered::parse(&String::from_utf8_lossy(&out.stdout)))
}

/// Loads `url` and writes a screenshot of the page to `png`.
pub fn screenshot(browser: &Path, url: &str, png: &Path) -> Result<(), String> {
    let profile = tempdir("shot")?;
    if let Some(dir) = png.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let status = headless(browser, &profile)
        .arg(format!(
            "--screenshot={}",
            std::path::absolute(png)
                .map_err(|e| e.to_string())?
                .display()
        ))
        .arg("--window-size=1400,1700")
        .arg(url)
        .output()
        .map_err(|e| format!("{}: {e}", browser.display()))?;
    let _ = std::fs::remove_dir_all(&profile);
    if !status.status.success() || !png.is_file() {
        return Err(format!("no screenshot of {url} ({})", status.status));
    }
    Ok(())
}

fn tempdir(what: &str) -> Result<PathBuf, String> {
    let dir = std::env::temp_dir().join(format!(
        "rri-chromium-{what}-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0)
    ));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

/// The page's checks after a run: the device's name, its state one of
/// `states`, and its answered count within `[low, high]` (what the
/// simulator saw answered, and what it sent: replies lost on the way back
/// are the device's answers all the same).
pub fn check(
    r: &Rendered,
    device: &str,
    states: &[&str],
    low: u64,
    high: u64,
) -> Result<(), String> {
    let mut wrong = Vec::new();
    if r.device != device {
        wrong.push(format!("device name {:?}, not {device:?}", r.device));
    }
    if !states.iter().any(|s| r.state.starts_with(s)) {
        wrong.push(format!("state {:?}, not {}", r.state, states.join(" or ")));
    }
    match r.answered {
        Some(n) if (low..=high).contains(&n) => {}
        Some(n) => wrong.push(format!("answered {n}, not within {low}..={high}")),
        None => wrong.push("no answered count".into()),
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{CHECK_FAILED}{} (DOM: {} bytes)",
            wrong.join("; "),
            r.dom.len()
        ))
    }
}

/// How a failed [`check`] begins (its items follow, `; ` between them).
pub const CHECK_FAILED: &str = "the page in the browser: ";

/// How long a page load may take here (Chromium's start on a loaded
/// machine included).
pub const LOAD_TIMEOUT: Duration = Duration::from_secs(60);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rendered_elements_are_found_by_id() {
        let dom = r#"<h1 id="device">AnyDevice</h1><span id="state" class="OPERATING">OPERATING</span><table><tr><td>answered</td><td class="n" id="answered">1234</td></tr></table>"#;
        let r = Rendered::parse(dom);
        assert_eq!(
            (r.device.as_str(), r.state.as_str(), r.answered),
            ("AnyDevice", "OPERATING", Some(1234))
        );
        assert!(check(&r, "AnyDevice", &["OPERATING"], 1200, 1300).is_ok());
        assert!(check(&r, "AnyDevice", &["ERROR 112602", "OPERATING"], 1200, 1300).is_ok());
        let e = check(&r, "Other", &["ERROR"], 0, 10).unwrap_err();
        assert!(
            e.contains("device name") && e.contains("state") && e.contains("answered 1234"),
            "{e}"
        );
    }
}
