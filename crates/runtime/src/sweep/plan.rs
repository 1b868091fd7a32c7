//! A checked sweep's data: the model factory, the cycles with their shared references, the variants and the
//! options (built by [`super::SweepBuilder`], run by `exec`).

use std::sync::Arc;

use invsim_model_api::{InverseModel, ModelInfo};

use crate::cycle::Cycle;
use crate::inverse::{Reference, SimulationOptions};

/// Makes a fresh copy of the swept model at its base parameters (called once per worker thread), or says why
/// it cannot.
pub type ModelFactory = Arc<dyn Fn() -> Result<Box<dyn InverseModel>, String> + Send + Sync>;

/// A checked sweep: the model, the variants, the cycles with their shared references; [`Sweep::run`] runs it.
pub struct Sweep {
    pub(super) factory: ModelFactory,
    /// The model's description (of the copy `build` made).
    pub(super) info: ModelInfo,
    pub(super) cycles: Vec<(Cycle, Arc<Reference>)>,
    pub(super) names: Vec<String>,
    pub(super) variants: Vec<Vec<f64>>,
    pub(super) opts: SimulationOptions,
    pub(super) threads: usize,
    /// The worker threads when a number other than 1 was asked for (`None`: rayon's global pool).
    pub(super) pool: Option<rayon::ThreadPool>,
}
