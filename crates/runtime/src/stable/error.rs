//! Why a stable inversion could not be planned or solved ([`crate::SimulateError::Stable`] carries it).

use thiserror::Error;

use crate::report::format_eigenvalues;

/// Why the stable (non-causal) inversion of the zero dynamics failed.
#[derive(Debug, Error)]
pub enum StableError {
    #[error("stable (non-causal) inversion of the zero dynamics failed: {reason}")]
    StableInversion { reason: String },
    #[error(
        "the zero dynamics change type along the reference: ∂q/∂η has {from} unstable eigenvalue(s) at the \
         equilibrium for y = {y_from} ({eigs_from}) but {to} at y = {y_to} ({eigs_to}); a bounded inverse needs a \
         fixed split into stable and unstable parts (Devasia, Chen & Paden 1996), so neither causal nor stable \
         inversion works over this whole reference; use --causal to integrate forward as far as the zero \
         dynamics are stable",
        eigs_from = format_eigenvalues(.eigenvalues_from),
        eigs_to = format_eigenvalues(.eigenvalues_to)
    )]
    ZeroDynamicsTypeChange {
        y_from: f64,
        y_to: f64,
        from: String,
        to: String,
        eigenvalues_from: Vec<[f64; 2]>,
        eigenvalues_to: Vec<[f64; 2]>,
    },
    #[error(
        "stable inversion needs {} s of {which}-actuation for the zero dynamics to decay to the tolerance \
         (slowest decay rate {} 1/s), more than the limit of {} s",
        crate::numfmt::num(*needed), crate::numfmt::num(*rate), crate::numfmt::num(*max)
    )]
    PreActuationTooLong {
        which: &'static str,
        needed: f64,
        rate: f64,
        max: f64,
    },
}
