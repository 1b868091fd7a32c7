//! What the reference panels of every figure share: the time range, the reference's axis (a speed tracked as
//! itself in km/h, any other output in its own unit) and the raw cycle's points.

use invsim_model_api::{ModelInfo, ReferenceMap};

use super::panels;
use crate::cycle::Cycle;

const MPS_TO_KMH: f64 = 3.6;

/// [t_first, t_last] (a unit interval after t_first if the run is a single sample).
pub(super) fn time_range(t: &[f64]) -> (f64, f64) {
    let t0 = t.first().copied().unwrap_or(0.0);
    let t1 = t.last().copied().unwrap_or(t0);
    (t0, if t1 > t0 { t1 } else { t0 + 1.0 })
}

/// The y axis label, the factor from the output's unit to the axis unit and whether 0 belongs on the axis:
/// a speed tracked as itself (identity reference) in km/h, any other output in its own unit.
pub(super) fn reference_axis(info: &ModelInfo, reference: ReferenceMap) -> (String, f64, bool) {
    let speed =
        reference.is_identity() && !matches!(info.output_unit.as_deref(), Some(u) if u != "m/s");
    if speed {
        ("speed [km/h]".to_string(), MPS_TO_KMH, true)
    } else {
        (
            panels::with_unit(&info.output, info.output_unit.as_deref()),
            1.0,
            false,
        )
    }
}

/// The raw cycle's points within [t0, t1] (piecewise linear, its own breakpoints), through `value`, held
/// beyond its ends (as the smoother does).
pub(super) fn raw_points(
    cycle: &Cycle,
    (t0, t1): (f64, f64),
    value: impl Fn(f64) -> f64,
) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = cycle
        .time
        .iter()
        .zip(&cycle.speed)
        .filter(|(&ti, _)| ti >= t0 && ti <= t1)
        .map(|(&ti, &s)| (ti, value(s)))
        .collect();
    match v.first() {
        Some(p) if p.0 <= t0 => {}
        _ => v.insert(0, (t0, value(cycle.speed_at(t0)))),
    }
    match v.last() {
        Some(p) if p.0 >= t1 => {}
        _ => v.push((t1, value(cycle.speed_at(t1)))),
    }
    v
}
