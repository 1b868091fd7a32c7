//! The size of a rendered figure (`--size`, `--dpi`): the layout's width and height in pixels at 96 dpi
//! (CSS pixels; `WxHin` gives inches, 96 pixels each) and the resolution the PNG is rasterised at: a
//! 1000×600 layout at `--dpi 192` is a 2000×1200-pixel PNG with the same proportions (text and lines scale
//! with it), and the SVG says the same size. Every number has a cap, checked before the run.

use super::error::PlotError;

/// The resolution of the layout's own pixels (CSS pixels).
pub const DEFAULT_DPI: f64 = 96.0;
/// The narrowest and widest layouts, in pixels at 96 dpi.
pub const MIN_WIDTH: f64 = 400.0;
pub const MAX_WIDTH: f64 = 8000.0;
/// The lowest and highest layouts, in pixels at 96 dpi.
pub const MIN_HEIGHT: f64 = 200.0;
pub const MAX_HEIGHT: f64 = 32_768.0;
/// The lowest and highest resolutions.
pub const MIN_DPI: f64 = 24.0;
pub const MAX_DPI: f64 = 1200.0;
/// The width of a figure without `--size`.
pub const DEFAULT_WIDTH: f64 = 1000.0;
pub use super::font::MAX_PIXELS;

/// How a figure is laid out and rasterised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Width of the layout in pixels at 96 dpi.
    pub width: f64,
    /// Height of the layout (`None`: as the panels need, 200 pixels of plot each).
    pub height: Option<f64>,
    /// Resolution of the image: pixels = layout pixels × dpi / 96.
    pub dpi: f64,
}

impl Default for Layout {
    fn default() -> Layout {
        Layout {
            width: DEFAULT_WIDTH,
            height: None,
            dpi: DEFAULT_DPI,
        }
    }
}

impl Layout {
    /// A layout of `size` (width, height; `None`: the default width, the height the panels need) at `dpi`
    /// (`None`: 96), each checked against its caps.
    pub fn new(size: Option<(f64, f64)>, dpi: Option<f64>) -> Result<Layout, PlotError> {
        let dpi = dpi.unwrap_or(DEFAULT_DPI);
        if !(MIN_DPI..=MAX_DPI).contains(&dpi) {
            return Err(PlotError::Dpi {
                given: dpi,
                min: MIN_DPI,
                max: MAX_DPI,
            });
        }
        let mut layout = Layout {
            dpi,
            ..Layout::default()
        };
        if let Some((w, h)) = size {
            layout.width = w;
            layout.height = Some(h);
        }
        let s = layout.scale();
        let pixels = layout.width * s * layout.height.unwrap_or(MIN_HEIGHT) * s;
        if pixels > MAX_PIXELS {
            return Err(PlotError::TooManyPixels {
                width: (layout.width * s).round(),
                height: (layout.height.unwrap_or(MIN_HEIGHT) * s).round(),
                max: MAX_PIXELS,
            });
        }
        Ok(layout)
    }

    /// Image pixels per layout pixel.
    pub fn scale(&self) -> f64 {
        self.dpi / DEFAULT_DPI
    }
}

/// `WxH` (pixels at 96 dpi) or `WxHin` (inches) as (width, height) in pixels at 96 dpi, inside
/// [`MIN_WIDTH`]…[`MAX_WIDTH`] × [`MIN_HEIGHT`]…[`MAX_HEIGHT`].
pub fn parse_size(given: &str) -> Result<(f64, f64), PlotError> {
    let bad = |why: String| PlotError::Size {
        given: given.to_string(),
        why,
    };
    let s = given.trim().to_ascii_lowercase();
    let (s, per) = match s.strip_suffix("in") {
        Some(rest) => (rest.trim_end().to_string(), DEFAULT_DPI),
        None => (
            s.strip_suffix("px").unwrap_or(&s).trim_end().to_string(),
            1.0,
        ),
    };
    let (w, h) = s
        .split_once(['x', '×'])
        .ok_or_else(|| bad("expected WIDTHxHEIGHT, e.g. 1200x800 (pixels) or 8x5in".to_string()))?;
    let number = |t: &str| -> Result<f64, PlotError> {
        match t.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(v * per),
            _ => Err(bad(format!("`{}` is not a positive number", t.trim()))),
        }
    };
    let (w, h) = (number(w)?, number(h)?);
    if !(MIN_WIDTH..=MAX_WIDTH).contains(&w) || !(MIN_HEIGHT..=MAX_HEIGHT).contains(&h) {
        return Err(bad(format!(
            "{w}×{h} pixels; the width must be {MIN_WIDTH}…{MAX_WIDTH} and the height \
             {MIN_HEIGHT}…{MAX_HEIGHT} pixels (at 96 dpi; an inch is 96 pixels)"
        )));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_in_pixels_and_inches() {
        assert_eq!(parse_size("1200x800").unwrap(), (1200.0, 800.0));
        assert_eq!(parse_size("8x5in").unwrap(), (768.0, 480.0));
        assert_eq!(parse_size(" 640 X 480px ").unwrap(), (640.0, 480.0));
        for bad in ["1200", "0x800", "1e9x800", "axb", "100x100", "1200x-5"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert!(Layout::new(Some((8000.0, 8000.0)), None).is_err());
        assert!(Layout::new(None, Some(5000.0)).is_err());
        assert_eq!(Layout::new(None, Some(192.0)).unwrap().scale(), 2.0);
    }
}
