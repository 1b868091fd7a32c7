//! A checked sweep's data: the model factory, the cycles with what every run on them shares, the variants and
//! the options (built by [`super::SweepBuilder`], run by `exec`).

use std::sync::Arc;

use crate::cycle::Cycle;
use crate::inverse::SimulationOptions;
use crate::plant::Plant;
use crate::run_keep::Shared;

/// Makes a fresh copy of the swept model at its base parameters (called once per worker thread), or says why
/// it cannot.
pub type ModelFactory = Arc<dyn Fn() -> Result<Plant, String> + Send + Sync>;

/// A checked sweep: the model, the variants, the cycles with their shared data; [`Sweep::run`] runs it.
pub struct Sweep {
    pub(super) factory: ModelFactory,
    /// The model's name (of the copy `build` made).
    pub(super) model: String,
    /// The accumulated outputs, sorted.
    pub(super) integrals: Vec<String>,
    /// The headline's columns (none without a `[headline]`).
    pub(super) headline: Vec<String>,
    /// The modes' names (empty for a model without modes).
    pub(super) modes: Vec<String>,
    /// Each cycle with what its runs share and their options (the look-ahead chosen for the cycle when the
    /// options ask for `auto`).
    pub(super) cycles: Vec<(Cycle, Shared, SimulationOptions)>,
    pub(super) names: Vec<String>,
    pub(super) variants: Vec<Vec<f64>>,
    pub(super) opts: SimulationOptions,
    pub(super) threads: usize,
    /// The worker threads when a number other than 1 was asked for (`None`: rayon's global pool).
    pub(super) pool: Option<rayon::ThreadPool>,
}
