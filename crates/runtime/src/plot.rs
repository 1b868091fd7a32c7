//! Plots of a run for a report, as Figs. 5 and 7 of Fröberg & Nielsen (2004): panels stacked over time, by
//! default the raw cycle with the smoothed reference y_d, the input with its bounds, one running integral
//! (the fuel used so far) and the engine's operating points; `--plot-vars` chooses any of the reference, the
//! input, the states, the `[outputs]`, `cum:NAME` and `engine`. Every axis label carries the model file's
//! unit.
//!
//! The figure is 1000 px wide by default, text at 14–20 px in the embedded DejaVu Sans; SVG or PNG by the file's
//! extension, the PNG rasterised from the same SVG in pure Rust (resvg), so no system font is needed.
//!
//! A figure's size and resolution (`--size`, `--dpi`: [`Layout`]) and its time window (`--window`:
//! [`Figure::windowed`]) are chosen when it is rendered; each panel's scale comes from its curves inside the
//! window, an input's bounds are guides drawn where they fall inside it. Models with an `[engine]` get the
//! engine's operating points coloured by the fuel flow (`engine_map`).
//!
//! Modules, in the one direction their imports go: `axis` (ranges, nice ticks), `font` (the embedded font:
//! text widths, PNG), `error` (why a plot fails), `svg` (text sizes and elements), `scatter` (the
//! operating-point panel), `layout` (size and resolution), `png_dpi` (the resolution in the PNG file),
//! `figure` (the SVG layout), `window` (the time window), `panels` (what each `--plot-vars` name draws),
//! `engine_map` (the engine's operating points), `reference` (the reference panels' axis and raw cycle),
//! `exogenous` (the panel of a `[signals]` signal, raw and smoothed), `modal` (the figures of runs with
//! operating modes, with the step panel of the mode sequence), this file.

mod axis;
mod engine_map;
mod error;
mod exogenous;
mod figure;
mod font;
mod hybrid;
mod layout;
mod map_layer;
mod modal;
mod panels;
mod png_dpi;
mod reference;
mod scatter;
mod steps;
mod svg;
mod window;

use std::path::Path;

use invsim_model_api::{ModelInfo, ReferenceMap};

use crate::cycle::Cycle;
use crate::forward::ForwardResult;
use crate::inverse::SimulationResult;
use exogenous::signal_raw_and_smoothed;
use panels::{input_panel, raw_series, resolve, signal_panel, smoothed_series, Var};
use reference::{raw_points, reference_axis, time_range};

pub use error::PlotError;
pub use figure::{
    min_height, Figure, Panel, Series, LABEL_SIZE, LEGEND_SIZE, PANEL_TITLE_SIZE, TICK_SIZE,
    TITLE_SIZE, WIDTH,
};
pub use font::{text_width, FONT_FAMILY};
pub use layout::{
    parse_size, Layout, DEFAULT_DPI, MAX_DPI, MAX_HEIGHT, MAX_PIXELS, MAX_WIDTH, MIN_DPI,
};
pub use map_layer::MapLayer;
pub use modal::{
    check_modal_vars, modal_default_vars, modal_forward_figure, modal_simulation_figure,
    modal_valid_vars,
};
pub use panels::{default_vars, valid_vars, MAX_BUCKETS};
pub use panels::{thin, PALETTE};
pub use scatter::{Scatter, ScatterPoint};
pub use window::{check_window, parse_window};

/// The file format of a plot, chosen by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotFormat {
    Svg,
    Png,
}

impl PlotFormat {
    /// `.svg` or `.png` (any case); anything else is an error naming the file.
    pub fn from_path(path: &Path) -> Result<PlotFormat, PlotError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("svg") => Ok(PlotFormat::Svg),
            Some("png") => Ok(PlotFormat::Png),
            _ => Err(PlotError::Format {
                path: path.display().to_string(),
            }),
        }
    }
}

/// Check `vars` (`--plot-vars`) against the model's panels; an empty list means [`default_vars`].
pub fn check_vars(info: &ModelInfo, vars: &[String]) -> Result<(), PlotError> {
    resolve_all(info, vars).map(|_| ())
}

fn resolve_all(info: &ModelInfo, vars: &[String]) -> Result<Vec<(String, Var)>, PlotError> {
    let valid = || valid_vars(info).join(", ");
    resolve_names(vars, || default_vars(info), valid, |n| resolve(info, n))
}

/// Most panels a plot draws: 64 panels are a figure about 19 000 pixels high (a 75 MB image in memory as
/// PNG), beyond what a screen or a page shows; checked before the run ([`check_vars`]), so that
/// `--plot-vars` repeating a name 2000 times (a 2 GB image) is refused at once.
pub const MAX_PANELS: usize = 64;

/// `--plot-vars` names (trimmed, blanks dropped; none given: `defaults()`), each resolved by `resolve`; an
/// unknown name, or only blanks, is an error listing `valid()`; more than [`MAX_PANELS`] is an error.
pub(crate) fn resolve_names<T>(
    vars: &[String],
    defaults: impl FnOnce() -> Vec<String>,
    valid: impl Fn() -> String,
    resolve: impl Fn(&str) -> Option<T>,
) -> Result<Vec<(String, T)>, PlotError> {
    let names: Vec<String> = if vars.is_empty() {
        defaults()
    } else {
        vars.iter().map(|v| v.trim().to_string()).collect()
    };
    if names.iter().all(|n| n.is_empty()) {
        return Err(PlotError::NoVars { valid: valid() });
    }
    let given = names.iter().filter(|n| !n.is_empty()).count();
    if given > MAX_PANELS {
        return Err(PlotError::TooManyPanels {
            given,
            max: MAX_PANELS,
        });
    }
    names
        .into_iter()
        .filter(|n| !n.is_empty())
        .map(|n| match resolve(&n) {
            Some(v) => Ok((n, v)),
            None => Err(PlotError::UnknownVar {
                name: n,
                valid: valid(),
            }),
        })
        .collect()
}

/// The figure of an inverse run of `info`'s model along `cycle`, with the panels `vars` (empty: the default).
pub fn simulation_figure(
    result: &SimulationResult,
    cycle: &Cycle,
    info: &ModelInfo,
    vars: &[String],
) -> Result<Figure, PlotError> {
    let vars = resolve_all(info, vars)?;
    if result.is_empty() {
        return Err(PlotError::Empty);
    }
    let t = result.time();
    let x_range = time_range(t);
    let input_title = format!("input {} (bounds reported, not clipped)", info.input);
    let columns = Columns {
        names: &result.columns,
        data: &result.data,
    };
    let reference = || simulation_reference(result, cycle, info, x_range);
    let exogenous = |i: usize| {
        let smoothed = columns.get(&info.signals[i].name);
        signal_raw_and_smoothed(info, i, result.signals.get(i), (t, smoothed), x_range)
    };
    let panels = build_panels(info, &vars, columns, (&reference, &exogenous), &input_title);
    let s = &result.summary;
    Ok(Figure {
        title: format!(
            "{} on {}: inverse simulation, look-ahead a = {} s",
            s.run.model, s.run.cycle, s.lookahead_s
        ),
        headline: None,
        x_label: "t [s]".to_string(),
        x_range,
        panels,
        scatter: engine_panel(info, &vars, columns),
    })
}

/// The figure of a forward run of `info`'s model (whose reference map is `reference`), with the panels
/// `vars` (empty: the default); its reference panel shows the raw cycle and the output achieved.
pub fn forward_figure(
    result: &ForwardResult,
    info: &ModelInfo,
    reference: ReferenceMap,
    vars: &[String],
) -> Result<Figure, PlotError> {
    let vars = resolve_all(info, vars)?;
    if result.is_empty() {
        return Err(PlotError::Empty);
    }
    let t = result.time();
    let input_title = format!("input {} applied by the driver", info.input);
    let columns = Columns {
        names: &result.columns,
        data: &result.data,
    };
    let reference = || forward_reference(result, info, reference);
    // The forward run integrates with the raw signals: their panels show the raw curve alone.
    let x_range = time_range(t);
    let exogenous =
        |i: usize| signal_raw_and_smoothed(info, i, result.signals.get(i), (&[], &[]), x_range);
    let panels = build_panels(info, &vars, columns, (&reference, &exogenous), &input_title);
    let s = &result.summary;
    Ok(Figure {
        title: format!(
            "{} on {}: forward simulation with the PI driver",
            s.run.model, s.run.cycle
        ),
        headline: None,
        x_label: "t [s]".to_string(),
        x_range,
        panels,
        scatter: engine_panel(info, &vars, columns),
    })
}

/// The series of a run, column by column (the first column is the time).
#[derive(Clone, Copy)]
struct Columns<'a> {
    names: &'a [String],
    data: &'a [Vec<f64>],
}

impl<'a> Columns<'a> {
    fn get(&self, name: &str) -> &'a [f64] {
        self.names
            .iter()
            .position(|c| c == name)
            .and_then(|i| self.data.get(i))
            .map_or(&[], Vec::as_slice)
    }
}

/// The engine's operating points when `vars` name them.
fn engine_panel(info: &ModelInfo, vars: &[(String, Var)], columns: Columns<'_>) -> Option<Scatter> {
    if !vars.iter().any(|(_, v)| *v == Var::Engine) {
        return None;
    }
    engine_map::engine_scatter(info, &info.outputs, |n| columns.get(n))
}

/// The panels of `vars` from the run's `columns` (the engine's operating points are no time panel).
fn build_panels(
    info: &ModelInfo,
    vars: &[(String, Var)],
    columns: Columns<'_>,
    (reference, exogenous): (&dyn Fn() -> Panel, &dyn Fn(usize) -> Panel),
    input_title: &str,
) -> Vec<Panel> {
    let t = columns.data.first().map_or(&[][..], Vec::as_slice);
    let column = |name: &str| columns.get(name);
    let mut k = 0;
    let mut panels = Vec::with_capacity(vars.len());
    for (_, var) in vars {
        let panel = match *var {
            Var::Engine => continue,
            Var::Reference => reference(),
            Var::Exogenous(i) => exogenous(i),
            Var::Input => input_panel(info, t, column(&info.input), input_title),
            Var::Signal(signal) => {
                let name = match signal {
                    panels::Signal::State(i) => &info.states[i],
                    panels::Signal::Output(i) | panels::Signal::Cumulative(i) => {
                        &info.outputs[i].name
                    }
                };
                k += 1;
                signal_panel(info, signal, t, column(name), k - 1)
            }
        };
        panels.push(panel);
    }
    panels
}

/// The reference panel of an inverse run: the raw cycle (through the reference map) and y_d.
fn simulation_reference(
    r: &SimulationResult,
    cycle: &Cycle,
    info: &ModelInfo,
    range: (f64, f64),
) -> Panel {
    let map = r.reference;
    let (y_label, factor, y_zero) = reference_axis(info, map);
    let raw = raw_points(cycle, range, |s| factor * (map.offset + map.scale * s));
    let yd: Vec<f64> = r.yd(0).unwrap_or(&[]).iter().map(|v| v * factor).collect();
    let raw_label = if map.is_identity() {
        "cycle (raw)".to_string()
    } else {
        format!("cycle as reference {} + {}·v", map.offset, map.scale)
    };
    let a = r.summary.lookahead_s;
    Panel {
        var: "reference".to_string(),
        title: format!(
            "reference of {}: the drive cycle and y_d smoothed with a = {a} s",
            info.output
        ),
        y_label,
        y_zero,
        series: vec![
            raw_series(raw_label, raw),
            smoothed_series("y_d (smoothed)".to_string(), r.time(), &yd),
        ],
        guides: Vec::new(),
    }
}

/// The reference panel of a forward run: the raw cycle y_c and the output the model achieved.
fn forward_reference(r: &ForwardResult, info: &ModelInfo, reference: ReferenceMap) -> Panel {
    let (y_label, factor, y_zero) = reference_axis(info, reference);
    let scaled = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * factor).collect() };
    let t = r.time();
    let achieved = r.column(&info.output).unwrap_or(&[]);
    Panel {
        var: "reference".to_string(),
        title: format!("{}: the raw cycle and what the model achieved", info.output),
        y_label,
        y_zero,
        series: vec![
            raw_series(
                "cycle y_c (raw)".to_string(),
                panels::thin(t, &scaled(r.cycle_speed())),
            ),
            smoothed_series(format!("achieved {}", info.output), t, &scaled(achieved)),
        ],
        guides: Vec::new(),
    }
}

impl Figure {
    /// The figure in `format`: SVG text, or PNG bytes rasterised from it.
    pub fn render(&self, format: PlotFormat) -> Result<Vec<u8>, PlotError> {
        self.render_with(format, &Layout::default())
    }

    /// The figure in `format` laid out and rasterised as `layout` asks (`--size`, `--dpi`).
    pub fn render_with(&self, format: PlotFormat, layout: &Layout) -> Result<Vec<u8>, PlotError> {
        let svg = self.to_svg_with(layout)?;
        match format {
            PlotFormat::Svg => Ok(svg.into_bytes()),
            PlotFormat::Png => font::svg_to_png(&svg).map(|png| png_dpi::with_dpi(png, layout.dpi)),
        }
    }

    /// Write the figure to `path`, as SVG or PNG by its extension.
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        let bytes = self.render(PlotFormat::from_path(path)?)?;
        std::fs::write(path, bytes).map_err(|e| PlotError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

/// Draw `result` (and the raw `cycle` it followed) into an SVG file at `path` with the default panels, labelled
/// without the model's units (they are not in the result): [`simulation_figure`] with the model's
/// [`ModelInfo`] labels every axis.
pub fn plot_svg(result: &SimulationResult, cycle: &Cycle, path: &Path) -> Result<(), PlotError> {
    let s = &result.summary;
    let info = ModelInfo {
        name: s.run.model.clone(),
        description: String::new(),
        source_hash: None,
        states: Vec::new(),
        state_units: Vec::new(),
        input: s.totals.input.clone(),
        input_unit: None,
        output: "y".to_string(),
        output_unit: None,
        engine: None,
        relative_degree: s.relative_degree,
        n_eta: 0,
        input_min: result.input_bounds[0],
        input_max: result.input_bounds[1],
        outputs: Vec::new(),
        parameters: Vec::new(),
        ..ModelInfo::default()
    };
    simulation_figure(result, cycle, &info, &[])?.write(path)
}
