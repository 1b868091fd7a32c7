//! One inverse simulation, as `invsim simulate` runs it: the cycle, the options, the model with its
//! parameters set, then `invsim_runtime::simulate`.

use invsim_runtime::inverse::{simulate_shared, Reference};
use invsim_runtime::{Cycle, SimulateError, SimulationOptions, SimulationResult};

use invsim_model_api::InverseModel;

use crate::error::Failure;

/// The options of a run (the keyword arguments of `Model.simulate` and `Model.sweep`).
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub dt: f64,
    pub lookahead: f64,
    pub verify: bool,
    pub causal: bool,
    pub include_extension: bool,
    pub keep_series: bool,
}

impl RunOptions {
    /// The runtime's options, validated, for `model_path` run by `engine` on `cycle` (an invalid option is
    /// reported as the command line reports it).
    pub fn build(
        &self,
        engine: &str,
        model_path: &str,
        cycle: &str,
    ) -> Result<SimulationOptions, Failure> {
        SimulationOptions::builder()
            .lookahead(self.lookahead)
            .dt(self.dt)
            .engine(engine)
            .verify(self.verify)
            .causal(self.causal)
            .include_extension(self.include_extension)
            .keep_series(self.keep_series)
            .build()
            .map_err(|e| stopped(model_path, cycle, e))
    }
}

/// A built-in cycle by name or a cycle file by path; a file's errors name the file.
pub fn load_cycle(spec: &str) -> Result<Cycle, Failure> {
    Cycle::load(spec).map_err(|e| {
        if Cycle::builtin(spec).is_some() {
            Failure::msg(e.to_string())
        } else {
            Failure::in_file(e.to_string(), spec)
        }
    })
}

/// Run the model instance `m` on `cycle`: the message of a stopped run is the command line's.
pub fn run_one(
    m: &dyn InverseModel,
    model_path: &str,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<SimulationResult, Failure> {
    invsim_runtime::simulate(m, cycle, opts).map_err(|e| stopped(model_path, &cycle.name, e))
}

/// [`run_one`] on a reference smoothed beforehand (the numbers are bit for bit those of [`run_one`]).
pub fn run_one_shared(
    m: &dyn InverseModel,
    model_path: &str,
    cycle: &Cycle,
    reference: &Reference,
    opts: &SimulationOptions,
) -> Result<SimulationResult, Failure> {
    simulate_shared(m, cycle, reference, opts, Vec::new())
        .map_err(|e| stopped(model_path, &cycle.name, e))
}

/// The command line's message for a run that could not start or had to stop.
fn stopped(model_path: &str, cycle: &str, e: SimulateError) -> Failure {
    Failure::msg(format!(
        "simulation of `{model_path}` on `{cycle}` stopped: {e}"
    ))
}
