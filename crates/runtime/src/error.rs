//! The errors the inverse and the forward simulation share: a bad output step, an unusable cycle, too many
//! samples, a failing model, a non-finite quantity. [`crate::SimulateError`] and [`crate::ForwardError`]
//! carry them transparently (same messages), next to their own.

use invsim_model_api::ModelError;
use thiserror::Error;

pub(crate) use crate::numfmt::num;

/// Why a run (inverse or forward) could not be run or was stopped, for the reasons both share.
#[derive(Debug, Error)]
pub enum RunError {
    #[error(
        "invalid output step dt = {} s (--dt): it must be a positive, finite number of seconds",
        num(*.0)
    )]
    InvalidDt(f64),
    #[error("cannot simulate cycle `{cycle}`: {reason}")]
    InvalidCycle { cycle: String, reason: String },
    #[error(
        "{} output samples (duration {} s at dt = {} s) exceed the limit of {max}; use a larger --dt",
        num(*samples), num(*duration), num(*dt)
    )]
    TooManySamples {
        samples: f64,
        duration: f64,
        dt: f64,
        max: usize,
    },
    #[error(
        "{} output sample(s) (duration {} s at dt = {} s) are fewer than the {min} a run needs; use a --dt of at \
         most {} s",
        num(*samples), num(*duration), num(*dt), num(*duration / (*min as f64 - 1.0))
    )]
    TooFewSamples {
        samples: f64,
        duration: f64,
        dt: f64,
        min: usize,
    },
    #[error(
        "the time series of {samples} samples × {columns} columns at dt = {} s would take {} GiB, more than the \
         limit of {} GiB for a stored series (--out, --plot); use a --dt of at least {} s, or leave out --out and \
         --plot (the summary needs no stored series)",
        num(*dt), num(*bytes / (1u64 << 30) as f64),
        *max_bytes >> 30, num(*min_dt)
    )]
    RecordTooLarge {
        samples: usize,
        columns: usize,
        bytes: f64,
        dt: f64,
        /// The smallest step whose series fits.
        min_dt: f64,
        /// The limit, bytes.
        max_bytes: u64,
    },
    #[error("the model failed at t = {} s: {source}", num(*t))]
    Model {
        t: f64,
        #[source]
        source: ModelError,
    },
    #[error("{quantity} is not finite ({value}) at t = {} s", num(*t))]
    NonFinite {
        t: f64,
        quantity: String,
        value: f64,
    },
    #[error(transparent)]
    Signal(#[from] crate::signals::SignalError),
    #[error(transparent)]
    Initial(#[from] crate::initial::InitialError),
}
