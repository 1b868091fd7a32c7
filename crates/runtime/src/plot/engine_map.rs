//! The engine's operating points for a model with an `[engine]` (`--plot-vars engine`, drawn by default):
//! every sample's engine speed and torque (the two `[outputs]` the section names), coloured by the fuel flow
//! the model computes there — the model's fuel map sampled where the run went — with the output the figure's
//! cumulative panel shows (`panels::fuel_output`); a model without an accumulated output gets the points in one
//! colour.

use invsim_model_api::{ModelInfo, OutputInfo};

use super::panels::{fuel_output, with_unit};
use super::scatter::{Scatter, ScatterPoint};

/// The operating-point panel of `info`'s engine from the run's columns (`column(name)`), `None` without an
/// `[engine]`; `outputs` are the model's outputs (a model with modes: those all modes share).
pub(crate) fn engine_scatter<'a>(
    info: &ModelInfo,
    outputs: &[OutputInfo],
    column: impl Fn(&str) -> &'a [f64],
) -> Option<Scatter> {
    let engine = info.engine.as_ref()?;
    let (speed, torque) = (outputs.get(engine.speed)?, outputs.get(engine.torque)?);
    let fuel = fuel_output(outputs).map(|i| &outputs[i]);
    let (t, x, y) = (column("t"), column(&speed.name), column(&torque.name));
    let c = fuel.map_or(&[][..], |f| column(&f.name));
    let points = (0..t.len().min(x.len()).min(y.len()))
        .map(|k| ScatterPoint {
            t: t[k],
            x: x[k],
            y: y[k],
            c: c.get(k).copied(),
        })
        .collect();
    let colour_label = fuel.map(|f| with_unit(&f.name, f.unit.as_deref()));
    let title = match &colour_label {
        Some(l) => format!(
            "engine operating points ({}, {}), coloured by the fuel flow {l} there",
            speed.name, torque.name
        ),
        None => format!("engine operating points ({}, {})", speed.name, torque.name),
    };
    Some(Scatter {
        var: "engine".to_string(),
        title,
        x_label: with_unit(&speed.name, speed.unit.as_deref()),
        y_label: with_unit(&torque.name, torque.unit.as_deref()),
        colour_label,
        points,
        background: None,
    })
}
