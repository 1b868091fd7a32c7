//! The buffers of one evaluation of a strategy's candidate and the values it gives at one instant
//! (docs/hybrids.md, ECMS): plain data, filled by the evaluation in `interval_cost.rs` and read by the
//! strategies, so that the minimiser's many evaluations per sample allocate nothing.

/// Buffers of one evaluation: the reference, the signals, the internal states, the states at t_k and t_k+1,
/// the outputs, the Runge–Kutta stages and a stage's state.
#[derive(Default)]
pub(super) struct Scratch {
    pub(super) y: Vec<f64>,
    pub(super) w: Vec<f64>,
    pub(super) eta: Vec<f64>,
    pub(super) x: Vec<f64>,
    pub(super) x1: Vec<f64>,
    pub(super) outs: Vec<f64>,
    pub(super) stages: [Vec<f64>; 4],
    pub(super) tmp: Vec<f64>,
    /// The state at a Runge–Kutta stage, its right-hand side, and the battery's power at stages 2, 3, 4.
    pub(super) xs: Vec<f64>,
    pub(super) dx: Vec<f64>,
    pub(super) batteries: [f64; 3],
}

/// A candidate's values at one instant: the free input, its signed margin to its bounds (a fraction of its
/// range: how far beyond them, or minus the distance to the nearer within; [`super::ecms::Ecms::margin`]), the fuel and battery powers, the model's rule outputs (`rule_request`, `rule_target`; NaN without
/// them).
#[derive(Clone, Copy)]
pub(super) struct Point {
    pub(super) u: f64,
    pub(super) margin: f64,
    pub(super) p_fuel: f64,
    pub(super) p_batt: f64,
    pub(super) rule: (f64, f64),
}
