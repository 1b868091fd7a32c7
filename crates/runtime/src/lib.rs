//! invsim's runtime: drive cycles, the paper's C-infinity kernel smoother, the inverse simulation driver and
//! the forward simulation with a PI driver that validates it.
//!
//! The driver works on any [`invsim_model_api::InverseModel`]: compiled code from `invsim-models` or the
//! interpreter tape from `invsim-inversion`.

pub mod cycle;
pub mod forward;
pub mod kernel;
pub mod ode;
pub mod output;
pub mod plot;
mod report;
pub mod simulate;
pub mod smoother;
pub mod stable;

pub use cycle::{Cycle, CycleError};
pub use forward::{
    forward, Bounds, ForwardError, ForwardOptions, ForwardResult, ForwardSummary, Method,
};
pub use kernel::Kernel;
pub use simulate::{simulate, SimulateError, SimulationOptions, SimulationResult, Summary};
pub use smoother::Smoother;
pub use stable::ZeroDynamicsClass;
