//! invsim's runtime: drive cycles, the paper's C-infinity kernel smoother, the inverse simulation driver and
//! the forward simulation with a PI driver that validates it.
//!
//! The driver works on any [`invsim_model_api::InverseModel`]: compiled code from `invsim-models` or the
//! interpreter tape from `invsim-inversion`.
//!
//! Modules, in the one direction their imports go: `numfmt` (numbers in messages); [`cycle`], [`kernel`], [`smoother`] and [`ode`] (the
//! numerics); [`progress`] and [`provenance`] (the run's callback and its record); `error`, [`grid`] and
//! `report` (what both simulations share: errors, the output grid, the summary blocks and formatting), then
//! [`operating_points`] and [`reference_deviation`] (summary blocks); [`stable`] (stable inversion of unstable zero dynamics); [`inverse`] (the
//! inverse simulation, using `stable`) and [`forward`](mod@forward) (the forward simulation); [`output`] and [`plot`]
//! (writing results); [`sweep`] (parameter sweeps over many variants, on `inverse`).

mod binomial;
pub mod cycle;
pub mod elevation;
mod error;
pub mod forward;
pub mod gradient;
pub mod grid;
pub mod headline;
pub mod initial;
pub mod inverse;
pub mod kernel;
pub mod lookahead;
pub mod modes;
pub mod numfmt;
pub mod ode;
pub mod operating_points;
pub mod output;
pub mod plant;
pub mod plot;
pub mod progress;
pub mod provenance;
pub mod reference_deviation;
mod report;
pub mod run;
pub mod run_keep;
pub mod signal_file;
pub mod signals;
pub mod smoother;
pub mod stable;
pub mod sweep;
pub mod textfmt;
pub mod tolerance_band;
pub mod units;

/// The inverse simulation under its former module name.
pub use inverse as simulate;

pub use cycle::{Cycle, CycleError};
pub use error::RunError;
pub use forward::{
    forward, Bounds, ForwardError, ForwardOptions, ForwardOptionsBuilder, ForwardResult,
    ForwardSummary, Method,
};
pub use headline::Headline;
pub use inverse::{
    simulate, SimulateError, SimulationOptions, SimulationOptionsBuilder, SimulationResult, Summary,
};
pub use kernel::Kernel;
pub use operating_points::OperatingPoints;
pub use plant::Plant;
pub use progress::Progress;
pub use provenance::{CycleRecord, FileRecord, Override, Provenance};
pub use reference_deviation::ReferenceDeviation;
pub use report::{columns_with_units, Column, CycleInfo, Totals};
pub use run::{RunFailure, RunResult};
pub use run_keep::RunKeep;
pub use signals::{ResolvedSignal, SignalError, SignalInput, SignalValue};
pub use smoother::{Smoother, ZeroDynamicsReference};
pub use stable::{StableError, ZeroDynamicsClass};
pub use sweep::{Figures, Sweep, SweepBuilder, SweepError, SweepResult, SweepRow};
