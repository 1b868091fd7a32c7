//! The figures of a run with operating modes (docs/reference.md §2.5), inverse or forward: the reference, one panel
//! per declared input (traction and brake, each with its bounds), under them a step panel of the mode
//! sequence — the gear of the mode in force (0 for an ungeared mode such as idle), or the mode's index with
//! the modes' names for a model without a gearbox — and the running integral of every accumulated output;
//! a model with `[signals]` adds one panel per signal after the reference, as single-mode figures do (raw
//! and smoothed for the inverse run, raw for the forward run, which integrates with the raw signal).
//! A hybrid's run with a strategy adds its state of charge and the engine's on/off band under the sequence
//! ([`super::hybrid`]). `--plot-vars` names: `reference`, each input, each signal, `gear` (or `mode`), the
//! states, the `[outputs]`, `cum:NAME`, a hybrid's `engine_on`.

use invsim_model_api::ModelInfo;

use super::engine_map::engine_scatter;
use super::error::PlotError;
use super::exogenous::signal_raw_and_smoothed;
use super::figure::{Figure, Panel, Series, PANEL_TITLE_SIZE};
use super::font::text_width;
use super::hybrid::{engine_on_panel, soc_panel, ENGINE_ON};
use super::panels::{
    self, fuel_output, input_panel, raw_series, signal_panel, smoothed_series, Signal, LOWER,
};
use super::reference::{raw_points, reference_axis, time_range};
use super::scatter::Scatter;
use super::steps::steps;
use super::Columns;
use crate::cycle::Cycle;
use crate::forward::ModalForwardResult;
use crate::modes::{ModalResult, ModalSpec};

/// What a panel of a modal figure shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ModalVar {
    Reference,
    Input(usize),
    Sequence,
    Signal(Signal),
    /// Exogenous signal i of the model's `[signals]`.
    Exogenous(usize),
    /// The engine's operating points (models with an `[engine]`).
    Engine,
    /// A hybrid's state of charge (state i, the `[hybrid]` table's `soc`), with SOC(0) as a guide.
    Soc(usize),
    /// A hybrid's engine on/off band (the strategy's run's `engine_on` column).
    EngineOn,
}

/// The names of the model's exogenous signals: its `[signals]` less the decided inputs a mode carries as
/// signals (their panel is the input's).
fn exogenous_names(spec: &ModalSpec<'_>) -> Vec<String> {
    let signals = info0(spec).signals.iter().map(|s| &s.name);
    signals
        .filter(|n| !spec.inputs.iter().any(|i| &i.name == *n))
        .cloned()
        .collect()
}

/// The state of charge of a hybrid (`[hybrid] soc`): its index among the states.
fn soc_state(spec: &ModalSpec<'_>) -> Option<usize> {
    let soc = &spec.hybrid?.soc;
    info0(spec).states.iter().position(|s| s == soc)
}

/// The name of the sequence panel: `gear` where some mode has a gear, else `mode`.
fn sequence_name(spec: &ModalSpec<'_>) -> &'static str {
    if spec.modes.iter().any(|m| m.gear.is_some()) {
        "gear"
    } else {
        "mode"
    }
}

fn info0<'s>(spec: &'s ModalSpec<'_>) -> &'s ModelInfo {
    spec.modes[0].model.info()
}

/// Every `--plot-vars` name of a model with modes.
pub fn modal_valid_vars(spec: &ModalSpec<'_>) -> Vec<String> {
    let info = info0(spec);
    let outputs = &info.outputs[..spec.n_outputs];
    let mut v = vec!["reference".to_string()];
    v.extend(spec.inputs.iter().map(|i| i.name.clone()));
    v.extend(exogenous_names(spec));
    v.push(sequence_name(spec).to_string());
    v.extend(info.states.iter().cloned());
    v.extend(outputs.iter().map(|o| o.name.clone()));
    v.extend(
        outputs
            .iter()
            .filter(|o| o.accumulate)
            .map(|o| format!("cum:{}", o.name)),
    );
    if info.engine.is_some() {
        v.push("engine".to_string());
    }
    if spec.hybrid.is_some() {
        v.push(ENGINE_ON.to_string());
    }
    v
}

/// The panels drawn without `--plot-vars`: the reference, each exogenous signal, every input, the mode
/// sequence, a hybrid's state of charge and engine on/off band, one running integral (the fuel used so far,
/// as single-mode figures) and the engine's operating points for a model with an `[engine]`.
pub fn modal_default_vars(spec: &ModalSpec<'_>) -> Vec<String> {
    let info = info0(spec);
    let outputs = &info.outputs[..spec.n_outputs];
    let mut v = vec!["reference".to_string()];
    v.extend(exogenous_names(spec));
    v.extend(spec.inputs.iter().map(|i| i.name.clone()));
    v.push(sequence_name(spec).to_string());
    if let Some(i) = soc_state(spec) {
        v.push(info.states[i].clone());
        v.push(ENGINE_ON.to_string());
    }
    v.extend(fuel_output(outputs).map(|i| format!("cum:{}", outputs[i].name)));
    if info.engine.is_some() {
        v.push("engine".to_string());
    }
    v
}

fn resolve(spec: &ModalSpec<'_>, name: &str) -> Option<ModalVar> {
    let info = info0(spec);
    let outputs = &info.outputs[..spec.n_outputs];
    if name == "reference" {
        return Some(ModalVar::Reference);
    }
    if name == sequence_name(spec) {
        return Some(ModalVar::Sequence);
    }
    if name == "engine" && info.engine.is_some() {
        return Some(ModalVar::Engine);
    }
    if spec.hybrid.is_some() && name == ENGINE_ON {
        return Some(ModalVar::EngineOn);
    }
    if let Some(i) = soc_state(spec).filter(|&i| info.states[i] == name) {
        return Some(ModalVar::Soc(i));
    }
    if let Some(i) = spec.inputs.iter().position(|i| i.name == name) {
        return Some(ModalVar::Input(i));
    }
    if let Some(i) = info.signals.iter().position(|s| s.name == name) {
        return Some(ModalVar::Exogenous(i));
    }
    if let Some(i) = info.states.iter().position(|s| s == name) {
        return Some(ModalVar::Signal(Signal::State(i)));
    }
    if let Some(i) = outputs.iter().position(|o| o.name == name) {
        return Some(ModalVar::Signal(Signal::Output(i)));
    }
    let acc = name.strip_prefix("cum:")?;
    outputs
        .iter()
        .position(|o| o.accumulate && o.name == acc)
        .map(|i| ModalVar::Signal(Signal::Cumulative(i)))
}

fn resolve_all(spec: &ModalSpec<'_>, vars: &[String]) -> Result<Vec<ModalVar>, PlotError> {
    let valid = || modal_valid_vars(spec).join(", ");
    let vars = super::resolve_names(
        vars,
        || modal_default_vars(spec),
        valid,
        |n| resolve(spec, n),
    )?;
    Ok(vars.into_iter().map(|(_, v)| v).collect())
}

/// Check `vars` (`--plot-vars`) against a model with modes; empty means [`modal_default_vars`].
pub fn check_modal_vars(spec: &ModalSpec<'_>, vars: &[String]) -> Result<(), PlotError> {
    resolve_all(spec, vars).map(|_| ())
}

/// The figure of an inverse run with modes along `cycle`.
pub fn modal_simulation_figure(
    result: &ModalResult,
    cycle: &Cycle,
    spec: &ModalSpec<'_>,
    vars: &[String],
) -> Result<Figure, PlotError> {
    let vars = resolve_all(spec, vars)?;
    let cols = Columns {
        names: &result.columns,
        data: &result.data,
    };
    let t = cols.get("t");
    if t.is_empty() {
        return Err(PlotError::Empty);
    }
    let x_range = time_range(t);
    let info = info0(spec);
    let map = spec.modes[0].model.reference();
    let reference = || {
        let (y_label, factor, y_zero) = reference_axis(info, map);
        let raw = raw_points(cycle, x_range, |s| factor * (map.offset + map.scale * s));
        let yd: Vec<f64> = cols.get("yd_0").iter().map(|v| v * factor).collect();
        Panel {
            var: "reference".to_string(),
            title: format!(
                "reference of {}: the drive cycle and y_d of the mode in force (look-ahead a = {} s, re-entry \
                 blends included)",
                info.output, result.summary.lookahead_s
            ),
            y_label,
            y_zero,
            series: vec![
                raw_series("cycle (raw)".to_string(), raw),
                smoothed_series("y_d (smoothed)".to_string(), t, &yd),
            ],
            guides: Vec::new(),
        }
    };
    // The raw signal and the smoothed one the modes took (the series' column of the signal).
    let exogenous = |i: usize| {
        let smoothed = cols.get(&info.signals[i].name);
        signal_raw_and_smoothed(info, i, result.signals.get(i), (t, smoothed), x_range)
    };
    let s = &result.summary;
    Ok(Figure {
        title: format!(
            "{} on {}: inverse simulation with modes, look-ahead a = {} s",
            s.run.model, s.run.cycle, s.lookahead_s
        ),
        headline: None,
        x_label: "t [s]".to_string(),
        x_range,
        scatter: modal_engine(spec, &vars, &cols),
        panels: build(
            spec,
            &vars,
            &cols,
            (&reference, &exogenous),
            "bounds reported, not clipped",
        ),
    })
}

/// The figure of a forward run with modes: its reference panel shows the raw cycle and the output achieved.
pub fn modal_forward_figure(
    result: &ModalForwardResult,
    spec: &ModalSpec<'_>,
    vars: &[String],
) -> Result<Figure, PlotError> {
    let vars = resolve_all(spec, vars)?;
    let cols = Columns {
        names: &result.columns,
        data: &result.data,
    };
    let t = cols.get("t");
    if t.is_empty() {
        return Err(PlotError::Empty);
    }
    let info = info0(spec);
    let reference = || {
        let (y_label, factor, y_zero) = reference_axis(info, spec.modes[0].model.reference());
        let scaled = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * factor).collect() };
        Panel {
            var: "reference".to_string(),
            title: format!("{}: the raw cycle and what the model achieved", info.output),
            y_label,
            y_zero,
            series: vec![
                raw_series(
                    "cycle y_c (raw)".into(),
                    panels::thin(t, &scaled(cols.get("yc"))),
                ),
                smoothed_series(
                    format!("achieved {}", info.output),
                    t,
                    &scaled(cols.get(&info.output)),
                ),
            ],
            guides: Vec::new(),
        }
    };
    // The forward run integrates with the raw signals: their panels show the raw curve alone.
    let x_range = time_range(t);
    let exogenous =
        |i: usize| signal_raw_and_smoothed(info, i, result.signals.get(i), (&[], &[]), x_range);
    let s = &result.summary;
    Ok(Figure {
        title: format!(
            "{} on {}: forward simulation with modes and the PI driver",
            s.run.model, s.run.cycle
        ),
        headline: None,
        x_label: "t [s]".to_string(),
        x_range,
        scatter: modal_engine(spec, &vars, &cols),
        panels: build(
            spec,
            &vars,
            &cols,
            (&reference, &exogenous),
            "applied by the driver",
        ),
    })
}

/// The engine's operating points when `vars` name them.
fn modal_engine(spec: &ModalSpec<'_>, vars: &[ModalVar], cols: &Columns<'_>) -> Option<Scatter> {
    if !vars.contains(&ModalVar::Engine) {
        return None;
    }
    let info = info0(spec);
    engine_scatter(info, &info.outputs[..spec.n_outputs], |n| cols.get(n))
}

/// The panels of `vars` (`exogenous(i)`: the panel of signal i); `how` ends each input panel's title.
fn build(
    spec: &ModalSpec<'_>,
    vars: &[ModalVar],
    cols: &Columns<'_>,
    (reference, exogenous): (&dyn Fn() -> Panel, &dyn Fn(usize) -> Panel),
    how: &str,
) -> Vec<Panel> {
    let info = info0(spec);
    let t = cols.get("t");
    let mut k = 0;
    // The engine's operating points are no time panel (`modal_engine`).
    vars.iter()
        .filter_map(|var| match *var {
            ModalVar::Engine => None,
            ModalVar::Reference => Some(reference()),
            ModalVar::Exogenous(i) => Some(exogenous(i)),
            ModalVar::Input(i) => Some(modal_input_panel(spec, i, cols, how)),
            ModalVar::Sequence => Some(sequence_panel(spec, t, cols)),
            ModalVar::EngineOn => {
                let families = spec.hybrid.map_or(&[][..], |h| &h.engine_on[..]);
                Some(engine_on_panel(families, t, cols.get(ENGINE_ON)))
            }
            ModalVar::Soc(i) => {
                k += 1;
                Some(soc_panel(info, i, t, cols.get(&info.states[i]), k - 1))
            }
            ModalVar::Signal(signal) => {
                let name = match signal {
                    Signal::State(i) => &info.states[i],
                    Signal::Output(i) | Signal::Cumulative(i) => &info.outputs[i].name,
                };
                k += 1;
                Some(signal_panel(info, signal, t, cols.get(name), k - 1))
            }
        })
        .collect()
}

/// The panel of input i: its values over the run (free, or given by the mode in force) and its bounds.
fn modal_input_panel(spec: &ModalSpec<'_>, i: usize, cols: &Columns<'_>, how: &str) -> Panel {
    let input = &spec.inputs[i];
    let info = ModelInfo {
        input: input.name.clone(),
        input_unit: input.unit.clone(),
        input_min: input.min,
        input_max: input.max,
        ..info0(spec).clone()
    };
    let mut free: Vec<&str> = Vec::new();
    for m in spec.modes.iter().filter(|m| m.free_input == i) {
        if !free.contains(&m.family.as_str()) {
            free.push(&m.family);
        }
    }
    let title = format!(
        "input {}: free in {}, the mode's value elsewhere ({how})",
        input.name,
        if free.is_empty() {
            "no mode".to_string()
        } else {
            free.join(", ")
        }
    );
    let mut p = input_panel(&info, cols.get("t"), cols.get(&input.name), &title);
    p.var = input.name.clone();
    p
}

/// The step panel of the mode sequence: the gear of the mode in force (0 for an ungeared mode), or the mode's
/// index with the modes' names.
fn sequence_panel(spec: &ModalSpec<'_>, t: &[f64], cols: &Columns<'_>) -> Panel {
    let name = sequence_name(spec);
    let v = cols.get(name);
    let (title, y_label) = if name == "gear" {
        let mut ungeared: Vec<&str> = Vec::new();
        for m in spec.modes.iter().filter(|m| m.gear.is_none()) {
            if !ungeared.contains(&m.family.as_str()) {
                ungeared.push(&m.family);
            }
        }
        let zero = if ungeared.is_empty() {
            String::new()
        } else {
            format!(" (0: {})", ungeared.join(", "))
        };
        (format!("gear of the mode in force{zero}"), "gear [-]")
    } else {
        let names: Vec<String> = spec
            .modes
            .iter()
            .enumerate()
            .map(|(k, m)| format!("{k} {}", m.name))
            .collect();
        (
            format!("mode in force: {}", names.join(", ")),
            "mode [index]",
        )
    };
    Panel {
        var: name.to_string(),
        title: fit(&title, 900.0),
        y_label: y_label.to_string(),
        y_zero: true,
        series: vec![Series {
            label: panels::with_unit(name, None),
            color: LOWER,
            width: 2.0,
            dashed: false,
            points: steps(t, v),
        }],
        guides: Vec::new(),
    }
}

/// `text` cut to `width` px at the panel title's size (with an ellipsis).
fn fit(text: &str, width: f64) -> String {
    let size = PANEL_TITLE_SIZE;
    if text_width(text, size) <= width {
        return text.to_string();
    }
    let mut s: String = text.to_string();
    while !s.is_empty() && text_width(&format!("{s} …"), size) > width {
        s.pop();
    }
    format!("{} …", s.trim_end_matches([',', ' ']))
}
