//! invsim's runtime: drive cycles, the paper's C-infinity kernel smoother and the inverse simulation driver.
//!
//! The driver works on any [`invsim_model_api::InverseModel`]: compiled code from `invsim-models` or the
//! interpreter tape from `invsim-inversion`.

pub mod cycle;
pub mod kernel;
pub mod ode;
pub mod smoother;
pub mod simulate;
pub mod output;
pub mod plot;

pub use cycle::{Cycle, CycleError};
pub use kernel::Kernel;
pub use smoother::Smoother;
pub use simulate::{simulate, SimulateError, SimulationOptions, SimulationResult, Summary};
