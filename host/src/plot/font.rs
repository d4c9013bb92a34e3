//! The bundled font (host/assets/DejaVuSans.ttf, licence beside it): plotters draws text with the
//! pure-Rust ab_glyph, so no system font library is needed.

use std::sync::OnceLock;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// The font family every plot uses.
pub const FAMILY: &str = "sans-serif";

/// Registers the bundled font as [`FAMILY`] (once per process).
pub fn register() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, FONT).is_ok()
    });
    anyhow::ensure!(ok, "the bundled font could not be loaded");
    Ok(())
}
