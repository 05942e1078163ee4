//! The TrueType font plotters draws every plot's labels with: the
//! latency plot's, the replay's and `--show-plot`'s.

/// A font for plot labels: plotters renders text with ab_glyph and needs a
/// TrueType file (Debian: fonts-dejavu-core); `RRI_PLOT_FONT` overrides.
fn font() -> Result<&'static [u8], String> {
    // A font the user named must be the one used.
    if let Some(path) = std::env::var_os("RRI_PLOT_FONT").filter(|p| !p.is_empty()) {
        return std::fs::read(&path)
            .map(|bytes| &*Box::leak(bytes.into_boxed_slice()))
            .map_err(|e| format!("RRI_PLOT_FONT={}: {e}", path.to_string_lossy()));
    }
    let candidates = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf".to_string(),
        "/usr/share/fonts/TTF/DejaVuSans.ttf".into(),
        "/Library/Fonts/Arial.ttf".into(),
        "C:\\Windows\\Fonts\\arial.ttf".into(),
    ];
    for c in candidates.iter().filter(|c| !c.is_empty()) {
        if let Ok(bytes) = std::fs::read(c) {
            return Ok(Box::leak(bytes.into_boxed_slice()));
        }
    }
    Err("no TrueType font for the plot labels: install fonts-dejavu-core or set RRI_PLOT_FONT=/path/to/font.ttf".into())
}

/// Registers the TrueType font plotters draws labels with (once).
pub fn ensure_font() -> Result<(), String> {
    static FONT: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    FONT.get_or_init(|| {
        let bytes = font()?;
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .map_err(|_| "font not usable".to_string())
    })
    .clone()
}
