//! The panels a plot can show (`--plot-vars`): the reference, the input with its bounds, any state, any
//! `[outputs]` signal and the running integral of any accumulated output, each labelled with the model's unit.
//!
//! Long runs are thinned for drawing: each of at most [`MAX_BUCKETS`] time buckets keeps its smallest and
//! largest value, so peaks (e.g. of the input at gear-change corners) survive.

use invsim_model_api::{ModelInfo, OutputInfo};

use super::figure::{Panel, Series};
use crate::report::integral_unit;

/// At most this many min/max buckets per series are drawn.
pub const MAX_BUCKETS: usize = 2000;

/// Line colours, distinct in print and for the common colour-vision deficiencies (Okabe & Ito 2008), with
/// black for the raw cycle.
pub(crate) const CYCLE: &str = "#000000";
pub(crate) const REFERENCE: &str = "#D55E00";
pub(crate) const INPUT: &str = "#0072B2";
pub(crate) const LOWER: &str = "#009E73";
pub(crate) const UPPER: &str = "#CC79A7";
/// The colours of curves that need one each (a figure's signals, the runs of a comparison).
pub const PALETTE: [&str; 6] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9",
];

/// What a panel shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Var {
    Reference,
    Input,
    Signal(Signal),
    /// Exogenous signal i of the model's `[signals]`: its raw and its smoothed curve.
    Exogenous(usize),
    /// The engine's operating points (models with an `[engine]`).
    Engine,
}

/// A panel of one column of the series (or its running integral).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Signal {
    State(usize),
    Output(usize),
    Cumulative(usize),
}

/// Every name `--plot-vars` accepts for `info`'s model, in the order of the model file: `reference`,
/// `input` (the input's own name is accepted too), the states, the `[outputs]`, `cum:NAME` for each
/// accumulated output, `engine` for a model with an `[engine]`.
pub fn valid_vars(info: &ModelInfo) -> Vec<String> {
    let mut v = vec!["reference".to_string(), "input".to_string()];
    v.extend(info.signals.iter().map(|s| s.name.clone()));
    v.extend(info.states.iter().cloned());
    v.extend(info.outputs.iter().map(|o| o.name.clone()));
    v.extend(
        info.outputs
            .iter()
            .filter(|o| o.accumulate)
            .map(|o| format!("cum:{}", o.name)),
    );
    if info.engine.is_some() {
        v.push("engine".to_string());
    }
    v
}

/// The panels drawn without `--plot-vars`: the reference, each exogenous signal (raw and smoothed), the input,
/// one running integral (the fuel used so far: [`fuel_output`], in litres where the model has a fuel volume)
/// and the engine's operating points for a model with an `[engine]`.
pub fn default_vars(info: &ModelInfo) -> Vec<String> {
    let mut v = vec!["reference".to_string()];
    v.extend(info.signals.iter().map(|s| s.name.clone()));
    v.push("input".to_string());
    v.extend(fuel_output(&info.outputs).map(|i| format!("cum:{}", info.outputs[i].name)));
    if info.engine.is_some() {
        v.push("engine".to_string());
    }
    v
}

/// The accumulated output the default figure integrates and the operating points are coloured by: the first
/// one in litres per second (the fuel volume: its per-100-km figure is l/100 km), else the first one.
pub(crate) fn fuel_output(outputs: &[OutputInfo]) -> Option<usize> {
    let acc = || outputs.iter().enumerate().filter(|(_, o)| o.accumulate);
    acc()
        .find(|(_, o)| o.unit.as_deref().map(str::trim) == Some("l/s"))
        .or_else(|| acc().next())
        .map(|(i, _)| i)
}

/// The panel `name` stands for, if any.
pub(crate) fn resolve(info: &ModelInfo, name: &str) -> Option<Var> {
    let name = name.trim();
    if name == "reference" {
        return Some(Var::Reference);
    }
    if name == "input" || name == info.input {
        return Some(Var::Input);
    }
    if name == "engine" && info.engine.is_some() {
        return Some(Var::Engine);
    }
    if let Some(i) = info.signals.iter().position(|s| s.name == name) {
        return Some(Var::Exogenous(i));
    }
    if let Some(i) = info.states.iter().position(|s| s == name) {
        return Some(Var::Signal(Signal::State(i)));
    }
    if let Some(i) = info.outputs.iter().position(|o| o.name == name) {
        return Some(Var::Signal(Signal::Output(i)));
    }
    let acc = name.strip_prefix("cum:")?;
    info.outputs
        .iter()
        .position(|o| o.accumulate && o.name == acc)
        .map(|i| Var::Signal(Signal::Cumulative(i)))
}

/// `name [unit]`, or the name alone where the model declares no unit.
pub(crate) fn with_unit(name: &str, unit: Option<&str>) -> String {
    match unit.map(str::trim).filter(|u| !u.is_empty()) {
        Some(u) => format!("{name} [{u}]"),
        None => name.to_string(),
    }
}

/// ` unit` after a number, nothing for a dimensionless (`-`) or undeclared unit.
fn unit_suffix(unit: Option<&str>) -> String {
    match unit.map(str::trim) {
        Some(u) if !u.is_empty() && u != "-" => format!(" {u}"),
        _ => String::new(),
    }
}

/// A solid curve of `t`, `v` (thinned).
pub(crate) fn series(
    label: String,
    color: &'static str,
    width: f64,
    t: &[f64],
    v: &[f64],
) -> Series {
    Series {
        label,
        color,
        width,
        dashed: false,
        points: thin(t, v),
    }
}

/// The smoothed curve of a raw one (y_d, a signal as the inverse used it, the output a forward run achieved):
/// dashed and wider, so that it stays distinct where it lies on the raw curve.
pub(crate) fn smoothed_series(label: String, t: &[f64], v: &[f64]) -> Series {
    Series {
        dashed: true,
        ..series(label, REFERENCE, 2.5, t, v)
    }
}

/// The raw curve under a smoothed one: thin and solid.
pub(crate) fn raw_series(label: String, points: Vec<(f64, f64)>) -> Series {
    Series {
        label,
        color: CYCLE,
        width: 1.2,
        dashed: false,
        points,
    }
}

/// The panel of the input `u` over `t`, scaled to `u`, with the model's bounds as dashed guides in their own
/// colours (drawn where they fall inside the scale).
pub(crate) fn input_panel(info: &ModelInfo, t: &[f64], u: &[f64], title: &str) -> Panel {
    let unit = info.input_unit.as_deref();
    let s = vec![series(with_unit(&info.input, unit), INPUT, 1.5, t, u)];
    let mut guides = Vec::new();
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last().copied().unwrap_or(1.0),
    );
    for (bound, name, color) in [
        (info.input_min, "lower bound", LOWER),
        (info.input_max, "upper bound", UPPER),
    ] {
        if let Some(b) = bound {
            guides.push(Series {
                label: format!("{name} {b}{}", unit_suffix(unit)),
                color,
                width: 2.0,
                dashed: true,
                points: vec![(t0, b), (t1, b)],
            });
        }
    }
    Panel {
        var: "input".to_string(),
        title: title.to_string(),
        y_label: with_unit(&info.input, unit),
        y_zero: false,
        series: s,
        guides,
    }
}

/// The panel of state `i`, output `i` or the running integral of output `i` (trapezoidal rule, as the
/// summary's integrals), from the column `v` over `t`; `k` picks the colour.
pub(crate) fn signal_panel(info: &ModelInfo, var: Signal, t: &[f64], v: &[f64], k: usize) -> Panel {
    let (var_name, title, label, values) = match var {
        Signal::State(i) => {
            let name = &info.states[i];
            let unit = info.state_units.get(i).cloned().flatten();
            let label = with_unit(name, unit.as_deref());
            (name.clone(), format!("state {name}"), label, v.to_vec())
        }
        Signal::Cumulative(i) => {
            let o = &info.outputs[i];
            // The integral's unit: kg/s → kg, W → J, else (unit)·s.
            let unit = o
                .unit
                .as_deref()
                .map(|u| integral_unit(u).unwrap_or(format!("({u})·s")));
            let label = with_unit(&format!("cumulative {}", o.name), unit.as_deref());
            let title = format!("{}, integrated over the run", o.name);
            (format!("cum:{}", o.name), title, label, cumulative(t, v))
        }
        Signal::Output(i) => {
            let o = &info.outputs[i];
            let label = with_unit(&o.name, o.unit.as_deref());
            (
                o.name.clone(),
                format!("output {}", o.name),
                label,
                v.to_vec(),
            )
        }
    };
    Panel {
        var: var_name,
        title,
        y_label: label.clone(),
        y_zero: matches!(var, Signal::Cumulative(_)),
        series: vec![series(label, PALETTE[k % PALETTE.len()], 1.5, t, &values)],
        guides: Vec::new(),
    }
}

/// ∫_{t_0}^{t_k} v dt by the trapezoidal rule at every sample.
pub(crate) fn cumulative(t: &[f64], v: &[f64]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(v.len());
    for k in 0..t.len().min(v.len()) {
        if k > 0 {
            acc += 0.5 * (v[k] + v[k - 1]) * (t[k] - t[k - 1]);
        }
        out.push(acc);
    }
    out
}

/// Points (t_k, v_k), thinned to the min and max of each of at most [`MAX_BUCKETS`] buckets, in time order.
pub fn thin(t: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
    let n = t.len().min(v.len());
    if n <= 2 * MAX_BUCKETS {
        return t.iter().zip(v).map(|(&a, &b)| (a, b)).collect();
    }
    let mut out = Vec::with_capacity(2 * MAX_BUCKETS + 1);
    for b in 0..MAX_BUCKETS {
        let (s, e) = (b * n / MAX_BUCKETS, (b + 1) * n / MAX_BUCKETS);
        let (mut imin, mut imax) = (s, s);
        for i in s..e {
            if v[i] < v[imin] {
                imin = i;
            }
            if v[i] > v[imax] {
                imax = i;
            }
        }
        let (i, j) = if imin <= imax {
            (imin, imax)
        } else {
            (imax, imin)
        };
        out.push((t[i], v[i]));
        if j != i {
            out.push((t[j], v[j]));
        }
    }
    if out.last().is_some_and(|p| p.0 < t[n - 1]) {
        out.push((t[n - 1], v[n - 1]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_extremes() {
        let t: Vec<f64> = (0..100_000).map(|k| k as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|x| x.sin()).collect();
        v[54_321] = 10.0;
        let p = thin(&t, &v);
        assert!(p.len() <= 2 * MAX_BUCKETS + 1);
        assert!(p.iter().any(|&(a, b)| a == t[54_321] && b == 10.0));
        assert!(p.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn cumulative_is_the_trapezoidal_integral() {
        let c = cumulative(&[0.0, 1.0, 3.0], &[1.0, 3.0, 3.0]);
        assert_eq!(c, vec![0.0, 2.0, 8.0]);
    }

    fn out(name: &str, unit: &str, accumulate: bool) -> OutputInfo {
        OutputInfo {
            name: name.into(),
            unit: Some(unit.into()),
            accumulate,
            per_distance: accumulate,
        }
    }

    #[test]
    fn the_fuel_output_is_the_volume_where_there_is_one() {
        let o = [
            out("n_e", "rpm", false),
            out("fuel", "kg/s", true),
            out("fuel_volume", "l/s", true),
        ];
        assert_eq!(fuel_output(&o), Some(2));
        assert_eq!(fuel_output(&o[..2]), Some(1));
        assert_eq!(fuel_output(&o[..1]), None);
    }
}
