//! Why a forward simulation could not be run or was stopped.

use thiserror::Error;

use crate::error::{num, RunError};
use crate::ode::StepFailure;

/// Why a forward simulation could not be run or was stopped.
#[derive(Debug, Error)]
pub enum ForwardError {
    #[error(
        "invalid integrator tolerances rtol = {}, atol = {}: both must be > 0 and finite",
        num(*rtol), num(*atol)
    )]
    InvalidTolerance { rtol: f64, atol: f64 },
    #[error("invalid driver parameter {name} = {}: it must be {}", num(*value), gain_rule(name))]
    InvalidGain { name: &'static str, value: f64 },
    #[error(
        "invalid trace-miss tolerances {} (output units) and {} s: both must be finite and ≥ 0",
        num(*speed), num(*time)
    )]
    InvalidTraceTolerance { speed: f64, time: f64 },
    #[error("invalid {what} = {}: it must be > 0 (and finite)", num(*value))]
    InvalidBudget { what: &'static str, value: f64 },
    #[error(
        "the integration would exceed its budget of {max} steps ({how}): after {steps} steps it reached only \
         t = {} s of {} s; {diagnosis}",
        num(*t), num(*t_end)
    )]
    StepBudget {
        t: f64,
        t_end: f64,
        steps: usize,
        max: usize,
        how: String,
        diagnosis: String,
    },
    #[error(
        "the run reached its time limit of {} s at t = {} s of {} s after {steps} steps; {diagnosis}",
        num(*limit), num(*t), num(*t_end)
    )]
    TimeLimit {
        limit: f64,
        t: f64,
        t_end: f64,
        steps: usize,
        diagnosis: String,
    },
    #[error("invalid initial state x0: {reason}")]
    InvalidX0 { reason: String },
    #[error(
        "cannot find the initial state at t0 = {} s: {reason}; the run starts in the equilibrium ψ⁻¹ gives at \
         the cycle's first speed: start the cycle at a speed where that equilibrium exists (e.g. prepend a \
         row at a speed the model can hold), change the parameters with --set, or give the internal states' start \
         values with `initial = VALUE` on each internal state in the model file or --initial NAME=VALUE",
        num(*t)
    )]
    InitialState { t: f64, reason: String },
    #[error("the forward run with modes cannot start: {reason}")]
    Modes { reason: String },
    #[error("the forward integration failed at t = {} s: {reason}", num(*t))]
    Integration { t: f64, reason: String },
    /// A map under `extrapolate = "error"` was evaluated outside its grid (contract §6).
    #[error("at {at}: {violation}")]
    MapOutsideGrid {
        at: String,
        violation: invsim_model_api::map::Violation,
    },
    /// A reason shared with the inverse simulation.
    #[error(transparent)]
    Run(#[from] RunError),
}

impl From<StepFailure> for ForwardError {
    fn from(f: StepFailure) -> Self {
        ForwardError::Integration {
            t: f.t,
            reason: f.reason,
        }
    }
}

/// What a driver parameter must be.
fn gain_rule(name: &str) -> &'static str {
    if name == "response" {
        "> 0 and finite (rad/s)"
    } else {
        "≥ 0 and finite"
    }
}
