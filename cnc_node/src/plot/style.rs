//! The look shared by the drawing code: the embedded font and the sizes
//! of the figure's parts, in pixels.

use plotters::style::FontStyle;
use std::sync::Once;

pub(crate) const FONT: &str = "sans-serif";

/// Registers the embedded font once (plotters' `ab_glyph` backend has no
/// system fonts).
pub(crate) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // the bundled fonts are valid; a failure would only lose text
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

pub(crate) const TITLE_PX: u32 = 22;
pub(crate) const TEXT_PX: u32 = 14;
pub(crate) const LEGEND_ROW_PX: u32 = 26;
pub(crate) const MARGIN_PX: u32 = 12;
pub(crate) const X_LABEL_AREA_PX: u32 = 44;
pub(crate) const Y_LABEL_AREA_PX: u32 = 70;
/// Least distance between drawn points of a polyline (Chebyshev), pixels.
pub(crate) const MIN_STEP_PX: i32 = 3;
