//! Why a forward simulation could not be run or was stopped.

use thiserror::Error;

use crate::error::RunError;
use crate::ode::StepFailure;

/// Why a forward simulation could not be run or was stopped.
#[derive(Debug, Error)]
pub enum ForwardError {
    #[error("invalid integrator tolerances rtol = {rtol}, atol = {atol}: both must be positive and finite")]
    InvalidTolerance { rtol: f64, atol: f64 },
    #[error(
        "invalid driver parameter {name} = {value}: it must be finite and ≥ 0 (the response > 0)"
    )]
    InvalidGain { name: &'static str, value: f64 },
    #[error(
        "invalid trace-miss tolerances {speed} (output units) and {time} s: both must be finite and ≥ 0"
    )]
    InvalidTraceTolerance { speed: f64, time: f64 },
    #[error("invalid initial state x0: {reason}")]
    InvalidX0 { reason: String },
    #[error("cannot find the initial state at t0 = {t} s: {reason}; give x0 explicitly")]
    InitialState { t: f64, reason: String },
    #[error("the forward integration failed at t = {t} s: {reason}")]
    Integration { t: f64, reason: String },
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
