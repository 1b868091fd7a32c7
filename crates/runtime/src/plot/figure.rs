//! A figure of panels stacked over one time axis, written as SVG by hand so that its layout is exact: every
//! text is measured with the embedded font, tick labels stay inside the canvas, legends sit above their plot
//! area and never cover a curve.
//!
//! Structure (what the tests parse): the root `<svg>` holds a `title` text, one `<g class="panel">` per panel
//! (with `panel-title`, `legend` > `legend-entry`, `axis-label y`, `tick` texts and `series` polylines) and
//! the `axis-label x` text under the last panel.

use std::fmt::Write as _;

use super::axis::Axis;
use super::error::PlotError;
use super::font::{text_width, ASCENT, DESCENT, FONT_FAMILY};
use super::layout::Layout;
use super::scatter::{self, Scatter};
use super::svg::{esc, text};

/// Width of every figure in pixels.
pub const WIDTH: f64 = super::layout::DEFAULT_WIDTH;
pub use super::svg::{LABEL_SIZE, LEGEND_SIZE, PANEL_TITLE_SIZE, TICK_SIZE, TITLE_SIZE};

const MARGIN: f64 = 12.0;
const TITLE_ROW: f64 = 40.0;
const HEADER_ROW: f64 = 24.0;
const LEGEND_ROW: f64 = 22.0;
const PLOT_HEIGHT: f64 = 200.0;
const HEADLINE_ROW: f64 = 24.0;
/// The lowest plot area of a panel a `--size` may leave.
const MIN_PLOT_HEIGHT: f64 = 40.0;

const TICK_ROW: f64 = 24.0;
const PANEL_GAP: f64 = 16.0;
const X_LABEL_ROW: f64 = 30.0;
const SWATCH: f64 = 26.0;

/// The lowest figure that draws `names` (`--plot-vars`; `engine` is the operating-point panel) with a
/// headline, one legend row per panel and 40 pixels of plot each: a `--size` below it is refused before the
/// run (a figure whose legends need more rows is refused when it is drawn).
pub fn min_height(names: &[String]) -> f64 {
    let scatter = names.iter().any(|n| n.trim() == "engine");
    let panels = names.iter().filter(|n| n.trim() != "engine").count() as f64;
    let per_panel = HEADER_ROW + LEGEND_ROW + 6.0 + TICK_ROW + PANEL_GAP + MIN_PLOT_HEIGHT;
    let mut h = MARGIN + TITLE_ROW + HEADLINE_ROW + panels * per_panel + MARGIN;
    if panels > 0.0 {
        h += X_LABEL_ROW - PANEL_GAP;
    }
    if scatter {
        h += scatter::FIXED + scatter::RATIO * MIN_PLOT_HEIGHT;
    }
    h.ceil()
}

/// One curve: its legend label, colour, line width, dash and points (x, y) in axis units.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    pub color: &'static str,
    pub width: f64,
    pub dashed: bool,
    pub points: Vec<(f64, f64)>,
}

/// One panel: a title, the y axis label (with its unit) and its curves.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The `--plot-vars` name that chose the panel.
    pub var: String,
    pub title: String,
    pub y_label: String,
    /// Include 0 in the y range (speeds).
    pub y_zero: bool,
    /// The curves; the y scale comes from their points inside the figure's time range.
    pub series: Vec<Series>,
    /// Lines for orientation (an input's bounds): drawn where they fall inside the scale, never widening it;
    /// in the legend either way ("off scale" when outside).
    pub guides: Vec<Series>,
}

/// A figure: title, the headline result under it, x-axis label, the x range, the panels top to bottom and
/// the operating-point panel under them.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub title: String,
    /// The run's result in a line under the title (l/100 km, kWh/100 km, …), if known.
    pub headline: Option<String>,
    pub x_label: String,
    pub x_range: (f64, f64),
    pub panels: Vec<Panel>,
    pub scatter: Option<Scatter>,
}

/// Horizontal placement shared by all panels: the plot area's left and right edges, the time axis and the
/// plot areas' height.
struct Frame {
    left: f64,
    right: f64,
    x: Axis,
    plot_h: f64,
}

impl Frame {
    fn px(&self, t: f64) -> f64 {
        self.left + self.x.frac(t) * (self.right - self.left)
    }
}

impl Figure {
    /// The figure as an SVG document, 1000 pixels wide, each panel's plot 200 pixels high.
    pub fn to_svg(&self) -> String {
        let (frame, axes) = self.frame(WIDTH, PLOT_HEIGHT);
        self.svg(&frame, &axes, (WIDTH, None, 1.0))
    }

    /// The figure as an SVG document laid out as `layout` asks: its width, its height (the panels' plots
    /// share what the titles, legends and ticks leave; an error if that is below 40 pixels each) and the
    /// size the SVG declares (× dpi / 96).
    pub fn to_svg_with(&self, layout: &Layout) -> Result<String, PlotError> {
        let (mut frame, axes) = self.frame(layout.width, PLOT_HEIGHT);
        if let Some(h) = layout.height {
            let units =
                self.panels.len() as f64 + self.scatter.as_ref().map_or(0.0, |_| scatter::RATIO);
            let fixed = self.fixed_height(&frame);
            let plot_h = (h - fixed) / units.max(1.0);
            if plot_h < MIN_PLOT_HEIGHT {
                return Err(PlotError::TooLow {
                    height: h,
                    needed: (fixed + MIN_PLOT_HEIGHT * units).ceil(),
                    panels: self.panels.len() + usize::from(self.scatter.is_some()),
                });
            }
            frame.plot_h = plot_h;
        }
        Ok(self.svg(&frame, &axes, (layout.width, layout.height, layout.scale())))
    }

    /// The frame of a figure `width` wide and the panels' y axes.
    fn frame(&self, width: f64, plot_h: f64) -> (Frame, Vec<Axis>) {
        let x = Axis::new(self.x_range.0, self.x_range.1, 10);
        let y_axes: Vec<Axis> = self
            .panels
            .iter()
            .map(|p| y_axis(p, self.x_range))
            .collect();
        let tick_w = y_axes
            .iter()
            .flat_map(|a| a.labels.iter())
            .map(|l| text_width(l, TICK_SIZE))
            .fold(0.0, f64::max);
        let left = MARGIN + LABEL_SIZE * (ASCENT + DESCENT) + 10.0 + tick_w + 8.0;
        let last_half = x
            .labels
            .last()
            .map_or(0.0, |l| text_width(l, TICK_SIZE) / 2.0);
        let right = width - MARGIN - last_half.max(12.0);
        (
            Frame {
                left,
                right,
                x,
                plot_h,
            },
            y_axes,
        )
    }

    /// The height of everything but the plot areas.
    fn fixed_height(&self, f: &Frame) -> f64 {
        let mut h = MARGIN + TITLE_ROW + self.headline.as_ref().map_or(0.0, |_| HEADLINE_ROW);
        for p in &self.panels {
            let rows = legend_rows(p, f.right - f.left);
            h += HEADER_ROW + rows as f64 * LEGEND_ROW + 6.0 + TICK_ROW + PANEL_GAP;
        }
        if !self.panels.is_empty() {
            h += X_LABEL_ROW - PANEL_GAP;
        }
        h + self.scatter.as_ref().map_or(0.0, |_| scatter::FIXED) + MARGIN
    }

    /// The SVG of the figure in `frame`, `width` wide (`height`: the height asked for, else the panels'),
    /// declared `scale` times its layout's size.
    fn svg(
        &self,
        frame: &Frame,
        axes: &[Axis],
        (width, height, scale): (f64, Option<f64>, f64),
    ) -> String {
        let mut body = String::new();
        let mut y = MARGIN + TITLE_ROW;
        if let Some(h) = &self.headline {
            text(
                &mut body,
                "headline",
                (MARGIN, y + 8.0),
                LABEL_SIZE,
                "start",
                h,
            );
            y += HEADLINE_ROW;
        }
        for (k, (panel, axis)) in self.panels.iter().zip(axes).enumerate() {
            y = write_panel(&mut body, k, panel, axis, frame, y);
        }
        if !self.panels.is_empty() {
            let x_mid = (frame.left + frame.right) / 2.0;
            let x_base = y - PANEL_GAP + X_LABEL_ROW - 8.0;
            text(
                &mut body,
                "axis-label x",
                (x_mid, x_base),
                LABEL_SIZE,
                "middle",
                &self.x_label,
            );
            y += X_LABEL_ROW - PANEL_GAP;
        }
        if let Some(sc) = &self.scatter {
            y = scatter::write(&mut body, sc, (frame.left, frame.right), y, frame.plot_h);
        }
        let height = height.unwrap_or((y + MARGIN).ceil());
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" viewBox="0 0 {width} {height}" font-family="{FONT_FAMILY}, sans-serif">"#,
            (width * scale).round(),
            (height * scale).round()
        );
        let _ = writeln!(
            s,
            r#"<rect width="{width}" height="{height}" fill="white"/>"#
        );
        text(
            &mut s,
            "title",
            (MARGIN, MARGIN + TITLE_SIZE),
            TITLE_SIZE,
            "start",
            &self.title,
        );
        s.push_str(&body);
        s.push_str("</svg>\n");
        s
    }
}

/// The y axis of a panel: its curves' range inside the time range `(t0, t1)`, with margins (the guides do
/// not count).
fn y_axis(p: &Panel, (t0, t1): (f64, f64)) -> Axis {
    let values = p
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|q| q.0 >= t0 && q.0 <= t1)
        .map(|q| q.1);
    Axis::padded(values, p.y_zero, 5)
}

/// The legend's entries: the curves, then the guides (marked when they lie outside the scale `y`).
fn legend_entries(p: &Panel, y: Option<&Axis>) -> Vec<Series> {
    let mut v = p.series.clone();
    for g in &p.guides {
        let mut g = g.clone();
        let off = y.is_some_and(|a| g.points.iter().all(|q| q.1 < a.lo || q.1 > a.hi));
        if off {
            g.label = format!("{} (off scale)", g.label);
        }
        v.push(g);
    }
    v
}

/// The number of legend rows of panel `p` in `width`.
fn legend_rows(p: &Panel, width: f64) -> usize {
    // "(off scale)" may lengthen a guide's label: counted as if it did.
    let mut entries = legend_entries(p, None);
    for g in entries.iter_mut().skip(p.series.len()) {
        g.label.push_str(" (off scale)");
    }
    legend_layout(&entries, width).last().map_or(0, |l| l.0 + 1)
}

/// Lay the legend's entries out in rows within `width`: (row, x offset) of each entry.
fn legend_layout(series: &[Series], width: f64) -> Vec<(usize, f64)> {
    let (mut row, mut x) = (0, 0.0);
    series
        .iter()
        .map(|s| {
            let w = SWATCH + 6.0 + text_width(&s.label, LEGEND_SIZE) + 20.0;
            if x > 0.0 && x + w > width {
                row += 1;
                x = 0.0;
            }
            let at = (row, x);
            x += w;
            at
        })
        .collect()
}

/// Write the legend of panel `p` at height `top`.
fn write_legend(s: &mut String, entries: &[Series], f: &Frame, top: f64) {
    // At most the rows `legend_rows` counted: the labels are at most as long as counted there.
    let layout = legend_layout(entries, f.right - f.left);
    s.push_str("<g class=\"legend\">\n");
    for (series, (row, dx)) in entries.iter().zip(&layout) {
        let (lx, ly) = (
            f.left + dx,
            top + HEADER_ROW + *row as f64 * LEGEND_ROW + 14.0,
        );
        let _ = write!(
            s,
            r#"<g class="legend-entry"><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" {}/>"#,
            lx,
            ly - 5.0,
            lx + SWATCH,
            ly - 5.0,
            stroke(series)
        );
        text(
            s,
            "legend-label",
            (lx + SWATCH + 6.0, ly),
            LEGEND_SIZE,
            "start",
            &series.label,
        );
        s.push_str("</g>\n");
    }
    s.push_str("</g>\n");
}

/// Write panel `k` starting at height `top`; the height where the next panel starts.
fn write_panel(s: &mut String, k: usize, p: &Panel, y: &Axis, f: &Frame, top: f64) -> f64 {
    let _ = writeln!(s, r#"<g class="panel" data-var="{}">"#, esc(&p.var));
    text(
        s,
        "panel-title",
        (f.left, top + PANEL_TITLE_SIZE),
        PANEL_TITLE_SIZE,
        "start",
        &p.title,
    );
    write_legend(s, &legend_entries(p, Some(y)), f, top);
    let rows = legend_rows(p, f.right - f.left);
    let y0 = top + HEADER_ROW + rows as f64 * LEGEND_ROW + 6.0;
    let y1 = y0 + f.plot_h;
    let py = |v: f64| y1 - y.frac(v) * f.plot_h;
    write_grid(s, f, y, y0, y1, &py);
    let _ = writeln!(
        s,
        r#"<clipPath id="plot{k}"><rect x="{:.2}" y="{y0:.2}" width="{:.2}" height="{:.2}"/></clipPath>"#,
        f.left,
        f.right - f.left,
        f.plot_h
    );
    let _ = writeln!(s, r#"<g clip-path="url(#plot{k})">"#);
    for guide in p
        .guides
        .iter()
        .filter(|g| g.points.iter().any(|q| q.1 >= y.lo && q.1 <= y.hi))
    {
        write_series(s, guide, f, &py);
    }
    // The first curve of the legend (the raw cycle, the input) is drawn last, on top.
    for series in p.series.iter().rev() {
        write_series(s, series, f, &py);
    }
    s.push_str("</g>\n");
    let _ = writeln!(
        s,
        r#"<rect class="frame" x="{:.2}" y="{y0:.2}" width="{:.2}" height="{:.2}" fill="none" stroke="black" stroke-width="1"/>"#,
        f.left,
        f.right - f.left,
        f.plot_h
    );
    let (y_label, size) = fit_y_label(&p.y_label, f.plot_h);
    let (lx, ly) = (MARGIN + LABEL_SIZE * ASCENT, (y0 + y1) / 2.0);
    let _ = writeln!(
        s,
        r#"<text class="axis-label y" x="{lx:.2}" y="{ly:.2}" font-size="{size}" text-anchor="middle" transform="rotate(-90 {lx:.2} {ly:.2})">{}</text>"#,
        esc(&y_label)
    );
    s.push_str("</g>\n");
    y1 + TICK_ROW + PANEL_GAP
}

/// Grid lines and tick labels of both axes (x labels under the plot area, y labels left of it).
fn write_grid(s: &mut String, f: &Frame, y: &Axis, y0: f64, y1: f64, py: &dyn Fn(f64) -> f64) {
    s.push_str("<g class=\"grid\" stroke=\"#d0d0d0\" stroke-width=\"1\">\n");
    for &t in &f.x.ticks {
        let x = f.px(t);
        let _ = writeln!(
            s,
            r#"<line x1="{x:.2}" y1="{y0:.2}" x2="{x:.2}" y2="{y1:.2}"/>"#
        );
    }
    for &v in &y.ticks {
        let yy = py(v);
        let _ = writeln!(
            s,
            r#"<line x1="{:.2}" y1="{yy:.2}" x2="{:.2}" y2="{yy:.2}"/>"#,
            f.left, f.right
        );
    }
    s.push_str("</g>\n");
    for (&t, l) in f.x.ticks.iter().zip(&f.x.labels) {
        text(
            s,
            "tick x",
            (f.px(t), y1 + 4.0 + TICK_SIZE),
            TICK_SIZE,
            "middle",
            l,
        );
    }
    for (&v, l) in y.ticks.iter().zip(&y.labels) {
        let base = py(v) + TICK_SIZE * (ASCENT - DESCENT) / 2.0;
        text(s, "tick y", (f.left - 8.0, base), TICK_SIZE, "end", l);
    }
}

/// A curve as polylines (one per run of finite points).
fn write_series(s: &mut String, series: &Series, f: &Frame, py: &dyn Fn(f64) -> f64) {
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for &(t, v) in &series.points {
        if t.is_finite() && v.is_finite() {
            if let Some(r) = runs.last_mut() {
                r.push((f.px(t), py(v)));
            }
        } else if runs.last().is_some_and(|r| !r.is_empty()) {
            runs.push(Vec::new());
        }
    }
    for run in runs.iter().filter(|r| !r.is_empty()) {
        let mut pts = String::with_capacity(run.len() * 16);
        for (x, y) in run {
            let _ = write!(pts, "{x:.2},{y:.2} ");
        }
        let _ = writeln!(
            s,
            r#"<polyline class="series" fill="none" {} points="{}"/>"#,
            stroke(series),
            pts.trim_end()
        );
    }
}

/// The stroke attributes of a curve: colour, width, joins and its dashes.
fn stroke(series: &Series) -> String {
    let dash = if series.dashed {
        r#" stroke-dasharray="8 5""#
    } else {
        ""
    };
    format!(
        r#"stroke="{}" stroke-width="{}" stroke-linejoin="round"{dash}"#,
        series.color, series.width
    )
}

/// A y label and its font size: the label size, or for a label longer than the plot is high the tick labels'
/// size; a label too long even then is shortened so that it fits beside its plot at that size ("cumulative X"
/// becomes "∫ X dt", then the middle of the name before the unit gives way to "…"). The panel's title keeps
/// the whole name.
fn fit_y_label(label: &str, plot_h: f64) -> (String, f64) {
    if text_width(label, LABEL_SIZE) <= plot_h {
        return (label.to_string(), LABEL_SIZE);
    }
    let fits = |l: &str| text_width(l, TICK_SIZE) <= plot_h;
    if fits(label) {
        return (label.to_string(), TICK_SIZE);
    }
    let (name, unit) = match label.rfind(" [") {
        Some(i) => label.split_at(i),
        None => (label, ""),
    };
    let short = match name.strip_prefix("cumulative ") {
        Some(rest) => format!("∫ {rest} dt"),
        None => name.to_string(),
    };
    let candidate = format!("{short}{unit}");
    if fits(&candidate) {
        return (candidate, TICK_SIZE);
    }
    let chars: Vec<char> = short.chars().collect();
    for keep in (2..chars.len()).rev() {
        let head: String = chars[..keep.div_ceil(2)].iter().collect();
        let tail: String = chars[chars.len() - keep / 2..].iter().collect();
        let candidate = format!("{head}…{tail}{unit}");
        if fits(&candidate) {
            return (candidate, TICK_SIZE);
        }
    }
    (format!("…{unit}"), TICK_SIZE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_y_labels_are_shortened_to_fit_at_the_tick_size() {
        assert_eq!(
            fit_y_label("v [m/s]", PLOT_HEIGHT),
            ("v [m/s]".to_string(), LABEL_SIZE)
        );
        let (l, size) = fit_y_label("cumulative fuel_no_cutoff [kg]", PLOT_HEIGHT);
        assert_eq!((l.as_str(), size), ("∫ fuel_no_cutoff dt [kg]", TICK_SIZE));
        let long = format!("{} [kW]", "x".repeat(80));
        let (l, size) = fit_y_label(&long, PLOT_HEIGHT);
        assert!(l.contains('…') && l.ends_with(" [kW]"), "{l}");
        assert!(text_width(&l, size) <= PLOT_HEIGHT && size == TICK_SIZE);
    }
}
