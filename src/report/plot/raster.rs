//! SVG → PNG with resvg, using only the embedded DejaVu Sans.
//!
//! The font is compiled into the binary (≈ 750 kB) and system fonts are never consulted, so a
//! PNG made on a headless CI box is pixel-identical to one made on a workstation, and text can
//! never silently vanish because a machine lacks fonts.

use std::sync::{Arc, OnceLock};

use resvg::tiny_skia;
use resvg::usvg::{self, fontdb};

use super::{PlotError, MAX_PNG_SIDE};

/// DejaVu Sans (Bitstream Vera licence, see `assets/fonts/LICENSE-DejaVu.txt`).
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The font database, built once: parsing the font's tables is cheap, but there is no reason
/// to copy 750 kB per figure.
fn fonts() -> Arc<fontdb::Database> {
    static DB: OnceLock<Arc<fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        // Generic families resolve to the one font we have.
        db.set_sans_serif_family("DejaVu Sans");
        db.set_serif_family("DejaVu Sans");
        db.set_monospace_family("DejaVu Sans");
        Arc::new(db)
    })
    .clone()
}

/// Parsing options with the embedded font as the only font and the default family.
pub(super) fn options() -> usvg::Options<'static> {
    usvg::Options {
        font_family: "DejaVu Sans".to_string(),
        fontdb: fonts(),
        ..usvg::Options::default()
    }
}

/// Rasterises `svg` to PNG bytes of `round(width·scale)` × `round(height·scale)` px on white.
pub(super) fn rasterize(
    svg: &str,
    width: u32,
    height: u32,
    scale: f32,
) -> Result<Vec<u8>, PlotError> {
    let scale = if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        0.0
    };
    let (pw, ph) = (
        (width as f32 * scale).round(),
        (height as f32 * scale).round(),
    );
    let invalid = || PlotError::InvalidSize {
        width: pw as u64,
        height: ph as u64,
    };
    if !(1.0..=MAX_PNG_SIDE as f32).contains(&pw) || !(1.0..=MAX_PNG_SIDE as f32).contains(&ph) {
        return Err(invalid());
    }
    let tree = usvg::Tree::from_str(svg, &options()).map_err(|e| PlotError::Svg(e.to_string()))?;
    let mut pixmap = tiny_skia::Pixmap::new(pw as u32, ph as u32).ok_or_else(invalid)?;
    pixmap.fill(tiny_skia::Color::WHITE);
    let size = tree.size();
    let transform = tiny_skia::Transform::from_scale(pw / size.width(), ph / size.height());
    resvg::render(&tree, transform, &mut pixmap.as_mut());
    pixmap
        .encode_png()
        .map_err(|e| PlotError::Encode(e.to_string()))
}
