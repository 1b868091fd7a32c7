//! `Model.forward`: the forward simulation of any model (with or without modes) along a cycle, closed by the
//! command line's PI driver, as `invsim forward` runs it.

use invsim_runtime::forward::{self, Bounds, ForwardOptions, Method};

use crate::engine::{Kind, Loaded};
use crate::error::Failure;
use crate::run::{gear_source, load_cycle, signal_input, Output, PySignal, RunSummary};

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
    let cycle = load_cycle(cycle_spec)?;
    let stopped = |e: String| {
        Failure::msg(format!(
            "forward simulation of `{model_path}` on `{}` stopped: {e}",
            cycle.name
        ))
    };
    let opts = req.options(model.engine_name(), &stopped)?;
    match &model.kind {
        Kind::Single(_) => {
            let m = model.single(params)?;
            let r =
                forward::forward(m.as_ref(), &cycle, &opts).map_err(|e| stopped(e.to_string()))?;
            let units = r
                .summary
                .columns
                .iter()
                .map(|c| (c.name.clone(), c.unit.clone()))
                .collect();
            Ok((RunSummary::Forward(r.summary), r.columns, r.data, units))
        }
        Kind::Modal(_) => {
            let plant = model.modal(params)?;
            let spec = plant.spec(gear_source(&plant, model_path, &cycle, cycle_spec)?);
            let r =
                forward::forward_modes(&spec, &cycle, &opts).map_err(|e| stopped(e.to_string()))?;
            let units = r.columns.iter().cloned().zip(r.units).collect();
            Ok((
                RunSummary::ModalForward(r.summary),
                r.columns,
                r.data,
                units,
            ))
        }
    }
}
