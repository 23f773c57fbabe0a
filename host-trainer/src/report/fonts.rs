//! The report's one font: DejaVu Sans, bundled (licence beside it in `assets/fonts/`) and
//! rasterised by `ab_glyph` in pure Rust, so the PNG figures render their text on any
//! machine: no system fonts, font-kit or fontconfig involved. SVG figures name the generic
//! `sans-serif` family and let the browser draw the text.

use std::sync::Once;

use plotters::style::{register_font, FontStyle};

/// DejaVu Sans (Bitstream Vera licence; DejaVu changes are public domain).
pub static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The family name figures ask for.
pub const FAMILY: &str = "sans-serif";

/// Register the bundled font under [`FAMILY`] (once per process).
pub fn ensure_registered() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font (checked by the test below), so this cannot fail.
        if register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_err() {
            panic!("the bundled DejaVu Sans does not parse");
        }
    });
}

#[cfg(test)]
mod tests {
    #[test]
    fn bundled_font_registers() {
        super::ensure_registered();
    }
}
