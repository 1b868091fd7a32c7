//! `Model.forward`: the forward simulation of any model (with or without modes) along a cycle, closed by the
//! command line's PI driver, as `invsim forward` runs it.

use invsim_runtime::forward::{Bounds, ForwardOptions, Method};

use invsim_runtime::{RunFailure, RunResult};

use crate::engine::Loaded;
use crate::error::Failure;
use crate::run::{cycle_file, load_cycle_checked, signal_input, Output, PySignal, RunSummary};

/// The options of a forward run (the keyword arguments of `Model.forward`; `None`: the command line's
/// default).
#[derive(Debug, Clone)]
pub struct ForwardRequest {
    pub dt: f64,
    pub kp: f64,
    pub ki: f64,
    pub response: f64,
    pub feedforward: bool,
    /// `"ignore"` or `"enforce"`.
    pub bounds: String,
    /// `"dopri5"` or `"rosenbrock23"`.
    pub method: String,
    pub rtol: f64,
    pub atol: f64,
    pub max_steps: Option<usize>,
    pub keep_series: bool,
    pub signals: Vec<PySignal>,
    pub initial: Vec<(String, f64)>,
}

impl ForwardRequest {
    /// The runtime's options, validated, for a run by `engine` (an invalid option is reported as the command
    /// line reports it).
    fn options(
        &self,
        engine: &str,
        stopped: &dyn Fn(String) -> Failure,
    ) -> Result<ForwardOptions, Failure> {
        let bounds = match self.bounds.as_str() {
            "ignore" => Bounds::Ignore,
            "enforce" => Bounds::Enforce,
            b => {
                return Err(Failure::msg(format!(
                    "bounds `{b}`: expected \"ignore\" or \"enforce\""
                )))
            }
        };
        let method = match self.method.as_str() {
            "dopri5" => Method::Dopri5,
            "rosenbrock23" => Method::Rosenbrock23,
            m => {
                return Err(Failure::msg(format!(
                    "method `{m}`: expected \"dopri5\" or \"rosenbrock23\""
                )))
            }
        };
        let mut opts = ForwardOptions::builder()
            .dt(self.dt)
            .engine(engine)
            .kp(self.kp)
            .ki(self.ki)
            .response(self.response)
            .feedforward(self.feedforward)
            .bounds(bounds)
            .method(method)
            .rtol(self.rtol)
            .atol(self.atol)
            .keep_series(self.keep_series)
            .max_steps(self.max_steps)
            .build()
            .map_err(|e| stopped(e.to_string()))?;
        opts.signals = self
            .signals
            .iter()
            .map(signal_input)
            .collect::<Result<_, _>>()?;
        opts.initial = self.initial.clone();
        Ok(opts)
    }
}

/// Run `model` (with `params` set) forward on `cycle_spec`.
pub fn forward_one(
    model: &Loaded,
    model_path: &str,
    cycle_spec: &str,
    params: &[(String, f64)],
    req: &ForwardRequest,
) -> Result<Output, Failure> {
    let (cycle, cycle_warnings) = load_cycle_checked(cycle_spec)?;
    let stopped = |e: String| {
        Failure::msg(format!(
            "forward simulation of `{model_path}` on `{}` stopped: {e}",
            cycle.name
        ))
    };
    let opts = req.options(model.engine_name(), &stopped)?;
    let file = cycle_file(cycle_spec);
    let mut result = model.with_plant(params, |plant| {
        plant.forward(&cycle, file, &opts).map_err(|e| match e {
            RunFailure::Gears(e) => Failure::in_file(format!("{model_path}: {e}"), model_path),
            e => stopped(e.to_string()),
        })
    })?;
    result.warnings_mut().splice(0..0, cycle_warnings);
    let units = result
        .columns()
        .iter()
        .cloned()
        .zip(result.units())
        .collect();
    Ok(match result {
        RunResult::Forward(r) => (RunSummary::Forward(r.summary), r.columns, r.data, units),
        RunResult::ModalForward(r, _) => (
            RunSummary::ModalForward(r.summary),
            r.columns,
            r.data,
            units,
        ),
        _ => return Err(Failure::msg("a forward run gave an inverse result")),
    })
}
