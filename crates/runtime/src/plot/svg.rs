//! The SVG pieces every part of a figure writes: the text sizes, a text element and XML escaping.

use std::fmt::Write as _;

/// Font sizes in pixels: figure title, panel titles, axis labels, tick labels and legend entries.
pub const TITLE_SIZE: f64 = 20.0;
pub const PANEL_TITLE_SIZE: f64 = 16.0;
pub const LABEL_SIZE: f64 = 16.0;
pub const TICK_SIZE: f64 = 14.0;
pub const LEGEND_SIZE: f64 = 14.0;

/// A `<text>` of `class` at (x, y) (baseline) in `size` px, anchored `anchor` (start, middle, end).
pub(super) fn text(
    s: &mut String,
    class: &str,
    (x, y): (f64, f64),
    size: f64,
    anchor: &str,
    content: &str,
) {
    let _ = writeln!(
        s,
        r#"<text class="{class}" x="{x:.2}" y="{y:.2}" font-size="{size}" text-anchor="{anchor}">{}</text>"#,
        esc(content)
    );
}

/// Escape text for XML.
pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
