//! invsim's runtime: drive cycles, the paper's C-infinity kernel smoother, the inverse simulation driver and
//! the forward simulation with a PI driver that validates it.
//!
//! The driver works on any [`invsim_model_api::InverseModel`]: compiled code from `invsim-models` or the
//! interpreter tape from `invsim-inversion`.
//!
//! Modules, in the one direction their imports go: [`cycle`], [`kernel`], [`smoother`] and [`ode`] (the
//! numerics); `error`, [`grid`] and `report` (what both simulations share: errors, the output grid, the
//! summary blocks and formatting); [`stable`] (stable inversion of unstable zero dynamics); [`inverse`] (the
//! inverse simulation, using `stable`) and [`forward`](mod@forward) (the forward simulation); [`output`] and [`plot`]
//! (writing results); [`sweep`] (parameter sweeps over many variants, on `inverse`).

pub mod cycle;
mod error;
pub mod forward;
pub mod grid;
pub mod inverse;
pub mod kernel;
pub mod ode;
pub mod output;
pub mod plot;
mod report;
pub mod smoother;
pub mod stable;
pub mod sweep;

/// The inverse simulation under its former module name.
pub use inverse as simulate;

pub use cycle::{Cycle, CycleError};
pub use error::RunError;
pub use forward::{
    forward, Bounds, ForwardError, ForwardOptions, ForwardOptionsBuilder, ForwardResult,
    ForwardSummary, Method,
};
pub use inverse::{
    simulate, SimulateError, SimulationOptions, SimulationOptionsBuilder, SimulationResult, Summary,
};
pub use kernel::Kernel;
pub use report::{CycleInfo, Totals};
pub use smoother::Smoother;
pub use stable::{StableError, ZeroDynamicsClass};
pub use sweep::{Figures, Sweep, SweepBuilder, SweepError, SweepResult, SweepRow};
