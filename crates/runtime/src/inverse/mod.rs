//! The inverse-simulation driver: the model's input and state along a smoothed drive cycle (Fröberg & Nielsen
//! 2004, eq. 24–32; Isidori, *Nonlinear Control Systems*, §4.1 and §4.3).
//!
//! For x' = f(x) + g(x)u, y = h(x) with relative degree r the normal form is
//!
//! ```text
//! ξ̇_i = ξ_{i+1} (i < r),   y^(r) = α(ξ, η) + β(ξ, η) u,   η̇ = q(ξ, η, y^(r)),   x = ψ⁻¹(ξ, η)
//! ```
//!
//! so with the reference y_d and its exact derivatives from the [`Smoother`](crate::Smoother) (paper eq. 33–35),
//! ξ = (y_d, ẏ_d, …, y_d^(r−1)) and the input that makes y follow y_d is u = (y_d^(r) − α) / β (eq. 26).
//! If r < n the internal coordinates η follow the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t)), which are
//! integrated here with an adaptive, error-controlled Dormand–Prince 5(4) method. This causal inversion is only
//! possible for minimum-phase systems (stable zero dynamics). When the zero dynamics have unstable eigenvalues
//! at the equilibria the reference passes (non-minimum phase or mixed), η is instead computed non-causally as
//! the bounded solution of the zero dynamics over a time grid extended by pre- and post-actuation
//! ([`crate::stable`]: Devasia, Chen & Paden 1996); [`SimulationOptions::causal`] forces forward integration,
//! which then stops with [`SimulateError::UnstableZeroDynamics`].

mod causal;
pub(crate) mod checks;
mod error;
mod inverter;
mod map_check;
mod options;
mod reference;
mod result;
mod run;
pub(crate) mod stage_reference;
mod summary;
mod verify;

use invsim_model_api::InverseModel;

use crate::cycle::Cycle;

pub use causal::ETA_BLOWUP;
pub use checks::{DISTANCE_WARNING, MAX_LOOKAHEAD_FRACTION, MIN_LOOKAHEAD_PER_DT};
pub use error::SimulateError;
pub use options::{
    SimulationOptions, SimulationOptionsBuilder, DEFAULT_ATOL, DEFAULT_DT, DEFAULT_LOOKAHEAD,
    DEFAULT_MAX_PRE_ACTUATION, DEFAULT_RTOL, DEFAULT_STABILITY_CHECK_INTERVAL, DEFAULT_STABLE_TOL,
};
pub use reference::Reference;
pub use result::SimulationResult;
pub use summary::{InputBeforeStart, StableInversionStats, Summary};

/// Simulate `model` inversely along `cycle`: at every grid time the smoothed reference y_d … y_d^(r), the input,
/// the state, η and the extra outputs (see the module docs and contract §3).
///
/// Accumulated outputs are integrated over the output grid with the trapezoidal rule,
/// ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2; input-bound violations are reported, never clipped.
pub fn simulate(
    model: &dyn InverseModel,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<SimulationResult, SimulateError> {
    run::run(model, cycle, opts, Vec::new(), None)
}

/// [`simulate`], reusing the column buffers of an earlier result: for repeated runs (parameter sweeps,
/// benchmarks) this saves allocating and first touching fresh memory, which costs about as much as the whole
/// inversion of a cheap model.
pub fn simulate_reusing(
    model: &dyn InverseModel,
    cycle: &Cycle,
    opts: &SimulationOptions,
    previous: SimulationResult,
) -> Result<SimulationResult, SimulateError> {
    run::run(model, cycle, opts, previous.data, None)
}

/// The smoothed reference of `cycle` for models like `model` (its relative degree and reference map) with
/// `opts`' look-ahead and dt, computed once to be shared by many runs ([`simulate_shared`]).
pub fn reference(
    model: &dyn InverseModel,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<Reference, SimulateError> {
    let info = model.info();
    run::reference(cycle, info, model.reference(), opts)
}

/// [`simulate_reusing`] on a reference computed beforehand by [`reference`]: the smoother is not rebuilt and,
/// where the run's grid is the reference's (no pre- or post-actuation), y_d … y_d^(r) are copied instead of
/// evaluated. The numbers are bit for bit those of [`simulate`]. A reference that does not fit (another
/// cycle, look-ahead, dt, relative degree or reference map — a parameter can move the map) is ignored and the
/// run smooths the cycle itself. `spare` are column buffers to reuse (an earlier result's `data`, or empty).
pub fn simulate_shared(
    model: &dyn InverseModel,
    cycle: &Cycle,
    reference: &Reference,
    opts: &SimulationOptions,
    spare: Vec<Vec<f64>>,
) -> Result<SimulationResult, SimulateError> {
    run::run(model, cycle, opts, spare, Some(reference))
}
