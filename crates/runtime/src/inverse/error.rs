//! Why an inverse simulation could not be run or was stopped.

use thiserror::Error;

use crate::error::{num, RunError};
use crate::report::format_eigenvalues;
use crate::smoother::SmootherError;
use crate::stable::StableError;

/// Why a simulation could not be run or was stopped.
#[derive(Debug, Error)]
pub enum SimulateError {
    #[error(
        "invalid look-ahead a = {} s: the kernel half-width (--lookahead) must be a positive, finite number of \
         seconds",
        num(*.0)
    )]
    InvalidLookahead(f64),
    #[error(
        "the look-ahead a = {} s is too short for the output step dt = {} s: the kernel's window 2a is narrower \
         than a step, so the samples miss the smoothed transitions and the integrals come out wrong; use a \
         look-ahead of at least {} s (half the step), or a smaller --dt",
        num(*lookahead), num(*dt), num(*min)
    )]
    LookaheadTooShort { lookahead: f64, dt: f64, min: f64 },
    #[error(
        "the look-ahead a = {} s is too long for a cycle of {} s: the kernel's window 2a would smooth the \
         cycle away; use a look-ahead of at most {} s (a quarter of the cycle)",
        num(*lookahead), num(*duration), num(*max)
    )]
    LookaheadTooLong {
        lookahead: f64,
        duration: f64,
        max: f64,
    },
    #[error(
        "invalid zero-dynamics tolerances rtol = {rtol_}, atol = {atol_}: both must be positive and finite",
        rtol_ = num(*.rtol), atol_ = num(*.atol)
    )]
    InvalidTolerance { rtol: f64, atol: f64 },
    #[error(
        "invalid stability check interval {v0_} s: it must be a positive, finite number of seconds",
        v0_ = num(*.0)
    )]
    InvalidCheckInterval(f64),
    #[error(
        "invalid transition time {v0_} s: it must be a positive, finite number of seconds",
        v0_ = num(*.0)
    )]
    InvalidTransitionTime(f64),
    #[error("invalid initial internal state eta0: {reason}")]
    InvalidEta0 { reason: String },
    #[error(
        "relative degree {relative_degree} is too high: the smoother provides y_d and its derivatives up to \
         order {max}"
    )]
    RelativeDegreeTooHigh { relative_degree: usize, max: usize },
    #[error("cannot smooth the drive cycle: {0}")]
    Smoother(#[from] SmootherError),
    #[error("at {at}: {violation}")]
    MapOutsideGrid {
        at: String,
        violation: invsim_model_api::map::Violation,
    },
    #[error(
        "the decoupling coefficient β(ξ, η) = L_g L_f^(r−1) h is {beta_} at t = {t_} s, so the input \
         u = (y^(r) − α)/β is undefined there: the relative degree is not well defined at this operating point",
        t_ = num(*.t), beta_ = num(*.beta)
    )]
    SingularDecoupling { t: f64, beta: f64 },
    #[error(
        "cannot find the initial internal state: Newton's method for the equilibrium q(ξ(t0), η, y_d^(r)(t0)) = 0 \
         at t0 = {} s {reason}; the run starts η in that equilibrium: start the cycle at a speed where it \
         exists (e.g. prepend a row at a speed the model can hold), change the parameters with --set, try \
         another --lookahead (it changes y_d^(r)(t0)), or give the internal states' start values with \
         `initial = VALUE` on each internal state in the model file or --initial NAME=VALUE",
        num(*t)
    )]
    ZeroDynamicsEquilibrium { t: f64, reason: String },
    #[error(
        "unstable zero dynamics at t = {t_} s: {detail}; eigenvalues of ∂q/∂η: {eigs}. The system is non-minimum \
         phase for this output, so causal inverse simulation diverges; stable (non-causal) inversion is needed",
        eigs = format_eigenvalues(.eigenvalues),
        t_ = num(*.t)
    )]
    UnstableZeroDynamics {
        t: f64,
        eigenvalues: Vec<[f64; 2]>,
        detail: String,
    },
    #[error("integrating the internal dynamics failed at t = {t_} s: {reason}",
        t_ = num(*.t)
    )]
    Integration { t: f64, reason: String },
    #[error(
        "verification failed: the original model dx/dt = f(x) + g(x)u could not be integrated forward with the \
         computed input at t = {t_} s: {reason} (the inverse itself completed; run without --verify to get it)",
        t_ = num(*.t)
    )]
    Verification { t: f64, reason: String },
    /// A reason shared with the forward simulation.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The stable inversion failed.
    #[error(transparent)]
    Stable(#[from] StableError),
    /// The parameter gradient asked for cannot be computed.
    #[error("parameter gradients: {0}")]
    Gradient(#[from] crate::gradient::error::GradientError),
}

impl From<crate::ode::StepFailure> for SimulateError {
    fn from(f: crate::ode::StepFailure) -> Self {
        SimulateError::Integration {
            t: f.t,
            reason: f.reason,
        }
    }
}
