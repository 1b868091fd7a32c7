//! The errors the inverse and the forward simulation share: a bad output step, an unusable cycle, too many
//! samples, a failing model, a non-finite quantity. [`crate::SimulateError`] and [`crate::ForwardError`]
//! carry them transparently (same messages), next to their own.

use invsim_model_api::ModelError;
use thiserror::Error;

/// Why a run (inverse or forward) could not be run or was stopped, for the reasons both share.
#[derive(Debug, Error)]
pub enum RunError {
    #[error("invalid output step dt = {0} s: it must be a positive, finite number of seconds")]
    InvalidDt(f64),
    #[error("cannot simulate cycle `{cycle}`: {reason}")]
    InvalidCycle { cycle: String, reason: String },
    #[error(
        "{samples} output samples (duration {duration} s at dt = {dt} s) exceed the limit of {max}; use a larger \
         --dt"
    )]
    TooManySamples {
        samples: f64,
        duration: f64,
        dt: f64,
        max: usize,
    },
    #[error("the model failed at t = {t} s: {source}")]
    Model {
        t: f64,
        #[source]
        source: ModelError,
    },
    #[error("{quantity} is not finite ({value}) at t = {t} s")]
    NonFinite {
        t: f64,
        quantity: String,
        value: f64,
    },
}
