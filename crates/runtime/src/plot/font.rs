//! The plot's one typeface, DejaVu Sans, embedded in the binary (crate `dejavu`): text widths for the layout
//! and the font of the PNG renderer, so that a plot never depends on the fonts a machine happens to have.

use std::sync::{Arc, OnceLock};

use resvg::{tiny_skia, usvg};

use super::error::PlotError;

/// Most pixels of a rendered figure (4 bytes each in memory): 1000 × 32 768, 128 MiB, above the 64 panels
/// a plot draws at most at the default size.
pub const MAX_PIXELS: f64 = 1000.0 * 32_768.0;

/// The family name the SVG asks for first (the embedded font's own name).
pub const FONT_FAMILY: &str = "DejaVu Sans";

fn face() -> Option<&'static ttf_parser::Face<'static>> {
    static FACE: OnceLock<Option<ttf_parser::Face<'static>>> = OnceLock::new();
    FACE.get_or_init(|| ttf_parser::Face::parse(dejavu::sans::regular(), 0).ok())
        .as_ref()
}

/// Advance width in pixels of `text` set in DejaVu Sans at `size` px (the sum of the glyphs' advances,
/// without kerning, which only narrows a line; 0.6 em per character if the font cannot be read).
pub fn text_width(text: &str, size: f64) -> f64 {
    let Some(face) = face() else {
        return 0.6 * size * text.chars().count() as f64;
    };
    let per_unit = size / f64::from(face.units_per_em());
    text.chars()
        .map(|c| {
            face.glyph_index(c)
                .and_then(|g| face.glyph_hor_advance(g))
                .map_or(0.6 * size, |a| f64::from(a) * per_unit)
        })
        .sum()
}

/// Ascent of DejaVu Sans above the baseline, as a fraction of the font size.
pub(crate) const ASCENT: f64 = 0.76;
/// Descent below the baseline, as a fraction of the font size.
pub(crate) const DESCENT: f64 = 0.24;

/// Rasterise `svg` (at the size it declares, scaling its view box to it) to PNG bytes with the embedded
/// font; an image above [`MAX_PIXELS`] is refused before its pixels are allocated.
pub(crate) fn svg_to_png(svg: &str) -> Result<Vec<u8>, PlotError> {
    let mut db = usvg::fontdb::Database::new();
    db.load_font_data(dejavu::sans::regular().to_vec());
    db.set_sans_serif_family(FONT_FAMILY);
    let opts = usvg::Options {
        font_family: FONT_FAMILY.to_string(),
        fontdb: Arc::new(db),
        ..usvg::Options::default()
    };
    let render = |e: String| PlotError::Render(e);
    let tree = usvg::Tree::from_str(svg, &opts).map_err(|e| render(e.to_string()))?;
    let size = tree.size().to_int_size();
    let (w, h) = (f64::from(size.width()), f64::from(size.height()));
    if w * h > MAX_PIXELS {
        return Err(PlotError::TooManyPixels {
            width: w,
            height: h,
            max: MAX_PIXELS,
        });
    }
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| render(format!("cannot allocate a {w}×{h} image")))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(&tree, tiny_skia::Transform::default(), &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| render(e.to_string()))
}
