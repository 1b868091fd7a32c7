//! The figure's operating-point panel: points (x, y) of the run — an engine's speed and torque — each
//! coloured by a third value (the fuel flow at that point, i.e. the model's fuel map where the run went) on a
//! sequential scale (viridis: dark blue low, yellow high) with its colour bar; its own axes, under the time
//! panels. Points closer than two pixels are drawn once. With an engine map (`[engine] map`) the map fills the
//! plot area on that scale instead, between the file's `map_range` or else the map's 5th and 95th percentile
//! there, and the points are drawn over it in black.

use std::collections::HashSet;
use std::fmt::Write as _;

use super::axis::Axis;
use super::font::{ASCENT, DESCENT};
use super::map_layer::{MapLayer, CELLS};
use super::svg::{esc, text, LABEL_SIZE, PANEL_TITLE_SIZE, TICK_SIZE};

/// One sample: its time, its position and its colour value (if any).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScatterPoint {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub c: Option<f64>,
}

/// An operating-point panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Scatter {
    /// The `--plot-vars` name that chose it.
    pub var: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// What the colours show (`None`: the points are drawn in one colour).
    pub colour_label: Option<String>,
    pub points: Vec<ScatterPoint>,
    /// The engine map drawn under the points, if the model has one.
    pub background: Option<MapLayer>,
}

impl Scatter {
    /// Draw the points over `layer`: the colours show the map, the points are black.
    pub fn over_map(&mut self, layer: MapLayer) {
        self.title = match self.title.split_once(", coloured by") {
            Some((head, _)) => format!("{head}, over the engine map {}", layer.label),
            None => format!("{}, over the engine map {}", self.title, layer.label),
        };
        self.colour_label = Some(layer.label.clone());
        self.background = Some(layer);
    }

    /// Say in the title that the points are those of `window` only.
    pub(super) fn note_window(&mut self, (t0, t1): (f64, f64)) {
        self.title = format!("{} (t = {t0} … {t1} s)", self.title);
    }
}

/// The plot area's height relative to a time panel's.
pub(super) const RATIO: f64 = 1.5;
const HEADER: f64 = 24.0 + 22.0 + 6.0;
const FOOT: f64 = 24.0 + 30.0;
/// The panel's height without its plot area.
pub(super) const FIXED: f64 = HEADER + FOOT;
const VIRIDIS: [(u8, u8, u8); 5] = [
    (0x44, 0x01, 0x54),
    (0x3b, 0x52, 0x8b),
    (0x21, 0x91, 0x8c),
    (0x5e, 0xc9, 0x62),
    (0xfd, 0xe7, 0x25),
];
const ONE_COLOUR: &str = "#0072B2";

/// The colour of `f` ∈ [0, 1] on the viridis scale.
fn colour(f: f64) -> String {
    let f = if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = f * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let w = x - i as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + w * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(a.0, b.0),
        mix(a.1, b.1),
        mix(a.2, b.2)
    )
}

/// Write the panel from height `top` between `left` and `right` with a plot area `plot_h` high; the height
/// where it ends.
pub(super) fn write(
    s: &mut String,
    sc: &Scatter,
    (left, right): (f64, f64),
    top: f64,
    plot_h: f64,
) -> f64 {
    let _ = writeln!(s, r#"<g class="scatter" data-var="{}">"#, esc(&sc.var));
    text(
        s,
        "panel-title",
        (left, top + PANEL_TITLE_SIZE),
        PANEL_TITLE_SIZE,
        "start",
        &sc.title,
    );
    let x = Axis::padded(sc.points.iter().map(|p| p.x), false, 10);
    let y = Axis::padded(sc.points.iter().map(|p| p.y), true, 5);
    let background = sc
        .background
        .as_ref()
        .map(|layer| layer.sample((x.lo, x.hi), (y.lo, y.hi)));
    let c_range = match (&background, sc.background.as_ref().and_then(|l| l.range)) {
        (Some(_), Some([lo, hi])) => (lo, hi),
        (Some(values), None) => percentile_range(values),
        (None, _) => super::axis::finite_range(sc.points.iter().filter_map(|p| p.c)),
    };
    write_colour_bar(s, sc, (left, top + 24.0), c_range);
    let (y0, y1) = (top + HEADER, top + HEADER + RATIO * plot_h);
    let px = |v: f64| left + x.frac(v) * (right - left);
    let py = |v: f64| y1 - y.frac(v) * (y1 - y0);
    write_axes(s, (&x, &y), (left, right), (y0, y1));
    let _ = writeln!(
        s,
        r#"<clipPath id="scatter"><rect x="{left:.2}" y="{y0:.2}" width="{:.2}" height="{:.2}"/></clipPath><g clip-path="url(#scatter)">"#,
        right - left,
        y1 - y0
    );
    if let Some(values) = &background {
        write_cells(s, values, c_range, (left, right), (y0, y1));
    }
    let mut seen = HashSet::new();
    for p in &sc.points {
        let (cx, cy) = (px(p.x), py(p.y));
        let fresh =
            cx.is_finite() && cy.is_finite() && seen.insert(((cx / 2.0) as i64, (cy / 2.0) as i64));
        if !fresh {
            continue;
        }
        if sc.background.is_some() {
            let _ = writeln!(
                s,
                r#"<circle class="point" cx="{cx:.1}" cy="{cy:.1}" r="2" fill="black" stroke="white" stroke-width="0.6"/>"#
            );
            continue;
        }
        let fill = match p.c {
            Some(c) if sc.colour_label.is_some() => {
                colour((c - c_range.0) / (c_range.1 - c_range.0))
            }
            _ => ONE_COLOUR.to_string(),
        };
        let _ = writeln!(
            s,
            r#"<circle class="point" cx="{cx:.1}" cy="{cy:.1}" r="2" fill="{fill}"/>"#
        );
    }
    s.push_str("</g>\n");
    let _ = writeln!(
        s,
        r#"<rect class="frame" x="{left:.2}" y="{y0:.2}" width="{:.2}" height="{:.2}" fill="none" stroke="black" stroke-width="1"/>"#,
        right - left,
        y1 - y0
    );
    let (lx, ly) = (12.0 + LABEL_SIZE * ASCENT, (y0 + y1) / 2.0);
    let _ = writeln!(
        s,
        r#"<text class="axis-label y" x="{lx:.2}" y="{ly:.2}" font-size="{LABEL_SIZE}" text-anchor="middle" transform="rotate(-90 {lx:.2} {ly:.2})">{}</text>"#,
        esc(&sc.y_label)
    );
    text(
        s,
        "axis-label x",
        ((left + right) / 2.0, y1 + FOOT - 8.0),
        LABEL_SIZE,
        "middle",
        &sc.x_label,
    );
    s.push_str("</g>\n");
    y1 + FOOT
}

/// Grid lines and tick labels of the panel's axes.
fn write_axes(
    s: &mut String,
    (x, y): (&Axis, &Axis),
    (left, right): (f64, f64),
    (y0, y1): (f64, f64),
) {
    let px = |v: f64| left + x.frac(v) * (right - left);
    let py = |v: f64| y1 - y.frac(v) * (y1 - y0);
    s.push_str("<g class=\"grid\" stroke=\"#d0d0d0\" stroke-width=\"1\">\n");
    for &v in &x.ticks {
        let _ = writeln!(
            s,
            r#"<line x1="{0:.2}" y1="{y0:.2}" x2="{0:.2}" y2="{y1:.2}"/>"#,
            px(v)
        );
    }
    for &v in &y.ticks {
        let _ = writeln!(
            s,
            r#"<line x1="{left:.2}" y1="{0:.2}" x2="{right:.2}" y2="{0:.2}"/>"#,
            py(v)
        );
    }
    s.push_str("</g>\n");
    for (&v, l) in x.ticks.iter().zip(&x.labels) {
        text(
            s,
            "tick x",
            (px(v), y1 + 4.0 + TICK_SIZE),
            TICK_SIZE,
            "middle",
            l,
        );
    }
    for (&v, l) in y.ticks.iter().zip(&y.labels) {
        let base = py(v) + TICK_SIZE * (ASCENT - DESCENT) / 2.0;
        text(s, "tick y", (left - 8.0, base), TICK_SIZE, "end", l);
    }
}

/// Levels of the map's colour scale (neighbouring cells of one level are drawn as one rectangle).
const LEVELS: f64 = 32.0;

/// The 5th and 95th percentile of the finite `values` (both 0 without any).
fn percentile_range(values: &[f64]) -> (f64, f64) {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (0.0, 0.0);
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.05), at(0.95))
}

/// The sampled map as cells on the colour scale, clamped to `range`, row by row from the bottom; a run of
/// cells of one level in a row is one rectangle, non-finite cells are left blank.
fn write_cells(
    s: &mut String,
    values: &[f64],
    (lo, hi): (f64, f64),
    (left, right): (f64, f64),
    (y0, y1): (f64, f64),
) {
    let [nx, ny] = CELLS;
    let (w, h) = ((right - left) / nx as f64, (y1 - y0) / ny as f64);
    let level = |v: f64| {
        let f = if hi > lo { (v - lo) / (hi - lo) } else { 0.5 };
        v.is_finite()
            .then(|| (f.clamp(0.0, 1.0) * (LEVELS - 1.0)).round())
    };
    s.push_str("<g class=\"engine-map\">\n");
    for (j, row) in values.chunks(nx).enumerate().take(ny) {
        let top = y1 - (j + 1) as f64 * h;
        let mut i = 0;
        while i < row.len() {
            let l = level(row[i]);
            let mut k = i + 1;
            while k < row.len() && level(row[k]) == l {
                k += 1;
            }
            if let Some(l) = l {
                let _ = writeln!(
                    s,
                    r#"<rect x="{:.2}" y="{top:.2}" width="{:.2}" height="{:.2}" fill="{}"/>"#,
                    left + i as f64 * w,
                    (k - i) as f64 * w + 0.3,
                    h + 0.3,
                    colour(l / (LEVELS - 1.0))
                );
            }
            i = k;
        }
    }
    s.push_str("</g>\n");
}

/// The colour bar: the scale's colours from its lowest to its highest value, labelled at both ends (with an
/// engine map, whose values beyond them are drawn in the end colours: "≤" and "≥").
fn write_colour_bar(s: &mut String, sc: &Scatter, (x, y): (f64, f64), (lo, hi): (f64, f64)) {
    let Some(label) = &sc.colour_label else {
        return;
    };
    s.push_str("<g class=\"legend\">\n");
    let num = crate::numfmt::num;
    let (below, above) = if sc.background.is_some() {
        ("≤ ", "≥ ")
    } else {
        ("", "")
    };
    let lo_text = format!("{label}: {below}{}", num(lo));
    let bar_x = x + super::font::text_width(&lo_text, TICK_SIZE) + 8.0;
    text(
        s,
        "legend-label",
        (x, y + 14.0),
        TICK_SIZE,
        "start",
        &lo_text,
    );
    for k in 0..40 {
        let _ = writeln!(
            s,
            r#"<rect x="{:.2}" y="{:.2}" width="5.2" height="12" fill="{}"/>"#,
            bar_x + 5.0 * f64::from(k),
            y + 3.0,
            colour(f64::from(k) / 39.0)
        );
    }
    text(
        s,
        "legend-label",
        (bar_x + 208.0, y + 14.0),
        TICK_SIZE,
        "start",
        &format!("{above}{}", num(hi)),
    );
    s.push_str("</g>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_colour_scale_runs_from_dark_blue_to_yellow() {
        assert_eq!(colour(0.0), "#440154");
        assert_eq!(colour(1.0), "#fde725");
        assert_eq!(colour(0.5), "#21918c");
        assert_eq!(colour(f64::NAN), "#440154");
    }
}
