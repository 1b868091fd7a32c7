//! The inverse-simulation driver: the model's input and state along a smoothed drive cycle (Fröberg & Nielsen
//! 2004, eq. 24–32; Isidori, *Nonlinear Control Systems*, §4.1 and §4.3).
//!
//! For x' = f(x) + g(x)u, y = h(x) with relative degree r the normal form is
//!
//! ```text
//! ξ̇_i = ξ_{i+1} (i < r),   y^(r) = α(ξ, η) + β(ξ, η) u,   η̇ = q(ξ, η, y^(r)),   x = ψ⁻¹(ξ, η)
//! ```
//!
//! so with the reference y_d and its exact derivatives from the [`Smoother`] (paper eq. 33–35),
//! ξ = (y_d, ẏ_d, …, y_d^(r−1)) and the input that makes y follow y_d is u = (y_d^(r) − α) / β (eq. 26).
//! If r < n the internal coordinates η follow the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t)), which are
//! integrated here with an adaptive, error-controlled Dormand–Prince 5(4) method. This causal inversion is only
//! possible for minimum-phase systems (stable zero dynamics). When the zero dynamics have unstable eigenvalues
//! at the equilibria the reference passes (non-minimum phase or mixed), η is instead computed non-causally as
//! the bounded solution of the zero dynamics over a time grid extended by pre- and post-actuation
//! ([`crate::stable`]: Devasia, Chen & Paden 1996); [`SimulationOptions::causal`] forces forward integration,
//! which then stops with [`SimulateError::UnstableZeroDynamics`].

mod causal;
mod error;
mod inverter;
mod options;
mod run;
mod summary;
mod verify;

use invsim_model_api::InverseModel;

use crate::cycle::Cycle;

pub use error::SimulateError;
pub use options::{
    SimulationOptions, SimulationOptionsBuilder, DEFAULT_ATOL, DEFAULT_DT, DEFAULT_LOOKAHEAD,
    DEFAULT_MAX_PRE_ACTUATION, DEFAULT_RTOL, DEFAULT_STABILITY_CHECK_INTERVAL, DEFAULT_STABLE_TOL,
};
pub use summary::{InputBeforeStart, StableInversionStats, Summary};

/// |η| above this means the internal dynamics have blown up.
pub const ETA_BLOWUP: f64 = 1e12;

/// Result of a run: the summary and the time series, stored column by column.
#[derive(Debug, Clone)]
pub struct SimulationResult {
    pub summary: Summary,
    /// Column names: `t`, `yd_0` … `yd_r`, the input, the states, `eta1` …, the `[outputs]`.
    pub columns: Vec<String>,
    /// One vector per column, each with `summary.samples` entries.
    pub data: Vec<Vec<f64>>,
    /// Index of the input's column in `columns`/`data`.
    pub input_column: usize,
    /// The input's bounds [min, max] as declared by the model (reported, never clipped).
    pub input_bounds: [Option<f64>; 2],
    /// How the cycle defined the reference: y_d = offset + scale · (smoothed cycle) (the model's
    /// [`InverseModel::reference`]).
    pub reference: invsim_model_api::ReferenceMap,
}

impl SimulationResult {
    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
    /// Sample times t_k.
    pub fn time(&self) -> &[f64] {
        &self.data[0]
    }
    /// y_d^(k) at the samples, k = 0 … r.
    pub fn yd(&self, k: usize) -> Option<&[f64]> {
        (k <= self.summary.relative_degree).then(|| self.data[1 + k].as_slice())
    }
    /// The computed input u at the samples.
    pub fn input(&self) -> &[f64] {
        &self.data[self.input_column]
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.data[0].len()
    }
    /// True if there are no samples (never the case for a successful run).
    pub fn is_empty(&self) -> bool {
        self.data[0].is_empty()
    }
}

/// Simulate `model` inversely along `cycle`: at every grid time the smoothed reference y_d … y_d^(r), the input,
/// the state, η and the extra outputs (see the module docs and contract §3).
///
/// Accumulated outputs are integrated over the output grid with the trapezoidal rule,
/// ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2; input-bound violations are reported, never clipped.
pub fn simulate<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<SimulationResult, SimulateError> {
    run::run(model, cycle, opts, Vec::new())
}

/// [`simulate`], reusing the column buffers of an earlier result: for repeated runs (parameter sweeps,
/// benchmarks) this saves allocating and first touching fresh memory, which costs about as much as the whole
/// inversion of a cheap model.
pub fn simulate_reusing<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
    previous: SimulationResult,
) -> Result<SimulationResult, SimulateError> {
    run::run(model, cycle, opts, previous.data)
}
